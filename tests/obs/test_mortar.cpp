// Two-body contact with dual mortar: the biorthogonality and partition of unity of the coupling,
// the patch test (two blocks on non-matching meshes of every face-type combination transmit a
// constant pressure exactly and reproduce the linear solution), action = reaction, agreement of
// TNNMG on the block-stacked hierarchies with the primal-dual active set method, flat TNNMG
// iteration counts under refinement, matching meshes against directly glued nodes, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

mesh::Mesh shifted(mesh::Mesh m, const Point& by) {
  for (Index v = 0; v < m.numVertices(); ++v) m.vertex(v) += by;
  return m;
}

/// Index of the vertex at x (exactly representable box coordinates), or -1.
Index vertexAt(const mesh::Mesh& m, const Point& x) {
  for (Index v = 0; v < m.numVertices(); ++v)
    if ((m.vertex(v) - x).norm() < 1e-12) return v;
  return -1;
}

void fix(DirichletValues& dir, Index v, int component, int d) {
  ASSERT_GE(v, 0);
  dir.constrained[static_cast<std::size_t>(v) * d + component] = 1;
  dir.values[static_cast<Eigen::Index>(v) * d + component] = 0;
}

/// Two blocks: the lower one (master) [0,1]^d, the upper one (slave) shifted by e_d, each refined
/// `levels` times. The lower block's bottom is on rollers, the upper block's top carries the
/// pressure p; the remaining rigid motions are fixed at corner vertices away from the interface.
template <int d>
struct StackedBlocks {
  mesh::Grid lower, upper;
  Material lowerMaterial{2e5, 0.3}, upperMaterial{1e5, 0.25};
  double p = 10;
  BodySystem<d> system;
  std::vector<Index> offsets;
  std::unique_ptr<MortarCoupling> coupling;
  std::unique_ptr<ContactProblem<d>> problem;

  StackedBlocks(CellType lowerType, int nLower, CellType upperType, int nUpper, int levels, int extraLowerLevels = 0)
      : lower(mesh::boxMesh(lowerType, nLower)),
        upper(shifted(mesh::boxMesh(upperType, nUpper), d == 2 ? Point(0, 1, 0) : Point(0, 0, 1))) {
    for (int l = 0; l < levels; ++l) upper.refineUniformly();
    for (int l = 0; l < levels + extraLowerLevels; ++l) lower.refineUniformly();
    const mesh::Mesh& ml = lower.leafView().mesh;
    const mesh::Mesh& mu = upper.leafView().mesh;
    BoundaryConditions bl, bu;
    std::array<bool, 3> normalOnly{false, false, false};
    normalOnly[d - 1] = true;
    bl.dirichlet.push_back({mesh::kBottom, normalOnly});
    const double pressure = p;
    bu.neumann.push_back({mesh::kTop, {}, [pressure](const Point&) { return pressure; }});
    auto sl = assembleBody<d>(ml, lowerMaterial, bl);
    auto su = assembleBody<d>(mu, upperMaterial, bu);
    if (d == 2) {
      fix(sl.dirichlet, vertexAt(ml, Point(0, 0, 0)), 0, d);
      fix(su.dirichlet, vertexAt(mu, Point(0, 2, 0)), 0, d);
    } else {
      fix(sl.dirichlet, vertexAt(ml, Point(0, 0, 0)), 0, d);
      fix(sl.dirichlet, vertexAt(ml, Point(0, 0, 0)), 1, d);
      fix(sl.dirichlet, vertexAt(ml, Point(1, 0, 0)), 1, d);
      fix(su.dirichlet, vertexAt(mu, Point(0, 0, 2)), 0, d);
      fix(su.dirichlet, vertexAt(mu, Point(0, 0, 2)), 1, d);
      fix(su.dirichlet, vertexAt(mu, Point(1, 0, 2)), 1, d);
    }
    system = stackBodies<d>({sl, su}, &offsets);
    coupling = std::make_unique<MortarCoupling>(MortarSurface{&mu, mesh::kBottom, offsets[1], "upper bottom"},
                                                MortarSurface{&ml, mesh::kTop, offsets[0], "lower top"},
                                                system.numVertices());
    problem = std::make_unique<ContactProblem<d>>(system.stiffness, system.load, system.dirichlet,
                                                  coupling->contactSet(), coupling->transformation());
  }

  /// The exact solution: uniaxial stress -p in the normal direction in both blocks.
  Eigen::VectorXd exact() const {
    Eigen::VectorXd u(system.load.size());
    auto strains = [&](const Material& m, double& lateral, double& normal) {
      const double E = m.youngsModulus, nu = m.poissonRatio;
      if (d == 3) {
        lateral = nu * p / E;
        normal = -p / E;
      } else {  // plane strain
        lateral = (1 + nu) * nu * p / E;
        normal = -(1 + nu) * (1 - nu) * p / E;
      }
    };
    double latL, norL, latU, norU;
    strains(lowerMaterial, latL, norL);
    strains(upperMaterial, latU, norU);
    const mesh::Mesh& ml = lower.leafView().mesh;
    const mesh::Mesh& mu = upper.leafView().mesh;
    for (Index v = 0; v < ml.numVertices(); ++v) {
      const Point& x = ml.vertex(v);
      for (int a = 0; a + 1 < d; ++a) u[(offsets[0] + v) * d + a] = latL * x[a];
      u[(offsets[0] + v) * d + d - 1] = norL * x[d - 1];
    }
    for (Index v = 0; v < mu.numVertices(); ++v) {
      const Point& x = mu.vertex(v);
      for (int a = 0; a + 1 < d; ++a) u[(offsets[1] + v) * d + a] = latU * x[a];
      u[(offsets[1] + v) * d + d - 1] = norL * 1.0 + norU * (x[d - 1] - 1.0);
    }
    return u;
  }
};

// --- the coupling itself -------------------------------------------------------------------------

TEST(MortarCoupling, PartitionOfUnityAndCoverage2D) {
  StackedBlocks<2> s(CellType::Quadrilateral, 5, CellType::Quadrilateral, 7, 0);
  const MortarCoupling& c = *s.coupling;
  EXPECT_EQ(c.size(), 8);  // every slave node of the 7 interface segments is covered
  EXPECT_EQ(c.statistics().uncoveredNodes, 0);
  double total = 0;
  for (Index k = 0; k < c.size(); ++k) {
    // fully covered: D_pp = int phi_p, and the gap of touching flat surfaces is zero
    EXPECT_NEAR(c.D(k), c.slaveMass(k), 1e-14);
    EXPECT_NEAR(c.weightedGap(k), 0.0, 1e-14);
    EXPECT_NEAR(c.normal(k)[1], -1.0, 1e-14);
    total += c.D(k);
  }
  EXPECT_NEAR(total, 1.0, 1e-14);
}

TEST(MortarCoupling, WeightedGapOfSeparatedSurfaces3D) {
  // the upper block lifted by 0.125: every weighted gap is 0.125 D_pp
  mesh::Mesh lower = mesh::boxMesh(CellType::Hexahedron, 3);
  mesh::Mesh upper = shifted(mesh::boxMesh(CellType::Tetrahedron, 4), Point(0, 0, 1.125));
  const Index n = lower.numVertices() + upper.numVertices();
  MortarCoupling c({&upper, mesh::kBottom, lower.numVertices(), "upper"}, {&lower, mesh::kTop, 0, "lower"}, n);
  ASSERT_EQ(c.size(), 25);
  for (Index k = 0; k < c.size(); ++k) {
    EXPECT_NEAR(c.weightedGap(k), 0.125 * c.D(k), 1e-14);
    double rowSum = 0;
    for (const auto& e : c.row(k)) rowSum += e.value;
    EXPECT_NEAR(rowSum, c.D(k), 1e-15);
  }
  const ContactSet cs = c.contactSet();
  for (Index k = 0; k < cs.size(); ++k) EXPECT_NEAR(cs.gap(k), 0.125, 1e-13);
  EXPECT_NEAR(cs.measure(), 1.0, 1e-13);
}

TEST(MortarCoupling, BiorthogonalDualBasisReproducesLinearFunctions3D) {
  // for a linear field f, sum_q M_pq f(x_q) = D_pp f(x_p) on a fully covered flat interface
  // (int psi_p f = f(x_p) int phi_p for f linear: biorthogonality), for quads over triangles
  mesh::Mesh lower = mesh::boxMesh(CellType::Tetrahedron, 3);
  mesh::Mesh upper = shifted(mesh::boxMesh(CellType::Hexahedron, 4), Point(0, 0, 1));
  const Index n = lower.numVertices() + upper.numVertices();
  MortarCoupling c({&upper, mesh::kBottom, lower.numVertices(), "upper"}, {&lower, mesh::kTop, 0, "lower"}, n);
  auto f = [](const Point& x) { return 1.0 + 2.0 * x[0] - 3.0 * x[1]; };
  for (Index k = 0; k < c.size(); ++k) {
    double s = 0;
    for (const auto& e : c.row(k)) s += e.value * f(lower.vertex(e.vertex));
    const Point& xp = upper.vertex(c.vertex(k) - lower.numVertices());
    EXPECT_NEAR(s, c.D(k) * f(xp), 1e-13) << "slave node " << k;
  }
}

// --- patch test ----------------------------------------------------------------------------------

template <int d>
void checkPatch(StackedBlocks<d>& s, ContactSolver<d>& solver, double tolerance) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(s.system.load.size());
  const ContactResult r = solver.solve(*s.problem, x);
  ASSERT_TRUE(r.converged) << solver.name();
  const Eigen::VectorXd u = s.problem->toDisplacement(x);
  const Eigen::VectorXd ue = s.exact();
  EXPECT_LE((u - ue).lpNorm<Eigen::Infinity>(), tolerance * ue.lpNorm<Eigen::Infinity>()) << solver.name();

  const ContactOutputs out = computeContactOutputs(*s.problem, x);
  EXPECT_EQ(out.contactNodes, s.coupling->size());
  double pmin = 1e300, pmax = -1e300;
  for (double pk : out.pressure) {
    pmin = std::min(pmin, pk);
    pmax = std::max(pmax, pk);
  }
  EXPECT_NEAR(pmin, s.p, tolerance * s.p) << solver.name();
  EXPECT_NEAR(pmax, s.p, tolerance * s.p) << solver.name();
  // action = reaction; the total force is p times the interface measure
  Eigen::VectorXd mu(s.coupling->size());
  for (Index k = 0; k < s.coupling->size(); ++k) mu[k] = out.multiplier[k];
  const Eigen::VectorXd fm = s.coupling->masterForces(mu);
  Eigen::Vector3d master = Eigen::Vector3d::Zero();
  for (Index v = 0; v < s.system.numVertices(); ++v) master.head<d>() += fm.template segment<d>(v * d);
  EXPECT_NEAR((out.force + master).norm(), 0.0, 1e-12 * out.force.norm());
  EXPECT_NEAR(out.force[d - 1], -s.p, tolerance * s.p);  // slave normals point down
  if (verbose())
    std::cout << solver.name() << ": " << r.iterations << " iterations, pressure " << pmin << " .. " << pmax
              << ", |u - u_exact| " << (u - ue).lpNorm<Eigen::Infinity>() << "\n";
}

struct PatchCase {
  CellType lower;
  int nLower;
  CellType upper;
  int nUpper;
};

class MortarPatch3D : public ::testing::TestWithParam<PatchCase> {};

TEST_P(MortarPatch3D, ConstantPressureAndLinearDisplacementExact) {
  const PatchCase c = GetParam();
  StackedBlocks<3> s(c.lower, c.nLower, c.upper, c.nUpper, 0);
  PrimalDualActiveSet<3> pdas;
  checkPatch(s, pdas, 1e-10);
}

// slave (upper) / master (lower) face types: quad/tri, tri/quad, quad/quad, tri/tri (prisms: triangles)
INSTANTIATE_TEST_SUITE_P(FaceTypes, MortarPatch3D,
                         ::testing::Values(PatchCase{CellType::Tetrahedron, 3, CellType::Hexahedron, 4},
                                           PatchCase{CellType::Hexahedron, 3, CellType::Tetrahedron, 4},
                                           PatchCase{CellType::Hexahedron, 5, CellType::Hexahedron, 7},
                                           PatchCase{CellType::Tetrahedron, 2, CellType::Prism, 3},
                                           PatchCase{CellType::Prism, 4, CellType::Pyramid, 3}));

TEST(MortarPatch2D, ConstantPressureAndLinearDisplacementExact) {
  for (auto [lt, ut] : {std::pair{CellType::Quadrilateral, CellType::Triangle},
                        std::pair{CellType::Triangle, CellType::Quadrilateral}}) {
    StackedBlocks<2> s(lt, 5, ut, 7, 0);
    PrimalDualActiveSet<2> pdas;
    checkPatch(s, pdas, 1e-10);
  }
}

TEST(MortarPatch2D, TnnmgOnStackedHierarchies) {
  StackedBlocks<2> s(CellType::Quadrilateral, 3, CellType::Triangle, 4, 3);
  TNNMG<2>::Options o;
  o.tolerance = 1e-13;
  o.maxIterations = 100;
  TNNMG<2> tnnmg({&s.lower, &s.upper}, o);
  checkPatch(s, tnnmg, 1e-9);
}

TEST(MortarPatch3D, TnnmgOnStackedHierarchiesWithDifferentDepths) {
  // the lower body has one level more than the upper one: on the coarsest stacked level the upper
  // body keeps its level-0 view (identity transfer)
  StackedBlocks<3> s(CellType::Hexahedron, 2, CellType::Tetrahedron, 3, 1, 1);
  ASSERT_EQ(s.lower.maxLevel(), 2);
  ASSERT_EQ(s.upper.maxLevel(), 1);
  TNNMG<3>::Options o;
  o.tolerance = 1e-13;
  o.maxIterations = 100;
  TNNMG<3> tnnmg({&s.lower, &s.upper}, o);
  checkPatch(s, tnnmg, 1e-9);
}

}  // namespace
