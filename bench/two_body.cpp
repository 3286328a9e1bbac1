// Two-body contact with dual mortar: TNNMG on the block-stacked hierarchies against the primal-dual
// active set method with CHOLMOD (PDAS), and against the one-body problem of the same slave body on a
// rigid plane (memory per unknown). The problem (3D): a block with a cylindrical bottom (hexahedra,
// width 1, height 0.5, depth 0.5, arc radius 1; the thesis' Geometry 1 shape) pressed 0.005 into a box
// [-1, 1] x [-0.5, 0.5] x [-1, 0] of tetrahedra (non-matching interface), both uniformly refined.
// Per level and solver, in a child process each (peak memory its own): unknowns, constrained slave
// nodes, iterations, mortar assembly time (search, clipping, quadrature, transformation), problem
// assembly time, solve time, peak memory. Writes a markdown table; progress goes to stderr.
//
//   build/bench/two_body perf.md --levels 1-3 [--pdas-max-dofs N] [--solvers tnnmg,pdas,onebody]
//                                [--box-type tetrahedron|hexahedron]   (the master box's cells)
//
// The cost of assembling several bodies (--problem step42-ball): deal.II's step-42 cube (16^3
// hexahedra, rollers on the sides, clamped bottom) with the rigid ball replaced by a meshed ball of
// curved hexahedra (radius 0.6, 32 x 8^level cells: level 4 is 131,072) as the master, its
// surface clamped, and the same ball prescribed at every vertex (a meshed rigid body,
// DirichletCondition::everywhere). Per ball level, in one child process: each body assembled alone as a one-body
// problem (ContactModel with that body only, ContactProblem set up), the two-body problem, its
// mortar terms, and the ratio two-body / (sum of the bodies + mortar), which is 1 when stacking the
// bodies and transforming the interface rows cost nothing; then TNNMG's solve. Writes a markdown
// table.
//
//   build/bench/two_body assembly.md --problem step42-ball --levels 2-4
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Measurement {
  bool ran = false, failed = false, converged = false;
  long long dofs = 0, slaveNodes = 0, activeNodes = 0;
  int iterations = 0;
  double mortarSeconds = 0, assemblySeconds = 0, solveSeconds = 0, peakMB = 0, load = 0;
  double bodySeconds[2] = {0, 0};  // --problem step42-ball: each body assembled alone
  char message[160] = {};
};

template <class F>
Measurement isolated(F f) {
  int fd[2];
  if (pipe(fd) != 0) throw std::runtime_error("pipe failed");
  std::cout.flush();
  std::cerr.flush();
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    Measurement m;
    try {
      m = f();
    } catch (const std::exception& e) {
      m.failed = true;
      std::snprintf(m.message, sizeof m.message, "%s", e.what());
    }
    m.ran = true;
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    m.peakMB = static_cast<double>(u.ru_maxrss) / 1024.0;
    if (write(fd[1], &m, sizeof m) != static_cast<ssize_t>(sizeof m)) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  Measurement m;
  const ssize_t got = read(fd[0], &m, sizeof m);
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got != static_cast<ssize_t>(sizeof m)) {
    m = Measurement();
    m.ran = m.failed = true;
    std::snprintf(m.message, sizeof m.message, "child process died (status %d; out of memory?)", status);
  }
  return m;
}

/// The problem's size and the mortar figures of the model's (first) pair.
void recordModel(Measurement& m, const ContactModel<3>& model, const ContactProblem<3>& problem) {
  m.mortarSeconds = model.couplings().front().coupling->statistics().seconds;
  m.slaveNodes = model.couplings().front().coupling->size();
  m.dofs = problem.numDofs();
}

mesh::Grid roundedBlock(int levels) {
  mesh::CurvedMesh rb = mesh::roundedBlockMesh(1.0, 0.5, 0.5, 1.0, mesh::CellType::Hexahedron, {4, 2, 2});
  const Point shift(-0.5, -0.25, 0);
  for (Index v = 0; v < rb.mesh.numVertices(); ++v) rb.mesh.vertex(v) += shift;
  mesh::Grid g(std::move(rb.mesh));
  for (const auto& [id, projection] : rb.projections)  // the projections move with the mesh
    g.setBoundaryProjection(id, [projection, shift](const Point& x) { return Point(projection(x - shift) + shift); });
  for (int l = 0; l < levels; ++l) g.refineUniformly();
  return g;
}

BoundaryConditions pushedTop() {
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, 0, -0.005); }});
  return bc;
}

mesh::CellType gBoxType = mesh::CellType::Tetrahedron;  // --box-type

Measurement runTwoBody(int levels, const std::string& solverName) {
  Measurement m;
  auto t0 = Clock::now();
  mesh::Grid upper = roundedBlock(levels);
  mesh::Grid lower(mesh::boxMesh(gBoxType, {4, 2, 2}, Point(-1, -0.5, -1), Point(1, 0.5, 0)));
  for (int l = 0; l < levels; ++l) lower.refineUniformly();
  const mesh::Mesh ml = lower.leafView().mesh, mu = upper.leafView().mesh;
  BoundaryConditions bl;
  bl.dirichlet.push_back({mesh::kBottom});
  ContactModel<3> model;
  model.addBody("box", ml, Material{1.0, 0.3}, bl);
  model.addBody("rounded block", mu, Material{1.0, 0.3}, pushedTop());
  model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "bottom / top");
  const ContactProblem<3> problem = model.assemble();
  m.assemblySeconds = since(t0);
  recordModel(m, model, problem);
  Eigen::VectorXd x;
  t0 = Clock::now();
  ContactResult r;
  if (solverName == "tnnmg") {
    TNNMG<3> solver({&lower, &upper});
    r = solver.solve(problem, x);
  } else {
    PrimalDualActiveSet<3> solver;
    r = solver.solve(problem, x);
  }
  m.solveSeconds = since(t0);
  m.iterations = r.iterations;
  m.converged = r.converged;
  m.activeNodes = r.activeSetSize;
  const Eigen::VectorXd mu_ = problem.multipliers(x);
  m.load = mu_.sum();
  return m;
}

Measurement runOneBody(int levels) {
  Measurement m;
  auto t0 = Clock::now();
  mesh::Grid upper = roundedBlock(levels);
  const mesh::Mesh mu = upper.leafView().mesh;
  const PlaneObstacle plane(Point(0, 0, 0), Point(0, 0, -1));
  ContactModel<3> model;
  model.addBody("rounded block", mu, Material{1.0, 0.3}, pushedTop());
  model.addObstacleContact(0, ContactSet(mu, mesh::kBottom, plane), "rigid plane");
  const ContactProblem<3> problem = model.assemble();
  m.assemblySeconds = since(t0);
  m.dofs = problem.numDofs();
  Eigen::VectorXd x;
  t0 = Clock::now();
  TNNMG<3> solver(upper);
  const ContactResult r = solver.solve(problem, x);
  m.solveSeconds = since(t0);
  m.iterations = r.iterations;
  m.converged = r.converged;
  m.activeNodes = r.activeSetSize;
  m.load = problem.multipliers(x).sum();
  return m;
}

/// step-42's cube (16^3 hexahedra) as the slave, a meshed ball (cubed sphere of curved hexahedra,
/// 32 cells refined `levels` times: level 4 has 131,072) as the clamped master.
Measurement runStep42Ball(int levels, bool rigid) {
  Measurement m;
  mesh::Grid cube(mesh::boxMesh(mesh::CellType::Hexahedron, {4, 4, 4}, Point(0, 0, 0), Point(1, 1, 1)));
  for (int l = 0; l < 2; ++l) cube.refineUniformly();
  mesh::CurvedMesh b = mesh::ballMesh(Point(0.5, 0.5, 1.59), 0.6, mesh::CellType::Hexahedron, 2);
  mesh::Grid ball(std::move(b.mesh));
  for (const auto& [id, projection] : b.projections) ball.setBoundaryProjection(id, projection);
  for (int l = 0; l < levels; ++l) ball.refineUniformly();
  const mesh::Mesh mc = cube.leafView().mesh, mb = ball.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kBottom});
  for (int side : {mesh::kLeft, mesh::kRight, mesh::kFront, mesh::kBack})
    bc.dirichlet.push_back({side, {true, true, false}});
  BoundaryConditions bb;
  if (rigid) {  // every vertex prescribed: a meshed rigid body
    DirichletCondition all;
    all.everywhere = true;
    bb.dirichlet.push_back(all);
  } else {
    bb.dirichlet.push_back({mesh::kCurvedSurface});
  }
  const Material steel{2e5, 0.3};
  // each body alone: the same assembly path with one body and no coupling
  for (int i = 0; i < 2; ++i) {
    const auto t0 = Clock::now();
    ContactModel<3> alone;
    alone.addBody(i == 0 ? "cube" : "ball", i == 0 ? mc : mb, steel, i == 0 ? bc : bb);
    const ContactProblem<3> p = alone.assemble();
    m.bodySeconds[i] = since(t0);
  }
  auto t0 = Clock::now();
  ContactModel<3> model;
  model.addBody("cube", mc, steel, bc);
  model.addBody("ball", mb, steel, bb);
  MortarOptions options;
  options.searchDistance = 0.05;
  model.addMortarPair(0, mesh::kTop, 1, mesh::kCurvedSurface, "top / ball", options);
  const ContactProblem<3> problem = model.assemble();
  m.assemblySeconds = since(t0);
  recordModel(m, model, problem);
  Eigen::VectorXd x;
  t0 = Clock::now();
  TNNMG<3> solver({&cube, &ball});
  const ContactResult r = solver.solve(problem, x);
  m.solveSeconds = since(t0);
  m.iterations = r.iterations;
  m.converged = r.converged;
  m.activeNodes = r.activeSetSize;
  m.load = problem.multipliers(x).sum();
  return m;
}

int step42Ball(const std::string& outFile, int first, int last) {
  std::ostringstream table;
  table << "| ball level | ball | ball cells | unknowns | cube alone s | ball alone s | mortar s | two bodies s | "
           "two bodies / (sum + mortar) | solve s | iterations | peak MB | load P |\n"
           "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (int level = first; level <= last; ++level) {
    for (const bool rigid : {false, true}) {
      std::cerr << "ball level " << level << (rigid ? ", rigid" : ", surface clamped") << " ..." << std::flush;
      const Measurement m = isolated([&] { return runStep42Ball(level, rigid); });
      if (m.failed) {
        std::cerr << " failed: " << m.message << "\n";
        table << "| " << level << " | failed: " << m.message << " ||||||||||||\n";
        continue;
      }
      const double ratio = m.assemblySeconds / (m.bodySeconds[0] + m.bodySeconds[1] + m.mortarSeconds);
      std::cerr << " " << m.dofs << " unknowns, assembly " << m.assemblySeconds << " s (ratio " << ratio << ")\n";
      table << std::setprecision(4) << "| " << level << " | "
            << (rigid ? "rigid (prescribed everywhere)" : "surface clamped") << " | " << (32LL << (3 * level))
            << " | " << m.dofs << " | " << m.bodySeconds[0] << " | " << m.bodySeconds[1] << " | " << m.mortarSeconds
            << " | " << m.assemblySeconds << " | " << ratio << " | " << m.solveSeconds << " | " << m.iterations
            << (m.converged ? "" : " (not converged)") << " | " << m.peakMB << " | " << m.load << " |\n";
    }
  }
  std::ofstream out(outFile);
  out << table.str();
  std::cout << table.str();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]).starts_with("-")) {
    std::cerr << "usage: two_body OUTPUT.md [--problem rounded-block|step42-ball] [--levels a-b] [--pdas-max-dofs N] "
                 "[--solvers tnnmg,pdas,onebody] [--box-type tetrahedron|hexahedron]\n";
    return 2;
  }
  const std::string outFile = argv[1];
  int first = 1, last = 3;
  long long pdasMax = 400000;
  std::string solvers = "tnnmg,pdas,onebody", problem = "rounded-block";
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--problem") {
      problem = value;
      if (problem != "rounded-block" && problem != "step42-ball") {
        std::cerr << "--problem: rounded-block or step42-ball\n";
        return 2;
      }
    } else if (key == "--levels") {
      if (std::sscanf(value.c_str(), "%d-%d", &first, &last) != 2) return 2;
    } else if (key == "--pdas-max-dofs") {
      pdasMax = std::stoll(value);
    } else if (key == "--box-type") {
      if (value == "hexahedron")
        gBoxType = mesh::CellType::Hexahedron;
      else if (value != "tetrahedron") {
        std::cerr << "--box-type: hexahedron or tetrahedron\n";
        return 2;
      }
    } else if (key == "--solvers") {
      solvers = value;
    } else {
      std::cerr << "unknown option " << key << "\n";
      return 2;
    }
  }
  if (problem == "step42-ball") return step42Ball(outFile, first, last);
  std::ostringstream table;
  table << "| level | solver | unknowns | slave nodes | active | iterations | mortar s | assembly s | solve s | "
           "peak MB | bytes/unknown | load P |\n|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (int level = first; level <= last; ++level) {
    long long dofs = 0;  // of this level's TNNMG run
    for (const std::string s : {"tnnmg", "pdas", "onebody"}) {
      if (solvers.find(s) == std::string::npos) continue;
      std::cerr << "level " << level << " " << s << " ..." << std::flush;
      Measurement m;
      if (s == "pdas") {
        if (dofs > pdasMax) {
          std::cerr << " skipped (" << dofs << " unknowns > --pdas-max-dofs)\n";
          continue;
        }
        m = isolated([&] { return runTwoBody(level, "pdas"); });
      } else if (s == "tnnmg") {
        m = isolated([&] { return runTwoBody(level, "tnnmg"); });
        dofs = m.dofs;
      } else {
        m = isolated([&] { return runOneBody(level); });
      }
      if (m.failed) {
        std::cerr << " failed: " << m.message << "\n";
        table << "| " << level << " | " << s << " | failed: " << m.message << " |||||||||\n";
        continue;
      }
      std::cerr << " " << m.dofs << " unknowns, " << m.iterations << " iterations, " << m.solveSeconds << " s\n";
      table << std::setprecision(4) << "| " << level << " | " << (s == "onebody" ? "tnnmg, one body on a rigid plane" : s)
            << " | " << m.dofs << " | " << m.slaveNodes << " | " << m.activeNodes << " | " << m.iterations
            << (m.converged ? "" : " (not converged)") << " | " << m.mortarSeconds << " | " << m.assemblySeconds
            << " | " << m.solveSeconds << " | " << m.peakMB << " | "
            << static_cast<long long>(m.peakMB * 1048576.0 / static_cast<double>(m.dofs)) << " | " << m.load << " |\n";
    }
  }
  std::ofstream out(outFile);
  out << table.str();
  std::cout << table.str();
  return 0;
}
