// Patch tests on distorted (non-affine) meshes of every cell type: first-order elements must
// reproduce any linear displacement field exactly, with Dirichlet data on the whole boundary or
// with tractions on part of it, and rigid motions must produce zero stress.
#include <gtest/gtest.h>

#include <random>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearElasticity.hpp"

using namespace obs;
using mesh::CellType;

namespace {

/// Outward unit normal of a face of the unit box by boundary id (BoxMesh.hpp numbering).
Eigen::Vector3d boxNormal(int dim, int id) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  const int axis = id <= 2 ? 0 : id <= 4 ? dim - 1 : 1;
  n[axis] = (id % 2 == 0) ? 1.0 : -1.0;
  return n;
}

struct LinearField {
  Eigen::Vector3d a;
  Eigen::Matrix3d B;
  int dim;
  Eigen::Vector3d operator()(const Point& x) const {
    Eigen::Vector3d u = a + B * x;
    if (dim == 2) u[2] = 0;
    return u;
  }
  Stress stress(const Material& m) const {
    Eigen::Matrix3d eps = 0.5 * (B + B.transpose());
    if (dim == 2) eps.row(2).setZero(), eps.col(2).setZero();
    return 2 * m.mu() * eps + m.lambda() * eps.trace() * Eigen::Matrix3d::Identity();
  }
};

LinearField randomLinearField(int dim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  LinearField f{Eigen::Vector3d(U(rng), U(rng), U(rng)), Eigen::Matrix3d::Zero(), dim};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) f.B(i, j) = 0.01 * U(rng);
  if (dim == 2) f.B.row(2).setZero(), f.B.col(2).setZero(), f.a[2] = 0;
  return f;
}

mesh::Mesh distortedBox(CellType t) {
  auto m = mesh::boxMesh(t, {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1));
  mesh::perturbInteriorVertices(m, 0.25, 1234);
  return m;
}

int numBoxFaces(int dim) { return dim == 2 ? 4 : 6; }

class PatchTest : public ::testing::TestWithParam<CellType> {};

/// Tolerances: displacement (absolute) and stress (relative); the defaults are for moderate nu.
void expectReproduces(const mesh::Mesh& m, const ElasticitySolution& s, const LinearField& u,
                      const Material& mat, double displacementTolerance = 1e-12, double stressTolerance = 1e-10) {
  const int d = m.dimension();
  double err = 0;
  for (Index v = 0; v < m.numVertices(); ++v)
    for (int c = 0; c < d; ++c)
      err = std::max(err, std::abs(s.displacement[v * d + c] - u(m.vertex(v))[c]));
  EXPECT_LT(err, displacementTolerance);
  const Stress exact = u.stress(mat);
  double serr = 0;
  for (const Stress& sc : s.cellStress) serr = std::max(serr, (sc - exact).cwiseAbs().maxCoeff());
  for (const Stress& sv : s.vertexStress) serr = std::max(serr, (sv - exact).cwiseAbs().maxCoeff());
  EXPECT_LT(serr, stressTolerance * exact.cwiseAbs().maxCoeff());
}

/// u on face 1, the exact tractions sigma(u) n on the other faces of the box.
BoundaryConditions tractionData(int d, const LinearField& u, const Material& mat) {
  const Stress sigma = u.stress(mat);
  BoundaryConditions bc;
  bc.dirichlet.push_back({1, {true, true, true}, u});
  for (int id = 2; id <= numBoxFaces(d); ++id) {
    const Eigen::Vector3d t = sigma * boxNormal(d, id);
    bc.neumann.push_back({id, [t](const Point&) { return t; }, {}});
  }
  return bc;
}

TEST_P(PatchTest, LinearFieldWithDirichletBoundary) {
  const auto m = distortedBox(GetParam());
  const Material mat{1000.0, 0.3};
  const auto u = randomLinearField(m.dimension(), 5);
  BoundaryConditions bc;
  for (int id = 1; id <= numBoxFaces(m.dimension()); ++id)
    bc.dirichlet.push_back({id, {true, true, true}, u});
  expectReproduces(m, solveLinearElasticity(m, mat, bc), u, mat);
}

TEST_P(PatchTest, LinearFieldWithTractions) {
  const auto m = distortedBox(GetParam());
  const int d = m.dimension();
  const Material mat{200.0, 0.45};
  const auto u = randomLinearField(d, 17);
  expectReproduces(m, solveLinearElasticity(m, mat, tractionData(d, u, mat)), u, mat);
}

TEST_P(PatchTest, RigidMotionGivesZeroStress) {
  const auto m = distortedBox(GetParam());
  const Material mat{1.0, 0.25};
  const Eigen::Vector3d w(0.01, -0.02, 0.03), c(0.1, 0.2, 0.3);
  const int d = m.dimension();
  VectorField rigid = [&](const Point& x) {
    Eigen::Vector3d u = d == 3 ? Eigen::Vector3d(c + w.cross(x)) : Eigen::Vector3d(c[0] - w[2] * x[1], c[1] + w[2] * x[0], 0);
    return u;
  };
  BoundaryConditions bc;
  for (int id = 1; id <= numBoxFaces(d); ++id) bc.dirichlet.push_back({id, {true, true, true}, rigid});
  const auto s = solveLinearElasticity(m, mat, bc);
  for (const Stress& sc : s.cellStress) EXPECT_LT(sc.cwiseAbs().maxCoeff(), 1e-13);
  for (Index v = 0; v < m.numVertices(); ++v)
    for (int k = 0; k < d; ++k) EXPECT_NEAR(s.displacement[v * d + k], rigid(m.vertex(v))[k], 1e-14);
}

TEST_P(PatchTest, PressureEqualsNormalTraction) {
  const auto m = distortedBox(GetParam());
  const int d = m.dimension();
  const Material mat{10.0, 0.2};
  BoundaryConditions withPressure, withTraction;
  for (auto* bc : {&withPressure, &withTraction}) bc->dirichlet.push_back({1, {true, true, true}, {}});
  withPressure.dirichlet[0].value = withTraction.dirichlet[0].value = [](const Point&) {
    return Eigen::Vector3d::Zero();
  };
  withPressure.neumann.push_back({2, {}, [](const Point& x) { return 1.0 + x[1]; }});
  withTraction.neumann.push_back({2, [](const Point& x) { return Eigen::Vector3d(-(1.0 + x[1]), 0, 0); }, {}});
  const auto a = solveLinearElasticity(m, mat, withPressure);
  const auto b = solveLinearElasticity(m, mat, withTraction);
  EXPECT_LT((a.displacement - b.displacement).lpNorm<Eigen::Infinity>(), 1e-12);
  EXPECT_GT(a.displacement.lpNorm<Eigen::Infinity>(), 1e-3);  // the load does something
  (void)d;
}

TEST_P(PatchTest, BBarLinearFieldWithTractionsNearlyIncompressible) {
  // B-bar (docs/theory.md#b-bar) replaces div u by its cell mean in the volumetric part; a linear
  // field has constant div u, so the patch test holds exactly, also at nu = 0.4999 and for the
  // recovered stresses.
  const auto m = distortedBox(GetParam());
  const int d = m.dimension();
  Material mat{200.0, 0.4999};
  mat.formulation = VolumetricFormulation::BBar;
  const auto u = randomLinearField(d, 23);
  // nu = 0.4999 amplifies the rounding of the volumetric part by lambda/mu ~ 5e3
  expectReproduces(m, solveLinearElasticity(m, mat, tractionData(d, u, mat)), u, mat, 1e-10, 1e-8);
}

TEST_P(PatchTest, BBarStiffnessActsLikeStandardOnLinearFields) {
  // K_bbar u = K u for every linear u (cell by cell: div u is constant); on simplices K_bbar = K.
  const auto m = distortedBox(GetParam());
  const int d = m.dimension();
  Material standard{3.0, 0.35}, bbar = standard;
  bbar.formulation = VolumetricFormulation::BBar;
  const auto u = randomLinearField(d, 31);
  Eigen::VectorXd x(m.numVertices() * d);
  for (Index v = 0; v < m.numVertices(); ++v) x.segment(v * d, d) = u(m.vertex(v)).head(d);
  Eigen::VectorXd ks, kb;
  if (d == 2) {
    ks = (assembleStiffness<2>(m, standard) * x);
    kb = (assembleStiffness<2>(m, bbar) * x);
  } else {
    ks = (assembleStiffness<3>(m, standard) * x);
    kb = (assembleStiffness<3>(m, bbar) * x);
  }
  EXPECT_LT((ks - kb).lpNorm<Eigen::Infinity>(), 1e-12 * ks.lpNorm<Eigen::Infinity>());
  const CellType t = GetParam();
  if (t == CellType::Triangle || t == CellType::Tetrahedron) {
    // the whole matrix: apply both to a random vector
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-1, 1);
    for (Eigen::Index i = 0; i < x.size(); ++i) x[i] = U(rng);
    const Eigen::VectorXd a = d == 2 ? (assembleStiffness<2>(m, standard) * x) : (assembleStiffness<3>(m, standard) * x);
    const Eigen::VectorXd b = d == 2 ? (assembleStiffness<2>(m, bbar) * x) : (assembleStiffness<3>(m, bbar) * x);
    EXPECT_LT((a - b).lpNorm<Eigen::Infinity>(), 1e-12 * a.lpNorm<Eigen::Infinity>());
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, PatchTest, ::testing::ValuesIn(mesh::kVolumeCellTypes),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

TEST(RigidMotions, CountedFromDirichletData) {
  const auto m2 = mesh::boxMesh(CellType::Quadrilateral, {4, 4, 1}, Point(0, 0, 0), Point(2, 1, 0));
  auto cond = [](int id, bool x, bool y, bool z) {
    return DirichletCondition{id, {x, y, z}, [](const Point&) { return Eigen::Vector3d::Zero(); }};
  };
  EXPECT_EQ(countFreeRigidMotions(m2, {}), 3);
  EXPECT_EQ(countFreeRigidMotions(m2, {cond(1, true, true, true)}), 0);  // clamped left
  EXPECT_EQ(countFreeRigidMotions(m2, {cond(3, false, true, false)}), 1);  // rollers bottom
  EXPECT_EQ(countFreeRigidMotions(m2, {cond(1, true, false, false)}), 1);  // symmetry left
  EXPECT_EQ(countFreeRigidMotions(m2, {cond(1, true, false, false), cond(3, false, true, false)}), 0);

  const auto m3 = mesh::boxMesh(CellType::Hexahedron, {2, 2, 2}, Point(0, 0, 0), Point(1, 1, 1));
  EXPECT_EQ(countFreeRigidMotions(m3, {}), 6);
  EXPECT_EQ(countFreeRigidMotions(m3, {cond(3, false, false, true)}), 3);  // bottom u_z = 0
  EXPECT_EQ(countFreeRigidMotions(m3, {cond(3, true, true, true)}), 0);
  // rollers on bottom plus symmetry planes left (u_x) and front (u_y): statically determinate
  EXPECT_EQ(countFreeRigidMotions(m3, {cond(3, false, false, true), cond(1, true, false, false),
                                       cond(5, false, true, false)}),
            0);
}

TEST(Material, Validation) {
  EXPECT_THROW((Material{0.0, 0.3}).validate(), obs::Error);
  EXPECT_THROW((Material{1.0, 0.5}).validate(), obs::Error);
  EXPECT_THROW((Material{1.0, -0.1}).validate(), obs::Error);
  EXPECT_NO_THROW((Material{1.0, 0.0}).validate());
}

}  // namespace
