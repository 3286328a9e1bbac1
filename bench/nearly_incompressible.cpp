// Multigrid smoothers for nearly incompressible elasticity (docs/performance.md#nearly-incompressible,
// docs/theory.md#vertex-patch-smoother): the Hertz scene of data/scenes/hertz.toml (unit cube of
// hexahedra, 4^3 coarse cells refined `levels` times, B-bar, the top pushed down by 0.005 onto a
// ball of radius 0.75) for Poisson ratios 0.3 ... 0.4999 and both smoothers of the linear V-cycle
// (point-block Gauss-Seidel, vertex-patch Schwarz). Per nu and smoother:
//   - the linear multigrid rate (LinearMultigrid::solve on the rotated stiffness, Dirichlet
//     components truncated, the contact normals free or clamped, a fixed pseudo-random right-hand
//     side, tolerance 1e-10, at most 200 iterations): V-cycles, geometric mean rate per iteration, seconds;
//   - TNNMG on the contact problem (tolerance 1e-10, at most `maxit` iterations): iterations,
//     V-cycles, seconds, converged;
//   - set-up seconds and memory of the smoothers.
//
//   build/bench/nearly_incompressible [levels] [maxit] [pre] [post] [cg-steps] [--skip-gs-above NU]
// (cg-steps > 0: LinearMultigridOptions::krylovSteps, the V-cycle as preconditioner of CG; the
// linear "cycles" columns then count V-cycles, i.e. solve() iterations x cg-steps).
// prints a markdown table (levels 2: 16^3 cells as in hertz.toml).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct LinearRun {
  int cycles = 0;
  double rate = 0, seconds = 0, setup = 0;
  bool converged = false;
  std::size_t memory = 0;
};

LinearRun linearRate(const mesh::Grid& grid, const ContactProblem<3>& problem, LinearSmoother smoother, bool clamped,
                     int pre, int post, int krylov) {
  const RotatedProblem<3> rot = problem.rotated();
  LinearMultigridOptions o;
  o.smoother = smoother;
  o.preSmoothing = pre;
  o.postSmoothing = post;
  o.krylovSteps = krylov;
  o.tolerance = 1e-10;
  o.maxIterations = 200;
  LinearRun run;
  auto t = Clock::now();
  LinearMultigrid<3> mg(grid, o);
  mg.setOperator(rot.matrix(), problemRotations(problem), rot.prescribed);
  std::vector<char> mask = rot.prescribed;
  if (clamped)
    for (const auto& c : problem.constraints())
      if (c.bounded()) mask[static_cast<std::size_t>(c.vertex) * 3] = 1;
  mg.truncate(mask);
  run.setup = since(t);
  run.memory = mg.smootherMemoryBytes();
  Eigen::VectorXd b(rot.matrix().rows() * 3);
  unsigned state = 12345;
  for (Eigen::Index i = 0; i < b.size(); ++i) {
    state = state * 1103515245u + 12345u;
    b[i] = static_cast<double>((state >> 8) & 0xffff) / 65536.0 - 0.5;
  }
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) b[static_cast<Eigen::Index>(i)] = 0;
  Eigen::VectorXd x;
  const LinearSolverResult r = mg.solve(b, x);
  run.cycles = static_cast<int>(mg.vcycles());
  run.rate = r.convergenceRate;
  run.seconds = r.seconds;
  run.converged = r.converged;
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  int levels = argc > 1 ? std::atoi(argv[1]) : 2;
  int maxit = argc > 2 ? std::atoi(argv[2]) : 500;
  int pre = argc > 3 ? std::atoi(argv[3]) : 3;
  int post = argc > 4 ? std::atoi(argv[4]) : 3;
  int krylov = argc > 5 && std::string(argv[5]).substr(0, 2) != "--" ? std::atoi(argv[5]) : 0;
  double skipGsAbove = 1;
  for (int i = 1; i + 1 < argc; ++i)
    if (std::string(argv[i]) == "--skip-gs-above") skipGsAbove = std::atof(argv[i + 1]);
  mesh::Grid grid(mesh::boxMesh(mesh::CellType::Hexahedron, 4));
  for (int l = 0; l < levels; ++l) grid.refineUniformly();
  const mesh::Mesh m = grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Eigen::Vector3d(0, 0, -0.005); }});
  const ContactSet cs(m, mesh::kBottom, BallObstacle(Point(0.5, 0.5, -0.75), 0.75));
  std::printf("Hertz B-bar, %d^3 hexahedra, %d levels, %lld unknowns, V(%d,%d), %d CG steps per correction\n\n",
              4 << levels, levels + 1, static_cast<long long>(m.numVertices()) * 3, pre, post, krylov);
  std::printf("| nu | smoother | linear cycles (free) | rate | linear cycles (clamped) | rate | s / cycle | "
              "TNNMG iterations | V-cycles | converged | TNNMG [s] | smoother set-up [s] | smoother memory [MB] |\n");
  std::printf("|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|\n");
  for (double nu : {0.3, 0.45, 0.49, 0.499, 0.4999}) {
    Material mat{3e5, nu};
    mat.formulation = VolumetricFormulation::BBar;
    const ContactProblem<3> problem(m, mat, bc, cs);
    for (LinearSmoother s : {LinearSmoother::GaussSeidel, LinearSmoother::VertexPatch}) {
      if (s == LinearSmoother::GaussSeidel && nu > skipGsAbove) continue;
      const LinearRun free = linearRate(grid, problem, s, false, pre, post, krylov);
      const LinearRun clamped = linearRate(grid, problem, s, true, pre, post, krylov);
      TNNMG<3>::Options o;
      o.tolerance = 1e-10;
      o.maxIterations = maxit;
      o.multigrid.smoother = s;
      o.multigrid.preSmoothing = pre;
      o.multigrid.postSmoothing = post;
      o.multigrid.krylovSteps = krylov;
      TNNMG<3> tnnmg(grid, o);
      Eigen::VectorXd u;
      const auto t = Clock::now();
      const ContactResult r = tnnmg.solve(problem, u);
      const double seconds = since(t);
      std::printf("| %g | %s | %d%s | %.3f | %d%s | %.3f | %.4f | %d | %d | %s | %.2f | %.2f | %.1f |\n", nu,
                  s == LinearSmoother::GaussSeidel ? "gauss-seidel" : "vertex-patch", free.cycles,
                  free.converged ? "" : "+", free.rate, clamped.cycles, clamped.converged ? "" : "+", clamped.rate,
                  clamped.seconds / std::max(clamped.cycles, 1), r.iterations, r.iterations * (krylov > 0 ? krylov : o.multigrid.cycles),
                  r.converged ? "yes" : "no", seconds, clamped.setup, static_cast<double>(clamped.memory) / 1e6);
      std::fflush(stdout);
    }
  }
  return 0;
}
