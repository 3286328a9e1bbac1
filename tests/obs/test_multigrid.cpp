// Multigrid hierarchy and linear multigrid: Galerkin operators against dense triple products (with
// rotations and truncation) and against the stiffness rediscretised on uniform levels, transfers as
// transposes, coarse updates only on truncation changes, CHOLMOD refactorisation, and V-cycle convergence for linear elasticity: mesh-independent rates
// over uniform levels for quadrilaterals, triangles, hexahedra and tetrahedra, and agreement with
// the direct solver.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "../GridCheck.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultigridHierarchy.hpp"

using namespace obs;
using mesh::CellType;

namespace {

const Material kMaterial{3e5, 0.25};

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

mesh::Grid refinedGrid(CellType type, int coarseCells, int levels) {
  mesh::Grid grid(mesh::boxMesh(type, coarseCells));
  for (int l = 0; l < levels; ++l) grid.refineUniformly();
  return grid;
}

template <int d>
Eigen::MatrixXd dense(const BlockSparseMatrix<d>& A, Index cols = -1) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(A.rows() * d, (cols < 0 ? A.rows() : cols) * d);
  for (Index i = 0; i < A.rows(); ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) M.block<d, d>(i * d, A.column(k) * d) = A.blockAt(k);
  return M;
}

template <int d>
Eigen::MatrixXd denseProlongation(const mesh::CsrMatrix& P) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(P.rows * d, P.cols * d);
  for (Index r = 0; r < P.rows; ++r)
    for (Index k = P.rowStart[r]; k < P.rowStart[r + 1]; ++k)
      M.block<d, d>(r * d, P.columns[k] * d) = P.values[k] * Eigen::Matrix<double, d, d>::Identity();
  return M;
}

/// Linear elasticity on the leaf mesh: bottom clamped, top moved, body force.
template <int d>
struct LinearSystem {
  BlockSparseMatrix<d> A;
  Eigen::VectorXd b;
  DirichletValues g;
  BoundaryConditions bc;
};

template <int d>
LinearSystem<d> linearSystem(const mesh::Mesh& m) {
  LinearSystem<d> s;
  s.bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, [](const Point&) { return Point::Zero(); }});
  s.bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point& x) {
                              return d == 2 ? Point(0.002 * x[0], -0.01, 0) : Point(0.002 * x[1], 0, -0.01);
                            }});
  s.bc.bodyForce = [](const Point&) { return d == 2 ? Point(0, -1e3, 0) : Point(0, 0, -1e3); };
  s.A = assembleStiffness<d>(m, kMaterial);
  s.b = assembleLoad<d>(m, s.bc);
  s.g = collectDirichlet(m, s.bc.dirichlet);
  applyDirichlet(s.A, s.b, s.g);
  return s;
}

struct RateCase {
  CellType type;
  int coarseCells;
  int maxLevels;
  int cycleIndex = 1;  ///< 1: V-cycle, 2: W-cycle
};
/// Prints the case by its fields (GoogleTest would print the struct's bytes, padding included).
void PrintTo(const RateCase& c, std::ostream* os) {
  *os << mesh::name(c.type) << ", " << c.coarseCells << " coarse cells, " << c.maxLevels << " levels, "
      << (c.cycleIndex == 2 ? "W" : "V") << "-cycle";
}

}  // namespace

TEST(MultigridHierarchy, LevelsAndProlongationsMatchTheGrid) {
  const mesh::Grid grid = refinedGrid(CellType::Quadrilateral, 2, 2);
  const MultigridHierarchy<2> h(grid);
  ASSERT_EQ(h.maxLevel(), 2);
  EXPECT_EQ(h.numVertices(0), 9);
  EXPECT_EQ(h.numVertices(1), 25);
  EXPECT_EQ(h.numVertices(2), grid.leafView().mesh.numVertices());
  for (int l = 0; l < 2; ++l) {
    EXPECT_EQ(h.prolongation(l).rows, h.numVertices(l + 1));
    EXPECT_EQ(h.prolongation(l).cols, h.numVertices(l));
    // interpolation preserves constants
    const std::vector<double> one(h.numVertices(l), 1.0);
    for (double v : h.prolongation(l) * one) EXPECT_NEAR(v, 1.0, 1e-14);
  }
  EXPECT_THROW(MultigridHierarchy<3>{grid}, obs::Error);
}

TEST(MultigridHierarchy, GalerkinOperatorsWithRotationsAndTruncationAreDenseTripleProducts) {
  for (CellType type : {CellType::Triangle, CellType::Hexahedron}) {
    const int dim = type == CellType::Triangle ? 2 : 3;
    auto check = [&]<int d>(std::integral_constant<int, d>) {
      const mesh::Grid grid = refinedGrid(type, d == 2 ? 2 : 1, 2);
      const mesh::Mesh m = grid.leafView().mesh;
      BlockSparseMatrix<d> A = assembleStiffness<d>(m, kMaterial);
      // a rotation at every vertex with x < 0.3, truncation of components here and there
      std::vector<VertexRotation<d>> rotations;
      Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(m.numVertices() * d, m.numVertices() * d);
      for (Index v = 0; v < m.numVertices(); ++v)
        if (m.vertex(v)[0] < 0.3) {
          const Point nu = Point(1, -2 - m.vertex(v)[1], d == 3 ? 0.5 : 0).normalized();
          const Eigen::Matrix<double, d, d> R = householderRotation(nu).topLeftCorner<d, d>();
          rotations.push_back({v, R});
          Q.block<d, d>(v * d, v * d) = R;
        }
      const Eigen::MatrixXd At = Q.transpose() * dense(A) * Q;  // the rotated operator A~
      BlockSparseMatrix<d> Arot = A;
      for (Index i = 0; i < A.rows(); ++i)
        for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k)
          Arot.blockAt(k) = At.block<d, d>(i * d, A.column(k) * d);
      std::vector<char> mask(m.numVertices() * d, 0);
      for (Index v = 0; v < m.numVertices(); ++v)
        if (m.vertex(v)[1] < 0.26 || v % 7 == 0) mask[v * d + (v % d)] = 1;

      MultigridHierarchy<d> h(grid);
      h.setFineOperator(Arot, rotations);
      EXPECT_EQ(h.truncate(mask), std::count(mask.begin(), mask.end(), 1));
      EXPECT_EQ(h.coarseUpdates(), 2);
      EXPECT_EQ(h.truncate(mask), 0);  // unchanged: no recomputation
      EXPECT_EQ(h.coarseUpdates(), 2);

      // dense reference: P~_T = T Q' P, A_1 = P~_T' A~ P~_T, A_0 = P_0' A_1 P_0
      Eigen::MatrixXd T = Eigen::MatrixXd::Identity(mask.size(), mask.size());
      for (std::size_t i = 0; i < mask.size(); ++i)
        if (mask[i]) T(i, i) = 0;
      const Eigen::MatrixXd Pt = T * Q.transpose() * denseProlongation<d>(h.prolongation(1));
      const Eigen::MatrixXd A1 = Pt.transpose() * At * Pt;
      const Eigen::MatrixXd P0 = denseProlongation<d>(h.prolongation(0));
      const Eigen::MatrixXd A0 = P0.transpose() * dense(h.coarseOperator(1)) * P0;
      const double scale = A1.cwiseAbs().maxCoeff();
      EXPECT_LT((dense(h.coarseOperator(1)) - A1).cwiseAbs().maxCoeff(), 1e-12 * scale) << name(type);
      EXPECT_LT((dense(h.coarseOperator(0)) - A0).cwiseAbs().maxCoeff(), 1e-12 * scale) << name(type);

      // restriction and prolongation are transposes of each other, and use P~_T on the top level
      const Eigen::VectorXd xf = Eigen::VectorXd::LinSpaced(h.numVertices(2) * d, -1, 2);
      const Eigen::VectorXd xc = Eigen::VectorXd::LinSpaced(h.numVertices(1) * d, 3, -1);
      Eigen::VectorXd rc, pf = Eigen::VectorXd::Zero(xf.size());
      h.restrict(1, xf, rc);
      h.prolongateAdd(1, xc, pf);
      EXPECT_LT((rc - Pt.transpose() * xf).norm(), 1e-12 * rc.norm());
      EXPECT_LT((pf - Pt * xc).norm(), 1e-12 * pf.norm());
    };
    if (dim == 2) check(std::integral_constant<int, 2>{});
    else check(std::integral_constant<int, 3>{});
  }
}

TEST(MultigridHierarchy, LocalUpdatesEqualAFullRecomputation) {
  // a truncation that changes at a few vertices is updated locally (rows near the changes only);
  // the result must be bitwise the operators of a hierarchy set up with the new mask from scratch
  for (CellType type : {CellType::Quadrilateral, CellType::Tetrahedron}) {
    auto check = [&]<int d>(std::integral_constant<int, d>) {
      const mesh::Grid grid = refinedGrid(type, 2, 3);
      const mesh::Mesh m = grid.leafView().mesh;
      const auto s = linearSystem<d>(m);
      std::vector<VertexRotation<d>> rotations;
      for (Index v = 0; v < m.numVertices(); ++v)
        if (m.vertex(v)[0] == 0.0)
          rotations.push_back({v, householderRotation(Point(0.2, d == 3 ? 0.1 : -1, -1).normalized())
                                      .topLeftCorner<d, d>()});
      std::vector<char> mask = s.g.constrained;
      MultigridHierarchy<d> h(grid);
      h.setFineOperator(s.A, rotations, mask);
      long long before = h.coarseRowsRecomputed();
      // truncate a few vertices of the left side, then release them one by one
      int added = 0;
      for (Index v = 0; v < m.numVertices() && added < 4; ++v)
        if (m.vertex(v)[0] == 0.0 && std::abs(m.vertex(v)[1] - 0.5) < 0.2 && !mask[v * d]) {
          mask[v * d] = 1;
          ++added;
        }
      EXPECT_EQ(h.truncate(mask), 4);
      for (int round = 0; round < 2; ++round) {
        EXPECT_FALSE(h.fullUpdate(h.maxLevel() - 1));
        EXPECT_LT(h.coarseRowsRecomputed() - before, h.numVertices(h.maxLevel() - 1));
        MultigridHierarchy<d> fresh(grid);
        fresh.setFineOperator(s.A, rotations, mask);
        for (int l = 0; l < h.maxLevel(); ++l) {  // every entry is the same sum in the same order
          const Eigen::MatrixXd a = dense(h.coarseOperator(l)), b = dense(fresh.coarseOperator(l));
          EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0) << name(type) << " level " << l;
        }
        for (std::size_t i = 0; i < mask.size(); i += d)
          if (mask[i] && !s.g.constrained[i]) {
            mask[i] = 0;  // release one
            break;
          }
        before = h.coarseRowsRecomputed();
        EXPECT_EQ(h.truncate(mask), 1);
      }
    };
    if (mesh::dimension(type) == 2) check(std::integral_constant<int, 2>{});
    else check(std::integral_constant<int, 3>{});
  }
}

TEST(MultigridHierarchy, FineDiagonalTermIsTheOperatorWithTheBlocksAdded) {
  // a diagonal term K (the friction curvature of TNNMG) must give the Galerkin operators of the
  // fine operator A + K, bitwise, both when set first (full product) and when changed afterwards
  // (local update), together with a truncation and rotations; removing it gives those of A again
  constexpr int d = 3;
  const mesh::Grid grid = refinedGrid(CellType::Hexahedron, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const auto s = linearSystem<d>(m);
  std::vector<VertexRotation<d>> rotations;
  std::vector<Index> bottom;
  for (Index v = 0; v < m.numVertices(); ++v)
    if (m.vertex(v)[2] == 0.0) {
      bottom.push_back(v);
      rotations.push_back({v, householderRotation(Point(0.1, 0.2, -1).normalized())});
    }
  const std::vector<char> mask = s.g.constrained;
  const auto term = [&](double scale, std::size_t count) {
    std::pair<std::vector<Index>, std::vector<Eigen::Matrix3d>> k;
    for (std::size_t i = 0; i < count && i < bottom.size(); ++i) {
      const Eigen::Vector3d e = Eigen::Vector3d(0, std::cos(0.3 * i), std::sin(0.3 * i));
      Eigen::Matrix3d K = Eigen::Matrix3d::Zero();
      K(1, 1) = K(2, 2) = 1;
      k.first.push_back(bottom[i]);
      k.second.push_back(scale * (1 + i) * (K - e * e.transpose()));
    }
    return k;
  };
  const auto withTerm = [&](const std::pair<std::vector<Index>, std::vector<Eigen::Matrix3d>>& k) {
    BlockSparseMatrix<d> B = s.A;
    for (std::size_t i = 0; i < k.first.size(); ++i) B.blockAt(B.diagonal(k.first[i])) += k.second[i];
    return B;
  };
  const auto expectSame = [&](const MultigridHierarchy<d>& h, const BlockSparseMatrix<d>& B, const char* what) {
    MultigridHierarchy<d> fresh(grid);
    fresh.setFineOperator(B, rotations, mask);
    for (int l = 0; l < h.maxLevel(); ++l) {
      const Eigen::MatrixXd a = dense(h.coarseOperator(l)), b = dense(fresh.coarseOperator(l));
      EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0) << what << ", level " << l;
    }
  };
  MultigridHierarchy<d> h(grid);
  h.setFineOperator(s.A, rotations, mask);
  const auto k1 = term(1e3, bottom.size());
  h.setFineDiagonal(k1.first, k1.second);
  const int updates = h.coarseUpdates();
  EXPECT_EQ(h.truncate(mask), 0);  // no truncation change, but the term: one update
  EXPECT_EQ(h.coarseUpdates(), updates + 1);
  EXPECT_EQ(h.changedVertices().size(), bottom.size());
  const BlockSparseMatrix<d> B1 = withTerm(k1);
  expectSame(h, B1, "first term");
  // a term changed at three vertices: a local update
  auto k2 = k1;
  for (int i = 0; i < 3; ++i) k2.second[static_cast<std::size_t>(i)] *= 2;
  h.setFineDiagonal(k2.first, k2.second);
  h.truncate(mask);
  EXPECT_FALSE(h.fullUpdate(h.maxLevel() - 1));
  const BlockSparseMatrix<d> B2 = withTerm(k2);
  expectSame(h, B2, "changed term");
  // the same term again: nothing to update
  h.setFineDiagonal(k2.first, k2.second);
  h.truncate(mask);
  EXPECT_TRUE(h.changedVertices().empty());
  // K x on the fine level
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(s.A.rows() * d, -1, 1);
  Eigen::VectorXd y = s.A * x;
  h.addFineDiagonal(x, y);
  EXPECT_LT((y - B2 * x).cwiseAbs().maxCoeff(), 1e-12 * (B2 * x).cwiseAbs().maxCoeff());
  // removed
  h.setFineDiagonal({}, {});
  h.truncate(mask);
  expectSame(h, s.A, "no term");
  EXPECT_THROW(h.setFineDiagonal({bottom[0], bottom[0]}, {Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()}), obs::Error);
  EXPECT_THROW(h.setFineDiagonal({-1}, {Eigen::Matrix3d::Zero()}), obs::Error);
  EXPECT_THROW(h.setFineDiagonal({bottom[0]}, {}), obs::Error);
}

TEST(LinearMultigrid, DiagonalTermConvergesToTheDirectSolutionOfTheSumOperator) {
  // V-cycles on (A + K)_T c = r with a strong diagonal term on the bottom layer (10 x the largest
  // diagonal entry of A, rank two per vertex, as the friction curvature): they converge, at a
  // multigrid rate, to what the direct correction gives for the same term
  constexpr int d = 3;
  const mesh::Grid grid = refinedGrid(CellType::Hexahedron, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const auto s = linearSystem<d>(m);
  double top = 0;
  for (Index p = 0; p < s.A.rows(); ++p) top = std::max(top, s.A.blockAt(s.A.diagonal(p)).diagonal().maxCoeff());
  std::vector<Index> vertices;
  std::vector<Eigen::Matrix3d> blocks;
  for (Index v = 0; v < m.numVertices(); ++v)
    if (std::abs(m.vertex(v)[2] - 0.5) < 1e-12) {  // an interior layer (the bottom is clamped)
      const Eigen::Vector3d e(std::cos(v), std::sin(v), 0);
      vertices.push_back(v);
      blocks.push_back(10 * top * (Eigen::Matrix3d::Identity() - e * e.transpose()));
    }
  ASSERT_GT(vertices.size(), 10u);
  const std::vector<char> mask = s.g.constrained;
  Eigen::VectorXd r = s.b;
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) r[static_cast<Eigen::Index>(i)] = 0;
  DirectCorrection<d> direct;
  direct.setOperator(s.A, {}, mask);
  EXPECT_TRUE(direct.setDiagonalTerm(vertices, blocks));
  direct.truncate(mask);
  Eigen::VectorXd exact;
  direct.apply(r, exact);
  LinearMultigridOptions o;
  o.cycles = 12;
  LinearMultigrid<d> mg(grid, o);
  mg.setOperator(s.A, {}, mask);
  EXPECT_TRUE(mg.setDiagonalTerm(vertices, blocks));
  mg.truncate(mask);
  Eigen::VectorXd c;
  mg.apply(r, c);
  EXPECT_LT((c - exact).cwiseAbs().maxCoeff(), 1e-8 * exact.cwiseAbs().maxCoeff());
  // without the term the solution differs: the term is not ignored
  DirectCorrection<d> plain;
  plain.setOperator(s.A, {}, mask);
  Eigen::VectorXd without;
  plain.apply(r, without);
  EXPECT_GT((without - exact).cwiseAbs().maxCoeff(), 1e-3 * exact.cwiseAbs().maxCoeff());
  // the vertex-patch smoother ignores the term and says so
  LinearMultigridOptions patch;
  patch.smoother = LinearSmoother::VertexPatch;
  LinearMultigrid<d> vp(grid, patch);
  vp.setOperator(s.A, {}, mask);
  EXPECT_FALSE(vp.setDiagonalTerm(vertices, blocks));
}

TEST(MultigridHierarchy, CoarseOperatorsShareTheirBlocksAndLocalUpdatesKeepThemShared) {
  // docs/performance.md#galerkin-products: on a uniformly refined box the coarse operators repeat
  // their blocks and are stored shared; a local update writes its rows into the shared storage
  // (BlockWriter) and gives bitwise the operators of a hierarchy set up from scratch
  constexpr int d = 3;
  const mesh::Grid grid = refinedGrid(CellType::Hexahedron, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  auto s = linearSystem<d>(m);
  ASSERT_TRUE(s.A.shareRepeatedBlocks());
  std::vector<char> mask = s.g.constrained;
  MultigridHierarchy<d> h(grid);
  h.setFineOperator(s.A, {}, mask);
  const int top = h.maxLevel() - 1;
  ASSERT_TRUE(h.coarseOperator(top).shared());
  EXPECT_LT(4 * h.coarseOperator(top).storedBlocks(), h.coarseOperator(top).nonZeroBlocks());
  int added = 0;
  for (Index v = 0; v < m.numVertices() && added < 3; ++v)
    if (m.vertex(v)[0] == 0.0 && std::abs(m.vertex(v)[1] - 0.5) < 0.2 && std::abs(m.vertex(v)[2] - 0.5) < 0.2) {
      mask[v * d] = 1;
      ++added;
    }
  ASSERT_EQ(h.truncate(mask), 3);
  EXPECT_FALSE(h.fullUpdate(top));
  EXPECT_TRUE(h.coarseOperator(top).shared());
  MultigridHierarchy<d> fresh(grid);
  fresh.setFineOperator(s.A, {}, mask);
  for (int l = 0; l <= top; ++l) {
    const auto& a = h.coarseOperator(l);
    const auto& b = fresh.coarseOperator(l);
    ASSERT_EQ(a.nonZeroBlocks(), b.nonZeroBlocks());
    Index differing = 0;
    for (Index k = 0; k < a.nonZeroBlocks(); ++k)
      differing += std::memcmp(a.blockAt(k).data(), b.blockAt(k).data(), sizeof(a.blockAt(k))) != 0;
    EXPECT_EQ(differing, 0) << "level " << l;
  }
}

TEST(MultigridHierarchy, CoarseComponentsWithoutFineSupportAreTruncatedOnCoarserLevels) {
  // docs/theory.md#multigrid-levels: truncating both components near x = 0 (component 0) and y = 0
  // (component 1) leaves coarse components of levels 2 and 1 without any untruncated fine support
  // (zero row and column). Their diagonal is patched to keep the smoothers defined, but the patch
  // must not enter the next Galerkin product: every A_l equals the Galerkin product of the truncated
  // fine problem, (P~_T P_{L-2} ... P_l)' A (P~_T P_{L-2} ... P_l), off the patched diagonal entries.
  constexpr int d = 2;
  const mesh::Grid grid = refinedGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const BlockSparseMatrix<d> A = assembleStiffness<d>(m, kMaterial);
  std::vector<char> mask(m.numVertices() * d, 0);
  for (Index v = 0; v < m.numVertices(); ++v) {
    if (m.vertex(v)[0] < 0.2) mask[v * d] = 1;
    if (m.vertex(v)[1] < 0.2) mask[v * d + 1] = 1;
  }
  MultigridHierarchy<d> h(grid);
  h.setFineOperator(A, {}, mask);
  ASSERT_EQ(h.maxLevel(), 3);

  Eigen::MatrixXd T = Eigen::MatrixXd::Identity(mask.size(), mask.size());
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) T(i, i) = 0;
  Eigen::MatrixXd P = T * denseProlongation<d>(h.prolongation(2));  // level 2 -> fine, truncated
  const Eigen::MatrixXd Af = dense(A);
  const double scale = Af.cwiseAbs().maxCoeff();
  int dead = 0;
  for (int l = 2; l >= 0; --l) {
    const Eigen::MatrixXd ref = P.transpose() * Af * P;  // the Galerkin product of the truncated problem
    Eigen::MatrixXd Al = dense(h.coarseOperator(l));
    for (Eigen::Index i = 0; i < ref.rows(); ++i)
      if (ref(i, i) == 0) {  // no untruncated fine support: zero row and column, a positive patch
        ++dead;
        EXPECT_GT(Al(i, i), 0) << "level " << l << " component " << i;
        Al(i, i) = 0;
      }
    EXPECT_LT((Al - ref).cwiseAbs().maxCoeff(), 1e-12 * scale) << "level " << l;
    if (l > 0) P = P * denseProlongation<d>(h.prolongation(l - 1));
  }
  EXPECT_GT(dead, 20);  // components on levels 2 and 1 (x = 0, 1/8 and y = 0, 1/8 on level 2)

  // the transfers between coarse levels truncate the same components: prolongating a coarse vector
  // and restricting it back never places a value in a component without fine support
  const Eigen::MatrixXd A2 = dense(h.coarseOperator(2));
  const Eigen::VectorXd xc = Eigen::VectorXd::LinSpaced(h.numVertices(1) * d, 1, 2);
  Eigen::VectorXd xf = Eigen::VectorXd::Zero(h.numVertices(2) * d), rc;
  h.prolongateAdd(1, xc, xf);
  h.restrict(1, xf, rc);
  const Eigen::MatrixXd A1 = dense(h.coarseOperator(1));
  for (Eigen::Index i = 0; i < xf.size(); ++i)
    if (A2.row(i).cwiseAbs().sum() == A2(i, i)) {
      EXPECT_EQ(xf[i], 0) << "level 2 component " << i;
    }
  for (Eigen::Index i = 0; i < rc.size(); ++i)
    if (A1.row(i).cwiseAbs().sum() == A1(i, i)) {
      EXPECT_EQ(rc[i], 0) << "level 1 component " << i;
    }
}

// On uniformly refined grids the level spaces are nested P1/Q1 spaces, so the Galerkin operator
// A_l = P_l' A_{l+1} P_l of every level must be the stiffness matrix assembled on level view l, to
// round-off. A prolongation that is not the exact interpolation on the refined cells breaks this
// (one edge midpoint of one level weighted 0.6/0.4 instead of 0.5/0.5 fails here, although it still
// reproduces constants). Issue 12: the tetrahedral V-cycle rate that grows with the level is not
// caused by such a defect (docs/performance.md#tetrahedral-multigrid-rates).
TEST(MultigridHierarchy, GalerkinOperatorsEqualTheRediscretisedStiffnessOnUniformLevels) {
  auto check = [&]<int d>(std::integral_constant<int, d>, CellType type, int coarseCells, int levels) {
    const mesh::Grid grid = refinedGrid(type, coarseCells, levels);
    MultigridHierarchy<d> h(grid);
    const BlockSparseMatrix<d> A = assembleStiffness<d>(grid.leafView().mesh, kMaterial);
    h.setFineOperator(A);
    ASSERT_EQ(h.maxLevel(), levels);
    for (int l = 0; l < levels; ++l) {
      const BlockSparseMatrix<d>& C = h.coarseOperator(l);
      const BlockSparseMatrix<d> K = assembleStiffness<d>(grid.levelView(l).mesh, kMaterial);
      ASSERT_EQ(C.rows(), K.rows());
      double scale = 0;
      for (Index k = 0; k < K.nonZeroBlocks(); ++k) scale = std::max(scale, K.blockAt(k).cwiseAbs().maxCoeff());
      double diff = 0;
      for (Index p = 0; p < C.rows(); ++p) {
        for (Index k = C.rowBegin(p); k < C.rowEnd(p); ++k) {
          const Index kk = K.find(p, C.column(k));
          diff = std::max(diff, (kk < 0 ? C.blockAt(k) : Eigen::Matrix<double, d, d>(C.blockAt(k) - K.blockAt(kk)))
                                    .cwiseAbs()
                                    .maxCoeff());
        }
        for (Index k = K.rowBegin(p); k < K.rowEnd(p); ++k)
          if (C.find(p, K.column(k)) < 0) diff = std::max(diff, K.blockAt(k).cwiseAbs().maxCoeff());
      }
      EXPECT_LT(diff, 1e-12 * scale) << mesh::name(type) << " level " << l;
    }
  };
  check(std::integral_constant<int, 3>{}, CellType::Tetrahedron, 2, 2);  // Kuhn tetrahedra, then the red split
  check(std::integral_constant<int, 3>{}, CellType::Tetrahedron, 1, 3);
  check(std::integral_constant<int, 3>{}, CellType::Hexahedron, 2, 2);
  check(std::integral_constant<int, 2>{}, CellType::Triangle, 2, 3);
  check(std::integral_constant<int, 2>{}, CellType::Quadrilateral, 2, 3);
}

TEST(MultigridHierarchy, FineOperatorOfAnotherMeshIsAnError) {
  const mesh::Grid grid = refinedGrid(CellType::Quadrilateral, 2, 1);
  MultigridHierarchy<2> h(grid);
  const auto A = assembleStiffness<2>(mesh::boxMesh(CellType::Quadrilateral, 3), kMaterial);
  EXPECT_THROW(h.setFineOperator(A), obs::Error);
  EXPECT_THROW(h.truncate(std::vector<char>(10, 0)), obs::Error);
}

TEST(CholmodSolver, RefactorizeWithTheSamePattern) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 4);
  auto s = linearSystem<2>(m);
  CholmodSolver solver(s.A);
  BlockSparseMatrix<2> B = s.A;
  for (Index k = 0; k < B.nonZeroBlocks(); ++k) B.blockAt(k) *= 2;
  solver.refactorize(B);
  const Eigen::VectorXd x = solver.solve(s.b);
  EXPECT_LT((B * x - s.b).norm(), 1e-10 * s.b.norm());
  const auto other = assembleStiffness<2>(mesh::boxMesh(CellType::Quadrilateral, 3), kMaterial);
  EXPECT_THROW(solver.refactorize(other), obs::Error);
}

// V(3,3)-cycle rates for linear elasticity (bottom clamped, top moved, body force), measured as
// LinearSolverResult::convergenceRate, the geometric mean of the ratios of successive energy-norm
// corrections down to 1e-11. Asserted bounds: rate <= 0.3 on every level, and mesh independence as
// a growth of at most 0.05 between the last two levels (level 1 is a two-grid method with an exact
// coarse solve and much faster). Measured (see docs/performance.md): quadrilaterals 0.037 0.057
// 0.065 0.065, triangles 0.095 0.171 0.210 0.218, hexahedra 0.010 0.054 0.069. Tetrahedra: the
// V-cycle gives 0.044 0.18 0.29 (still growing with the number of levels: 0.34 and 0.37 on levels
// 4 and 5; a pre-asymptotic growth towards a level-independent limit, not a defect, see
// docs/performance.md#tetrahedral-multigrid-rates), so for them the bound on the growth is checked
// with W-cycles (0.044 0.165 0.206), and the V-cycle only against 0.3.
class LinearMultigridRates : public ::testing::TestWithParam<RateCase> {};

TEST_P(LinearMultigridRates, AreMeshIndependentAndMatchTheDirectSolver) {
  const RateCase rc = GetParam();
  const int dim = mesh::dimension(rc.type);
  std::vector<double> rates;
  mesh::Grid grid(mesh::boxMesh(rc.type, rc.coarseCells));
  for (int level = 1; level <= rc.maxLevels; ++level) {
    grid.refineUniformly();
    const mesh::Mesh m = grid.leafView().mesh;
    auto run = [&]<int d>(std::integral_constant<int, d>) {
      const auto s = linearSystem<d>(m);
      LinearMultigridOptions o;
      o.tolerance = 1e-11;
      o.cycleIndex = rc.cycleIndex;
      LinearMultigrid<d> mg(grid, o);
      mg.setOperator(s.A);
      mg.truncate(s.g.constrained);
      Eigen::VectorXd x;
      const LinearSolverResult r = mg.solve(s.b, x);
      EXPECT_TRUE(r.converged);
      const Eigen::VectorXd ref = solveLinearElasticity(m, kMaterial, s.bc).displacement;
      EXPECT_LT((x - ref).norm(), 1e-8 * ref.norm()) << "level " << level;
      for (Index i = 0; i < x.size(); ++i)
        if (s.g.constrained[i]) {
          ASSERT_EQ(x[i], s.g.values[i]);
        }
      rates.push_back(r.convergenceRate);
      if (verbose())
        std::cout << "  " << mesh::name(rc.type) << (rc.cycleIndex == 2 ? " W" : " V") << " level " << level
                  << ": " << x.size() << " dofs, " << r.iterations << " cycles, rate " << r.convergenceRate
                  << ", residual reduction " << r.residualReduction << ", " << r.seconds << " s\n";
    };
    if (dim == 2) run(std::integral_constant<int, 2>{});
    else run(std::integral_constant<int, 3>{});
  }
  for (std::size_t l = 0; l < rates.size(); ++l) EXPECT_LE(rates[l], 0.3) << "level " << l + 1;
  if (rc.type != CellType::Tetrahedron || rc.cycleIndex == 2) {
    EXPECT_LE(rates.back(), rates[rates.size() - 2] + 0.05);
  }
}

INSTANTIATE_TEST_SUITE_P(Types, LinearMultigridRates,
                         ::testing::Values(RateCase{CellType::Quadrilateral, 4, 4},
                                           RateCase{CellType::Triangle, 4, 4},
                                           RateCase{CellType::Hexahedron, 2, 3},
                                           RateCase{CellType::Tetrahedron, 2, 3},
                                           RateCase{CellType::Tetrahedron, 2, 3, 2}),
                         [](const auto& info) {
                           return std::string(mesh::name(info.param.type)) + (info.param.cycleIndex == 2 ? "W" : "V");
                         });

TEST(LinearMultigrid, SingularTruncatedCoarseOperators) {
  // one coarse cube with all eight vertices clamped: the truncated prolongation has dependent
  // columns (coarse functions vanishing at every free fine vertex), A_0 is only semidefinite
  const mesh::Grid grid = refinedGrid(CellType::Tetrahedron, 1, 2);
  const mesh::Mesh m = grid.leafView().mesh;
  const auto s = linearSystem<3>(m);
  LinearMultigrid<3> mg(grid);
  mg.setOperator(s.A);
  mg.truncate(s.g.constrained);
  Eigen::VectorXd x;
  const LinearSolverResult r = mg.solve(s.b, x);
  EXPECT_TRUE(r.converged);
  EXPECT_LE(r.convergenceRate, 0.2);
  const Eigen::VectorXd ref = solveLinearElasticity(m, kMaterial, s.bc).displacement;
  EXPECT_LT((x - ref).norm(), 1e-8 * ref.norm());
}

TEST(LinearMultigrid, GridWithoutRefinementSolvesDirectly) {
  const mesh::Grid grid(mesh::boxMesh(CellType::Quadrilateral, 4));
  const mesh::Mesh m = grid.leafView().mesh;
  const auto s = linearSystem<2>(m);
  LinearMultigrid<2> mg(grid);
  mg.setOperator(s.A);
  mg.truncate(s.g.constrained);
  Eigen::VectorXd x;
  const LinearSolverResult r = mg.solve(s.b, x);
  EXPECT_TRUE(r.converged);
  EXPECT_LE(r.iterations, 2);
  const Eigen::VectorXd ref = solveLinearElasticity(m, kMaterial, s.bc).displacement;
  EXPECT_LT((x - ref).norm(), 1e-10 * ref.norm());
}

TEST(LinearMultigrid, LevelSecondsAccountForEveryPhaseOnItsLevel) {
  // the phase timers: one entry per level, smoothing and transfers on levels 1 .. L only, the direct
  // solve on level 0 only; they grow with every cycle and resetLevelSeconds() zeroes them
  const mesh::Grid grid = refinedGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const auto s = linearSystem<2>(m);
  LinearMultigrid<2> mg(grid);
  mg.setOperator(s.A);
  mg.truncate(s.g.constrained);
  ASSERT_EQ(mg.levelSeconds().size(), 4u);
  Eigen::VectorXd c;
  const auto total = [&](const LinearMultigrid<2>::LevelSeconds& t) {
    return t.smoothing + t.defect + t.restriction + t.prolongation + t.coarseSolve;
  };
  mg.vcycle(s.b, c);
  const std::vector<LinearMultigrid<2>::LevelSeconds> once = mg.levelSeconds();
  mg.vcycle(s.b, c);
  for (std::size_t l = 0; l < 4; ++l) {
    const auto& t = mg.levelSeconds()[l];
    if (l == 0) {
      EXPECT_GT(t.coarseSolve, 0.0);
      EXPECT_EQ(t.smoothing + t.defect + t.restriction + t.prolongation, 0.0);
    } else {
      EXPECT_GT(t.smoothing, 0.0) << "level " << l;
      EXPECT_GT(t.defect, 0.0) << "level " << l;
      EXPECT_GT(t.restriction, 0.0) << "level " << l;
      EXPECT_GT(t.prolongation, 0.0) << "level " << l;
      EXPECT_EQ(t.coarseSolve, 0.0) << "level " << l;
    }
    EXPECT_GT(total(t), total(once[l])) << "level " << l;
  }
  mg.resetLevelSeconds();
  ASSERT_EQ(mg.levelSeconds().size(), 4u);
  for (const auto& t : mg.levelSeconds()) EXPECT_EQ(total(t), 0.0);
}

TEST(LinearMultigrid, LocallyRefinedGridConverges) {
  mesh::Grid grid(mesh::boxMesh(CellType::Triangle, 4));
  for (int cycle = 0; cycle < 4; ++cycle) {
    const mesh::Mesh m = grid.leafMesh();
    for (Index e : grid.leafElements()) {
      Point c = Point::Zero();
      for (Index v : grid.vertices(e)) c += grid.vertex(v) / grid.vertices(e).size();
      if ((c - Point(0.5, 0, 0)).norm() < 0.3) grid.mark(e);
    }
    grid.adapt();
    obs::test::checkGrid(grid);
  }
  const mesh::Mesh m = grid.leafView().mesh;
  const auto s = linearSystem<2>(m);
  LinearMultigrid<2> mg(grid);
  mg.setOperator(s.A);
  mg.truncate(s.g.constrained);
  Eigen::VectorXd x;
  const LinearSolverResult r = mg.solve(s.b, x);
  EXPECT_TRUE(r.converged);
  EXPECT_LE(r.convergenceRate, 0.3);
  const Eigen::VectorXd ref = solveLinearElasticity(m, kMaterial, s.bc).displacement;
  EXPECT_LT((x - ref).norm(), 1e-8 * ref.norm());
  if (verbose())
    std::cout << "  local: " << grid.maxLevel() << " levels, " << x.size() << " dofs, " << r.iterations
              << " V-cycles, rate " << r.convergenceRate << "\n";
}
