// Contact solver comparison: TNNMG, the primal-dual active set method with CHOLMOD (PDAS) and
// projected Gauss-Seidel (PGS) on the thesis' punch (Example 1, 2D quadrilaterals) and Hertz problem
// (Example 3, 3D hexahedra and tetrahedra) at increasing uniform refinement, plus one linear
// multigrid solve of the same size without contact (punch, Hertz: the contact boundary clamped instead;
// step-42: the ball's indentation profile min(g, 0) prescribed as the vertical displacement). Per run:
// unknowns, iterations, wall time, peak memory. Each run is a child process (fork), so the peak
// resident set size (getrusage ru_maxrss) is that of the run alone: problem assembly plus solver.
// Writes a markdown table (docs/performance.md keeps the figures); progress goes to stderr.
//
// Sample runs:
//   build/bench/contact_solvers perf.md                       # modest sizes, under a minute
//   build/bench/contact_solvers perf.md --punch-levels 2-8 --hertz-levels 1-5   # long
// Options:
//   --punch-levels a-b     uniform levels of the punch (coarse grid 4 x 4 quadrilaterals), default 2-5
//   --hertz-levels a-b     uniform levels of the Hertz problem (coarse 2 x 2 x 2 cubes), default 1-3
//   --hertz-coarse n       coarse Hertz grid n x n x n cubes (default 2; n = 3 with level 4 gives the
//                          352,947 unknowns of the dolfinx reference run)
//   --hertz-types list     hexahedron,tetrahedron (default both)
//   --step42-levels a-b    the linear-elastic step-42 peer case (unit cube, ball R = 0.6 at
//                          (0.5, 0.5, 1.59), E = 2e5, nu = 0.3; coarse 2^3 hexahedra), default: not run
//   --solvers list         tnnmg,pdas,pgs,mg (default all)
//   --pdas-max-dofs-2d N   skip PDAS above N unknowns in 2D (default 2500000)
//   --pdas-max-dofs-3d N   skip PDAS above N unknowns in 3D (default 200000)
//   --pgs-max-iterations N, --pgs-max-seconds S   PGS caps (default 2000, 60): reported as not converged
//   --tolerance t          relative energy-norm correction of the iterative solvers (default 1e-10)
//   --cycle-index k        1: V-cycles (default), 2: W-cycles, in TNNMG's linear correction and "mg"
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <tuple>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;
using Clock = std::chrono::steady_clock;

namespace {

const Material kMaterial{3e5, 0.25};  // docs/theory.md#analytic-references

struct Settings {
  int punchFrom = 2, punchTo = 5, hertzFrom = 1, hertzTo = 3, hertzCoarse = 2;
  int step42From = 1, step42To = 0;  // not run by default
  std::vector<CellType> hertzTypes{CellType::Hexahedron, CellType::Tetrahedron};
  std::vector<std::string> solvers{"tnnmg", "pdas", "pgs", "mg"};
  long long pdasMax2D = 2500000, pdasMax3D = 200000;
  int pgsMaxIterations = 2000;
  double pgsMaxSeconds = 60;
  double tolerance = 1e-10;
  int cycleIndex = 1;  ///< --cycle-index: 1 V-cycles, 2 W-cycles (TNNMG's correction and "mg")
};

/// What a child process reports back through the pipe.
struct Measurement {
  bool ran = false, converged = false, failed = false;
  int iterations = 0;
  long long dofs = 0, active = 0;
  double seconds = 0, setupSeconds = 0, totalSeconds = 0, energy = 0, kkt = 0;
  double rssBeforeMB = 0, peakMB = 0;
  int operatorUpdates = 0;
  char message[160] = {};
};

double rssMB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Small problems are solved three times and the fastest time is reported (timer noise).
int repeats(long long dofs) { return dofs < 50000 ? 3 : 1; }

/// Runs f in a child process and returns its measurement with the child's peak memory.
template <class F>
Measurement isolated(F f) {
  int fd[2];
  if (pipe(fd) != 0) throw std::runtime_error("pipe failed");
  std::cout.flush();
  std::cerr.flush();
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    const auto start = Clock::now();
    Measurement m;
    try {
      m = f();
    } catch (const std::exception& e) {
      m.failed = true;
      std::snprintf(m.message, sizeof m.message, "%s", e.what());
    }
    m.ran = true;
    m.totalSeconds = since(start);
    m.peakMB = rssMB();
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

/// The problems, on the leaf view of a uniformly refined grid: the punch (d = 2), the Hertz problem and
/// the linear-elastic step-42 peer case (d = 3).
enum class Problem { Punch, Hertz, Step42 };

template <int d>
struct Setup {
  mesh::Grid grid;
  mesh::Mesh mesh;
  Material material = kMaterial;
  std::unique_ptr<Obstacle> obstacle;
  BoundaryConditions bc;
  std::optional<ContactSet> contact;
  std::optional<ContactProblem<d>> problem;
  int contactBoundary = mesh::kBottom;

  Setup(Problem which, CellType type, int coarse, int level) : grid(mesh::boxMesh(type, coarse)) {
    for (int l = 0; l < level; ++l) grid.refineUniformly();
    mesh = grid.leafView().mesh;
    const auto fixed = [](const Point&) { return Point::Zero(); };
    if (which == Problem::Punch) {  // g = 0 on x in [0.4375, 0.5625], direction -e_y (docs/theory.md#analytic-references)
      bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, -0.01, 0); }});
      obstacle = std::make_unique<StripObstacle>(Point(0.5, 0, 0), 0.0625, Point(0, -1, 0));
    } else if (which == Problem::Hertz) {  // rigid ball R = 0.75 touching (0.5, 0.5, 0) (docs/theory.md#analytic-references)
      bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, 0, -0.005); }});
      obstacle = std::make_unique<BallObstacle>(Point(0.5, 0.5, -0.75), 0.75);
    } else {  // step-42, linear elastic: ball R = 0.6 at (0.5, 0.5, 1.59) pressed 0.01 into the top face
      material = Material{2e5, 0.3};
      bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, fixed});
      for (int side : {mesh::kLeft, mesh::kRight, mesh::kFront, mesh::kBack})
        bc.dirichlet.push_back({side, {true, true, false}, fixed});
      obstacle = std::make_unique<BallObstacle>(Point(0.5, 0.5, 1.59), 0.6, Point::UnitZ());
      contactBoundary = mesh::kTop;
    }
  }
  void assemble() {
    contact.emplace(mesh, contactBoundary, *obstacle);
    problem.emplace(mesh, material, bc, *contact);
  }
};

template <int d>
Measurement runSolver(Problem which, CellType type, int coarse, int level, const std::string& solver,
                      const Settings& s) {
  Setup<d> setup(which, type, coarse, level);
  Measurement m;
  if (solver == "mg") {
    // the same mesh and data, the contact boundary clamped instead of the obstacle
    BoundaryConditions bc = setup.bc;
    if (which == Problem::Step42) {  // the ball's indentation profile prescribed on the top face
      const Obstacle* ball = setup.obstacle.get();
      bc.dirichlet.push_back({mesh::kTop, {false, false, true},
                              [ball](const Point& x) { return Point(0, 0, std::min(ball->gap(x), 0.0)); }});
    } else {
      bc.dirichlet.push_back({setup.contactBoundary, {true, true, true}, [](const Point&) { return Point::Zero(); }});
    }
    BlockSparseMatrix<d> A = assembleStiffness<d>(setup.mesh, setup.material);
    Eigen::VectorXd b = assembleLoad<d>(setup.mesh, bc);
    const DirichletValues g = collectDirichlet(setup.mesh, bc.dirichlet);
    applyDirichlet(A, b, g);
    A.shareRepeatedBlocks();  // as the contact problem's operator that TNNMG works on
    m.dofs = A.rows() * d;
    m.rssBeforeMB = rssMB();
    LinearMultigridOptions o;
    o.tolerance = s.tolerance;
    o.cycleIndex = s.cycleIndex;
    auto t0 = Clock::now();
    LinearMultigrid<d> mg(setup.grid, o);
    m.setupSeconds = since(t0);
    LinearSolverResult r;
    m.seconds = 1e300;
    for (int k = 0; k < repeats(m.dofs); ++k) {
      t0 = Clock::now();
      mg.setOperator(A);
      mg.truncate(g.constrained);
      Eigen::VectorXd x;
      r = mg.solve(b, x);
      m.seconds = std::min(m.seconds, since(t0));
    }
    m.iterations = r.iterations;
    m.converged = r.converged;
    return m;
  }
  setup.assemble();
  const ContactProblem<d>& problem = *setup.problem;
  m.dofs = problem.numDofs();
  m.rssBeforeMB = rssMB();
  Eigen::VectorXd u;
  ContactResult r;
  if (solver == "tnnmg") {
    typename TNNMG<d>::Options o;
    o.tolerance = s.tolerance;
    o.multigrid.cycleIndex = s.cycleIndex;
    auto t0 = Clock::now();
    TNNMG<d> tnnmg(setup.grid, o);
    m.setupSeconds = since(t0);
    m.seconds = 1e300;
    for (int k = 0; k < repeats(m.dofs); ++k) {
      u.resize(0);
      t0 = Clock::now();
      r = tnnmg.solve(problem, u);
      m.seconds = std::min(m.seconds, since(t0));
    }
    m.operatorUpdates = tnnmg.statistics().operatorUpdates;
  } else if (solver == "pdas") {
    PrimalDualActiveSet<d> pdas;
    m.seconds = 1e300;
    for (int k = 0; k < repeats(m.dofs); ++k) {
      u.resize(0);
      const auto t0 = Clock::now();
      r = pdas.solve(problem, u);
      m.seconds = std::min(m.seconds, since(t0));
    }
  } else {  // pgs, in chunks (restarting from the last iterate) so that the time cap can be checked
    typename ProjectedGaussSeidel<d>::Options o;
    o.tolerance = s.tolerance;
    o.stagnationIterations = s.pgsMaxIterations + 1;
    const auto t0 = Clock::now();
    int done = 0, chunk = 20;
    while (done < s.pgsMaxIterations) {
      o.maxIterations = std::min(chunk, s.pgsMaxIterations - done);
      ProjectedGaussSeidel<d> pgs(o);
      r = pgs.solve(problem, u);
      done += r.iterations;
      const double elapsed = since(t0);
      if (r.converged || elapsed >= s.pgsMaxSeconds) break;
      // the next chunk as large as the remaining time allows (few restarts)
      chunk = static_cast<int>(std::clamp((s.pgsMaxSeconds - elapsed) / (elapsed / done), 10.0, 1e9));
    }
    m.seconds = since(t0);
    r.iterations = done;
  }
  m.iterations = r.iterations;
  m.converged = r.converged;
  m.energy = problem.energy(u);
  m.kkt = r.kkt.max();
  m.active = r.activeSetSize;
  return m;
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string cell(const Measurement& m, bool withIterations = true) {
  if (!m.ran) return withIterations ? "– | – | –" : "– | –";
  if (m.failed) return "failed | | ";
  std::string it = std::to_string(m.iterations) + (m.converged ? "" : " (not conv.)");
  return (withIterations ? it + " | " : std::string()) + fmt("%.3g", m.seconds) + " | " + fmt("%.0f", m.peakMB);
}

bool has(const std::vector<std::string>& list, const std::string& s) {
  return std::find(list.begin(), list.end(), s) != list.end();
}

template <int d>
void study(const std::string& title, Problem which, CellType type, int coarse, int from, int to, const Settings& s,
           std::ostream& md) {
  md << "### " << title << "\n\n"
     << "| level | unknowns | active | TNNMG it | TNNMG s | TNNMG MB | TNNMG run s | updates | PDAS it | PDAS s | PDAS MB "
        "| PGS it | PGS s | PGS MB | MG it | MG s | MG MB | TNNMG / MG | PDAS / TNNMG | energy diff |\n"
     << "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (int level = from; level <= to; ++level) {
    std::map<std::string, Measurement> res;
    const long long pdasMax = d == 2 ? s.pdasMax2D : s.pdasMax3D;
    long long dofs = 0;
    for (const std::string solver : {"tnnmg", "mg", "pdas", "pgs"}) {
      if (!has(s.solvers, solver)) continue;
      if (solver == "pdas" && dofs > pdasMax) continue;
      std::cerr << title << " level " << level << ": " << solver << " ..." << std::flush;
      res[solver] = isolated([&] { return runSolver<d>(which, type, coarse, level, solver, s); });
      const Measurement& m = res[solver];
      if (m.dofs > 0) dofs = m.dofs;
      std::cerr << " " << (m.failed ? std::string("failed: ") + m.message
                                     : std::to_string(m.iterations) + " it, " + fmt("%.3g", m.seconds) + " s, " +
                                           fmt("%.0f", m.peakMB) + " MB")
                << "\n";
    }
    if (dofs == 0 && res.count("pdas")) dofs = res["pdas"].dofs;
    const Measurement &t = res["tnnmg"], &p = res["pdas"], &g = res["pgs"], &mg = res["mg"];
    auto ratio = [](const Measurement& a, const Measurement& b) {
      return a.ran && b.ran && !a.failed && !b.failed && b.seconds > 0 ? fmt("%.2f", a.seconds / b.seconds)
                                                                       : std::string("–");
    };
    std::string ediff = "–";
    if (t.ran && p.ran && !t.failed && !p.failed)
      ediff = fmt("%.1e", std::abs(t.energy - p.energy) / std::max(std::abs(p.energy), 1e-300));
    md << "| " << level << " | " << dofs << " | " << (t.ran ? std::to_string(t.active) : std::string("–")) << " | "
       << cell(t) << " | " << (t.ran && !t.failed ? fmt("%.3g", t.totalSeconds) : std::string("–")) << " | "
       << (t.ran ? std::to_string(t.operatorUpdates) : std::string("–")) << " | " << cell(p)
       << " | " << cell(g) << " | " << cell(mg) << " | " << ratio(t, mg) << " | " << ratio(p, t) << " | " << ediff
       << " |\n";
  }
  md << "\n";
}

std::pair<int, int> parseRange(const std::string& v) {
  const auto dash = v.find('-');
  if (dash == std::string::npos) return {std::stoi(v), std::stoi(v)};
  return {std::stoi(v.substr(0, dash)), std::stoi(v.substr(dash + 1))};
}

std::vector<std::string> parseList(const std::string& v) {
  std::vector<std::string> out;
  std::stringstream ss(v);
  for (std::string item; std::getline(ss, item, ',');) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  std::string output;
  std::ostringstream command;
  command << "build/bench/contact_solvers";
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      command << " " << a;
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::runtime_error("missing value after " + a);
        command << " " << argv[i + 1];
        return argv[++i];
      };
      if (a == "--punch-levels") std::tie(s.punchFrom, s.punchTo) = parseRange(value());
      else if (a == "--hertz-levels") std::tie(s.hertzFrom, s.hertzTo) = parseRange(value());
      else if (a == "--hertz-coarse") s.hertzCoarse = std::stoi(value());
      else if (a == "--step42-levels") std::tie(s.step42From, s.step42To) = parseRange(value());
      else if (a == "--hertz-types") {
        s.hertzTypes.clear();
        for (const auto& t : parseList(value()))
          if (t == "hexahedron") s.hertzTypes.push_back(CellType::Hexahedron);
          else if (t == "tetrahedron") s.hertzTypes.push_back(CellType::Tetrahedron);
          else throw std::runtime_error("unknown type " + t);
      } else if (a == "--solvers") s.solvers = parseList(value());
      else if (a == "--pdas-max-dofs-2d") s.pdasMax2D = std::stoll(value());
      else if (a == "--pdas-max-dofs-3d") s.pdasMax3D = std::stoll(value());
      else if (a == "--pgs-max-iterations") s.pgsMaxIterations = std::stoi(value());
      else if (a == "--pgs-max-seconds") s.pgsMaxSeconds = std::stod(value());
      else if (a == "--tolerance") s.tolerance = std::stod(value());
      else if (a == "--cycle-index") {
        s.cycleIndex = std::stoi(value());
        if (s.cycleIndex != 1 && s.cycleIndex != 2) throw std::runtime_error("--cycle-index must be 1 (V) or 2 (W)");
      }
      else if (!a.starts_with("-") && output.empty()) output = a;
      else throw std::runtime_error("unknown argument " + a);
    }
    if (output.empty()) throw std::runtime_error("no output file given");
  } catch (const std::exception& e) {
    std::cerr << "contact_solvers: " << e.what() << "\nusage: contact_solvers OUTPUT.md [options] (see the source header)\n";
    return 2;
  }

  std::ostringstream md;
  md << "Generated by `" << command.str() << "` (" << sysconf(_SC_NPROCESSORS_ONLN) << " cores; the obs solvers "
     << "are single-threaded, CHOLMOD uses OpenBLAS, which may use all cores). Tolerance " << s.tolerance
     << " (relative energy-norm correction) for TNNMG, PGS and MG; PDAS stops at a repeated active set. Time: "
        "wall seconds of the solve (TNNMG: the whole solve() including its setup; MG: setOperator, "
        "truncate and solve; neither includes building the grid hierarchy; fastest of 3 runs below 5e4 "
        "unknowns); TNNMG run s: the whole TNNMG run from nothing (grid refinement, assembly, contact set, "
        "hierarchy, solve; all 3 repeats below 5e4 "
        "unknowns); MB: peak resident "
        "memory of the run (assembly + solver, one process per run); updates: coarse-operator "
        "recomputations; energy diff: |J(TNNMG) - J(PDAS)| / |J(PDAS)|; –: not run.\n\n";
  if (s.punchFrom <= s.punchTo)
    study<2>("Punch (2D, quadrilaterals, coarse 4 x 4)", Problem::Punch, CellType::Quadrilateral, 4, s.punchFrom,
             s.punchTo, s, md);
  const std::string c = std::to_string(s.hertzCoarse);
  for (CellType t : s.hertzTypes)
    if (s.hertzFrom <= s.hertzTo)
      study<3>("Hertz (3D, " + std::string(mesh::name(t)) + ", coarse " + c + " x " + c + " x " + c + ")",
               Problem::Hertz, t, s.hertzCoarse, s.hertzFrom, s.hertzTo, s, md);
  if (s.step42From <= s.step42To)
    study<3>("step-42 peer case (3D, hexahedron, coarse 2 x 2 x 2; level 5 = 64^3)", Problem::Step42,
             CellType::Hexahedron, 2, s.step42From, s.step42To, s, md);
  std::ofstream out(output);
  out << md.str();
  if (!out) {
    std::cerr << "contact_solvers: cannot write " << output << "\n";
    return 1;
  }
  std::cout << md.str();
  return 0;
}
