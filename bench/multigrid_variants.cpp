// Hypothesis tests for the tetrahedral V-cycle rates (issue 12): the V-cycle of LinearMultigrid
// written out from MultigridHierarchy's Galerkin operators and transfers (CHOLMOD on level 0), with
// the smoother exchangeable, on the problem of bench/multigrid_rates (unit cube from the n x n x n
// box, bottom clamped, zero right-hand side, random start, rate rho_40 = |e_40|_A / |e_39|_A).
// Variants, one change each against the V-cycle of obs:
//   natural        point-block Gauss-Seidel in the vertex order of the grid (obs' order: the vertices
//                  of level 0, then those created on level 1, ...), forward before and backward
//                  after the coarse correction; reproduces multigrid_rates' V-cycle row
//   lexicographic  the same in lexicographic order of the coordinates (z, then y, then x)
//   random         the same in a random order (fixed seed)
//   point-wise     scalar Gauss-Seidel over the components instead of d x d blocks
//   Jacobi 0.6     damped block Jacobi, omega = 0.6, the same number of sweeps
//   all clamped    natural, with all six faces clamped (full elliptic regularity, no free faces)
// Writes the markdown block "multigrid_variants" (MarkdownBlock.hpp) of OUTPUT.md, or standard output.
//
//   OPENBLAS_NUM_THREADS=1 build/bench/multigrid_variants docs/performance.md --levels 4
// Options: --type tetrahedron|hexahedron (default tetrahedron), --coarse N (default 2; the all-clamped
// variant needs N >= 2 for a free coarse vertex), --levels L (default 4), --smoothing NU (nu1 = nu2,
// may repeat; default 1 and 3), --nu POISSON (default 0.25).
#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "MarkdownBlock.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/MultigridHierarchy.hpp"
#include "obs/obs/Parallel.hpp"

namespace {

using namespace obs;

constexpr int kCycles = 40;

enum class Variant { Natural, Lexicographic, Random, PointWise, Jacobi, AllClamped };
const char* name(Variant v) {
  switch (v) {
    case Variant::Natural: return "natural";
    case Variant::Lexicographic: return "lexicographic";
    case Variant::Random: return "random";
    case Variant::PointWise: return "point-wise";
    case Variant::Jacobi: return "Jacobi 0.6";
    case Variant::AllClamped: return "all clamped";
  }
  return "";
}

/// As multigrid_rates: elasticity, or the scalar Laplacian on each component (trace of the nu = 0
/// elasticity blocks over 4 mu).
BlockSparseMatrix<3> stiffness(const mesh::Mesh& m, bool laplace, double nu) {
  if (!laplace) return assembleStiffness<3>(m, Material{1.0, nu});
  const Material material{1.0, 0.0};
  BlockSparseMatrix<3> A = assembleStiffness<3>(m, material);
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) {
    auto& B = A.blockAt(k);
    B = (B.trace() / (4 * material.mu())) * Eigen::Matrix3d::Identity();
  }
  return A;
}

struct Level {
  const BlockSparseMatrix<3>* A = nullptr;
  std::vector<Index> order;
  std::vector<Eigen::Matrix3d> inverse;  ///< of the diagonal block restricted to the free components
  std::vector<std::uint8_t> bits;        ///< truncated components (finest level)
};

void smooth(const Level& L, Variant v, const Eigen::VectorXd& r, Eigen::VectorXd& x, bool backward) {
  const auto& A = *L.A;
  if (v == Variant::Jacobi) {
    const Eigen::VectorXd y = A * x;
    for (Index p = 0; p < A.rows(); ++p) x.segment<3>(3 * p) += 0.6 * L.inverse[p] * (r - y).segment<3>(3 * p);
    return;
  }
  const auto n = static_cast<Index>(L.order.size());
  for (Index i = 0; i < n; ++i) {
    const Index p = L.order[backward ? n - 1 - i : i];
    if (L.bits[p] == 7) continue;
    Eigen::Vector3d s = r.segment<3>(3 * p);
    for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k) s -= A.blockAt(k) * x.segment<3>(3 * A.column(k));
    if (v == Variant::PointWise) {
      const Eigen::Matrix3d& D = A(p, p);
      for (int c = 0; c < 3; ++c) {
        const int cc = backward ? 2 - c : c;
        if (L.bits[p] & (1u << cc)) continue;
        const double dc = s[cc] / D(cc, cc);
        x[3 * p + cc] += dc;
        s -= D.col(cc) * dc;
      }
    } else {
      x.segment<3>(3 * p) += L.inverse[p] * s;
    }
  }
}

double rate(const mesh::Grid& grid, bool laplace, double nu, int smoothing, Variant v) {
  const mesh::Mesh fm = grid.leafView().mesh;
  BlockSparseMatrix<3> A = stiffness(fm, laplace, nu);
  BoundaryConditions bc;
  std::vector<int> clamped = {mesh::kBottom};
  if (v == Variant::AllClamped) clamped = {mesh::kLeft, mesh::kRight, mesh::kBottom, mesh::kTop, mesh::kFront, mesh::kBack};
  for (int id : clamped) bc.dirichlet.push_back({id, {true, true, true}, [](const Point&) { return Point::Zero(); }});
  const DirichletValues g = collectDirichlet(fm, bc.dirichlet);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(fm.numVertices()) * 3);
  applyDirichlet(A, b, g);
  MultigridHierarchy<3> H(grid);
  H.setFineOperator(A, {}, g.constrained);
  const int L = H.maxLevel();
  std::vector<Level> levels(L + 1);
  std::mt19937 shuffle(7);
  for (int l = 1; l <= L; ++l) {
    Level& lv = levels[l];
    lv.A = l == L ? &A : &H.coarseOperator(l);
    const Index n = lv.A->rows();
    lv.bits = l == L ? H.truncationBits() : std::vector<std::uint8_t>(n, 0);
    lv.inverse.resize(n);
    for (Index p = 0; p < n; ++p) {
      Eigen::Matrix3d D = (*lv.A)(p, p);
      for (int c = 0; c < 3; ++c)
        if (lv.bits[p] & (1u << c)) {
          D.row(c).setZero();
          D.col(c).setZero();
          D(c, c) = 1;
        }
      lv.inverse[p] = D.inverse();
      for (int c = 0; c < 3; ++c)
        if (lv.bits[p] & (1u << c)) {
          lv.inverse[p].row(c).setZero();
          lv.inverse[p].col(c).setZero();
        }
    }
    lv.order.resize(n);
    std::iota(lv.order.begin(), lv.order.end(), Index{0});
    if (v == Variant::Lexicographic) {
      const mesh::Mesh m = l == L ? fm : grid.levelView(l).mesh;
      std::sort(lv.order.begin(), lv.order.end(), [&](Index a, Index c) {
        const Point &x = m.vertex(a), &y = m.vertex(c);
        if (x[2] != y[2]) return x[2] < y[2];
        if (x[1] != y[1]) return x[1] < y[1];
        return x[0] < y[0];
      });
    } else if (v == Variant::Random) {
      std::shuffle(lv.order.begin(), lv.order.end(), shuffle);
    }
  }
  const CholmodSolver coarse(H.coarseOperator(0));
  std::vector<Eigen::VectorXd> rhs(L + 1), sol(L + 1), defect(L + 1);
  auto cycle = [&](auto&& self, int l, const Eigen::VectorXd& r, Eigen::VectorXd& x) -> void {
    if (l == 0) {
      coarse.solve(r, x);
      return;
    }
    x.setZero(r.size());
    for (int s = 0; s < smoothing; ++s) smooth(levels[l], v, r, x, false);
    defect[l] = r - *levels[l].A * x;  // truncated rows are removed by the restriction
    H.restrict(l - 1, defect[l], rhs[l - 1]);
    self(self, l - 1, rhs[l - 1], sol[l - 1]);
    H.prolongateAdd(l - 1, sol[l - 1], x);
    for (int s = 0; s < smoothing; ++s) smooth(levels[l], v, r, x, true);
  };
  std::mt19937 gen(12345);
  std::uniform_real_distribution<double> uni(-1, 1);
  Eigen::VectorXd x(b.size()), r, c;
  for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = g.constrained[i] ? 0.0 : uni(gen);
  double previous = std::sqrt(A.energy(x)), current = previous;
  for (int k = 1; k <= kCycles; ++k) {
    r = -(A * x);
    for (Eigen::Index i = 0; i < x.size(); ++i)
      if (g.constrained[i]) r[i] = 0;
    cycle(cycle, L, r, c);
    x += c;
    previous = current;
    current = std::sqrt(A.energy(x));
  }
  return current / previous;
}

}  // namespace

int main(int argc, char** argv) {
  std::string page;
  mesh::CellType type = mesh::CellType::Tetrahedron;
  int coarse = 2, levels = 4;
  double nu = 0.25;
  std::vector<int> smoothing;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const bool more = i + 1 < argc;
      if (a == "--type" && more) {
        const std::string t = argv[++i];
        if (t == "tetrahedron") type = mesh::CellType::Tetrahedron;
        else if (t == "hexahedron") type = mesh::CellType::Hexahedron;
        else throw std::invalid_argument("unknown type " + t);
      } else if (a == "--coarse" && more) {
        coarse = std::stoi(argv[++i]);
      } else if (a == "--levels" && more) {
        levels = std::stoi(argv[++i]);
      } else if (a == "--smoothing" && more) {
        smoothing.push_back(std::stoi(argv[++i]));
      } else if (a == "--nu" && more) {
        nu = std::stod(argv[++i]);
      } else if (a.rfind("--", 0) != 0 && page.empty()) {
        page = a;
      } else {
        throw std::invalid_argument("unknown argument " + a);
      }
    }
    if (coarse < 2 || levels < 1) throw std::invalid_argument("--coarse >= 2 and --levels >= 1 required");
  } catch (const std::exception& e) {
    std::cerr << "multigrid_variants: " << e.what() << "\n";
    return 2;
  }
  if (smoothing.empty()) smoothing = {1, 3};
  obs::setThreads(1);
  std::ostringstream md;
  md << "V-cycle rates rho_" << kCycles << " with one change each (bench/multigrid_variants.cpp), " << mesh::name(type)
     << ", unit cube from the " << coarse << " x " << coarse << " x " << coarse
     << " box, bottom clamped unless noted; elasticity E = 1, nu = " << nu << ".\n\n| problem | smoother | V(nu,nu) |";
  for (int l = 1; l <= levels; ++l) md << " L = " << l << " |";
  md << "\n|---|---|---|";
  for (int l = 1; l <= levels; ++l) md << "---|";
  md << "\n";
  const std::vector<Variant> variants = {Variant::Natural,   Variant::Lexicographic, Variant::Random,
                                         Variant::PointWise, Variant::Jacobi,        Variant::AllClamped};
  for (const bool laplace : {false, true})
    for (const int s : smoothing)
      for (const Variant v : variants) {
        mesh::Grid grid(mesh::boxMesh(type, coarse));
        md << "| " << (laplace ? "Laplace" : "elasticity") << " | " << name(v) << " | " << s << " |";
        for (int l = 1; l <= levels; ++l) {
          grid.refineUniformly();
          const double rho = rate(grid, laplace, nu, s, v);
          std::cerr << (laplace ? "Laplace" : "elasticity") << " " << name(v) << " V(" << s << "," << s << ") L = " << l
                    << ": rho_" << kCycles << " " << rho << std::endl;
          md << " " << std::fixed << std::setprecision(3) << rho << " |";
        }
        md << "\n";
      }
  return obs::bench::emitMarkdownBlock(page, "multigrid_variants", md.str());
}
