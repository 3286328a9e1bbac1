// The Newmark family in 3D (docs/theory.md#newmark): a small hexahedral block dropped (slightly sideways)
// onto a plane. Without contact: linear momentum (M v, M~ v for the redistributed schemes) is conserved by
// every scheme, and the energy each scheme conserves exactly is conserved (classical: E; HHW: E~;
// KLR: E~ + tau^2/8 a'M~a). With contact: the contact-implicit, contact-stabilized, alpha(p) and
// alpha = 1/2 schemes never gain energy, no scheme with the non-penetration set penetrates, the
// persistency schemes conserve their energy (Laursen-Chawla E, HHW E~), and HHW's massless rows
// behave as in 2D over a long run with release (test_newmark.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Newmark.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

Material material(double E) {
  Material m{E, 0.3};
  m.density = 1;
  return m;
}

/// The hexahedral block [0, 1] x [0, 1] x [z0, z0 + 0.5] (4 x 4 x 4 cells: M~ needs several cells across, test_mass) above the obstacle
/// {z <= 0}; contact boundary = bottom face.
struct Block3 {
  mesh::Grid grid;
  PlaneObstacle plane{Point(0, 0, 0), Point(0, 0, -1)};
  std::unique_ptr<ContactSet> contact;
  explicit Block3(double z0)
      : grid(mesh::boxMesh(CellType::Hexahedron, {4, 4, 4}, Point(0, 0, z0), Point(1, 1, z0 + 0.5))) {
    contact = std::make_unique<ContactSet>(grid.leafView().mesh, mesh::kBottom, plane);
  }
  Index vertices() const { return contact->numMeshVertices(); }
  /// Uniform velocity plus a spin about the vertical axis through the block's centre.
  Eigen::VectorXd velocity(const Eigen::Vector3d& v, double spin) const {
    const mesh::Mesh m = grid.leafView().mesh;
    Eigen::VectorXd out(3 * vertices());
    for (Index p = 0; p < vertices(); ++p) {
      const Point& x = m.vertex(p);
      out.segment<3>(3 * p) = v + spin * Eigen::Vector3d(-(x[1] - 0.5), x[0] - 0.5, 0);
    }
    return out;
  }
};

NewmarkOptions opts(NewmarkScheme s, double tau) {
  NewmarkOptions o;
  o.scheme = s;
  o.timeStep = tau;
  o.solver.tolerance = 1e-11;  // tighter than the default 1e-10: the checks below are this tight
  return o;
}

std::vector<StepRecord> run(const Block3& b, NewmarkScheme s, double tau, const Eigen::VectorXd& v0, int steps) {
  NewmarkFamily<3> st(b.grid, material(200), {}, *b.contact, opts(s, tau));
  st.initialize(Eigen::VectorXd::Zero(3 * b.vertices()), v0);
  std::vector<StepRecord> out{st.record()};
  for (int k = 0; k < steps; ++k) out.push_back(st.step());
  return out;
}

/// The energy the scheme conserves without contact (and, for the persistency schemes, with contact).
double conserved(NewmarkScheme s, const StepRecord& r) {
  if (s == NewmarkScheme::KhenousLabordeRenard) return r.energyModified;
  return usesRedistributedMass(s) ? r.energyRedistributed : r.energy;
}

TEST(Newmark3D, WithoutContactMomentumAndTheSchemesEnergy) {
  const Block3 b(100);  // far above the plane
  const Eigen::VectorXd v0 = b.velocity(Eigen::Vector3d(0.5, -0.2, -1.0), 0.8);
  for (NewmarkScheme s : allNewmarkSchemes()) {
    const auto rec = run(b, s, 0.01, v0, 30);
    const StepRecord& r0 = rec.front();
    double momentum = 0, drift = 0;
    for (const StepRecord& r : rec) {
      const bool red = usesRedistributedMass(s);
      momentum = std::max(momentum, ((red ? r.momentumRedistributed : r.momentum) -
                                     (red ? r0.momentumRedistributed : r0.momentum)).norm() /
                                        (red ? r0.momentumRedistributed : r0.momentum).norm());
      drift = std::max(drift, std::abs(conserved(s, r) - conserved(s, r0)) / conserved(s, r0));
      EXPECT_EQ(r.activeSolution, 0) << name(s);
    }
    if (verbose()) std::cout << name(s) << ": momentum drift " << momentum << ", energy drift " << drift << "\n";
    EXPECT_LT(momentum, 1e-12) << name(s);
    // classical, HHW (= trapezoidal rule with M~ without contact), KLR (modified energy): exact;
    // the contact schemes coincide with the classical one without contact
    EXPECT_LT(drift, 1e-11) << name(s);
  }
}

TEST(Newmark3D, DroppedBlockDissipatesConservesAndDoesNotPenetrate) {
  const Block3 b(0.01);
  const Eigen::VectorXd v0 = b.velocity(Eigen::Vector3d(0.1, 0.05, -1.0), 0.3);
  const double tau = 0.005;
  for (NewmarkScheme s : allNewmarkSchemes()) {
    const auto rec = run(b, s, tau, v0, 60);
    const double E0 = conserved(s, rec.front());
    const bool dissipative = s == NewmarkScheme::ContactImplicit || s == NewmarkScheme::ContactStabilized ||
                             s == NewmarkScheme::ImprovedContactStabilized || s == NewmarkScheme::AlphaHalf;
    int contactSteps = 0;
    Index maxActive = 0;
    double penetration = 0, drift = 0;
    for (std::size_t k = 1; k < rec.size(); ++k) {
      const StepRecord& r = rec[k];
      contactSteps += r.activeSolution > 0;
      maxActive = std::max(maxActive, r.activeSolution);
      penetration = std::max(penetration, r.maxPenetration);
      drift = std::max(drift, std::abs(conserved(s, r) - E0) / E0);
      if (dissipative) { EXPECT_LE(r.energy, rec[k - 1].energy + 1e-10 * E0) << name(s) << " step " << k; }
      if (!usesPersistency(s)) { EXPECT_LE(r.maxPenetration, 1e-9) << name(s) << " step " << k; }
    }
    if (verbose())
      std::cout << name(s) << ": contact steps " << contactSteps << ", max active " << maxActive << ", E_end/E_0 "
                << rec.back().energy / rec.front().energy << ", drift of its energy " << drift << ", max penetration "
                << penetration << "\n";
    EXPECT_GT(contactSteps, 0) << name(s);
    EXPECT_GE(maxActive, 5) << name(s);  // multi-vertex impact (25 bottom vertices)
    if (dissipative) { EXPECT_LT(rec.back().energy, rec.front().energy) << name(s); }
    if (usesPersistency(s)) {  // Laursen-Chawla: E; HHW: E~; penetration is allowed
      EXPECT_LT(drift, 1e-9) << name(s);
      if (s == NewmarkScheme::LaursenChawla) { EXPECT_GT(penetration, 1e-4); }
    }
  }
}

// On a grid of repeated cells the stepper keeps its matrices with shared blocks (one copy per
// distinct block, docs/performance.md#shared-blocks): the products it forms every step give the bits
// of the assembled stiffness.
TEST(Newmark3D, MatricesOfRepeatedCellsShareTheirBlocksWithTheSameProducts) {
  const Block3 b(0.01);
  const mesh::Mesh m = b.grid.leafView().mesh;
  BlockSparseMatrix<3> plain = assembleStiffness<3>(m, material(200));
  plain.unshareBlocks();
  ASSERT_FALSE(plain.shared());
  const Eigen::VectorXd x = Eigen::VectorXd::Random(3 * b.vertices());
  const Eigen::VectorXd Ax = plain * x;
  for (NewmarkScheme s : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::HagerHuebnerWohlmuth}) {
    NewmarkFamily<3> st(b.grid, material(200), {}, *b.contact, opts(s, 0.005));
    EXPECT_TRUE(st.stiffness().shared()) << name(s);
    EXPECT_TRUE(st.mass().shared()) << name(s);
    EXPECT_LT(4 * st.stiffness().storedBlocks(), st.stiffness().nonZeroBlocks()) << name(s);
    const Eigen::VectorXd y = st.stiffness() * x;
    EXPECT_EQ((y - Ax).cwiseAbs().maxCoeff(), 0.0) << name(s);
    EXPECT_EQ(st.stiffness().energy(x), plain.energy(x)) << name(s);
  }
}

TEST(Newmark3D, HagerHuebnerWohlmuthMasslessRowsAfterRelease) {
  // as checkHagerHuebnerWohlmuthLongRun in test_newmark.cpp: E~ conserved over impact and release;
  // without contact the residual of the massless rows alternates, (A u^{n+1})_C = -(A u^n)_C
  const Block3 b(0.005);
  const Eigen::VectorXd v0 = b.velocity(Eigen::Vector3d(0.1, 0.05, -1.0), 0.3);
  const double tau = 0.005;
  const Index n = b.vertices();
  NewmarkFamily<3> st(b.grid, material(200), {}, *b.contact, opts(NewmarkScheme::HagerHuebnerWohlmuth, tau));
  st.initialize(Eigen::VectorXd::Zero(3 * n), v0);
  const StepRecord r0 = st.record();
  std::vector<char> massless(static_cast<std::size_t>(n), 0);
  for (Index p : b.contact->vertices()) massless[static_cast<std::size_t>(p)] = 1;
  int contactSteps = 0, freeSteps = 0;
  Index previousActive = 0;
  double drift = 0, identity = 0;
  Eigen::VectorXd u = st.state().u;
  for (int k = 1; k <= 150; ++k) {
    const StepRecord r = st.step();
    drift = std::max(drift, std::abs(r.energyRedistributed - r0.energyRedistributed) / r0.energyRedistributed);
    contactSteps += r.activeSolution > 0;
    if (contactSteps > 0 && r.activeSolution == 0 && previousActive == 0 && r.maxPenetration == 0) {
      ++freeSteps;
      const Eigen::VectorXd a1 = st.stiffness() * st.state().u, a0 = st.stiffness() * u;
      double scale = 0, mismatch = 0;
      for (Index p = 0; p < n; ++p)
        if (massless[static_cast<std::size_t>(p)]) {
          scale = std::max(scale, a0.segment<3>(3 * p).norm());
          mismatch = std::max(mismatch, (a1.segment<3>(3 * p) + a0.segment<3>(3 * p)).norm());
        }
      if (scale > 0) identity = std::max(identity, mismatch / scale);
    }
    previousActive = r.activeSolution;
    u = st.state().u;
  }
  if (verbose())
    std::cout << "3D HHW: E~ drift " << drift << ", contact steps " << contactSteps << ", free steps " << freeSteps
              << ", massless-row identity " << identity << ", E_end/E_0 " << st.record().energy / r0.energy << "\n";
  EXPECT_GT(contactSteps, 0);
  ASSERT_GT(freeSteps, 10);
  EXPECT_LT(drift, 1e-9);
  EXPECT_LT(identity, 1e-8);
}

}  // namespace
