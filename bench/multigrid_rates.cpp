// Asymptotic convergence rates of the linear multigrid cycle over uniform levels (issue 12: "the
// tetrahedral V-cycle rate grows with the level"). Unit cube from the n x n x n box (tetrahedra: six
// Kuhn tetrahedra per block), bottom face z = 0 clamped, the other faces free, refined uniformly L
// times (L + 1 grid levels). Problems: linear elasticity (E = 1, nu as given), or the scalar Laplacian
// (the P1/Q1 stiffness of grad u . grad v, applied to each of the three components alone, so the
// same block solver runs it). Zero right-hand side and a random start (uniform in [-1, 1], fixed
// seed): the iterate is the error e_k. The rate is the single-cycle reduction after K = 40 cycles,
//     rho_K = ||e_K||_A / ||e_K-1||_A.
// The cycle (nu forward sweeps before, nu backward sweeps after the coarse correction) is symmetric
// in the energy inner product, so rho_k is non-decreasing in k and converges to the spectral radius
// of the error propagator from below: rho_K is a lower bound that is sharp once the slowest mode
// dominates (the geometric mean over cycles 21..40 is printed on standard error as a check).
// The cycle is LinearMultigrid's (point-block Gauss-Seidel, CHOLMOD on level 0, Galerkin coarse
// operators). With --two-grid the same smoothing on the finest level is combined with an exact
// (CHOLMOD) solve of the Galerkin operator of level L - 1: the two-grid method, which separates the
// rate of one grid transfer from the accumulation over the levels of the V-cycle.
//
// With --check, per level it also reports the checks of the transfer and the grid: the largest
// deviation of the prolongation from the exact interpolation of the coordinates (P x_c = x_f for a
// linear function), the largest entry of A_l - (rediscretised stiffness of level view l) relative to
// the largest entry (nested P1/Q1 spaces: round-off), the number of cells, and for tetrahedra the
// smallest dihedral angle, the largest ratio longest edge / inradius and the number of shape classes
// (sorted edge lengths relative to the longest, to 1e-9) of the level's cells.
//
// Writes the markdown block "multigrid_rates" (with --w "multigrid_rates-w"; MarkdownBlock.hpp) of
// OUTPUT.md, or standard output.
//
//   OPENBLAS_NUM_THREADS=1 build/bench/multigrid_rates OUT.md --coarse 1 --levels 5 --two-grid --check
// (docs/performance.md#tetrahedral-multigrid-rates summarises the table; the full one of the last run
// is kept in docs/performance-history.md)
// Options: --type tetrahedron|hexahedron (may repeat; default both), --problem elasticity|laplace
// (may repeat; default both), --coarse N (box blocks per direction, default 1), --levels L (largest
// number of refinements, default 4), --smoothing NU (nu1 = nu2, may repeat; default 1 and 3), --nu
// POISSON (default 0.25), --w (W-cycles), --two-grid (also the two-grid rates), --check.
#include <Eigen/Dense>
#include <Eigen/Sparse>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "MarkdownBlock.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultigridHierarchy.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/TruncatedGaussSeidel.hpp"

namespace {

using namespace obs;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr int kFirst = 20, kLast = 40;

enum class Problem { Elasticity, Laplace };
const char* name(Problem p) { return p == Problem::Elasticity ? "elasticity" : "Laplace"; }

/// The fine operator: elasticity, or the scalar Laplacian on each component. The diagonal blocks of
/// the nu = 0 elasticity stiffness are mu (grad u . grad v + d_i u d_i v) for component i, so their
/// trace is 4 mu grad u . grad v.
BlockSparseMatrix<3> stiffness(const mesh::Mesh& m, Problem problem, double nu) {
  if (problem == Problem::Elasticity) return assembleStiffness<3>(m, Material{1.0, nu});
  const Material material{1.0, 0.0};
  BlockSparseMatrix<3> A = assembleStiffness<3>(m, material);
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) {
    auto& B = A.blockAt(k);
    const double s = B.trace() / (4 * material.mu());
    B = s * Eigen::Matrix3d::Identity();
  }
  return A;
}

struct Rate {
  double rate = 0, mean = 0, seconds = 0;
  long long unknowns = 0;
};

/// rho_K and the geometric mean over cycles kFirst + 1 .. kLast of x <- x + cycle(-A x) from a random
/// start (zero at the clamped components).
template <class Cycle>
Rate iterate(const BlockSparseMatrix<3>& A, const DirichletValues& g, Cycle&& cycle) {
  std::mt19937 gen(12345);
  std::uniform_real_distribution<double> uni(-1, 1);
  Eigen::VectorXd x(static_cast<Eigen::Index>(A.rows()) * 3), r, c;
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = g.constrained[i] ? 0.0 : uni(gen);
  const auto t0 = Clock::now();
  std::vector<double> e{std::sqrt(A.energy(x))};
  for (int k = 1; k <= kLast; ++k) {
    r = -(A * x);
    for (Eigen::Index i = 0; i < x.size(); ++i)
      if (g.constrained[i]) r[i] = 0;
    cycle(r, c);
    x += c;
    e.push_back(std::sqrt(A.energy(x)));
  }
  Rate out;
  out.seconds = since(t0) / kLast;
  out.rate = e[kLast] / e[kLast - 1];
  out.mean = std::pow(e[kLast] / e[kFirst], 1.0 / (kLast - kFirst));
  out.unknowns = static_cast<long long>(x.size() - g.count());
  return out;
}

/// The fine problem: the operator with the clamped bottom eliminated (applyDirichlet) and the mask.
struct FineProblem {
  BlockSparseMatrix<3> A;
  DirichletValues g;
};

FineProblem fineProblem(const mesh::Grid& grid, Problem problem, double nu) {
  const mesh::Mesh m = grid.leafView().mesh;
  FineProblem f{stiffness(m, problem, nu), {}};
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, [](const Point&) { return Point::Zero(); }});
  f.g = collectDirichlet(m, bc.dirichlet);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m.numVertices()) * 3);
  applyDirichlet(f.A, b, f.g);
  return f;
}

Rate measure(const mesh::Grid& grid, Problem problem, double nu, int smoothing, int cycleIndex) {
  const FineProblem f = fineProblem(grid, problem, nu);
  LinearMultigridOptions o;
  o.preSmoothing = o.postSmoothing = smoothing;
  o.cycleIndex = cycleIndex;
  LinearMultigrid<3> mg(grid, o);
  mg.setOperator(f.A);
  mg.truncate(f.g.constrained);
  return iterate(f.A, f.g, [&](const Eigen::VectorXd& r, Eigen::VectorXd& c) { mg.vcycle(r, c); });
}

/// The two-grid method: the V-cycle's smoothing on the finest level, an exact solve on level L - 1.
Rate measureTwoGrid(const mesh::Grid& grid, Problem problem, double nu, int smoothing) {
  const FineProblem f = fineProblem(grid, problem, nu);
  MultigridHierarchy<3> H(grid);
  H.setFineOperator(f.A, {}, f.g.constrained);
  const int L = H.maxLevel();
  TruncatedGaussSeidel<3> smoother;
  smoother.setMatrix(f.A, &H.truncationBits(), "the fine operator");
  const CholmodSolver coarse(H.coarseOperator(L - 1));
  Eigen::VectorXd d, dc, xc;
  return iterate(f.A, f.g, [&](const Eigen::VectorXd& r, Eigen::VectorXd& x) {
    x.setZero(r.size());
    for (int s = 0; s < smoothing; ++s) smoother.sweep(r, x, false);
    d = r - f.A * x;  // the truncated rows are removed by the restriction
    H.restrict(L - 1, d, dc);
    coarse.solve(dc, xc);
    H.prolongateAdd(L - 1, xc, x);
    for (int s = 0; s < smoothing; ++s) smoother.sweep(r, x, true);
  });
}

// ---- checks ------------------------------------------------------------------------------------

Eigen::SparseMatrix<double> scalarSparse(const BlockSparseMatrix<3>& A) {
  std::vector<Eigen::Triplet<double>> t;
  for (Index p = 0; p < A.rows(); ++p)
    for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) t.emplace_back(3 * p + i, 3 * A.column(k) + j, A.blockAt(k)(i, j));
  Eigen::SparseMatrix<double> S(3 * A.rows(), 3 * A.rows());
  S.setFromTriplets(t.begin(), t.end());
  return S;
}

struct Check {
  int level = 0;
  double interpolation = 0;  ///< max |P x_c - x_f| over the vertices of level l + 1
  double galerkin = -1;      ///< max |A_l - K_l| / max |K_l| (level l < L)
  double minAngle = 0, maxAspect = 0;
  int classes = 0;
  long long cells = 0, tetrahedra = 0;
};

double dihedralMin(const std::array<Point, 4>& x) {
  double best = 180;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) {
      int o[2], n = 0;
      for (int k = 0; k < 4; ++k)
        if (k != a && k != b) o[n++] = k;
      // the angle along edge ab between the faces (a, b, o0) and (a, b, o1)
      const Point e = (x[b] - x[a]).normalized();
      Point u = x[o[0]] - x[a], v = x[o[1]] - x[a];
      u -= u.dot(e) * e;
      v -= v.dot(e) * e;
      best = std::min(best, std::acos(std::clamp(u.normalized().dot(v.normalized()), -1.0, 1.0)) * 180 / M_PI);
    }
  return best;
}

std::vector<Check> checks(const mesh::Grid& grid, Problem problem, double nu) {
  const int L = grid.maxLevel();
  MultigridHierarchy<3> H(grid);
  const mesh::Mesh fine = grid.leafView().mesh;
  const BlockSparseMatrix<3> A = stiffness(fine, problem, nu);
  H.setFineOperator(A);
  std::vector<Check> out;
  for (int l = 0; l <= L; ++l) {
    Check c;
    c.level = l;
    const mesh::Mesh m = l == L ? fine : grid.levelView(l).mesh;
    if (l < L) {
      const mesh::Mesh mf = l + 1 == L ? fine : grid.levelView(l + 1).mesh;
      const mesh::CsrMatrix& P = H.prolongation(l);
      for (Index r = 0; r < P.rows; ++r) {
        Point y = Point::Zero();
        for (Index k = P.rowStart[r]; k < P.rowStart[r + 1]; ++k) y += P.values[k] * m.vertex(P.columns[k]);
        c.interpolation = std::max(c.interpolation, (y - mf.vertex(r)).norm());
      }
      const Eigen::SparseMatrix<double> K = scalarSparse(stiffness(m, problem, nu));
      const Eigen::SparseMatrix<double> D = scalarSparse(H.coarseOperator(l)) - K;
      double dmax = 0, kmax = 0;
      for (int j = 0; j < D.outerSize(); ++j)
        for (Eigen::SparseMatrix<double>::InnerIterator it(D, j); it; ++it) dmax = std::max(dmax, std::abs(it.value()));
      for (int j = 0; j < K.outerSize(); ++j)
        for (Eigen::SparseMatrix<double>::InnerIterator it(K, j); it; ++it) kmax = std::max(kmax, std::abs(it.value()));
      c.galerkin = dmax / kmax;
    }
    std::set<std::array<long long, 6>> shapes;
    c.minAngle = 180;
    c.cells = m.numCells();
    for (Index e = 0; e < m.numCells(); ++e) {
      if (m.cellType(e) != mesh::CellType::Tetrahedron) continue;
      ++c.tetrahedra;
      const auto v = m.cellVertices(e);
      std::array<Point, 4> x;
      for (int i = 0; i < 4; ++i) x[i] = m.vertex(v[i]);
      std::array<double, 6> len;
      int n = 0;
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) len[n++] = (x[b] - x[a]).norm();
      std::sort(len.begin(), len.end());
      std::array<long long, 6> key;
      for (int i = 0; i < 6; ++i) key[i] = std::llround(len[i] / len[5] * 1e9);
      shapes.insert(key);
      // inradius = 3 V / (sum of the face areas)
      const double V = std::abs((x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0]))) / 6;
      double S = 0;
      for (int f = 0; f < 4; ++f) {
        int o[3], k = 0;
        for (int i = 0; i < 4; ++i)
          if (i != f) o[k++] = i;
        S += 0.5 * (x[o[1]] - x[o[0]]).cross(x[o[2]] - x[o[0]]).norm();
      }
      c.maxAspect = std::max(c.maxAspect, len[5] / (3 * V / S));
      c.minAngle = std::min(c.minAngle, dihedralMin(x));
    }
    c.classes = static_cast<int>(shapes.size());
    out.push_back(c);
  }
  return out;
}

std::string fmt(double v, int digits = 3) { return obs::bench::fixed(v, digits); }

}  // namespace

int main(int argc, char** argv) {
  std::string page;
  std::vector<mesh::CellType> types;
  std::vector<Problem> problems;
  std::vector<int> smoothing;
  int coarse = 1, levels = 4, cycleIndex = 1;
  double nu = 0.25;
  bool check = false, twoGrid = false;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const bool more = i + 1 < argc;
      if (a == "--type" && more) {
        const std::string t = argv[++i];
        if (t == "tetrahedron") types.push_back(mesh::CellType::Tetrahedron);
        else if (t == "hexahedron") types.push_back(mesh::CellType::Hexahedron);
        else throw std::invalid_argument("unknown type " + t);
      } else if (a == "--problem" && more) {
        const std::string p = argv[++i];
        if (p == "elasticity") problems.push_back(Problem::Elasticity);
        else if (p == "laplace") problems.push_back(Problem::Laplace);
        else throw std::invalid_argument("unknown problem " + p);
      } else if (a == "--coarse" && more) {
        coarse = std::stoi(argv[++i]);
      } else if (a == "--levels" && more) {
        levels = std::stoi(argv[++i]);
      } else if (a == "--smoothing" && more) {
        smoothing.push_back(std::stoi(argv[++i]));
      } else if (a == "--nu" && more) {
        nu = std::stod(argv[++i]);
      } else if (a == "--w") {
        cycleIndex = 2;
      } else if (a == "--two-grid") {
        twoGrid = true;
      } else if (a == "--check") {
        check = true;
      } else if (a.rfind("--", 0) != 0 && page.empty()) {
        page = a;
      } else {
        throw std::invalid_argument("unknown argument " + a);
      }
    }
    if (coarse < 1 || levels < 1) throw std::invalid_argument("--coarse and --levels must be >= 1");
    for (int s : smoothing)
      if (s < 1) throw std::invalid_argument("--smoothing must be >= 1");
  } catch (const std::exception& e) {
    std::cerr << "multigrid_rates: " << e.what() << "\n";
    return 2;
  }
  if (types.empty()) types = {mesh::CellType::Tetrahedron, mesh::CellType::Hexahedron};
  if (problems.empty()) problems = {Problem::Elasticity, Problem::Laplace};
  if (smoothing.empty()) smoothing = {1, 3};
  obs::setThreads(1);

  const std::string cycle = cycleIndex == 2 ? "W" : "V";
  std::ostringstream md;
  md << "Rates rho_" << kLast << " = |e_" << kLast << "|_A / |e_" << kLast - 1
     << "|_A (a lower bound of the spectral radius of the cycle, see bench/multigrid_rates.cpp), unit cube from the "
     << coarse << " x " << coarse << " x " << coarse
     << " box, bottom clamped, other faces free, zero right-hand side, random start. Elasticity: E = 1, nu = " << nu
     << ". Level L = L refinements of the box (L + 1 grid levels, " << coarse << " * 2^L cells per edge); "
     << "\"two-grid\" = the same smoothing on level L with an exact solve on level L - 1.\n\n";
  md << "| cells | problem | method |";
  for (int l = 1; l <= levels; ++l) md << " L = " << l << " |";
  md << "\n|---|---|---|";
  for (int l = 1; l <= levels; ++l) md << "---|";
  md << "\n";
  std::ostringstream checkMd;
  for (const auto type : types) {
    struct Series {
      std::string problem, method;
      std::vector<std::string> cells;
    };
    std::vector<Series> rows;
    for (const Problem p : problems)
      for (const int s : smoothing) {
        std::ostringstream nus;
        nus << "(" << s << "," << s << ")";
        rows.push_back({name(p), cycle + nus.str(), {}});
        if (twoGrid) rows.push_back({name(p), "two-grid " + nus.str(), {}});
      }
    std::vector<std::string> unknowns;
    mesh::Grid grid(mesh::boxMesh(type, coarse));
    for (int l = 1; l <= levels; ++l) {
      grid.refineUniformly();
      std::size_t row = 0;
      for (const Problem p : problems)
        for (const int s : smoothing)
          for (int method = 0; method < (twoGrid ? 2 : 1); ++method) {
            const Rate r = method == 0 ? measure(grid, p, nu, s, cycleIndex) : measureTwoGrid(grid, p, nu, s);
            rows[row++].cells.push_back(fmt(r.rate));
            if (row == 1) unknowns.push_back(std::to_string(r.unknowns));
            std::cerr << mesh::name(type) << " " << name(p) << " " << (method == 0 ? cycle : "two-grid ") << "(" << s
                      << "," << s << ") L = " << l << ": " << r.unknowns << " unknowns, rho_" << kLast << " " << r.rate
                      << ", mean over cycles " << kFirst + 1 << ".." << kLast << " " << r.mean << ", " << r.seconds
                      << " s per cycle" << std::endl;
          }
      if (check && l == levels) {
        checkMd << "\n" << mesh::name(type) << ", " << levels << " refinements of the " << coarse << " x " << coarse
                << " x " << coarse << " box (" << name(problems.front()) << "):\n\n"
                << "| level | max abs(P x_c - x_f) | max abs(A_l - K_l) / max abs(K_l) | cells | min dihedral angle | "
                   "max h_max / r_in | shape classes |\n|---|---|---|---|---|---|---|\n";
        for (const Check& c : checks(grid, problems.front(), nu)) {
          std::ostringstream gal, inter;
          gal << std::scientific << std::setprecision(1) << c.galerkin;
          inter << std::scientific << std::setprecision(1) << c.interpolation;
          checkMd << "| " << c.level << " | " << (c.level < levels ? inter.str() : "-") << " | "
                  << (c.galerkin >= 0 ? gal.str() : "-") << " | " << c.cells << " | "
                  << (c.tetrahedra ? fmt(c.minAngle, 2) : "-") << " | " << (c.tetrahedra ? fmt(c.maxAspect, 3) : "-")
                  << " | " << (c.tetrahedra ? std::to_string(c.classes) : "-") << " |\n";
        }
      }
    }
    for (const Series& s : rows) {
      md << "| " << mesh::name(type) << " | " << s.problem << " | " << s.method << " |";
      for (const auto& c : s.cells) md << " " << c << " |";
      md << "\n";
    }
    md << "| " << mesh::name(type) << " | unknowns (" << name(problems.front()) << ") | |";
    for (const auto& u : unknowns) md << " " << u << " |";
    md << "\n";
  }
  const std::string text = md.str() + checkMd.str();
  return obs::bench::emitMarkdownBlock(page, cycleIndex == 2 ? "multigrid_rates-w" : "multigrid_rates", text);
}
