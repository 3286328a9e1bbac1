// The residual estimator (docs/theory.md#residual-estimator): second derivatives on non-affine cells, zero
// estimate for linear fields (patch test on distorted meshes of every cell type, with tractions, pressures,
// rollers and a contact boundary), hand-computed values on a two-triangle mesh, the sum identity
// sum_e eta_e^2 = sum_k eta_k^2 = sum_p eta_p^2, and detection of stale results.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>
#include <span>
#include <string>

#include "obs/estimators/ElementGeometry.hpp"
#include "obs/estimators/ResidualEstimator.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/RedRefinement.hpp"
#include "obs/mesh/ReferenceElement.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/Obstacle.hpp"

using namespace obs;
using namespace obs::estimators;
using mesh::CellType;

namespace {

/// u(x) = a + B x and its (constant) stress.
struct LinearField {
  int dim;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
  Eigen::Vector3d operator()(const Point& x) const { return a + B * x; }
  Eigen::Matrix3d stress(const Material& m) const {
    const Eigen::Matrix3d eps = 0.5 * (B + B.transpose());
    return 2 * m.mu() * eps + m.lambda() * eps.trace() * Eigen::Matrix3d::Identity();
  }
  Eigen::VectorXd interpolate(const mesh::Mesh& m) const {
    Eigen::VectorXd u(m.numVertices() * dim);
    for (Index v = 0; v < m.numVertices(); ++v) u.segment(v * dim, dim) = (*this)(m.vertex(v)).head(dim);
    return u;
  }
};

LinearField randomLinearField(int dim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  LinearField f{dim};
  for (int i = 0; i < dim; ++i) {
    f.a[i] = U(rng);
    for (int j = 0; j < dim; ++j) f.B(i, j) = 0.01 * U(rng);
  }
  return f;
}

Eigen::Vector3d boxNormal(int dim, int id) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[id <= 2 ? 0 : id <= 4 ? dim - 1 : 1] = id % 2 == 0 ? 1.0 : -1.0;
  return n;
}

double sumSquares(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0, [](double s, double x) { return s + x * x; });
}

/// sum_e eta_e^2 = eta^2 = sum_k eta_k^2 = sum_p eta_p^2, and per contribution over cells / vertices.
void expectSumIdentity(const EstimatorResult& r) {
  const double eta2 = r.total * r.total;
  double byContribution = 0;
  for (const Contribution& c : r.contributions) {
    byContribution += c.value * c.value;
    const double cells = sumSquares(r.cellFields.at(c.name));
    const double verts = r.vertexFields.at(c.name).squaredNorm();
    EXPECT_NEAR(cells, c.value * c.value, 1e-12 * std::max(eta2, 1e-300)) << c.name;
    EXPECT_NEAR(verts, c.value * c.value, 1e-12 * std::max(eta2, 1e-300)) << c.name;
  }
  EXPECT_NEAR(sumSquares(r.indicators), eta2, 1e-12 * eta2);
  EXPECT_NEAR(byContribution, eta2, 1e-12 * eta2);
  EXPECT_NEAR(r.vertexFields.at("eta").squaredNorm(), eta2, 1e-12 * eta2);
  for (double e : r.indicators) EXPECT_GE(e, 0.0);
}

class ResidualPatch : public ::testing::TestWithParam<CellType> {};

// eta_1 needs the Hessians of the physical shape functions on non-affine cells: compare them with
// central differences of the physical gradients (d grad / dx = (d grad / dxi) J^{-1}).
TEST_P(ResidualPatch, HessiansMatchFiniteDifferences) {
  const CellType t = GetParam();
  const auto& ref = mesh::referenceElement(t);
  const int d = ref.dim;
  mesh::Mesh m(d);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-0.12, 0.12);
  std::vector<Index> verts;
  for (const Point& x : ref.vertices) {
    Point y = 2.0 * x;
    for (int a = 0; a < d; ++a) y[a] += U(rng);
    verts.push_back(m.addVertex(y));
  }
  m.addCell(t, std::span<const Index>(verts));
  const Point xi = ref.centroid + Point(0.05, -0.03, d == 3 ? 0.04 : 0.0);
  const double delta = 1e-5;
  auto check = [&]<int D>() {
    PointValues<D> pv, plus, minus;
    pv.reinit(m, 0, xi, true);
    const Eigen::Matrix<double, D, D> Jinv = pv.jacobian().inverse();
    double maxError = 0, maxEntry = 0;
    for (int i = 0; i < pv.numVertices(); ++i) {
      Eigen::Matrix<double, D, D> dg;  // dg(a, k) = d (grad phi_i)_a / d xi_k
      for (int k = 0; k < D; ++k) {
        Point e = Point::Zero();
        e[k] = delta;
        plus.reinit(m, 0, xi + e, false);
        minus.reinit(m, 0, xi - e, false);
        dg.col(k) = (plus.gradient(i) - minus.gradient(i)) / (2 * delta);
      }
      const Eigen::Matrix<double, D, D> H = dg * Jinv;
      maxError = std::max(maxError, (H - pv.hessian(i)).cwiseAbs().maxCoeff());
      maxEntry = std::max(maxEntry, pv.hessian(i).cwiseAbs().maxCoeff());
      EXPECT_LT((pv.hessian(i) - pv.hessian(i).transpose()).norm(), 1e-12);
    }
    EXPECT_LT(maxError, 1e-6) << mesh::name(t);
    if (t != CellType::Triangle && t != CellType::Tetrahedron) {
      EXPECT_GT(maxEntry, 1e-3) << "cell not distorted enough to test anything";
    }
  };
  if (d == 2)
    check.template operator()<2>();
  else
    check.template operator()<3>();
}

// The estimators differentiate u_h as a whole on non-affine cells (PointValues with perBasis =
// false: grad u_h = (sum_i u_i gradhat_i') J^{-1} and the component Hessians without the per-basis
// Hessians). Compare with the per-basis sums of the straightforward evaluation (perBasis = true,
// checked against finite differences above) for a random nodal field on a distorted cell, and the
// component Hessians with central differences of the whole-field gradient; on affine cells both
// modes are the same code and must agree bitwise. A cell whose vertices are an affine image of the
// reference vertices (parallel = true: its map is affine) keeps J over its points and drops X.
class WholeField : public ::testing::TestWithParam<std::tuple<CellType, bool>> {};

TEST_P(WholeField, DerivativesMatchPerBasisSums) {
  const CellType t = std::get<0>(GetParam());
  const bool parallel = std::get<1>(GetParam());
  const auto& ref = mesh::referenceElement(t);
  const int d = ref.dim;
  mesh::Mesh m(d);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-0.15, 0.15);
  Eigen::Matrix3d A = 0.5 * Eigen::Matrix3d::Identity();  // a sheared, stretched affine image
  A(0, 1) = 0.11;
  A(1, 2) = -0.07;
  A(2, 0) = 0.05;
  if (d == 2) A.row(2).setZero(), A.col(2).setZero();
  std::vector<Index> verts;
  for (const Point& x : ref.vertices) {
    Point y = A * x + Point(1.0, 2.0, d == 3 ? 3.0 : 0.0);  // away from the origin, as on a mesh
    if (!parallel)
      for (int a = 0; a < d; ++a) y[a] += 0.5 * U(rng);
    verts.push_back(m.addVertex(y));
  }
  m.addCell(t, std::span<const Index>(verts));
  Eigen::VectorXd u(static_cast<Eigen::Index>(verts.size()) * d);
  for (Eigen::Index k = 0; k < u.size(); ++k) u[k] = 1e-3 * U(rng);
  const bool affine = affineCellType(t);
  auto check = [&]<int D>() {
    using Mat = Eigen::Matrix<double, D, D>;
    const auto& rule = mesh::quadratureRule(t, 4);
    double maxH = 0;
    PointValues<D> whole;  // one object over the points: the kept geometry of flat cells is used
    for (std::size_t q = 0; q < rule.size(); ++q) {
      PointValues<D> basis, plus, minus;
      basis.reinit(m, 0, rule.points[q], true, true);
      whole.reinit(m, 0, rule.points[q], true, false);
      EXPECT_TRUE(basis.perBasis());
      EXPECT_EQ(whole.perBasis(), affine);
      EXPECT_EQ(whole.flat(), parallel && !affine) << mesh::name(t);
      if (whole.flat()) {
        EXPECT_NEAR(whole.determinant(), basis.determinant(), 1e-14 * basis.determinant());
      } else {
        EXPECT_EQ(whole.determinant(), basis.determinant());
      }
      const Mat G0 = basis.fieldGradient(u, verts), G1 = whole.fieldGradient(u, verts);
      std::array<Mat, D> H0, H1;
      basis.fieldHessians(u, verts, H0);
      whole.fieldHessians(u, verts, H1);
      Mat sum = Mat::Zero();  // the per-basis sum written out
      for (int i = 0; i < basis.numVertices(); ++i)
        sum += u.template segment<D>(verts[i] * D) * basis.gradient(i).transpose();
      EXPECT_EQ((G0 - sum).cwiseAbs().maxCoeff(), 0.0);
      if (affine) {
        EXPECT_EQ((G1 - G0).cwiseAbs().maxCoeff(), 0.0) << mesh::name(t);
      } else {
        EXPECT_LT((G1 - G0).norm(), 1e-13 * G0.norm()) << mesh::name(t);
      }
      // Hessians of the components: against the per-basis sums and against central differences
      // of the whole-field gradient, d2 u_c / dx_a dx_k = sum_l d G_ca / dxi_l (J^{-1})_lk
      const Mat Jinv = whole.jacobian().inverse();
      const double delta = 1e-5;
      std::array<Mat, D> fd;
      for (int c = 0; c < D; ++c) fd[c].setZero();
      for (int l = 0; l < D; ++l) {
        Point e = Point::Zero();
        e[l] = delta;
        plus.reinit(m, 0, rule.points[q] + e, false, false);
        minus.reinit(m, 0, rule.points[q] - e, false, false);
        const Mat dG = (plus.fieldGradient(u, verts) - minus.fieldGradient(u, verts)) / (2 * delta);
        for (int c = 0; c < D; ++c)
          for (int a = 0; a < D; ++a)
            for (int k = 0; k < D; ++k) fd[c](a, k) += dG(c, a) * Jinv(l, k);
      }
      // Laplace u and grad div u without the component Hessians
      Eigen::Matrix<double, D, 1> lap, gd, lap0, gd0;
      whole.fieldLaplacianGradDiv(u, verts, lap, gd);
      basis.fieldLaplacianGradDiv(u, verts, lap0, gd0);
      for (int a = 0; a < D; ++a) {
        double g = 0;
        for (int b = 0; b < D; ++b) g += H0[b](a, b);
        EXPECT_EQ(lap0[a], H0[a].trace());
        EXPECT_EQ(gd0[a], g);
        const double scale = std::max(std::max(H0[0].norm(), H0[D - 1].norm()), 1e-300);
        if (affine) {
          EXPECT_EQ(lap[a], lap0[a]);
          EXPECT_EQ(gd[a], gd0[a]);
        } else {
          EXPECT_NEAR(lap[a], lap0[a], 1e-12 * scale) << mesh::name(t);
          EXPECT_NEAR(gd[a], gd0[a], 1e-12 * scale) << mesh::name(t);
        }
      }
      for (int c = 0; c < D; ++c) {
        const double scale = std::max(H0[c].norm(), 1e-300);
        maxH = std::max(maxH, H0[c].norm());
        if (affine) {
          EXPECT_EQ((H1[c] - H0[c]).cwiseAbs().maxCoeff(), 0.0) << mesh::name(t);
        } else {
          EXPECT_LT((H1[c] - H0[c]).norm(), 1e-12 * scale) << mesh::name(t) << " component " << c;
          EXPECT_LT((H1[c] - fd[c]).norm(), 1e-6 * scale) << mesh::name(t) << " component " << c;
          EXPECT_LT((H1[c] - H1[c].transpose()).norm(), 1e-12 * scale);
        }
      }
    }
    if (!affine) {
      EXPECT_GT(maxH, 1e-4) << "field not curved enough to test anything";
    }
  };
  if (d == 2)
    check.template operator()<2>();
  else
    check.template operator()<3>();
}

INSTANTIATE_TEST_SUITE_P(AllCellTypes, WholeField,
                         ::testing::Combine(::testing::ValuesIn(mesh::kVolumeCellTypes),
                                            ::testing::Bool()),
                         [](const auto& info) {
                           return std::string(mesh::name(std::get<0>(info.param))) +
                                  (std::get<1>(info.param) ? "_parallel" : "_distorted");
                         });

/// The unit box of `type`: "distorted" (interior vertices moved), "undistorted" (boxes and their
/// prisms and pyramids: affine maps, PointValues::flat(); the estimator shares its tables between
/// translates) or "graded" (4 cells along x, so that the x differences are exact and every row is
/// translates, and rows of different sizes in y and z: a table reused on one difference only is
/// wrong there).
namespace {
mesh::Mesh variantBox(CellType type, const std::string& variant) {
  const std::array<int, 3> cells{variant == "graded" ? 4 : 3, 3, 3};
  auto m = mesh::boxMesh(type, cells, Point(0, 0, 0), Point(1, 1, 1));
  if (variant == "distorted") mesh::perturbInteriorVertices(m, 0.25, 17);
  if (variant == "graded")
    for (Index v = 0; v < m.numVertices(); ++v) {
      Point& x = m.vertex(v);
      x = Point(x[0], x[1] * (0.2 + 0.8 * x[1]), x[2] * x[2] * x[2]);
    }
  return m;
}

/// A random field (components uniform in [-1e-3, 1e-3]) on m and its residual estimate, the side
/// of id 1 clamped.
struct RandomFieldEstimate {
  Material material{1000.0, 0.3};
  Eigen::VectorXd uh;
  EstimatorResult result;
  RandomFieldEstimate(const mesh::Mesh& m, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(-1, 1);
    uh.resize(m.numVertices() * m.dimension());
    for (Eigen::Index k = 0; k < uh.size(); ++k) uh[k] = 1e-3 * U(rng);
    BoundaryConditions bc;
    bc.dirichlet.push_back({1, {true, true, true}});
    result = ResidualEstimator().estimate(EstimatorInput(m, material, bc, uh));
  }
};

/// eta_2 of the estimate, recomputed point by point with the per-basis gradients of both sides of
/// every interior face: sqrt of the sum over faces of (sum_{p in f} h_p) int_f |[sigma_h n]|^2.
template <int D>
double pointwiseEta2(const mesh::Mesh& m, const RandomFieldEstimate& e) {
  using Mat = Eigen::Matrix<double, D, D>;
  const Eigen::VectorXd& h = e.result.vertexFields.at("h");
  const double lambda = e.material.lambda(), mu = e.material.mu();
  PointValues<D> pv;
  auto stress = [&](Index c, const Point& xi) {
    pv.reinit(m, c, xi, false, true);
    Mat G = Mat::Zero();
    const auto verts = m.cellVertices(c);
    for (int i = 0; i < pv.numVertices(); ++i)
      G += e.uh.template segment<D>(verts[i] * D) * pv.gradient(i).transpose();
    return Mat(lambda * G.trace() * Mat::Identity() + mu * (G + G.transpose()));
  };
  const mesh::FaceTable faces(m);
  double sum = 0;
  for (Index f = 0; f < faces.numFaces(); ++f) {
    if (faces.numCells(f) != 2) continue;
    const auto side0 = faces.side(f, 0);
    const Index c1 = faces.side(f, 1).cell;
    const std::vector<Index> fv = cellFaceVertices(m, side0.cell, side0.localFace);
    double j2 = 0;
    for (const CellFacePoint& q : cellFaceQuadrature(m, side0.cell, side0.localFace, 4)) {
      const Point xi1 = referencePointOnFace(m, c1, fv, std::span<const double>(q.shape.data(), fv.size()));
      const Mat jump = stress(side0.cell, q.xi) - stress(c1, xi1);
      j2 += q.weight * (jump * q.normal.template head<D>()).squaredNorm();
    }
    for (Index p : fv) sum += h[p] * j2;
  }
  return std::sqrt(sum);
}
}  // namespace

// eta_1 of a random (curved) field on the three variantBox meshes of every cell type, recomputed
// here with the per-basis Hessians: sum over cells of (sum_{p in e} h_p^2) ||div sigma_h||_e^2.
TEST_P(ResidualPatch, ElementResidualMatchesPerBasisEvaluation) {
 for (const std::string variant : {"distorted", "undistorted", "graded"}) {
  const mesh::Mesh m = variantBox(GetParam(), variant);
  const int d = m.dimension();
  const RandomFieldEstimate e(m, 5);
  const Eigen::VectorXd& uh = e.uh;
  const EstimatorResult& r = e.result;
  const Eigen::VectorXd& h = r.vertexFields.at("h");
  const double lambda = e.material.lambda(), mu = e.material.mu();
  auto eta1 = [&]<int D>() {
    PointValues<D> pv;
    double sum = 0;
    for (Index c = 0; c < m.numCells(); ++c) {
      const auto verts = m.cellVertices(c);
      const auto& rule = mesh::quadratureRule(m.cellType(c), 4);
      double r2 = 0;
      for (std::size_t q = 0; q < rule.size(); ++q) {
        pv.reinit(m, c, rule.points[q], true, true);
        Eigen::Matrix<double, D, 1> div = Eigen::Matrix<double, D, 1>::Zero();
        for (int i = 0; i < pv.numVertices(); ++i) {
          const Eigen::Matrix<double, D, 1> ui = uh.template segment<D>(verts[i] * D);
          div += mu * pv.hessian(i).trace() * ui + (lambda + mu) * pv.hessian(i) * ui;
        }
        r2 += pv.determinant() * rule.weights[q] * div.squaredNorm();
      }
      double hp2 = 0;
      for (Index p : verts) hp2 += h[p] * h[p];
      sum += hp2 * r2;
    }
    return std::sqrt(sum);
  };
  const double expected = d == 2 ? eta1.template operator()<2>() : eta1.template operator()<3>();
  if (!affineCellType(GetParam())) {
    ASSERT_GT(expected, 0);
  }
  EXPECT_NEAR(r.contribution("eta_1"), expected, 1e-12 * std::max(expected, 1e-300))
      << mesh::name(GetParam()) << " " << variant;
 }
}

// eta_2 of a random field on the three variantBox meshes of every cell type, recomputed here point
// by point with the per-basis gradients of both sides of every interior face: sum over faces of
// (sum_{p in f} h_p) int_f |[sigma_h n]|^2 (the estimator's tables of flat cells, its constant
// jumps between affine cells and its point-by-point path against one evaluation).
TEST_P(ResidualPatch, JumpResidualMatchesPointwiseEvaluation) {
  for (const std::string variant : {"distorted", "undistorted", "graded"}) {
    const mesh::Mesh m = variantBox(GetParam(), variant);
    const int d = m.dimension();
    const RandomFieldEstimate e(m, 7);
    const EstimatorResult& r = e.result;
    const double expected = d == 2 ? pointwiseEta2<2>(m, e) : pointwiseEta2<3>(m, e);
    ASSERT_GT(expected, 0);
    EXPECT_NEAR(r.contribution("eta_2"), expected, 1e-12 * expected) << mesh::name(GetParam()) << " " << variant;
  }
}

// A box of hexahedra with a different spacing in every row, column and layer: every cell is flat and
// none is a translate of another, so each thread's face tables outgrow their bound (16,384) and are
// cleared while the faces are evaluated; eta_2 is still the point-by-point value.
TEST(ResidualEstimator, FaceTablesBeyondTheirBoundGiveThePointwiseJumps) {
  const int n = 24;  // 13,824 cells, about 6 x 13,824 side tables
  auto m = mesh::boxMesh(CellType::Hexahedron, {n, n, n}, Point(0, 0, 0), Point(1, 1, 1));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(0.5, 1.5);
  std::array<std::vector<double>, 3> grid;  // increasing coordinates 0 .. 1 with random steps
  for (auto& g : grid) {
    g.assign(n + 1, 0.0);
    for (int i = 1; i <= n; ++i) g[i] = g[i - 1] + U(rng);
    for (double& x : g) x /= g[n];
  }
  for (Index v = 0; v < m.numVertices(); ++v) {
    Point& x = m.vertex(v);
    for (int a = 0; a < 3; ++a) x[a] = grid[a][static_cast<std::size_t>(std::lround(x[a] * n))];
  }
  const RandomFieldEstimate e(m, 11);
  const double expected = pointwiseEta2<3>(m, e);
  ASSERT_GT(expected, 0);
  EXPECT_NEAR(e.result.contribution("eta_2"), expected, 1e-12 * expected);
}

// A linear field with exact tractions on the Neumann part and Dirichlet values elsewhere: every
// contribution vanishes, also on distorted (non-affine) cells, where it needs the Hessian terms.
TEST_P(ResidualPatch, LinearFieldGivesZero) {
  auto m = mesh::boxMesh(GetParam(), {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1));
  mesh::perturbInteriorVertices(m, 0.25, 99);
  const int d = m.dimension();
  const Material mat{1000.0, 0.3};
  const LinearField u = randomLinearField(d, 3);
  const Eigen::Matrix3d sigma = u.stress(mat);
  BoundaryConditions bc;
  bc.dirichlet.push_back({1, {true, true, true}, u});
  for (int id = 2; id <= 2 * d; ++id) {
    const Eigen::Vector3d n = boxNormal(d, id);
    bc.neumann.push_back({id, [sigma, n](const Point&) { return Eigen::Vector3d(sigma * n); }, {}});
  }
  const Eigen::VectorXd uh = u.interpolate(m);
  const EstimatorResult r = ResidualEstimator().estimate(EstimatorInput(m, mat, bc, uh));
  const double scale = sigma.norm();
  ASSERT_GT(scale, 0);
  for (const Contribution& c : r.contributions) EXPECT_LT(c.value, 1e-11 * scale) << c.name;
  EXPECT_LT(r.total, 1e-11 * scale);

  // the same field with the Neumann faces left free (sigma n != 0 there): eta_3 only
  BoundaryConditions free;
  free.dirichlet = bc.dirichlet;
  const EstimatorResult f = ResidualEstimator().estimate(EstimatorInput(m, mat, free, uh));
  EXPECT_GT(f.contribution("eta_3"), 1e-3 * scale);
  EXPECT_LT(f.contribution("eta_1") + f.contribution("eta_2"), 1e-11 * scale);
  expectSumIdentity(f);
  EXPECT_TRUE(f.validFor(m));
}

// h_p = diam omega_p: the largest distance between two vertices of the cells around p, by brute force
// over the pairs of those cells' vertices, on a distorted, an undistorted (the diameter between two
// vertices opposite through p, where the pruning of patchDiameters meets its bound exactly) and a
// once red-refined graded box (patches of different sizes and shapes), bit for bit.
TEST_P(ResidualPatch, PatchDiametersAreTheLargestDistanceInThePatch) {
  for (const std::string variant : {"distorted", "undistorted", "graded"}) {
    mesh::Mesh m = variantBox(GetParam(), variant);
    if (variant == "graded") m = mesh::refineUniformly(m);
    const std::vector<double> h = patchDiameters(m);
    ASSERT_EQ(h.size(), static_cast<std::size_t>(m.numVertices()));
    std::vector<std::vector<Index>> around(static_cast<std::size_t>(m.numVertices()));
    for (Index c = 0; c < m.numCells(); ++c)
      for (Index p : m.cellVertices(c)) around[p].push_back(c);
    std::vector<double> expected(h.size(), 0.0);
    for (Index p = 0; p < m.numVertices(); ++p)
      for (Index c1 : around[p])
        for (Index c2 : around[p])
          for (Index a : m.cellVertices(c1))
            for (Index b : m.cellVertices(c2)) expected[p] = std::max(expected[p], (m.vertex(a) - m.vertex(b)).norm());
    for (Index p = 0; p < m.numVertices(); ++p)
      EXPECT_EQ(h[p], expected[p]) << mesh::name(GetParam()) << " " << variant << " vertex " << p;
  }
}

INSTANTIATE_TEST_SUITE_P(AllCellTypes, ResidualPatch, ::testing::ValuesIn(mesh::kVolumeCellTypes),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

// Pressure loads (t = -p n) and rollers (Dirichlet on one component: the other keeps its residual).
TEST(ResidualEstimator, PressureAndRollerBoundaries) {
  auto m = mesh::boxMesh(CellType::Quadrilateral, 4);
  mesh::perturbInteriorVertices(m, 0.2, 5);
  const Material mat{50.0, 0.25};
  // uniform compression u = -c x: sigma = -p I with p = 2 (lambda + mu) c in plane strain
  const double c = 1e-3, p = 2 * (mat.lambda() + mat.mu()) * c;
  LinearField comp{2};
  comp.B(0, 0) = comp.B(1, 1) = -c;
  BoundaryConditions bc;
  for (int id = 1; id <= 4; ++id) bc.neumann.push_back({id, {}, [p](const Point&) { return p; }});
  const Eigen::VectorXd uc = comp.interpolate(m);
  EXPECT_LT(ResidualEstimator().estimate(EstimatorInput(m, mat, bc, uc)).total, 1e-12 * p);

  // uniaxial tension in x: left face a roller (u_x fixed), right face loaded, top/bottom free
  const double s = 2.0, ex = s * (mat.lambda() + 2 * mat.mu()) /
                             (4 * mat.mu() * (mat.lambda() + mat.mu()));
  LinearField ten{2};
  ten.B(0, 0) = ex;
  ten.B(1, 1) = -mat.lambda() / (mat.lambda() + 2 * mat.mu()) * ex;  // sigma_yy = 0
  ASSERT_NEAR(ten.stress(mat)(0, 0), s, 1e-12);
  BoundaryConditions roller;
  roller.dirichlet.push_back({mesh::kLeft, {true, false, false}, ten});
  roller.neumann.push_back({mesh::kRight, [s](const Point&) { return Eigen::Vector3d(s, 0, 0); }, {}});
  const Eigen::VectorXd ut = ten.interpolate(m);
  EXPECT_LT(ResidualEstimator().estimate(EstimatorInput(m, mat, roller, ut)).total, 1e-12 * s);
  roller.dirichlet[0].fixed = {false, true, false};  // now the x residual s on the left face counts
  const auto r = ResidualEstimator().estimate(EstimatorInput(m, mat, roller, ut));
  double expected = 0;  // sum over left faces of |F| s^2 sum_{p in F} h_p
  const auto& h = r.vertexFields.at("h");
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    if (m.boundaryFaceId(f) == mesh::kLeft)
      for (Index v : m.boundaryFaceVertices(f))
        expected += mesh::boundaryFaceMeasure(m, f) * s * s * h[v];
  EXPECT_NEAR(r.contribution("eta_3"), std::sqrt(expected), 1e-10 * std::sqrt(expected));
}

// Two triangles T0 = (0,0),(1,0),(1,1) and T1 = (0,0),(1,1),(0,1); u = (a, 0) at (1,0), 0 elsewhere:
// u_h = (a (x - y), 0) on T0, 0 on T1, so sigma_0 = a [[lambda + 2mu, -mu], [-mu, lambda]], sigma_1 = 0.
// All h_p = sqrt(2). Diagonal (length sqrt 2, n = (1,-1)/sqrt 2): |J^I|^2 = a^2/2 ((lambda+3mu)^2 +
// (lambda+mu)^2), eta_2^2 = (h_0 + h_2) sqrt(2) |J^I|^2 = 2 a^2 ((lambda+3mu)^2 + (lambda+mu)^2).
// Traction-free faces of T0: bottom sigma_0 n = a (mu, -lambda), right a (lambda+2mu, -mu), each
// weighted with h_p + h_q = 2 sqrt 2.
TEST(ResidualEstimator, TwoTrianglesByHand) {
  mesh::Mesh m(2);
  for (const Point& x : {Point(0, 0, 0), Point(1, 0, 0), Point(1, 1, 0), Point(0, 1, 0)}) m.addVertex(x);
  m.addCell(CellType::Triangle, {0, 1, 2});
  m.addCell(CellType::Triangle, {0, 2, 3});
  m.addBoundaryFace({0, 1}, 3);
  m.addBoundaryFace({1, 2}, 2);
  m.addBoundaryFace({2, 3}, 4);
  m.addBoundaryFace({3, 0}, 1);
  const Material mat{1.0, 0.25};
  const double l = mat.lambda(), mu = mat.mu(), a = 0.1;
  Eigen::VectorXd u = Eigen::VectorXd::Zero(8);
  u[2] = a;
  const BoundaryConditions bc;
  const auto r = ResidualEstimator().estimate(EstimatorInput(m, mat, bc, u));

  const double jump2 = (l + 3 * mu) * (l + 3 * mu) + (l + mu) * (l + mu);
  const double eta2sq = 2 * a * a * jump2;
  const double eta3sq = 2 * std::sqrt(2.0) * a * a * (mu * mu + l * l + (l + 2 * mu) * (l + 2 * mu) + mu * mu);
  EXPECT_NEAR(r.contribution("eta_1"), 0.0, 1e-15);
  EXPECT_NEAR(r.contribution("eta_2"), std::sqrt(eta2sq), 1e-14);
  EXPECT_NEAR(r.contribution("eta_3"), std::sqrt(eta3sq), 1e-14);
  EXPECT_EQ(r.contribution("eta_4"), 0.0);
  // element indicators: the diagonal half to each triangle, the free faces of T0 to T0
  EXPECT_NEAR(r.indicators[0], std::sqrt(eta2sq / 2 + eta3sq), 1e-14);
  EXPECT_NEAR(r.indicators[1], std::sqrt(eta2sq / 2), 1e-14);
  // patch values: eta_{2,p}^2 = h_p ||J^I||^2 = a^2 jump2 at the diagonal's ends, 0 elsewhere
  const Eigen::VectorXd& e2 = r.vertexFields.at("eta_2");
  EXPECT_NEAR(e2[0], a * std::sqrt(jump2), 1e-14);
  EXPECT_NEAR(e2[2], a * std::sqrt(jump2), 1e-14);
  EXPECT_EQ(e2[1], 0.0);
  EXPECT_EQ(e2[3], 0.0);
  for (int v = 0; v < 4; ++v) EXPECT_NEAR(r.vertexFields.at("h")[v], std::sqrt(2.0), 1e-15);
  expectSumIdentity(r);
}

// The potential contact boundary is traction-free Neumann: sigma n splits into eta_4 (tangential)
// and eta_5 (normal); the faces no longer count in eta_3.
TEST(ResidualEstimator, ContactBoundaryIsTractionFree) {
  auto m = mesh::boxMesh(CellType::Quadrilateral, 4);
  const Material mat{10.0, 0.3};
  // sigma = s e_y e_y (uniaxial in y): sigma n = s e_y on top and bottom, 0 on the sides
  const double s = 0.5, ey = s * (mat.lambda() + 2 * mat.mu()) / (4 * mat.mu() * (mat.lambda() + mat.mu()));
  LinearField u{2};
  u.B(1, 1) = ey;
  u.B(0, 0) = -mat.lambda() / (mat.lambda() + 2 * mat.mu()) * ey;
  ASSERT_NEAR(u.stress(mat)(1, 1), s, 1e-12);
  ASSERT_NEAR(u.stress(mat)(0, 0), 0, 1e-12);
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, u});
  bc.neumann.push_back({mesh::kTop, [s](const Point&) { return Eigen::Vector3d(0, s, 0); }, {}});
  const Eigen::VectorXd uh = u.interpolate(m);
  EstimatorInput in(m, mat, bc, uh);
  EXPECT_LT(ResidualEstimator().estimate(in).total, 1e-13);
  in.contactBoundaryIds = {mesh::kTop};  // the Neumann data on the top is now ignored
  const auto r = ResidualEstimator().estimate(in);
  double expected = 0;
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    if (m.boundaryFaceId(f) == mesh::kTop)
      for (Index v : m.boundaryFaceVertices(f))
        expected += mesh::boundaryFaceMeasure(m, f) * s * s * r.vertexFields.at("h")[v];
  EXPECT_NEAR(r.contribution("eta_5"), std::sqrt(expected), 1e-12);
  EXPECT_LT(r.contribution("eta_4"), 1e-13);
  EXPECT_LT(r.contribution("eta_3") + r.contribution("eta_2") + r.contribution("eta_1"), 1e-13);
  expectSumIdentity(r);
  // sides as contact boundary: sigma n = 0 there, nothing changes
  in.contactBoundaryIds = {mesh::kLeft, mesh::kRight};
  EXPECT_LT(ResidualEstimator().estimate(in).total, 1e-13);

  // a contact set on the top with the tilted direction nu = (1,1)/sqrt 2: w = -s e_y splits into
  // equal normal and tangential parts; the total stays the same
  const PlaneObstacle obstacle(Point(0, 2, 0), Point(1, 1, 0).normalized());
  const ContactSet set(m, mesh::kTop, obstacle);
  const ContactData contact{&set, nullptr, &obstacle};
  in.contactBoundaryIds.clear();
  in.contact = &contact;
  EXPECT_EQ(contactBoundaryIds(in), std::vector<int>{mesh::kTop});
  const auto tilted = ResidualEstimator().estimate(in);
  EXPECT_NEAR(tilted.contribution("eta_4"), std::sqrt(expected / 2), 1e-12);
  EXPECT_NEAR(tilted.contribution("eta_5"), std::sqrt(expected / 2), 1e-12);
  EXPECT_NEAR(tilted.total, r.total, 1e-12);
}

// A random displacement on a distorted mixed-type mesh with body force, every kind of boundary and a
// contact boundary: the decomposition identities hold to round-off.
TEST(ResidualEstimator, SumIdentityOnMixedMesh) {
  auto m = mesh::mixedBoxMesh3D({2, 2, 4}, Point(0, 0, 0), Point(1, 1, 2));
  mesh::perturbInteriorVertices(m, 0.2, 11);
  const Material mat{3.0, 0.2};
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::VectorXd u(m.numVertices() * 3);
  for (Eigen::Index i = 0; i < u.size(); ++i) u[i] = 0.01 * U(rng);
  BoundaryConditions bc;
  bc.bodyForce = [](const Point& x) { return Eigen::Vector3d(x[1], 1, -x[0]); };
  bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, {}});
  bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, {}});
  bc.neumann.push_back({mesh::kRight, {}, [](const Point& x) { return 1 + x[2]; }});
  EstimatorInput in(m, mat, bc, u);
  in.contactBoundaryIds = {mesh::kTop};
  const auto r = ResidualEstimator().estimate(in);
  ASSERT_EQ(r.contributions.size(), 5u);
  for (const Contribution& c : r.contributions) EXPECT_GT(c.value, 0) << c.name;
  expectSumIdentity(r);
  EXPECT_EQ(r.estimator, "residual");
  EXPECT_EQ(r.indicators.size(), static_cast<std::size_t>(m.numCells()));
}

TEST(ResidualEstimator, StaleResultsAndBadInputAreDetected) {
  auto m = mesh::boxMesh(CellType::Triangle, 2);
  const Material mat{1.0, 0.3};
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(m.numVertices() * 2);
  const BoundaryConditions bc;
  EstimatorInput in(m, mat, bc, u);
  in.meshRevision = 7;
  const auto r = ResidualEstimator().estimate(in);
  EXPECT_EQ(r.total, 0.0);
  EXPECT_TRUE(r.validFor(m));
  EXPECT_TRUE(r.validFor(m, 7));
  EXPECT_FALSE(r.validFor(m, 8));
  EXPECT_NO_THROW(r.requireValidFor(m));
  const auto fine = mesh::refineUniformly(m);
  EXPECT_FALSE(r.validFor(fine));
  EXPECT_THROW(r.requireValidFor(fine), obs::Error);
  auto moved = m;
  moved.vertex(4) += Point(0.01, 0, 0);
  EXPECT_FALSE(r.validFor(moved));
  try {
    r.contribution("eta_9");
    FAIL();
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("eta_1, eta_2"), std::string::npos) << e.what();
  }
  const Eigen::VectorXd wrong = Eigen::VectorXd::Zero(5);
  try {
    ResidualEstimator().estimate(EstimatorInput(m, mat, bc, wrong));
    FAIL();
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("displacement has 5 entries"), std::string::npos) << e.what();
  }
}

}  // namespace
