// TNNMG with friction against frictionless TNNMG on the same meshes (docs/performance.md#friction):
// a block pressed onto a rigid cylinder (2D, quadrilaterals, unit square, top moved by
// (0.004, -0.02), nu = 0.3) or ball (3D, hexahedra, unit cube on a ball of radius 0.75, top moved by
// (0.006, 0.003, -0.03)), uniformly refined. Per level: unknowns, TNNMG iterations and time without
// friction, with Tresca friction (slip bound 0.3 x the mean contact pressure of the frictionless
// solution) and with Coulomb friction mu = 0.3 (the fixed point over Tresca solves: solves, TNNMG
// iterations per solve, total time), and the stick / slip counts of the Coulomb solution. All
// solves to the relative correction 1e-10. In 3D also the Tresca solve with the curvature of the
// friction term left out of the linear correction (TNNMG::Options::frictionCurvature = false), after
// a frictionless solve in its own TNNMG as above. Writes a markdown table; progress goes to stderr.
//
//   build/bench/friction friction.md [--dim 2|3] [--levels 3-8] [--baseline] [--mu-sweep LIST]
//                                    [--cycles N] [--history] [--direct]
//
// --cycles N: N V-cycles per TNNMG correction (default 1). --history: the relative correction of
// every iteration of the frictionless and the Tresca solves on stderr. --direct: those solves with
// the exact correction (DirectCorrection, a CHOLMOD factorisation per truncation change) instead of
// multigrid, on small levels.
// With --baseline: per level the Tresca problem above solved from zero by TNNMG and by the
// primal-dual active set method with CHOLMOD (semismooth Newton), each in a child process of its own:
// iterations, seconds (solver construction and solve), peak memory of the child (ru_maxrss, which
// includes the problem's assembly, the same in both), and the difference of the two solutions. A
// solve that throws (the active set cycling) is a row "failed after" with its time.
//
// With --mu-sweep 0.1,0.3,...: on the one mesh of --levels (a single level), the Coulomb fixed point
// for each mu from a zero start (relative change 1e-8, at most 50 Tresca solves): solves, whether it
// converged and contracted, the last change, total TNNMG iterations, the stick / slip counts and the
// ratio of tangential to mu times normal force.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// The benchmark problem of the file comment on `level` uniform refinements: the grid, its leaf mesh
/// and the frictionless contact problem on it (friction is set by the callers).
template <int d>
struct Setup {
  mesh::Grid grid;
  mesh::Mesh leaf;
  std::unique_ptr<Obstacle> obstacle;
  std::optional<ContactProblem<d>> problem;

  explicit Setup(int level)
      : grid(mesh::boxMesh(d == 2 ? mesh::CellType::Quadrilateral : mesh::CellType::Hexahedron, 2)) {
    for (int l = 0; l < level; ++l) grid.refineUniformly();
    leaf = grid.leafView().mesh;
    BoundaryConditions bc;
    const Point top = d == 2 ? Point(0.004, -0.02, 0) : Point(0.006, 0.003, -0.03);
    bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
    if constexpr (d == 2) obstacle = std::make_unique<DiskObstacle>(Point(0.5, -0.5, 0), 0.5);
    else obstacle = std::make_unique<BallObstacle>(Point(0.5, 0.5, -0.75), 0.75);
    problem.emplace(leaf, Material{3e5, 0.3}, bc, ContactSet(leaf, mesh::kBottom, *obstacle));
  }
};

/// --cycles N: V-cycles per TNNMG correction (default 1); --history: the relative correction of
/// every iteration of the frictionless and the Tresca solve of measure() on stderr.
int gCycles = 1;
bool gHistory = false;
bool gDirect = false;  ///< --direct: the exact correction (DirectCorrection, CHOLMOD) in measure()

/// A TNNMG on `grid`, with the multigrid correction or (--direct) the exact one.
template <int d>
std::unique_ptr<TNNMG<d>> makeTnnmg(const mesh::Grid& grid, const typename TNNMG<d>::Options& o) {
  if (gDirect) return std::make_unique<TNNMG<d>>(grid, o, std::make_unique<DirectCorrection<d>>());
  return std::make_unique<TNNMG<d>>(grid, o);
}

/// TNNMG to the relative correction 1e-10, at most 500 iterations.
template <int d>
typename TNNMG<d>::Options tnnmgOptions() {
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-10;
  o.maxIterations = 500;
  o.multigrid.cycles = gCycles;
  return o;
}

void printHistory(const char* what, int level, const ContactResult& r) {
  if (!gHistory) return;
  std::cerr << "level " << level << ", " << what << ":";
  for (const IterationRecord& h : r.history) std::cerr << " " << std::setprecision(3) << h.correction;
  std::cerr << "\n";
}

/// The Tresca slip bounds of the benchmark: 0.3 x the nodal normal forces of a frictionless solution
/// (the first Coulomb iterate). Bounds proportional to the pressure slip at the edge of the contact
/// zone, where the pressure falls to zero; a uniform bound (0.3 x the mean pressure) made every node
/// stick in 3D.
std::vector<double> trescaBounds(const ContactOutputs& frictionless) {
  std::vector<double> s(frictionless.multiplier.size());
  for (std::size_t k = 0; k < s.size(); ++k) s[k] = 0.3 * std::max(frictionless.multiplier[k], 0.0);
  return s;
}

struct Row {
  long long dofs = 0;
  int plain = 0, tresca = 0, solves = 0;
  int flat = -1;             ///< 3D: Tresca iterations with the curvature left out of the correction
  double flatSeconds = 0;
  long long coulombIterations = 0;
  double plainSeconds = 0, trescaSeconds = 0, coulombSeconds = 0;
  Index contact = 0, stick = 0, slip = 0;
  bool converged = true;
};

template <int d>
Row measure(int level) {
  Setup<d> setup(level);
  const mesh::Grid& grid = setup.grid;
  ContactProblem<d>& problem = *setup.problem;
  const typename TNNMG<d>::Options o = tnnmgOptions<d>();
  Row r;
  r.dofs = problem.numDofs();
  {
    const auto solver = makeTnnmg<d>(grid, o);
    TNNMG<d>& tnnmg = *solver;
    Eigen::VectorXd u;
    auto t0 = Clock::now();
    const ContactResult c = tnnmg.solve(problem, u);
    r.plainSeconds = since(t0);
    r.plain = c.iterations;
    r.converged = r.converged && c.converged;
    problem.setFriction(trescaBounds(computeContactOutputs(problem, u)));
    Eigen::VectorXd v;
    t0 = Clock::now();
    const ContactResult t = tnnmg.solve(problem, v);
    r.trescaSeconds = since(t0);
    r.tresca = t.iterations;
    r.converged = r.converged && t.converged;
    printHistory("frictionless", level, c);
    printHistory("Tresca", level, t);
  }
  if (d == 3) {  // the same two solves with the curvature of the friction term left out
    typename TNNMG<d>::Options flat = o;
    flat.frictionCurvature = false;
    const auto solver = makeTnnmg<d>(grid, flat);
    TNNMG<d>& tnnmg = *solver;
    const std::vector<double> bounds = problem.slipBounds();
    problem.setFriction({});
    Eigen::VectorXd u, v;
    tnnmg.solve(problem, u);
    problem.setFriction(bounds);
    const auto t0 = Clock::now();
    const ContactResult t = tnnmg.solve(problem, v);
    r.flatSeconds = since(t0);
    r.flat = t.iterations;
    r.converged = r.converged && t.converged;
  }
  {
    TNNMG<d> tnnmg(grid, o);
    Eigen::VectorXd u;
    const auto t0 = Clock::now();
    CoulombOptions co;
    co.mu = 0.3;
    co.tolerance = 1e-8;
    const CoulombResult c = solveCoulomb(problem, tnnmg, u, co);
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

struct BaselineRow {
  long long dofs = 0;
  int iterations[2] = {0, 0};
  double seconds[2] = {0, 0}, peakMB[2] = {0, 0};
  bool converged[2] = {false, false};
  double difference = 0;  ///< ||u_tnnmg - u_pdas|| / ||u_tnnmg||
};

/// The Tresca problem of measure() on `level`, solved by TNNMG (solver 0) or PDAS (1) in a child
/// process; writes iterations, seconds, peak MB, converged and the solution to the pipe.
template <int d>
void baselineChild(int level, int solver, int fd) {
  Setup<d> setup(level);
  const mesh::Grid& grid = setup.grid;
  ContactProblem<d>& problem = *setup.problem;
  const typename TNNMG<d>::Options o = tnnmgOptions<d>();
  {  // the slip bound of measure()
    TNNMG<d> tnnmg(grid, o);
    Eigen::VectorXd u;
    tnnmg.solve(problem, u);
    problem.setFriction(trescaBounds(computeContactOutputs(problem, u)));
  }
  Eigen::VectorXd u;
  ContactResult r;
  const auto t0 = Clock::now();
  try {
    if (solver == 0) {
      TNNMG<d> tnnmg(grid, o);
      r = tnnmg.solve(problem, u);
    } else {
      PrimalDualActiveSet<d> pdas;
      r = pdas.solve(problem, u);
    }
  } catch (const Error& e) {  // a failed solve (e.g. a cycling active set) is a row, not an abort
    std::cerr << "level " << level << ", " << (solver == 0 ? "tnnmg" : "pdas") << ": " << e.what() << "\n";
    r.converged = false;
    r.iterations = -1;
    u.setZero(problem.numDofs());
  }
  const double seconds = since(t0);
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  const double head[4] = {double(r.iterations), seconds, usage.ru_maxrss / 1024.0, r.converged ? 1.0 : 0.0};
  const long long n = u.size();
  if (write(fd, head, sizeof head) != sizeof head || write(fd, &n, sizeof n) != sizeof n ||
      write(fd, u.data(), sizeof(double) * static_cast<std::size_t>(n)) != static_cast<ssize_t>(sizeof(double) * n))
    _exit(3);
  _exit(0);
}

/// Reads exactly `size` bytes from fd (false on a short read).
bool readAll(int fd, void* data, std::size_t size) {
  auto* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t k = read(fd, p, size);
    if (k <= 0) return false;
    p += k;
    size -= static_cast<std::size_t>(k);
  }
  return true;
}

BaselineRow baseline(int level, int dim) {
  BaselineRow row;
  Eigen::VectorXd solutions[2];
  for (int solver = 0; solver < 2; ++solver) {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
    const pid_t pid = fork();
    if (pid == 0) {
      close(fds[0]);
      if (dim == 2) baselineChild<2>(level, solver, fds[1]);
      else baselineChild<3>(level, solver, fds[1]);
    }
    close(fds[1]);
    double head[4];
    long long n = 0;
    if (!readAll(fds[0], head, sizeof head) || !readAll(fds[0], &n, sizeof n))
      throw std::runtime_error("the child of level " + std::to_string(level) + " failed");
    solutions[solver].resize(n);
    if (!readAll(fds[0], solutions[solver].data(), sizeof(double) * static_cast<std::size_t>(n)))
      throw std::runtime_error("the child of level " + std::to_string(level) + " failed");
    close(fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    row.iterations[solver] = static_cast<int>(head[0]);
    row.seconds[solver] = head[1];
    row.peakMB[solver] = head[2];
    row.converged[solver] = head[3] != 0;
    row.dofs = n;
  }
  row.difference = (solutions[0] - solutions[1]).norm() / solutions[0].norm();
  return row;
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
  Setup<d> setup(level);
  ContactProblem<d>& problem = *setup.problem;
  TNNMG<d> tnnmg(setup.grid, tnnmgOptions<d>());
  Eigen::VectorXd u;
  SweepRow r;
  r.mu = mu;
  const auto t0 = Clock::now();
  CoulombOptions co;
  co.mu = mu;
  co.tolerance = 1e-8;
  const CoulombResult c = solveCoulomb(problem, tnnmg, u, co);
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
    std::cerr << "usage: friction OUT.md [--dim 2|3] [--levels A-B] [--baseline] [--mu-sweep LIST] [--cycles N] [--history] [--direct]\n";
    return 2;
  }
  int dim = 2, first = 3, last = 8;
  std::vector<double> mus;
  bool withBaseline = false;
  for (int i = 2; i < argc; ++i)  // the flags without a value
    if (std::string(argv[i]) == "--baseline" || std::string(argv[i]) == "--history" || std::string(argv[i]) == "--direct") {
      (std::string(argv[i]) == "--baseline" ? withBaseline : std::string(argv[i]) == "--history" ? gHistory : gDirect) = true;
      for (int j = i; j + 1 < argc; ++j) argv[j] = argv[j + 1];
      --argc;
      --i;
    }
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--dim") dim = std::stoi(value);
    else if (key == "--cycles") gCycles = std::stoi(value);
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
  if (withBaseline) {
    std::ostringstream table;
    table << "| level | unknowns | TNNMG it | s | MB | PDAS it | s | MB | PDAS / TNNMG time | \\|u_TNNMG - u_PDAS\\| / \\|u\\| |\n"
             "|---|---|---|---|---|---|---|---|---|---|\n";
    for (int level = first; level <= last; ++level) {
      const BaselineRow r = baseline(level, dim);
      const auto its = [&](int k) {
        return r.iterations[k] < 0 ? std::string("failed after") : std::to_string(r.iterations[k]) + (r.converged[k] ? "" : " (not converged)");
      };
      table << std::setprecision(3) << "| " << level << " | " << r.dofs << " | " << its(0) << " | " << r.seconds[0]
            << " | " << r.peakMB[0] << " | " << its(1) << " | " << r.seconds[1] << " | " << r.peakMB[1] << " | "
            << r.seconds[1] / r.seconds[0] << " | ";
      if (r.converged[0] && r.converged[1]) table << r.difference;
      table << " |\n";
      std::cerr << "level " << level << ": TNNMG " << r.seconds[0] << " s, PDAS " << r.seconds[1] << " s\n";
    }
    std::ofstream out(argv[1]);
    out << "Tresca friction, " << dim << "D: TNNMG against the primal-dual active set method with CHOLMOD (bench/friction.cpp)\n\n"
        << table.str();
    return 0;
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
  table << "| level | unknowns | frictionless: it | s | Tresca: it | s | it ratio | "
        << (dim == 3 ? "Tresca, correction without curvature: it | s | " : "")
        << "Coulomb: solves | it per solve | s | contact | stick | slip |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|"
        << (dim == 3 ? "---|---|" : "") << "\n";
  bool ok = true;
  for (int level = first; level <= last; ++level) {
    const Row r = dim == 2 ? measure<2>(level) : measure<3>(level);
    ok = ok && r.converged;
    table << std::setprecision(3) << "| " << level << " | " << r.dofs << " | " << r.plain << " | " << r.plainSeconds
          << " | " << r.tresca << " | " << r.trescaSeconds << " | " << double(r.tresca) / r.plain << " | ";
    if (dim == 3) table << r.flat << " | " << r.flatSeconds << " | ";
    table << r.solves << " | " << double(r.coulombIterations) / r.solves << " | " << r.coulombSeconds << " | "
          << r.contact << " | " << r.stick << " | " << r.slip << " |" << (r.converged ? "" : " not converged") << "\n";
    std::cerr << "level " << level << ": " << r.dofs << " unknowns, " << r.plain << " / " << r.tresca << " it, Coulomb "
              << r.solves << " solves\n";
  }
  std::ofstream out(argv[1]);
  out << "TNNMG with and without friction, " << dim << "D (bench/friction.cpp)\n\n" << table.str();
  return ok ? 0 : 1;
}
