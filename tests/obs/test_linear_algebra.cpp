// Block sparse matrices, CHOLMOD and the symmetric Dirichlet elimination against dense Eigen.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"

using namespace obs;
using mesh::CellType;

namespace {

/// Two quadrilaterals side by side plus a triangle on top: a small mixed 2D mesh.
mesh::Mesh smallMesh() {
  mesh::Mesh m(2);
  for (Point p : {Point(0, 0, 0), Point(1, 0, 0), Point(2, 0, 0), Point(0, 1, 0), Point(1, 1, 0),
                  Point(2, 1, 0), Point(1, 2, 0)})
    m.addVertex(p);
  m.addCell(CellType::Quadrilateral, {0, 1, 4, 3});
  m.addCell(CellType::Quadrilateral, {1, 2, 5, 4});
  m.addCell(CellType::Triangle, {4, 5, 6});
  m.addBoundaryFace({0, 1}, 1);
  m.addBoundaryFace({1, 2}, 1);
  m.setBoundaryName(1, "bottom");
  return m;
}

Eigen::MatrixXd dense(const BlockSparseMatrix<2>& A) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(A.rows() * 2, A.rows() * 2);
  for (Index i = 0; i < A.rows(); ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) D.block<2, 2>(2 * i, 2 * A.column(k)) = A.blockAt(k);
  return D;
}

TEST(BlockSparseMatrix, MeshPatternCouplesCellNeighboursOnly) {
  const auto m = smallMesh();
  const auto A = BlockSparseMatrix<2>::withMeshPattern(m);
  EXPECT_EQ(A.rows(), 7);
  EXPECT_GE(A.find(0, 4), 0);   // same quadrilateral (diagonal)
  EXPECT_EQ(A.find(0, 2), -1);  // different cells
  EXPECT_EQ(A.find(0, 6), -1);
  EXPECT_GE(A.find(6, 5), 0);
  for (Index i = 0; i < A.rows(); ++i) EXPECT_GE(A.diagonal(i), 0);
}

TEST(BlockSparseMatrix, StiffnessIsSymmetricWithRigidKernel) {
  const auto m = smallMesh();
  const auto A = assembleStiffness<2>(m, Material{10.0, 0.3});
  const Eigen::MatrixXd D = dense(A);
  EXPECT_LT((D - D.transpose()).norm(), 1e-12 * D.norm());
  // rigid motions (two translations, one rotation) are in the kernel; nothing else is
  Eigen::MatrixXd R(14, 3);
  for (Index v = 0; v < 7; ++v) {
    const Point& x = m.vertex(v);
    R.row(2 * v) << 1, 0, -x[1];
    R.row(2 * v + 1) << 0, 1, x[0];
  }
  EXPECT_LT((D * R).norm(), 1e-12 * D.norm());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(D);
  int zero = 0;
  for (int k = 0; k < 14; ++k) zero += eig.eigenvalues()[k] < 1e-10 * eig.eigenvalues().maxCoeff();
  EXPECT_EQ(zero, 3);
  // multiply agrees with the dense product
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(14, -1, 2);
  EXPECT_LT((A * x - D * x).norm(), 1e-12 * D.norm());
}

TEST(CholmodSolver, SolvesDirichletEliminatedSystemLikeDense) {
  const auto m = smallMesh();
  auto A = assembleStiffness<2>(m, Material{10.0, 0.3});
  const Eigen::MatrixXd D0 = dense(A);
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(14, 0.5, -0.5);
  const Eigen::VectorXd b0 = b;
  DirichletCondition dc{1, {true, true, false}, [](const Point& x) { return Eigen::Vector3d(0.1 * x[0], -0.2, 0); }};
  const DirichletValues g = collectDirichlet(m, {dc});
  EXPECT_EQ(g.count(), 6);  // vertices 0, 1, 2, both components
  applyDirichlet(A, b, g);
  const Eigen::MatrixXd D = dense(A);
  EXPECT_LT((D - D.transpose()).norm(), 1e-14 * D.norm());
  CholmodSolver solver(A);
  const Eigen::VectorXd x = solver.solve(b);
  // Reference: solve the free block of the original system densely.
  std::vector<int> freeIdx;
  for (int k = 0; k < 14; ++k)
    if (!g.constrained[k]) freeIdx.push_back(k);
  Eigen::MatrixXd Aff(freeIdx.size(), freeIdx.size());
  Eigen::VectorXd rhs(freeIdx.size());
  for (std::size_t i = 0; i < freeIdx.size(); ++i) {
    rhs[i] = b0[freeIdx[i]] - D0.row(freeIdx[i]).dot(g.values);
    for (std::size_t j = 0; j < freeIdx.size(); ++j) Aff(i, j) = D0(freeIdx[i], freeIdx[j]);
  }
  const Eigen::VectorXd xf = Aff.ldlt().solve(rhs);
  for (std::size_t i = 0; i < freeIdx.size(); ++i) EXPECT_NEAR(x[freeIdx[i]], xf[i], 1e-12);
  for (int k = 0; k < 14; ++k)
    if (g.constrained[k]) {
      EXPECT_DOUBLE_EQ(x[k], g.values[k]);
    }
  EXPECT_GT(solver.factorNonZeros(), 0);
}

TEST(CholmodSolver, ReportsIndefiniteMatrix) {
  const auto m = smallMesh();
  auto A = assembleStiffness<2>(m, Material{10.0, 0.3});
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) A.blockAt(k) *= -1;  // negative definite
  EXPECT_THROW(CholmodSolver{A}, obs::Error);
}

}  // namespace
