// Mass matrices (consistent, lumped with the HRZ fallback) for all six element types and the mass
// redistribution of Khenous-Laborde-Renard (docs/theory.md#mass-redistribution): total mass rho |Omega|,
// first and second moments (centre of gravity, moment of inertia), zero rows/columns at the contact
// vertices, optimality of the constrained least squares, and the
// smallest eigenvalue of M~ on the remaining vertices.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <random>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/RedRefinement.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/MassMatrix.hpp"
#include "obs/obs/MassRedistribution.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

mesh::Mesh unitBox(CellType t) { return mesh::boxMesh(t, mesh::dimension(t) == 2 ? 4 : 3); }

/// The unit cube of n^3 boxes of type t, its consistent mass and its bottom face (z = 0) as the contact
/// vertices, whose mass the redistribution removes.
struct BottomContactCube {
  mesh::Mesh m;
  ScalarSparseMatrix M;
  std::vector<char> contact;
  BottomContactCube(CellType t, int n) : m(mesh::boxMesh(t, n)), M(assembleConsistentMass(m, Material{})) {
    contact.assign(static_cast<std::size_t>(m.numVertices()), 0);
    for (Index v = 0; v < m.numVertices(); ++v) contact[static_cast<std::size_t>(v)] = m.vertex(v)[2] == 0.0;
  }
};

/// sum_ij M_ij w_j for a vertex weight w (1: total mass, x_c: first moment).
double moment(const ScalarSparseMatrix& M, const mesh::Mesh& m, int c) {
  double s = 0;
  for (Eigen::Index i = 0; i < M.outerSize(); ++i)
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it)
      s += it.value() * (c < 0 ? 1.0 : m.vertex(static_cast<Index>(it.col()))[c]);
  return s;
}

/// sum_ij M_ij x_i,a x_j,b (second moment: int rho x_a x_b for the consistent M).
double secondMoment(const ScalarSparseMatrix& M, const mesh::Mesh& m, int a, int b) {
  double s = 0;
  for (Eigen::Index i = 0; i < M.outerSize(); ++i)
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it)
      s += it.value() * m.vertex(static_cast<Index>(i))[a] * m.vertex(static_cast<Index>(it.col()))[b];
  return s;
}

class MassTest : public ::testing::TestWithParam<CellType> {};

TEST_P(MassTest, TotalMassAndFirstMomentsOfConsistentAndLumped) {
  const CellType t = GetParam();
  const mesh::Mesh m = unitBox(t);
  Material mat{1.0, 0.3};
  mat.density = 2.5;
  const int dim = mesh::dimension(t);
  const ScalarSparseMatrix M = assembleConsistentMass(m, mat);
  int hrz = -1;
  const Eigen::VectorXd ml = assembleLumpedMass(m, mat, &hrz);
  // |Omega| = 1, centroid (1/2, 1/2, 1/2): exact up to round-off
  EXPECT_NEAR(moment(M, m, -1), 2.5, 1e-13);
  EXPECT_NEAR(ml.sum(), 2.5, 1e-13);
  for (int c = 0; c < dim; ++c) {
    EXPECT_NEAR(moment(M, m, c), 2.5 * 0.5, 1e-13) << "coordinate " << c;
    double s = 0;
    for (Index v = 0; v < m.numVertices(); ++v) s += ml[v] * m.vertex(v)[c];
    EXPECT_NEAR(s, 2.5 * 0.5, 1e-13) << "coordinate " << c;
  }
  // non-negative basis functions: positive row sums everywhere, no HRZ fallback needed
  EXPECT_EQ(hrz, 0);
  EXPECT_GT(ml.minCoeff(), 0);
  // symmetric, positive definite
  const Eigen::MatrixXd D(M);
  EXPECT_LT((D - D.transpose()).norm(), 1e-15 * D.norm());
  const double lmin = smallestEigenvalue(M, std::vector<char>(m.numVertices(), 0));
  EXPECT_GT(lmin, 0);
  // block expansion: M (x) I_d agrees with M on the stiffness pattern
  if (dim == 2) {
    const auto pattern = BlockSparseMatrix<2>::withMeshPattern(m);
    const auto B = expandMass<2>(M, pattern);
    Eigen::VectorXd one = Eigen::VectorXd::Zero(2 * m.numVertices());
    for (Index v = 0; v < m.numVertices(); ++v) one[2 * v + 1] = 1;
    EXPECT_NEAR(one.dot(B * one), 2.5, 1e-13);
  }
}

TEST_P(MassTest, RedistributionKeepsMassCentreOfGravityAndSecondMoments) {
  const CellType t = GetParam();
  const int dim = mesh::dimension(t);
  // 6 (2D) / 4 (3D; tetrahedra 6) cells per direction; on 3 cells across M~ is indefinite (the bottom
  // layer carries 1/6 of the mass; see docs/dynamics.md)
  const mesh::Mesh m = mesh::boxMesh(t, dim == 2 ? 6 : (t == CellType::Tetrahedron ? 6 : 4));
  const ScalarSparseMatrix M = assembleConsistentMass(m, Material{});
  // contact vertices: the bottom face (y = 0 in 2D, z = 0 in 3D)
  std::vector<char> contact(m.numVertices(), 0);
  for (Index v = 0; v < m.numVertices(); ++v) contact[v] = m.vertex(v)[dim - 1] == 0.0;
  const RedistributedMass R = redistributeMass(M, m.vertices(), dim, contact);
  const ScalarSparseMatrix& Mt = R.matrix;
  EXPECT_LE(R.residual, 1e-14);
  EXPECT_GT(R.movedMass, 0);
  EXPECT_NEAR(moment(Mt, m, -1), moment(M, m, -1), 1e-13);
  for (int c = 0; c < dim; ++c) EXPECT_NEAR(moment(Mt, m, c), moment(M, m, c), 1e-13) << "coordinate " << c;
  // second moments: those of M are int_[0,1]^d x_a x_b = 1/3 (a = b), 1/4 (a != b); M~ keeps them
  for (int a = 0; a < dim; ++a)
    for (int b = 0; b < dim; ++b) {
      EXPECT_NEAR(secondMoment(M, m, a, b), a == b ? 1.0 / 3 : 0.25, 1e-13) << a << b;
      EXPECT_NEAR(secondMoment(Mt, m, a, b), secondMoment(M, m, a, b), 1e-13) << a << b;
    }
  // the moment of inertia about the vertical axis through the centre: changed by removing the
  // bottom layer alone (M0), restored by the redistribution
  {
    ScalarSparseMatrix M0 = M;
    for (Eigen::Index i = 0; i < M0.outerSize(); ++i)
      for (ScalarSparseMatrix::InnerIterator it(M0, i); it; ++it)
        if (contact[i] || contact[it.col()]) it.valueRef() = 0;
    auto inertia = [&](const ScalarSparseMatrix& A) {  // int rho |x_h - c_h|^2, horizontal coordinates
      double J = 0;
      for (int a = 0; a < dim - 1; ++a) {
        const double mass = moment(A, m, -1), first = moment(A, m, a);
        J += secondMoment(A, m, a, a) - first * first / mass;
      }
      return J;
    };
    if (verbose())
      std::cout << mesh::name(t) << ": horizontal moment of inertia of M " << inertia(M) << ", of M~ " << inertia(Mt)
                << ", of M without the contact rows " << inertia(M0) << "\n";
    EXPECT_NEAR(inertia(Mt), inertia(M), 1e-13);
    EXPECT_GT(std::abs(inertia(M0) - inertia(M)), 1e-3 * inertia(M));
  }
  // zero rows/columns at the contact vertices, pattern of M kept, symmetric
  const Eigen::MatrixXd D(Mt), D0(M);
  for (Index i = 0; i < m.numVertices(); ++i)
    for (Index j = 0; j < m.numVertices(); ++j) {
      if (contact[i] || contact[j]) { EXPECT_EQ(D(i, j), 0.0); }
      if (D0(i, j) == 0.0) { EXPECT_EQ(D(i, j), 0.0); }
    }
  EXPECT_LT((D - D.transpose()).norm(), 1e-15 * D.norm());
  // positive semidefinite on the remaining vertices
  const double lmin = smallestEigenvalue(Mt, contact);
  const double lminM = smallestEigenvalue(M, contact);
  if (verbose())
    std::cout << mesh::name(t) << ": moved mass " << R.movedMass << ", Uzawa sweeps " << R.iterations
              << ", smallest eigenvalue of M~ (remaining vertices) " << lmin << " (of M restricted: " << lminM << ")\n";
  EXPECT_GT(lmin, 0) << "smallest eigenvalue " << lmin;
  EXPECT_LE(R.iterations, 3);
  // the sparse LDL' inertia check agrees with the dense eigenvalue
  const DefinitenessCheck pd = checkPositiveDefinite(Mt, contact);
  EXPECT_TRUE(pd.positiveDefinite);
  EXPECT_EQ(pd.nonPositivePivots, 0);
  EXPECT_EQ(pd.size, static_cast<Eigen::Index>(std::count(contact.begin(), contact.end(), 0)));
}

TEST(MassRedistribution, DefinitenessCheckCountsNegativeEigenvalues) {
  // 3^3 tetrahedral unit cube without mass at the bottom: M~ indefinite (dense smallest eigenvalue
  // -2.5e-3); the LDL' inertia (negative pivots = negative eigenvalues) must agree with the dense count
  const BottomContactCube cube(CellType::Tetrahedron, 3);
  const mesh::Mesh& m = cube.m;
  const ScalarSparseMatrix& M = cube.M;
  const std::vector<char>& contact = cube.contact;
  // without the lower bound (with it no M~ exists here: the constraints need a nearly massless layer)
  MassRedistributionOptions unbounded;
  unbounded.minimumScale = -std::numeric_limits<double>::infinity();
  const RedistributedMass R = redistributeMass(M, m.vertices(), 3, contact, unbounded);
  const double lmin = smallestEigenvalue(R.matrix, contact);
  EXPECT_LT(lmin, -1e-5);
  try {
    redistributeMass(M, m.vertices(), 3, contact);
    ADD_FAILURE() << "no error with the bound";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("entries are at the bound"), std::string::npos) << e.what();
  }
  // dense count of negative eigenvalues
  Eigen::Index negative = 0;
  {
    std::vector<Eigen::Index> idx;
    for (Index v = 0; v < m.numVertices(); ++v)
      if (!contact[v]) idx.push_back(v);
    Eigen::MatrixXd D0(R.matrix), D(idx.size(), idx.size());
    for (std::size_t a = 0; a < idx.size(); ++a)
      for (std::size_t b = 0; b < idx.size(); ++b) D(a, b) = D0(idx[a], idx[b]);
    const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(D).eigenvalues();
    negative = (ev.array() < 0).count();
  }
  const DefinitenessCheck pd = checkPositiveDefinite(R.matrix, contact);
  if (verbose()) std::cout << "3^3 tetrahedra: " << negative << " negative eigenvalues, LDL' " << pd.nonPositivePivots << "\n";
  EXPECT_FALSE(pd.positiveDefinite);
  EXPECT_GE(negative, 1);
  EXPECT_EQ(pd.nonPositivePivots, negative);
  // the full consistent matrix is positive definite; a zero matrix breaks down (not positive definite)
  EXPECT_TRUE(checkPositiveDefinite(M, std::vector<char>(m.numVertices(), 0)).positiveDefinite);
  ScalarSparseMatrix Z = M;
  Z *= 0.0;
  EXPECT_FALSE(checkPositiveDefinite(Z, std::vector<char>(m.numVertices(), 0)).positiveDefinite);
  EXPECT_THROW(checkPositiveDefinite(M, std::vector<char>(3, 0)), obs::Error);
  EXPECT_THROW(checkPositiveDefinite(M, std::vector<char>(m.numVertices(), 1)), obs::Error);
}

INSTANTIATE_TEST_SUITE_P(AllTypes, MassTest, ::testing::ValuesIn(mesh::kVolumeCellTypes),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

TEST(MassRedistribution, IsTheClosestMatrixWithTheConstraints) {
  const mesh::Mesh m = mesh::boxMesh(CellType::Quadrilateral, 5);
  const ScalarSparseMatrix M = assembleConsistentMass(m, Material{});
  std::vector<char> contact(m.numVertices(), 0);
  for (Index v = 0; v < m.numVertices(); ++v) contact[v] = m.vertex(v)[1] == 0.0;
  const RedistributedMass R = redistributeMass(M, m.vertices(), 2, contact);
  const Eigen::MatrixXd D(R.matrix), D0(M);
  // the distance: sum over the kept pattern K of (M~_ij - M_ij)^2 / |M_ij|
  auto kept = [&](Index i, Index j) { return !contact[i] && !contact[j] && D0(i, j) != 0; };
  auto distance = [&](const Eigen::MatrixXd& X) {
    double s = 0;
    for (Index i = 0; i < m.numVertices(); ++i)
      for (Index j = 0; j < m.numVertices(); ++j)
        if (kept(i, j)) s += std::pow(X(i, j) - D0(i, j), 2) / std::abs(D0(i, j));
    return s;
  };
  const double dist = distance(D);
  // admissible competitors: M~ + P with P symmetric on the kept pattern and C(P) = 0
  std::mt19937 gen(7);
  std::normal_distribution<double> N(0, 1e-3);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::MatrixXd P = Eigen::MatrixXd::Zero(D.rows(), D.cols());
    for (Index i = 0; i < m.numVertices(); ++i)
      for (Index j = i; j < m.numVertices(); ++j)
        if (kept(i, j)) P(i, j) = P(j, i) = N(gen);
    // project P onto {C(P) = 0} in the inner product sum_K P_ij Q_ij / |M_ij| (constraints: weights
    // 1, x, y, x_i x_j, (x_i y_j + y_i x_j)/2, y_i y_j in the original coordinates; the projection
    // subtracts sum_a l_a |M| W^a)
    std::vector<Eigen::MatrixXd> W(6, Eigen::MatrixXd::Zero(D.rows(), D.cols())), Wm = W;
    for (Index i = 0; i < m.numVertices(); ++i)
      for (Index j = 0; j < m.numVertices(); ++j)
        if (kept(i, j)) {
          const double w = std::abs(D0(i, j));
          const mesh::Point &xi = m.vertex(i), &xj = m.vertex(j);
          W[0](i, j) = 1;
          W[1](i, j) = 0.5 * (xi[0] + xj[0]);
          W[2](i, j) = 0.5 * (xi[1] + xj[1]);
          W[3](i, j) = xi[0] * xj[0];
          W[4](i, j) = 0.5 * (xi[0] * xj[1] + xi[1] * xj[0]);
          W[5](i, j) = xi[1] * xj[1];
          Wm[0](i, j) = w;  // |M| W^a
          for (int a = 1; a < 6; ++a) Wm[a](i, j) = w * W[a](i, j);
        }
    Eigen::Matrix<double, 6, 6> G;
    Eigen::Matrix<double, 6, 1> r;
    for (int a = 0; a < 6; ++a) {
      r[a] = (W[a].array() * P.array()).sum();
      for (int b = 0; b < 6; ++b) G(a, b) = (W[a].array() * Wm[b].array()).sum();
    }
    const Eigen::Matrix<double, 6, 1> l = G.ldlt().solve(r);
    for (int a = 0; a < 6; ++a) P -= l[a] * Wm[a];
    for (int a = 0; a < 6; ++a) EXPECT_NEAR((W[a].array() * P.array()).sum(), 0.0, 1e-15) << "constraint " << a;
    const double other = distance(D + P);
    EXPECT_GT(other, dist) << "trial " << trial;
    // orthogonality of the optimum: |M~ + P - M|^2 = |M~ - M|^2 + |P|^2 in the weighted norm
    EXPECT_NEAR(other, dist + distance(D0 + P), 1e-12 * other);
  }
}

/// The ball of data/scenes/dynamics_ball.toml (pyramids, 2 inner cells, radius 1) refined `levels` times
/// with the new surface vertices projected onto the sphere; contact = the whole surface.
mesh::Mesh refinedBall(int levels, std::vector<char>& contact) {
  const mesh::CurvedMesh c = mesh::ballMesh(mesh::Point::Zero(), 1.0, CellType::Pyramid, 2);
  mesh::Mesh m = c.mesh;
  for (int l = 0; l < levels; ++l) {
    m = mesh::refineUniformly(m);
    for (Index f = 0; f < m.numBoundaryFaces(); ++f)
      for (Index v : m.boundaryFaceVertices(f)) m.vertex(v) = c.projections.at(mesh::kCurvedSurface)(m.vertex(v));
  }
  contact.assign(m.numVertices(), 0);
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    for (Index v : m.boundaryFaceVertices(f)) contact[v] = 1;
  return m;
}

TEST(MassRedistribution, LowerBoundKeepsTheBallsDiagonalPositive) {
  // Geometry A with the whole sphere massless (refine 2, 4321 vertices): the unbounded minimiser
  // rescales the kept entries by 1 + q, q quadratic; keeping the second moments moves mass outwards
  // and 1 + q < 0 at the centre, i.e. a negative diagonal entry (the KLR/HHW failure on the ball).
  // With the bound M~_ij >= theta M_ij the constraints still hold, no entry is below the bound, the
  // unbounded ones are M_ij (1 + q_ij) with the same polynomial form, and M~ is positive definite.
  std::vector<char> contact;
  const mesh::Mesh m = refinedBall(2, contact);
  ASSERT_EQ(m.numVertices(), 4321);
  const ScalarSparseMatrix M = assembleConsistentMass(m, Material{});
  // without the bound: negative diagonal entries (what NewmarkFamily rejected before)
  MassRedistributionOptions unbounded;
  unbounded.minimumScale = -std::numeric_limits<double>::infinity();
  const RedistributedMass R0 = redistributeMass(M, m.vertices(), 3, contact, unbounded);
  EXPECT_EQ(R0.boundedEntries, 0);
  EXPECT_LE(R0.residual, 1e-11);
  Index negativeDiagonal = 0;
  double minDiagonal0 = std::numeric_limits<double>::infinity();
  for (Index v = 0; v < m.numVertices(); ++v)
    if (!contact[v]) {
      negativeDiagonal += R0.matrix.coeff(v, v) < 0;
      minDiagonal0 = std::min(minDiagonal0, R0.matrix.coeff(v, v));
    }
  EXPECT_GT(negativeDiagonal, 0);
  const RedistributedMass R = redistributeMass(M, m.vertices(), 3, contact);  // theta = 0.1
  const double theta = MassRedistributionOptions{}.minimumScale;
  EXPECT_EQ(theta, 0.1);
  EXPECT_GT(R.boundedEntries, 0);
  EXPECT_GE(R.minimumFactor, theta - 1e-15);
  EXPECT_LE(R.residual, 1e-11);
  EXPECT_NEAR(moment(R.matrix, m, -1), moment(M, m, -1), 1e-12);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(moment(R.matrix, m, a), moment(M, m, a), 1e-12) << a;
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(secondMoment(R.matrix, m, a, b), secondMoment(M, m, a, b), 1e-12) << a << b;
  }
  double minDiagonal = std::numeric_limits<double>::infinity();
  for (Index v = 0; v < m.numVertices(); ++v)
    if (!contact[v]) minDiagonal = std::min(minDiagonal, R.matrix.coeff(v, v));
  EXPECT_GT(minDiagonal, 0);
  // entries: at the bound exactly theta M_ij, elsewhere above it
  Eigen::Index atBound = 0;
  for (Eigen::Index i = 0; i < M.outerSize(); ++i)
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it) {
      if (contact[i] || contact[it.col()]) continue;
      const double f = R.matrix.coeff(i, it.col()) / it.value();
      EXPECT_GE(f, theta * (1 - 1e-14));
      atBound += f <= theta * (1 + 1e-14);
    }
  EXPECT_EQ(atBound, R.boundedEntries);
  const DefinitenessCheck pd = checkPositiveDefinite(R.matrix, contact);
  if (verbose())
    std::cout << "ball refine 2: without the bound " << negativeDiagonal << " negative diagonal entries (smallest "
              << minDiagonal0 << ", factor " << R0.minimumFactor << "); entries at the bound theta = " << theta << ": " << R.boundedEntries << " of "
              << M.nonZeros() << ", min factor " << R.minimumFactor << ", min diagonal " << minDiagonal
              << ", sweeps " << R.iterations << ", residual " << R.residual << ", negative pivots "
              << pd.nonPositivePivots << " of " << pd.size << " vertices with mass\n";
  EXPECT_TRUE(pd.positiveDefinite) << pd.nonPositivePivots << " non-positive pivots";
  EXPECT_LE(R.iterations, 20);
}

TEST(MassRedistribution, LowerBoundChangesNothingWhereItIsInactive) {
  // the 4^3 hexahedral unit cube without mass at the bottom: every factor 1 + q is far above 0.1, so the
  // bounded and the unbounded minimiser are the same matrix, bit for bit
  const BottomContactCube cube(CellType::Hexahedron, 4);
  const mesh::Mesh& m = cube.m;
  const ScalarSparseMatrix& M = cube.M;
  const std::vector<char>& contact = cube.contact;
  MassRedistributionOptions zero;
  zero.minimumScale = 0;
  const RedistributedMass a = redistributeMass(M, m.vertices(), 3, contact, zero);
  const RedistributedMass b = redistributeMass(M, m.vertices(), 3, contact);
  EXPECT_EQ(a.boundedEntries, 0);
  EXPECT_EQ(b.boundedEntries, 0);
  EXPECT_GT(b.minimumFactor, 0.1);
  EXPECT_EQ(Eigen::MatrixXd(a.matrix - b.matrix).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(a.iterations, b.iterations);
  MassRedistributionOptions bad;
  bad.minimumScale = 1;
  EXPECT_THROW(redistributeMass(M, m.vertices(), 3, contact, bad), obs::Error);
  bad.minimumScale = std::nan("");
  EXPECT_THROW(redistributeMass(M, m.vertices(), 3, contact, bad), obs::Error);
  // no bound at all: the same matrix as well
  MassRedistributionOptions none;
  none.minimumScale = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(Eigen::MatrixXd(redistributeMass(M, m.vertices(), 3, contact, none).matrix - b.matrix).cwiseAbs().maxCoeff(), 0.0);
}

TEST(MassRedistribution, FirstMomentsOnlyKeepMassAndCentreOfGravity) {
  // moments = 1 (the thesis' M~ of Sec. 5.2.6): 1 + d constraints; mass and centre of gravity kept to
  // round-off, the second moment in the normal direction not (removing the bottom layer lowers it and
  // only the rescaling by an affine polynomial is left to restore it)
  const BottomContactCube cube(CellType::Hexahedron, 4);
  const mesh::Mesh& m = cube.m;
  const ScalarSparseMatrix& M = cube.M;
  const std::vector<char>& contact = cube.contact;
  MassRedistributionOptions first;
  first.moments = 1;
  const RedistributedMass R = redistributeMass(M, m.vertices(), 3, contact, first);
  EXPECT_EQ(R.multipliers.size(), 4);
  EXPECT_LE(R.residual, 1e-14);
  EXPECT_NEAR(moment(R.matrix, m, -1), moment(M, m, -1), 1e-13);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(moment(R.matrix, m, c), moment(M, m, c), 1e-13) << "coordinate " << c;
  EXPECT_GT(std::abs(secondMoment(R.matrix, m, 2, 2) - secondMoment(M, m, 2, 2)), 1e-4);
  const RedistributedMass full = redistributeMass(M, m.vertices(), 3, contact);
  EXPECT_EQ(full.multipliers.size(), 10);
  EXPECT_NEAR(secondMoment(full.matrix, m, 2, 2), secondMoment(M, m, 2, 2), 1e-13);
  for (int bad : {3, -1}) {
    MassRedistributionOptions o;
    o.moments = bad;
    EXPECT_THROW(redistributeMass(M, m.vertices(), 3, contact, o), obs::Error) << bad;
  }
}

TEST(MassRedistribution, NoMomentsOnlyZeroTheContactRows) {
  // moments = 0 (the thesis' control run of Fig. 5.3(b)): M with the rows and columns of the contact
  // vertices zeroed, every other entry bit for bit that of M, the removed mass lost (not moved)
  const BottomContactCube cube(CellType::Hexahedron, 4);
  const mesh::Mesh& m = cube.m;
  const ScalarSparseMatrix& M = cube.M;
  const std::vector<char>& contact = cube.contact;
  MassRedistributionOptions none;
  none.moments = 0;
  const RedistributedMass R = redistributeMass(M, m.vertices(), 3, contact, none);
  EXPECT_EQ(R.multipliers.size(), 0);
  EXPECT_EQ(R.iterations, 0);
  double removed = 0;
  for (Eigen::Index i = 0; i < M.outerSize(); ++i)
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it) {
      const bool zeroed = contact[static_cast<std::size_t>(i)] || contact[static_cast<std::size_t>(it.col())];
      EXPECT_EQ(R.matrix.coeff(i, it.col()), zeroed ? 0.0 : it.value()) << i << ", " << it.col();
      if (zeroed) removed += it.value();
    }
  EXPECT_EQ(R.movedMass, removed);
  EXPECT_GT(removed, 0);
  // the total mass drops by the removed mass (to round-off of the sums)
  EXPECT_NEAR(moment(R.matrix, m, -1), moment(M, m, -1) - removed, 1e-14 * moment(M, m, -1));
}

TEST(MassLumping, HrzFallbackForNonPositiveRowSums) {
  Eigen::MatrixXd local(2, 2);
  local << 1.0, -1.2, -1.2, 3.0;  // row sums -0.2, 1.8
  bool hrz = false;
  const Eigen::VectorXd l = lumpCellMass(local, &hrz);
  EXPECT_TRUE(hrz);
  EXPECT_NEAR(l.sum(), local.sum(), 1e-15);  // keeps the cell mass
  EXPECT_NEAR(l[0], 0.4, 1e-15);             // M_ii * total / trace
  EXPECT_NEAR(l[1], 1.2, 1e-15);
  local << 2.0, 1.0, 1.0, 2.0;
  EXPECT_EQ(lumpCellMass(local, &hrz), Eigen::Vector2d(3.0, 3.0));
  EXPECT_FALSE(hrz);
  local << -1.0, 0.0, 0.0, 1.0;
  EXPECT_THROW(lumpCellMass(local), obs::Error);
}

TEST(MassMatrix, BadInput) {
  const mesh::Mesh m = mesh::boxMesh(CellType::Triangle, 2);
  Material bad{1.0, 0.3};
  bad.density = 0;
  EXPECT_THROW(assembleConsistentMass(m, bad), obs::Error);
  bad.density = -1;
  EXPECT_THROW(assembleLumpedMass(m, bad), obs::Error);
  bad.density = std::nan("");
  EXPECT_THROW(assembleLumpedMass(m, bad), obs::Error);
  const ScalarSparseMatrix M = assembleConsistentMass(m, Material{});
  EXPECT_THROW(redistributeMass(M, m.vertices(), 2, std::vector<char>(m.numVertices(), 1)), obs::Error);
  EXPECT_THROW(redistributeMass(M, m.vertices(), 2, std::vector<char>(3, 0)), obs::Error);
  // only the top row keeps mass: its vertices lie on one line, the second moments cannot be kept
  std::vector<char> allButTop(m.numVertices(), 1);
  for (Index v = 0; v < m.numVertices(); ++v) allButTop[v] = m.vertex(v)[1] != 1.0;
  try {
    redistributeMass(M, m.vertices(), 2, allButTop);
    ADD_FAILURE() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("do not determine"), std::string::npos) << e.what();
  }
}

}  // namespace
