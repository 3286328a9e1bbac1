// TNNMG with friction against frictionless TNNMG on the same meshes (docs/performance.md#friction):
// a block pressed onto a rigid cylinder (2D, quadrilaterals, unit square, top moved by
// (0.004, -0.02), nu = 0.3) or ball (3D, hexahedra, unit cube on a ball of radius 0.75, top moved by
// (0.006, 0.003, -0.03)), uniformly refined. Per level: unknowns, TNNMG iterations and time without
// friction, with Tresca friction (slip bound 0.3 x the mean contact pressure of the frictionless
// solution) and with Coulomb friction mu = 0.3 (the fixed point over Tresca solves: solves, TNNMG
// iterations per solve, total time), and the stick / slip counts of the Coulomb solution. All
// solves to the relative correction 1e-10. Writes a markdown table; progress goes to stderr.
//
//   build/bench/friction friction.md [--dim 2|3] [--levels 3-8]
//
// With --mu-sweep 0.1,0.3,...: on the one mesh of --levels (a single level), the Coulomb fixed point
// for each mu from a zero start (relative change 1e-8, at most 50 Tresca solves): solves, whether it
// converged and contracted, the last change, total TNNMG iterations, the stick / slip counts and the
// ratio of tangential to mu times normal force.
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Row {
  long long dofs = 0;
  int plain = 0, tresca = 0, solves = 0;
  long long coulombIterations = 0;
  double plainSeconds = 0, trescaSeconds = 0, coulombSeconds = 0;
  Index contact = 0, stick = 0, slip = 0;
  bool converged = true;
};

template <int d>
Row measure(int level) {
  mesh::Grid grid(mesh::boxMesh(d == 2 ? mesh::CellType::Quadrilateral : mesh::CellType::Hexahedron, 2));
  for (int l = 0; l < level; ++l) grid.refineUniformly();
  const mesh::Mesh& m = grid.leafView().mesh;
  const Material material{3e5, 0.3};
  BoundaryConditions bc;
  const Point top = d == 2 ? Point(0.004, -0.02, 0) : Point(0.006, 0.003, -0.03);
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  std::unique_ptr<Obstacle> obstacle;
  if constexpr (d == 2) obstacle = std::make_unique<DiskObstacle>(Point(0.5, -0.5, 0), 0.5);
  else obstacle = std::make_unique<BallObstacle>(Point(0.5, 0.5, -0.75), 0.75);
  ContactProblem<d> problem(m, material, bc, ContactSet(m, mesh::kBottom, *obstacle));
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-10;
  o.maxIterations = 500;
  Row r;
  r.dofs = problem.numDofs();
  {
    TNNMG<d> tnnmg(grid, o);
    Eigen::VectorXd u;
    auto t0 = Clock::now();
    const ContactResult c = tnnmg.solve(problem, u);
    r.plainSeconds = since(t0);
    r.plain = c.iterations;
    r.converged = r.converged && c.converged;
    const ContactOutputs out = computeContactOutputs(problem, u);
    const double meanPressure = out.contactArea > 0 ? (out.force.norm() / out.contactArea) : 0;
    problem.setFriction(trescaSlipBounds(problem.contactSet(), 0.3 * meanPressure));
    Eigen::VectorXd v;
    t0 = Clock::now();
    const ContactResult t = tnnmg.solve(problem, v);
    r.trescaSeconds = since(t0);
    r.tresca = t.iterations;
    r.converged = r.converged && t.converged;
  }
  {
    TNNMG<d> tnnmg(grid, o);
    Eigen::VectorXd u;
    const auto t0 = Clock::now();
    const CoulombResult c = solveCoulomb(problem, tnnmg, u, {0.3, 50, 1e-8});
    r.coulombSeconds = since(t0);
    r.solves = c.iterations;
    r.coulombIterations = c.innerIterations;
    r.converged = r.converged && c.converged;
    const ContactOutputs out = computeContactOutputs(problem, u);
    r.contact = out.contactNodes;
    r.stick = out.stickNodes;
    r.slip = out.slipNodes;
  }
  return r;
}

struct SweepRow {
  double mu = 0;
  int solves = 0;
  bool converged = false, contracting = true;
  double lastChange = 0, seconds = 0, ratio = 0;
  long long iterations = 0;
  Index contact = 0, stick = 0, slip = 0;
};

template <int d>
SweepRow sweep(int level, double mu) {
  mesh::Grid grid(mesh::boxMesh(d == 2 ? mesh::CellType::Quadrilateral : mesh::CellType::Hexahedron, 2));
  for (int l = 0; l < level; ++l) grid.refineUniformly();
  const mesh::Mesh& m = grid.leafView().mesh;
  const Material material{3e5, 0.3};
  BoundaryConditions bc;
  const Point top = d == 2 ? Point(0.004, -0.02, 0) : Point(0.006, 0.003, -0.03);
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  std::unique_ptr<Obstacle> obstacle;
  if constexpr (d == 2) obstacle = std::make_unique<DiskObstacle>(Point(0.5, -0.5, 0), 0.5);
  else obstacle = std::make_unique<BallObstacle>(Point(0.5, 0.5, -0.75), 0.75);
  ContactProblem<d> problem(m, material, bc, ContactSet(m, mesh::kBottom, *obstacle));
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-10;
  o.maxIterations = 500;
  TNNMG<d> tnnmg(grid, o);
  Eigen::VectorXd u;
  SweepRow r;
  r.mu = mu;
  const auto t0 = Clock::now();
  const CoulombResult c = solveCoulomb(problem, tnnmg, u, {mu, 50, 1e-8});
  r.seconds = since(t0);
  r.solves = c.iterations;
  r.converged = c.converged;
  r.contracting = c.contracting;
  r.lastChange = c.changes.back();
  r.iterations = c.innerIterations;
  const ContactOutputs out = computeContactOutputs(problem, u);
  r.contact = out.contactNodes;
  r.stick = out.stickNodes;
  r.slip = out.slipNodes;
  double normal = 0;
  for (double x : out.multiplier) normal += x;
  r.ratio = mu > 0 && normal > 0 ? out.tangentialForce.norm() / (mu * normal) : 0;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]).starts_with("-")) {
    std::cerr << "usage: friction OUT.md [--dim 2|3] [--levels A-B]\n";
    return 2;
  }
  int dim = 2, first = 3, last = 8;
  std::vector<double> mus;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--dim") dim = std::stoi(value);
    else if (key == "--mu-sweep") {
      std::stringstream list(value);
      for (std::string x; std::getline(list, x, ',');) mus.push_back(std::stod(x));
    }
    else if (key == "--levels") {
      const auto dash = value.find('-');
      first = std::stoi(value.substr(0, dash));
      last = dash == std::string::npos ? first : std::stoi(value.substr(dash + 1));
    } else {
      std::cerr << "friction: unknown option " << key << "\n";
      return 2;
    }
  }
  if ((dim != 2 && dim != 3) || first < 0 || last < first) {
    std::cerr << "friction: invalid --dim or --levels\n";
    return 2;
  }
  if (!mus.empty()) {
    std::ostringstream table;
    table << "| mu | Tresca solves | converged | contracting | last change | TNNMG iterations | s | contact | stick | "
             "slip | Q / (mu P) |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (double mu : mus) {
      const SweepRow r = dim == 2 ? sweep<2>(first, mu) : sweep<3>(first, mu);
      table << std::setprecision(3) << "| " << r.mu << " | " << r.solves << " | " << (r.converged ? "yes" : "no")
            << " | " << (r.contracting ? "yes" : "no") << " | " << r.lastChange << " | " << r.iterations << " | "
            << r.seconds << " | " << r.contact << " | " << r.stick << " | " << r.slip << " | " << r.ratio << " |\n";
      std::cerr << "mu " << mu << ": " << r.solves << " solves\n";
    }
    std::ofstream out(argv[1]);
    out << "Coulomb fixed point against mu, " << dim << "D, level " << first << " (bench/friction.cpp)\n\n"
        << table.str();
    return 0;
  }
  std::ostringstream table;
  table << "| level | unknowns | frictionless: it | s | Tresca: it | s | it ratio | Coulomb: solves | it per solve | s | "
           "contact | stick | slip |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  bool ok = true;
  for (int level = first; level <= last; ++level) {
    const Row r = dim == 2 ? measure<2>(level) : measure<3>(level);
    ok = ok && r.converged;
    table << std::setprecision(3) << "| " << level << " | " << r.dofs << " | " << r.plain << " | " << r.plainSeconds
          << " | " << r.tresca << " | " << r.trescaSeconds << " | " << double(r.tresca) / r.plain << " | "
          << r.solves << " | " << double(r.coulombIterations) / r.solves << " | " << r.coulombSeconds << " | "
          << r.contact << " | " << r.stick << " | " << r.slip << " |" << (r.converged ? "" : " not converged") << "\n";
    std::cerr << "level " << level << ": " << r.dofs << " unknowns, " << r.plain << " / " << r.tresca << " it, Coulomb "
              << r.solves << " solves\n";
  }
  std::ofstream out(argv[1]);
  out << "TNNMG with and without friction, " << dim << "D (bench/friction.cpp)\n\n" << table.str();
  return ok ? 0 : 1;
}
