// Two-body contact with dual mortar: the biorthogonality and partition of unity of the coupling,
// the patch test (two blocks on non-matching meshes of every face-type combination transmit a
// constant pressure exactly and reproduce the linear solution), action = reaction, agreement of
// TNNMG on the block-stacked hierarchies with the primal-dual active set method, flat TNNMG
// iteration counts under refinement, matching meshes against directly glued nodes, and bad input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

/// TNNMG on the stacked hierarchies of two grids, solved far below the patch tests' tolerance.
template <int d>
TNNMG<d> tightTnnmg(const mesh::Grid& lower, const mesh::Grid& upper) {
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-13;
  o.maxIterations = 100;
  return TNNMG<d>({&lower, &upper}, o);
}

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

  /// slaveRollers: the upper (slave) block's sides x = 0 (and y = 0 in 3D) on rollers, so that the slave
  /// nodes on those sides carry a Dirichlet component orthogonal to the contact normal (the exact
  /// solution, lateral strain times x, is zero there)
  StackedBlocks(CellType lowerType, int nLower, CellType upperType, int nUpper, int levels, int extraLowerLevels = 0,
                bool slaveRollers = false)
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
    if (slaveRollers) {
      bu.dirichlet.push_back({mesh::kLeft, {true, false, false}});
      if (d == 3) bu.dirichlet.push_back({mesh::kFront, {false, true, false}});
    }
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
  // out.force = sum mu_p n_p; the slave receives -out.force, the master `master`
  EXPECT_NEAR((master - out.force).norm(), 0.0, 1e-12 * out.force.norm());
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
/// Prints the case by its fields (GoogleTest would print the struct's bytes, padding included).
void PrintTo(const PatchCase& c, std::ostream* os) {
  *os << mesh::name(c.lower) << " " << c.nLower << " / " << mesh::name(c.upper) << " " << c.nUpper;
}

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
                                           PatchCase{CellType::Prism, 4, CellType::Pyramid, 3}),
                         [](const ::testing::TestParamInfo<PatchCase>& info) {
                           // e.g. "tetrahedron3_hexahedron4": lower and upper block (deterministic
                           // names; gtest would otherwise print the struct's padding bytes)
                           const PatchCase& c = info.param;
                           return std::string(mesh::name(c.lower)) + std::to_string(c.nLower) + "_" +
                                  std::string(mesh::name(c.upper)) + std::to_string(c.nUpper);
                         });

// --- patch test on distorted and inclined interfaces ---------------------------------------------

/// Two blocks as in StackedBlocks, with the vertices of both meshes moved within the interface plane
/// (every vertex off the blocks' sides by its own pseudo-random offset of up to `distortion` times
/// the mesh size per component, the same for a whole column, so that the interface faces stay planar
/// but the quadrilaterals are no longer parallelograms), then the whole geometry rotated (inclined:
/// the interface normal is no coordinate axis). Both blocks are held by the exact solution on their
/// far faces (lower bottom, upper top), so the discrete problem reproduces the linear solution of
/// uniaxial stress p exactly if and only if the coupling is exact on these faces.
struct DistortedBlocks {
  mesh::Mesh lower, upper;
  Material lowerMaterial{2e5, 0.3}, upperMaterial{1e5, 0.25};
  double p = 10;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  BodySystem<3> system;
  std::vector<Index> offsets;
  std::unique_ptr<MortarCoupling> coupling;
  std::unique_ptr<ContactProblem<3>> problem;

  /// Exact displacement at the unrotated point y (lower block: y_z <= 1).
  Point exactAt(const Point& y, bool upperBlock) const {
    const Material& m = upperBlock ? upperMaterial : lowerMaterial;
    const double lateral = m.poissonRatio * p / m.youngsModulus, normal = -p / m.youngsModulus;
    const double lowerNormal = -p / lowerMaterial.youngsModulus;
    return Point(lateral * y[0], lateral * y[1], upperBlock ? lowerNormal + normal * (y[2] - 1) : normal * y[2]);
  }

  static void distort(mesh::Mesh& m, int n, double distortion, unsigned seed) {
    const double h = 1.0 / n;
    for (Index v = 0; v < m.numVertices(); ++v) {
      Point& x = m.vertex(v);
      if (x[0] < 1e-12 || x[0] > 1 - 1e-12 || x[1] < 1e-12 || x[1] > 1 - 1e-12) continue;
      // SplitMix64 of the column (i, j) and the seed: the same offset for every vertex of a column
      std::uint64_t z = (static_cast<std::uint64_t>(std::lround(x[0] * n)) * 1000003u +
                         static_cast<std::uint64_t>(std::lround(x[1] * n))) * 7919u + seed;
      auto next = [&z]() {
        z += 0x9e3779b97f4a7c15ull;
        std::uint64_t r = z;
        r = (r ^ (r >> 30)) * 0xbf58476d1ce4e5b9ull;
        r = (r ^ (r >> 27)) * 0x94d049bb133111ebull;
        return static_cast<double>((r ^ (r >> 31)) >> 11) * 0x1.0p-53 * 2 - 1;  // in [-1, 1)
      };
      const double dx = next(), dy = next();
      x[0] += distortion * h * dx;
      x[1] += distortion * h * dy;
    }
  }

  DistortedBlocks(CellType lowerType, int nLower, CellType upperType, int nUpper, double distortion, unsigned seed,
                  bool inclined)
      : lower(mesh::boxMesh(lowerType, nLower)), upper(shifted(mesh::boxMesh(upperType, nUpper), Point(0, 0, 1))) {
    distort(lower, nLower, distortion, seed);
    distort(upper, nUpper, distortion, seed + 1);
    if (inclined) R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    for (mesh::Mesh* m : {&lower, &upper})
      for (Index v = 0; v < m->numVertices(); ++v) m->vertex(v) = R * m->vertex(v);
    const Eigen::Matrix3d Rt = R.transpose();
    BoundaryConditions bl, bu;
    bl.dirichlet.push_back({mesh::kBottom, {true, true, true}, [this, Rt](const Point& x) { return Point(R * exactAt(Rt * x, false)); }});
    bu.dirichlet.push_back({mesh::kTop, {true, true, true}, [this, Rt](const Point& x) { return Point(R * exactAt(Rt * x, true)); }});
    system = stackBodies<3>({assembleBody<3>(lower, lowerMaterial, bl), assembleBody<3>(upper, upperMaterial, bu)}, &offsets);
    coupling = std::make_unique<MortarCoupling>(MortarSurface{&upper, mesh::kBottom, offsets[1], "upper bottom"},
                                                MortarSurface{&lower, mesh::kTop, offsets[0], "lower top"},
                                                system.numVertices());
    problem = std::make_unique<ContactProblem<3>>(system.stiffness, system.load, system.dirichlet,
                                                  coupling->contactSet(), coupling->transformation());
  }

  Eigen::VectorXd exact() const {
    Eigen::VectorXd u(system.load.size());
    const Eigen::Matrix3d Rt = R.transpose();
    for (Index v = 0; v < lower.numVertices(); ++v) u.segment<3>((offsets[0] + v) * 3) = R * exactAt(Rt * lower.vertex(v), false);
    for (Index v = 0; v < upper.numVertices(); ++v) u.segment<3>((offsets[1] + v) * 3) = R * exactAt(Rt * upper.vertex(v), true);
    return u;
  }
};

struct DistortedCase {
  CellType lower;
  int nLower;
  CellType upper;
  int nUpper;
  unsigned seed;
  bool inclined;
  double distortion = 0.3;  ///< largest move per component, in mesh sizes
};
void PrintTo(const DistortedCase& c, std::ostream* os) {
  *os << mesh::name(c.lower) << " " << c.nLower << " / " << mesh::name(c.upper) << " " << c.nUpper << ", seed "
      << c.seed << (c.inclined ? ", inclined" : "") << ", distortion " << c.distortion;
}

class MortarPatchDistorted : public ::testing::TestWithParam<DistortedCase> {};

TEST_P(MortarPatchDistorted, ConstantPressureAndLinearDisplacementExact) {
  const DistortedCase c = GetParam();
  DistortedBlocks s(c.lower, c.nLower, c.upper, c.nUpper, c.distortion, c.seed, c.inclined);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(s.system.load.size());
  PrimalDualActiveSet<3> pdas;
  const ContactResult r = pdas.solve(*s.problem, x);
  ASSERT_TRUE(r.converged);
  const Eigen::VectorXd u = s.problem->toDisplacement(x), ue = s.exact();
  const ContactOutputs out = computeContactOutputs(*s.problem, x);
  EXPECT_EQ(out.contactNodes, s.coupling->size());
  double pmin = 1e300, pmax = -1e300;
  for (double pk : out.pressure) {
    pmin = std::min(pmin, pk);
    pmax = std::max(pmax, pk);
  }
  // exact up to the round-off of the solve: 1e-10 relative (the pressure of a coupling with a
  // quadrature error on these faces is off by 1e-7 .. 1e-6)
  EXPECT_NEAR(pmin, s.p, 1e-10 * s.p);
  EXPECT_NEAR(pmax, s.p, 1e-10 * s.p);
  EXPECT_LE((u - ue).lpNorm<Eigen::Infinity>(), 1e-10 * ue.lpNorm<Eigen::Infinity>());
  if (verbose())
    std::cout << "pressure " << std::setprecision(12) << pmin << " .. " << pmax << ", |u - u_exact| / |u| "
              << (u - ue).lpNorm<Eigen::Infinity>() / ue.lpNorm<Eigen::Infinity>() << "\n";
}

// slave (upper) / master (lower): distorted quadrilaterals over triangles and over distorted
// quadrilaterals, triangles over distorted quadrilaterals; flat and inclined; several seeds; moves of
// 0.3 h (non-affinity up to 0.5) and, in the last three, 0.1 h and 0.03 h (the quadrature degree of
// MortarCoupling depends on the non-affinity of the faces)
INSTANTIATE_TEST_SUITE_P(
    FaceTypes, MortarPatchDistorted,
    ::testing::Values(DistortedCase{CellType::Tetrahedron, 3, CellType::Hexahedron, 4, 1, false},
                      DistortedCase{CellType::Tetrahedron, 3, CellType::Hexahedron, 4, 2, true},
                      DistortedCase{CellType::Tetrahedron, 5, CellType::Hexahedron, 3, 3, false},
                      DistortedCase{CellType::Hexahedron, 3, CellType::Hexahedron, 4, 4, false},
                      DistortedCase{CellType::Hexahedron, 5, CellType::Hexahedron, 4, 5, true},
                      DistortedCase{CellType::Hexahedron, 4, CellType::Tetrahedron, 3, 6, true},
                      DistortedCase{CellType::Prism, 4, CellType::Hexahedron, 3, 7, true},
                      DistortedCase{CellType::Tetrahedron, 3, CellType::Hexahedron, 4, 8, true, 0.1},
                      DistortedCase{CellType::Hexahedron, 5, CellType::Hexahedron, 4, 9, false, 0.1},
                      DistortedCase{CellType::Hexahedron, 3, CellType::Hexahedron, 4, 10, true, 0.03}),
    [](const ::testing::TestParamInfo<DistortedCase>& info) {
      const DistortedCase& c = info.param;
      return std::string(mesh::name(c.lower)) + std::to_string(c.nLower) + "_" + std::string(mesh::name(c.upper)) +
             std::to_string(c.nUpper) + "_seed" + std::to_string(c.seed) + (c.inclined ? "_inclined" : "_flat") +
             "_distortion" + std::to_string(static_cast<int>(std::lround(100 * c.distortion)));
    });

TEST(MortarPatch2D, ConstantPressureAndLinearDisplacementExact) {
  for (auto [lt, ut] : {std::pair{CellType::Quadrilateral, CellType::Triangle},
                        std::pair{CellType::Triangle, CellType::Quadrilateral}}) {
    StackedBlocks<2> s(lt, 5, ut, 7, 0);
    PrimalDualActiveSet<2> pdas;
    checkPatch(s, pdas, 1e-10);
  }
}

TEST(MortarPatch, RollersOnTheSlaveSideKeepThePatchTestExact) {
  // the slave nodes on the rollers have u_x (and u_y) prescribed, orthogonal to their normal -e_d:
  // allowed as for one body, and the patch test stays exact (PDAS and TNNMG)
  {
    StackedBlocks<2> s(CellType::Quadrilateral, 5, CellType::Triangle, 7, 0, 0, true);
    ASSERT_FALSE(s.problem->basisSkip().empty());
    PrimalDualActiveSet<2> pdas;
    checkPatch(s, pdas, 1e-10);
  }
  {
    StackedBlocks<3> s(CellType::Tetrahedron, 3, CellType::Hexahedron, 4, 0, 0, true);
    Index skipped = 0;
    for (std::uint8_t b : s.problem->basisSkip()) skipped += b != 0;
    EXPECT_EQ(skipped, 9);  // the slave nodes on x = 0 or y = 0 of the 5 x 5 interface nodes
    PrimalDualActiveSet<3> pdas;
    checkPatch(s, pdas, 1e-10);
  }
  {
    StackedBlocks<3> s(CellType::Hexahedron, 2, CellType::Tetrahedron, 3, 1, 0, true);
    TNNMG<3> tnnmg = tightTnnmg<3>(s.lower, s.upper);
    checkPatch(s, tnnmg, 1e-9);
  }
}

/// The operators of two problems agree bit for bit: pattern and every block.
template <int d>
void expectSameOperator(const ContactProblem<d>& a, const ContactProblem<d>& b) {
  const BlockSparseMatrix<d>& A = a.rotatedMatrix();
  const BlockSparseMatrix<d>& B = b.rotatedMatrix();
  ASSERT_EQ(A.rows(), B.rows());
  ASSERT_TRUE(std::ranges::equal(A.rowStarts(), B.rowStarts()));
  ASSERT_TRUE(std::ranges::equal(A.columns(), B.columns()));
  Index differ = 0;
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) differ += A.blockAt(k) != B.blockAt(k);
  EXPECT_EQ(differ, 0);
  EXPECT_TRUE(a.rhs().cwiseEqual(b.rhs()).all());
}

/// assembleBodies on ContactProblem::transformedPattern (zero blocks where T'AT gains columns) is
/// transformed in place; stackBodies of the bodies' own matrices is transformed into a new matrix.
/// Both give T'AT bit for bit.
template <int d>
void compareTransformations(StackedBlocks<d>& s) {
  const mesh::Mesh& ml = s.lower.leafView().mesh;
  const mesh::Mesh& mu = s.upper.leafView().mesh;
  const mesh::Mesh* meshes[] = {&ml, &mu};
  const Material* materials[] = {&s.lowerMaterial, &s.upperMaterial};
  const BoundaryConditions none;
  const BoundaryConditions* conditions[] = {&none, &none};
  const mesh::CsrMatrix C = s.coupling->transformation();
  // the stiffness alone: assembleBodies is bitwise stackBodies of assembleBody
  BodySystem<d> plain = assembleBodies<d>(meshes, materials, conditions);
  BodySystem<d> stacked =
      stackBodies<d>({assembleBody<d>(ml, s.lowerMaterial, none), assembleBody<d>(mu, s.upperMaterial, none)});
  ASSERT_TRUE(std::ranges::equal(plain.stiffness.columns(), stacked.stiffness.columns()));
  for (Index k = 0; k < plain.stiffness.nonZeroBlocks(); ++k)
    ASSERT_TRUE(plain.stiffness.blockAt(k) == stacked.stiffness.blockAt(k)) << "block " << k;
  // widened: the pattern grows, the matrix's own blocks stay
  BodySystem<d> widened = assembleBodies<d>(meshes, materials, conditions, nullptr,
                                            [&](typename BlockSparseMatrix<d>::Pattern& p) {
                                              p = ContactProblem<d>::transformedPattern(std::move(p), C);
                                            });
  EXPECT_GT(widened.stiffness.nonZeroBlocks(), plain.stiffness.nonZeroBlocks());
  const ContactProblem<d> copy(s.system.stiffness, s.system.load, s.system.dirichlet, s.coupling->contactSet(), C);
  const ContactProblem<d> inPlace(std::move(widened.stiffness), s.system.load, s.system.dirichlet,
                                  s.coupling->contactSet(), C);
  expectSameOperator(copy, inPlace);
}

TEST(MortarPatch, TransformationInPlaceEqualsTheCopy) {
  {  // with slave rollers (basisSkip)
    StackedBlocks<3> s(CellType::Tetrahedron, 3, CellType::Hexahedron, 4, 1, 0, true);
    ASSERT_FALSE(s.problem->basisSkip().empty());
    compareTransformations(s);
  }
  {
    StackedBlocks<2> s(CellType::Quadrilateral, 5, CellType::Triangle, 7, 1);
    compareTransformations(s);
  }
}

TEST(MortarPatch, SlaveDirichletAlongTheNormalIsAnError) {
  // u_y prescribed at the slave nodes on x = 0 of the 2D interface: along the normal, not allowed
  StackedBlocks<2> s(CellType::Quadrilateral, 5, CellType::Triangle, 7, 0);
  DirichletValues dir = s.system.dirichlet;
  const mesh::Mesh& mu = s.upper.leafView().mesh;
  fix(dir, s.offsets[1] + vertexAt(mu, Point(0, 1, 0)), 1, 2);
  try {
    ContactProblem<2>(s.system.stiffness, s.system.load, dir, s.coupling->contactSet(), s.coupling->transformation());
    ADD_FAILURE() << "no obs::Error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not orthogonal to its contact normal"), std::string::npos) << e.what();
  }
}

TEST(MortarTwoBody, TouchingWithoutLoadIsNoContactAndTheZeroStartIsTheSolution) {
  // two blocks touching with gap 0, no load, zero Dirichlet data: the weighted gaps are exactly zero
  // (their rounding, +-1e-17, is cut), so the zero start is the exact solution: TNNMG stops at its
  // first iteration, and no vertex is in contact (closed, but without force)
  for (CellType lower : {CellType::Tetrahedron, CellType::Hexahedron}) {
    StackedBlocks<3> s(lower, 3, CellType::Hexahedron, 4, 1);
    for (Index k = 0; k < s.coupling->size(); ++k) ASSERT_EQ(s.coupling->weightedGap(k), 0.0) << k;
    s.problem->setLoad(Eigen::VectorXd::Zero(s.system.load.size()));
    TNNMG<3> tnnmg({&s.lower, &s.upper});
    Eigen::VectorXd x = Eigen::VectorXd::Zero(s.system.load.size());
    const ContactResult r = tnnmg.solve(*s.problem, x);
    EXPECT_TRUE(r.converged);
    EXPECT_LE(r.iterations, 1);
    EXPECT_EQ(x.lpNorm<Eigen::Infinity>(), 0.0);
    const ContactOutputs out = computeContactOutputs(*s.problem, x);
    EXPECT_EQ(out.contactNodes, 0);
    EXPECT_EQ(out.force.norm(), 0.0);
    // with the load, every slave node is in contact again
    StackedBlocks<3> loaded(lower, 3, CellType::Hexahedron, 4, 1);
    Eigen::VectorXd y = Eigen::VectorXd::Zero(loaded.system.load.size());
    TNNMG<3> tnnmgLoaded({&loaded.lower, &loaded.upper});
    ASSERT_TRUE(tnnmgLoaded.solve(*loaded.problem, y).converged);
    EXPECT_EQ(computeContactOutputs(*loaded.problem, y).contactNodes, loaded.coupling->size());
  }
}

TEST(MortarPatch2D, TnnmgOnStackedHierarchies) {
  StackedBlocks<2> s(CellType::Quadrilateral, 3, CellType::Triangle, 4, 3);
  TNNMG<2> tnnmg = tightTnnmg<2>(s.lower, s.upper);
  checkPatch(s, tnnmg, 1e-9);
}

TEST(MortarPatch3D, TnnmgOnStackedHierarchiesWithDifferentDepths) {
  // the lower body has one level more than the upper one: on the coarsest stacked level the upper
  // body keeps its level-0 view (identity transfer)
  StackedBlocks<3> s(CellType::Hexahedron, 2, CellType::Tetrahedron, 3, 1, 1);
  ASSERT_EQ(s.lower.maxLevel(), 2);
  ASSERT_EQ(s.upper.maxLevel(), 1);
  TNNMG<3> tnnmg = tightTnnmg<3>(s.lower, s.upper);
  checkPatch(s, tnnmg, 1e-9);
}

// --- a nonlinear two-body problem: an elastic half-cylinder pressed onto an elastic block ---------

/// Half disk of radius 1 (centre (0, 1), slave: its arc) pushed down by `push` at its flat top onto
/// the block [-2, 2] x [-2, 0] (master: its top), whose bottom is clamped; both refined `levels`
/// times (the arc projected onto the circle).
struct CylinderOnBlock {
  mesh::Grid block, cylinder;
  Material material{1.0, 0.3};
  BodySystem<2> system;
  std::vector<Index> offsets;
  std::unique_ptr<MortarCoupling> coupling;
  std::unique_ptr<ContactProblem<2>> problem;

  CylinderOnBlock(int levels, double push, CellType type = CellType::Quadrilateral)
      : block(mesh::boxMesh(type, {8, 4, 1}, Point(-2, -2, 0), Point(2, 0, 0))),
        cylinder(makeCylinder(type)) {
    for (int l = 0; l < levels; ++l) {
      block.refineUniformly();
      cylinder.refineUniformly();
    }
    const mesh::Mesh& mb = block.leafView().mesh;
    const mesh::Mesh& mc = cylinder.leafView().mesh;
    BoundaryConditions bb, bc;
    bb.dirichlet.push_back({mesh::kBottom});
    bc.dirichlet.push_back({mesh::kHalfDiskTop, {true, true, true}, [push](const Point&) { return Point(0, -push, 0); }});
    system = stackBodies<2>({assembleBody<2>(mb, material, bb), assembleBody<2>(mc, material, bc)}, &offsets);
    coupling = std::make_unique<MortarCoupling>(MortarSurface{&mc, mesh::kCurvedSurface, offsets[1], "cylinder arc"},
                                                MortarSurface{&mb, mesh::kTop, offsets[0], "block top"},
                                                system.numVertices());
    problem = std::make_unique<ContactProblem<2>>(system.stiffness, system.load, system.dirichlet,
                                                  coupling->contactSet(), coupling->transformation());
  }

  static mesh::Grid makeCylinder(CellType type) {
    mesh::CurvedMesh cm = mesh::halfDiskMesh(Point(0, 1, 0), 1.0, type, 2);
    mesh::Grid g(std::move(cm.mesh));
    for (auto& [id, f] : cm.projections) g.setBoundaryProjection(id, f);
    return g;
  }
};

TEST(MortarTwoBody, TnnmgAgreesWithPdasAndIterationsStayFlat2D) {
  std::vector<int> iterations;
  for (int levels = 1; levels <= 4; ++levels) {
    CylinderOnBlock s(levels, 0.05);
    PrimalDualActiveSet<2> pdas;
    Eigen::VectorXd xp = Eigen::VectorXd::Zero(s.system.load.size());
    const ContactResult rp = pdas.solve(*s.problem, xp);
    ASSERT_TRUE(rp.converged);
    TNNMG<2>::Options o;
    o.tolerance = 1e-10;
    TNNMG<2> tnnmg({&s.block, &s.cylinder}, o);
    Eigen::VectorXd xt = Eigen::VectorXd::Zero(s.system.load.size());
    const ContactResult rt = tnnmg.solve(*s.problem, xt);
    ASSERT_TRUE(rt.converged);
    iterations.push_back(rt.iterations);
    EXPECT_NEAR(rt.energy, rp.energy, 1e-10 * std::abs(rp.energy));
    const ContactOutputs out = computeContactOutputs(*s.problem, xt);
    EXPECT_GT(out.contactNodes, 2);
    EXPECT_EQ(rt.activeSetSize, rp.activeSetSize);
    // action = reaction
    Eigen::VectorXd mu(s.coupling->size());
    for (Index k = 0; k < s.coupling->size(); ++k) mu[k] = out.multiplier[k];
    const Eigen::VectorXd fm = s.coupling->masterForces(mu);
    Eigen::Vector2d master = Eigen::Vector2d::Zero();
    for (Index v = 0; v < s.system.numVertices(); ++v) master += fm.segment<2>(2 * v);
    EXPECT_NEAR((master - out.force.head<2>()).norm(), 0.0, 1e-12 * out.force.norm());
    EXPECT_LT(master[1], 0.0);  // the cylinder pushes the block down
    if (verbose()) {
      // Hertz (docs/theory.md#two-body-hertz: two cylinders, here R2 = infinity): b = sqrt(4 P R / (pi E*))
      const double Estar = 1.0 / (2 * (1 - 0.09) / 1.0);
      const double P = out.force.norm();
      std::cout << "levels " << levels << ": unknowns " << s.system.load.size() << ", TNNMG " << rt.iterations
                << " (PDAS " << rp.iterations << "), contact nodes " << out.contactNodes << ", P " << P
                << ", half-width " << out.contactRadius << " (Hertz " << std::sqrt(4 * P / (M_PI * Estar))
                << "), mortar " << s.coupling->statistics().seconds << " s\n";
    }
  }
  for (int it : iterations) EXPECT_LE(it, 20);
  EXPECT_LE(iterations.back() - iterations.front(), 4);
}

/// The cells of `m` with x >= 0, renumbered, with its boundary faces there and, as boundary id
/// `cutId`, the cell edges on x = 0 (2D).
mesh::Mesh rightHalf(const mesh::Mesh& m, int cutId) {
  const double eps = 1e-12;
  mesh::Mesh out(2);
  std::vector<Index> to(static_cast<std::size_t>(m.numVertices()), -1);
  for (Index v = 0; v < m.numVertices(); ++v)
    if (m.vertex(v)[0] >= -eps) to[static_cast<std::size_t>(v)] = out.addVertex(m.vertex(v));
  std::map<std::pair<Index, Index>, int> edges;  // edges on x = 0 of the kept cells, with their count
  for (Index c = 0; c < m.numCells(); ++c) {
    const auto cv = m.cellVertices(c);
    if (!std::all_of(cv.begin(), cv.end(), [&](Index v) { return to[static_cast<std::size_t>(v)] >= 0; })) continue;
    std::vector<Index> w;
    for (Index v : cv) w.push_back(to[static_cast<std::size_t>(v)]);
    out.addCell(m.cellType(c), w);
    for (std::size_t i = 0; i < cv.size(); ++i) {
      const Index a = cv[i], b = cv[(i + 1) % cv.size()];
      if (std::abs(m.vertex(a)[0]) <= eps && std::abs(m.vertex(b)[0]) <= eps)
        ++edges[{std::min(to[static_cast<std::size_t>(a)], to[static_cast<std::size_t>(b)]),
                 std::max(to[static_cast<std::size_t>(a)], to[static_cast<std::size_t>(b)])}];
    }
  }
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
    const auto fv = m.boundaryFaceVertices(f);
    if (to[static_cast<std::size_t>(fv[0])] >= 0 && to[static_cast<std::size_t>(fv[1])] >= 0 &&
        !(std::abs(m.vertex(fv[0])[0]) <= eps && std::abs(m.vertex(fv[1])[0]) <= eps))
      out.addBoundaryFace({to[static_cast<std::size_t>(fv[0])], to[static_cast<std::size_t>(fv[1])]}, m.boundaryFaceId(f));
  }
  for (const auto& [e, count] : edges)
    if (count == 1) {
      // oriented as the cell's boundary: the kept cells lie at x > 0, so the edge runs downwards
      const bool down = out.vertex(e.first)[1] > out.vertex(e.second)[1];
      out.addBoundaryFace({down ? e.first : e.second, down ? e.second : e.first}, cutId);
    }
  return out;
}

TEST(MortarTwoBody, SymmetryPlaneThroughACurvedSlaveSurface2D) {
  // A half-cylinder pressed onto a block, and its right half with symmetry rollers (u_x = 0 on
  // x = 0) on both bodies. The slave vertex on the symmetry line has one slave face, so its averaged
  // normal leans by half that face's angle (1e-2 here) and its prescribed u_x is not orthogonal to it:
  // the constraint acts along the normal projected onto the free component (as for one body), and
  // the half problem carries half the load of the whole one up to the dropped term of the tilted
  // normal, which vanishes as h^2 (the tilt and the master's u_x next to the line, each O(h)). The
  // meshes are mirror-symmetric.
  const double push = 0.05;
  const Material material{1.0, 0.3};
  const auto solve = [&](bool half, int levels) {
    const int kSymmetry = 7;
    mesh::CurvedMesh cyl = mesh::halfDiskMesh(Point(0, 1, 0), 1.0, CellType::Triangle, 2);
    mesh::Mesh blockMesh = mesh::boxMesh(CellType::Quadrilateral, {8, 4}, Point(-2, -2, 0), Point(2, 0, 0));
    if (half) {
      cyl.mesh = rightHalf(cyl.mesh, kSymmetry);
      blockMesh = mesh::boxMesh(CellType::Quadrilateral, {4, 4}, Point(0, -2, 0), Point(2, 0, 0));
    }
    mesh::Grid cylinder(std::move(cyl.mesh)), block(std::move(blockMesh));
    for (const auto& [id, projection] : cyl.projections) cylinder.setBoundaryProjection(id, projection);
    for (int l = 0; l < levels; ++l) {
      cylinder.refineUniformly();
      block.refineUniformly();
    }
    const mesh::Mesh& mb = block.leafView().mesh;
    const mesh::Mesh& mc = cylinder.leafView().mesh;
    BoundaryConditions bb, bc;
    bb.dirichlet.push_back({mesh::kBottom});
    bc.dirichlet.push_back({mesh::kHalfDiskTop, {true, true, true}, [push](const Point&) { return Point(0, -push, 0); }});
    if (half) {
      bb.dirichlet.push_back({mesh::kLeft, {true, false, false}});
      bc.dirichlet.push_back({kSymmetry, {true, false, false}});
    }
    ContactModel<2> model;
    model.addBody("block", mb, material, bb);
    model.addBody("cylinder", mc, material, bc);
    model.addMortarPair(1, mesh::kCurvedSurface, 0, mesh::kTop, "arc / top");
    const ContactProblem<2> problem = model.assemble();
    PrimalDualActiveSet<2> pdas;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(problem.numDofs());
    const ContactResult r = pdas.solve(problem, x);
    EXPECT_TRUE(r.converged);
    const ContactOutputs out = computeContactOutputs(problem, x);
    return std::pair<double, Index>(std::abs(out.force[1]), out.contactNodes);  // the vertical load
  };
  std::vector<double> difference;
  for (int levels = 2; levels <= 4; ++levels) {
    const auto [whole, wholeNodes] = solve(false, levels);
    const auto [half, halfNodes] = solve(true, levels);
    EXPECT_EQ(2 * halfNodes - 1, wholeNodes);  // the vertex on the symmetry line counted once
    difference.push_back(std::abs(2 * half - whole) / whole);
    if (verbose())
      std::cout << "levels " << levels << ": whole P " << whole << ", 2 x half P " << 2 * half << ", relative difference "
                << difference.back() << "\n";
  }
  // measured 2.3e-3, 8.4e-4, 1.9e-4: second order
  EXPECT_GT(difference[0] / difference[1], 2.5);
  EXPECT_GT(difference[1] / difference[2], 2.5);
  EXPECT_LT(difference[2], 4e-4);
}

TEST(MortarTwoBody, MasterPrescribedEverywhereIsARigidBodyAtNoCost) {
  // The lower block (master) prescribed at every vertex (DirichletCondition::everywhere) against the
  // same block with all six sides clamped (its interior free, and zero in the solution): the same
  // contact solution. The first costs no stiffness (ContactModel::assemble skips its cells) and no
  // sweeps (its rows keep only their diagonal block: ContactProblem's isolated prescribed vertices).
  const mesh::Mesh lower = mesh::boxMesh(CellType::Tetrahedron, 4);
  const mesh::Mesh upper = shifted(mesh::boxMesh(CellType::Hexahedron, 5), Point(0, 0, 1));
  const Material material{2e5, 0.3};
  BoundaryConditions bu;
  bu.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point& x) { return Point(0, 0, -1e-4 * (1 + x[0])); }});
  const auto solve = [&](bool everywhere, Index& masterBlocks) {
    BoundaryConditions bl;
    if (everywhere) {
      DirichletCondition all;
      all.everywhere = true;
      bl.dirichlet.push_back(all);
    } else {
      for (int side : {mesh::kLeft, mesh::kRight, mesh::kFront, mesh::kBack, mesh::kBottom, mesh::kTop})
        bl.dirichlet.push_back({side});
    }
    ContactModel<3> model;
    model.addBody("lower", lower, material, bl);
    model.addBody("upper", upper, material, bu);
    model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "bottom / top");
    const ContactProblem<3> problem = model.assemble();
    const BlockSparseMatrix<3>& A = problem.rotatedMatrix();
    masterBlocks = A.rowStarts()[static_cast<std::size_t>(lower.numVertices())];
    PrimalDualActiveSet<3> pdas;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(problem.numDofs());
    const ContactResult r = pdas.solve(problem, x);
    EXPECT_TRUE(r.converged);
    return std::pair<Eigen::VectorXd, double>(problem.toDisplacement(x), computeContactOutputs(problem, x).force.norm());
  };
  Index rigidBlocks = 0, clampedBlocks = 0;
  const auto [rigid, rigidLoad] = solve(true, rigidBlocks);
  const auto [clamped, clampedLoad] = solve(false, clampedBlocks);
  EXPECT_EQ(rigidBlocks, lower.numVertices());  // one block per master row
  EXPECT_GT(clampedBlocks, rigidBlocks);  // the free interior vertices keep their rows
  EXPECT_GT(rigidLoad, 0);
  EXPECT_NEAR(rigidLoad, clampedLoad, 1e-9 * clampedLoad);
  EXPECT_LT((rigid - clamped).lpNorm<Eigen::Infinity>(), 1e-9 * clamped.lpNorm<Eigen::Infinity>());
}

TEST(MortarCoupling, MatchingMeshesCoupleNodeToNode) {
  // identical interface meshes: M = D, so C pairs every slave node with the coincident master node
  for (CellType type : {CellType::Hexahedron, CellType::Tetrahedron, CellType::Prism}) {
    mesh::Mesh lower = mesh::boxMesh(type, 3);
    mesh::Mesh upper = shifted(mesh::boxMesh(type, 3), Point(0, 0, 1));
    const Index off = lower.numVertices();
    MortarCoupling c({&upper, mesh::kBottom, off, "upper"}, {&lower, mesh::kTop, 0, "lower"}, off + upper.numVertices());
    ASSERT_EQ(c.size(), 16);
    const mesh::CsrMatrix C = c.transformation();
    for (Index k = 0; k < c.size(); ++k) {
      const Index p = c.vertex(k);
      const Point& x = upper.vertex(p - off);
      double sum = 0;
      for (Index m = C.rowStart[p]; m < C.rowStart[p + 1]; ++m) {
        sum += C.values[m];
        if ((lower.vertex(C.columns[m]) - x).norm() < 1e-12)
          EXPECT_NEAR(C.values[m], 1.0, 1e-13);
        else
          EXPECT_NEAR(C.values[m], 0.0, 1e-13);
      }
      EXPECT_NEAR(sum, 1.0, 1e-14);
    }
  }
}

TEST(MortarTwoBody, RigidLimitApproachesSignorini2D) {
  // a block 1e6 times stiffer than the cylinder: the contact force of the two-body problem tends to
  // the one of the cylinder against the rigid plane y = 0 (node-based Signorini) with refinement,
  // when both constrain the same direction: the mortar constraint acts along the slave normals, so
  // the Signorini problem takes the gap to the plane along the radial direction of the cylinder.
  // (With the plane's own direction e_y the forces differ by O(b/R), b the contact half-width: the
  // choice of direction in the linearised constraint; printed with OBS_TEST_VERBOSE.)
  std::vector<double> differences;
  for (int levels = 1; levels <= 3; ++levels) {
    CylinderOnBlock s(levels, 0.05);
    s.material = Material{1.0, 0.3};
    const mesh::Mesh& mb = s.block.leafView().mesh;
    const mesh::Mesh& mc = s.cylinder.leafView().mesh;
    BoundaryConditions bb, bc;
    bb.dirichlet.push_back({mesh::kBottom});
    bc.dirichlet.push_back({mesh::kHalfDiskTop, {true, true, true}, [](const Point&) { return Point(0, -0.05, 0); }});
    std::vector<Index> offsets;
    const auto sys = stackBodies<2>({assembleBody<2>(mb, Material{1e6, 0.3}, bb), assembleBody<2>(mc, s.material, bc)}, &offsets);
    const ContactProblem<2> twoBody(sys.stiffness, sys.load, sys.dirichlet, s.coupling->contactSet(),
                                    s.coupling->transformation());
    PrimalDualActiveSet<2> pdas;
    Eigen::VectorXd x = Eigen::VectorXd::Zero(sys.load.size());
    ASSERT_TRUE(pdas.solve(twoBody, x).converged);
    const double F2 = computeContactOutputs(twoBody, x).force.norm();

    auto signorini = [&](const Obstacle& obstacle) {
      const ContactSet cs(mc, mesh::kCurvedSurface, obstacle);
      const ContactProblem<2> oneBody(mc, s.material, bc, cs);
      Eigen::VectorXd u = Eigen::VectorXd::Zero(oneBody.numDofs());
      EXPECT_TRUE(pdas.solve(oneBody, u).converged);
      return computeContactOutputs(oneBody, u).force.norm();
    };
    const FunctionObstacle radial(
        [](const Point& x) {
          const Point n = (x - Point(0, 1, 0)).normalized();
          return n[1] < -1e-3 ? -x[1] / n[1] : std::numeric_limits<double>::infinity();
        },
        [](const Point& x) { return Point((x - Point(0, 1, 0)).normalized()); }, "plane along radii", 2);
    const double F1 = signorini(radial);
    const double Fplane = signorini(PlaneObstacle(Point(0, 0, 0), Point(0, -1, 0)));
    differences.push_back(std::abs(F2 - F1) / F1);
    if (verbose())
      std::cout << "levels " << levels << ": two-body " << F2 << ", Signorini along radii " << F1
                << ", Signorini along e_y " << Fplane << "\n";
  }
  // measured 1.5e-4, 2.8e-5, 5.5e-6 (weighted against nodal gaps, and the 1e-6 compliance of the block)
  EXPECT_LT(differences.back(), 2e-5);
  for (std::size_t i = 1; i < differences.size(); ++i) EXPECT_LT(differences[i], differences[i - 1] / 3);
}

TEST(MortarTwoBody, RoundedBlockOnBoxTnnmgAgreesWithPdas3D) {
  // a block with a cylindrical bottom (slave, hexahedra) pressed onto a box of tetrahedra (master)
  mesh::CurvedMesh rb = mesh::roundedBlockMesh(1.0, 1.0, 0.5, 1.0, CellType::Hexahedron, {4, 2, 2});
  for (Index v = 0; v < rb.mesh.numVertices(); ++v) rb.mesh.vertex(v) += Point(-0.5, -0.25, 0);
  mesh::Grid upper(std::move(rb.mesh));
  mesh::Grid lower(mesh::boxMesh(CellType::Tetrahedron, {4, 2, 2}, Point(-1, -0.5, -1), Point(1, 0.5, 0)));
  upper.refineUniformly();
  lower.refineUniformly();
  const mesh::Mesh& mu = upper.leafView().mesh;
  const mesh::Mesh& ml = lower.leafView().mesh;
  BoundaryConditions bu, bl;
  bu.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, 0, -0.01); }});
  bl.dirichlet.push_back({mesh::kBottom});
  const Material m{1.0, 0.3};
  std::vector<Index> offsets;
  const auto sys = stackBodies<3>({assembleBody<3>(ml, m, bl), assembleBody<3>(mu, m, bu)}, &offsets);
  MortarCoupling c({&mu, mesh::kBottom, offsets[1], "rounded bottom"}, {&ml, mesh::kTop, offsets[0], "box top"},
                   sys.numVertices());
  const ContactProblem<3> problem(sys.stiffness, sys.load, sys.dirichlet, c.contactSet(), c.transformation());
  PrimalDualActiveSet<3> pdas;
  Eigen::VectorXd xp = Eigen::VectorXd::Zero(sys.load.size());
  const ContactResult rp = pdas.solve(problem, xp);
  ASSERT_TRUE(rp.converged);
  TNNMG<3> tnnmg({&lower, &upper});
  Eigen::VectorXd xt = Eigen::VectorXd::Zero(sys.load.size());
  const ContactResult rt = tnnmg.solve(problem, xt);
  ASSERT_TRUE(rt.converged);
  EXPECT_LE(rt.iterations, 20);
  EXPECT_NEAR(rt.energy, rp.energy, 1e-10 * std::abs(rp.energy));
  const ContactOutputs out = computeContactOutputs(problem, xt);
  EXPECT_GT(out.contactNodes, 4);
  EXPECT_LT(out.force[2], 0);  // force = sum mu_p n_p along the slave normals (down); the box pushes up
  EXPECT_TRUE(std::isnan(rt.errorBound));  // mortar unknowns: no diagonal lower bound can be declared
  ContactProblem<3> copy = problem;
  EXPECT_THROW(copy.setDiagonalLowerBound(std::vector<double>(static_cast<std::size_t>(sys.numVertices()), 1.0)),
               obs::Error);
  if (verbose())
    std::cout << "3D: " << sys.load.size() << " unknowns, TNNMG " << rt.iterations << ", PDAS " << rp.iterations
              << ", contact nodes " << out.contactNodes << ", force " << out.force.transpose() << "\n";
}

TEST(MortarCoupling, PotentialContactZoneDoesNotShrinkWithRefinement) {
  // every slave vertex within 0.1 of the master surface is constrained, however fine the mesh (a
  // search distance tied to the face size left the rim of the contact zone unconstrained on fine
  // grids: the cylinder then penetrated the block there)
  for (int levels : {2, 5}) {
    mesh::Grid block(mesh::boxMesh(CellType::Quadrilateral, {8, 4, 1}, Point(-2, -2, 0), Point(2, 0, 0)));
    mesh::Grid cylinder = CylinderOnBlock::makeCylinder(CellType::Triangle);
    for (int l = 0; l < levels; ++l) {
      block.refineUniformly();
      cylinder.refineUniformly();
    }
    const mesh::Mesh& mb = block.leafView().mesh;
    const mesh::Mesh& mc = cylinder.leafView().mesh;
    const Index off = mb.numVertices();
    MortarCoupling c({&mc, mesh::kCurvedSurface, off, "arc"}, {&mb, mesh::kTop, 0, "top"}, off + mc.numVertices());
    std::vector<char> constrained(mc.numVertices(), 0);
    for (Index k = 0; k < c.size(); ++k) constrained[c.vertex(k) - off] = 1;
    Index near = 0;
    for (Index f = 0; f < mc.numBoundaryFaces(); ++f)
      if (mc.boundaryFaceId(f) == mesh::kCurvedSurface)
        for (Index v : mc.boundaryFaceVertices(f))
          if (mc.vertex(v)[1] < 0.1) {
            EXPECT_TRUE(constrained[v]) << "levels " << levels << ", vertex at " << mc.vertex(v).transpose();
            ++near;
          }
    EXPECT_GT(near, 4);
  }
}

TEST(MortarCoupling, BadInput) {
  mesh::Mesh lower = mesh::boxMesh(CellType::Hexahedron, 2);
  mesh::Mesh upper = shifted(mesh::boxMesh(CellType::Hexahedron, 2), Point(0, 0, 1));
  const Index off = lower.numVertices(), n = off + upper.numVertices();
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // unknown boundary id
  EXPECT_NE(message([&] { MortarCoupling({&upper, 42, off, "upper"}, {&lower, mesh::kTop, 0, "lower"}, n); })
                .find("no boundary face has this id"), std::string::npos);
  // the same body on both sides
  EXPECT_NE(message([&] { MortarCoupling({&lower, mesh::kTop, 0, "a"}, {&lower, mesh::kBottom, 0, "b"}, n); })
                .find("same body"), std::string::npos);
  // surfaces far apart: no slave node covered, the distance is given
  mesh::Mesh far = shifted(mesh::boxMesh(CellType::Hexahedron, 2), Point(5, 0, 1));
  const std::string m = message([&] { MortarCoupling({&far, mesh::kBottom, off, "far"}, {&lower, mesh::kTop, 0, "lower"}, n); });
  EXPECT_NE(m.find("covers no slave node"), std::string::npos) << m;
  EXPECT_NE(m.find("distance between their bounding boxes 4"), std::string::npos) << m;
  // a NaN coordinate
  mesh::Mesh bad = upper;
  bad.vertex(0)[2] = std::nan("");
  EXPECT_NE(message([&] { MortarCoupling({&bad, mesh::kBottom, off, "bad"}, {&lower, mesh::kTop, 0, "lower"}, n); })
                .find("non-finite"), std::string::npos);
  // offsets outside the stacked numbering
  EXPECT_NE(message([&] { MortarCoupling({&upper, mesh::kBottom, n, "upper"}, {&lower, mesh::kTop, 0, "lower"}, n); })
                .find("offsets"), std::string::npos);
  // a clamped slave node (its normal component prescribed)
  BoundaryConditions bu;
  bu.dirichlet.push_back({mesh::kBottom});
  std::vector<Index> offsets;
  const auto sys = stackBodies<3>({assembleBody<3>(lower, Material{1, 0.3}, {}), assembleBody<3>(upper, Material{1, 0.3}, bu)}, &offsets);
  MortarCoupling c({&upper, mesh::kBottom, offsets[1], "upper"}, {&lower, mesh::kTop, 0, "lower"}, sys.numVertices());
  EXPECT_NE(message([&] { ContactProblem<3>(sys.stiffness, sys.load, sys.dirichlet, c.contactSet(), c.transformation()); })
                .find("not orthogonal to its contact normal"), std::string::npos);
}

}  // namespace
