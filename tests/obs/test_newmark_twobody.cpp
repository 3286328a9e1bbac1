// The Newmark family for two elastic bodies coupled by dual mortar (docs/theory.md#dynamic-two-body-contact):
// two free blocks with non-matching meshes fly at each other, collide and separate. Every scheme:
// the linear momentum of the two bodies is conserved to round-off (thesis (5.46); with M~ for the
// redistributed schemes), the contact forces on the two sides are equal and opposite, the
// non-penetration schemes keep the normal jump below the gap, the dissipative schemes never gain
// energy, the persistency scheme conserves it, and the classical scheme satisfies its energy identity.
// A model of one body against an obstacle gives the one-body stepper's states bitwise. The forces at
// the constrained nodes (nodalContactForces) are the vertex forces at the slave nodes and sum to the
// recorded contact force.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/Newmark.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }
Point P(double x, double y, double z = 0) { return Point(x, y, z); }

Material material(double E, double nu, double rho) {
  Material m{E, nu};
  m.density = rho;
  return m;
}

/// Lower block [0, 1] x [0, 1] (quadrilaterals, master: its top) moving up with speed 1, upper block
/// [0.1, 0.9] x [1 + gap, 1.5 + gap] (triangles, slave: its bottom) moving down with speed 1; no
/// Dirichlet data, so both bodies are free. Non-matching meshes (5 vs 7 cells across, refined).
struct Collision {
  mesh::Grid lower, upper;
  mesh::Mesh lowerMesh, upperMesh;
  ContactModel<2> model;
  explicit Collision(int levels = 1, double gap = 0.02)
      : lower(mesh::boxMesh(CellType::Quadrilateral, {5, 5, 1}, P(0, 0), P(1, 1))),
        upper(mesh::boxMesh(CellType::Triangle, {7, 4, 1}, P(0.1, 1 + gap), P(0.9, 1.5 + gap))) {
    for (int l = 0; l < levels; ++l) {
      lower.refineUniformly();
      upper.refineUniformly();
    }
    lowerMesh = lower.leafView().mesh;
    upperMesh = upper.leafView().mesh;
    model.addBody("lower", lowerMesh, material(2e3, 0.3, 1), {});
    model.addBody("upper", upperMesh, material(1e3, 0.25, 2), {});
    model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "upper/lower");
  }
  std::vector<const mesh::Grid*> grids() const { return {&lower, &upper}; }
  Index vertices() const { return lowerMesh.numVertices() + upperMesh.numVertices(); }
  /// Initial velocity: +1 (lower) and -1 (upper) in y.
  Eigen::VectorXd velocity() const {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(2 * vertices());
    for (Index p = 0; p < vertices(); ++p) v[2 * p + 1] = p < lowerMesh.numVertices() ? 1.0 : -1.0;
    return v;
  }
};

NewmarkOptions opts(NewmarkScheme s, double tau) {
  NewmarkOptions o;
  o.scheme = s;
  o.timeStep = tau;
  o.solver.tolerance = 1e-12;
  return o;
}

/// Mean y velocity of a body's vertices [begin, end).
double meanVelocity(const Eigen::VectorXd& v, Index begin, Index end) {
  double s = 0;
  for (Index p = begin; p < end; ++p) s += v[2 * p + 1];
  return s / static_cast<double>(end - begin);
}

}  // namespace

TEST(NewmarkTwoBody, EverySchemeConservesMomentumAndBalancesTheContactForces) {
  const double tau = 1e-3;
  const int steps = 120;  // impact at t ~ 0.01, the blocks separate before t ~ 0.1
  for (NewmarkScheme scheme : allNewmarkSchemes()) {
    SCOPED_TRACE(std::string(name(scheme)));
    Collision c;
    NewmarkFamily<2> st(c.grids(), c.model, opts(scheme, tau));
    const Eigen::VectorXd v0 = c.velocity();
    st.initialize(Eigen::VectorXd::Zero(v0.size()), v0);
    const bool redistributed = usesRedistributedMass(scheme);
    const StepRecord first = st.record();
    const Eigen::Vector3d p0 = redistributed ? first.momentumRedistributed : first.momentum;
    ASSERT_GT(std::abs(p0[1]), 0.1);
    double maxForce = 0, maxImbalance = 0, maxMomentumError = 0, maxPenetration = 0, maxGain = 0;
    const bool persistency = usesPersistency(scheme);
    double previousEnergy = first.energy;
    int contactSteps = 0;
    for (int k = 0; k < steps; ++k) {
      const StepRecord r = st.step();
      const Eigen::VectorXd F = st.contactForces();
      Eigen::Vector2d total = Eigen::Vector2d::Zero();
      double magnitude = 0;
      for (Index p = 0; p < c.vertices(); ++p) {
        total += F.segment<2>(2 * p);
        magnitude = std::max(magnitude, F.segment<2>(2 * p).norm());
      }
      maxForce = std::max(maxForce, r.contactForce.norm());
      // the forces at the constrained nodes before the transformation: F at the slave nodes
      // (never master columns), 0 elsewhere; their sum is the record's force on the master side
      const Eigen::VectorXd Fn = st.nodalContactForces();
      const ContactSet& cs = st.problem().contactSet();
      Eigen::Vector2d nodal = Eigen::Vector2d::Zero();
      for (Index p = 0; p < c.vertices(); ++p) {
        if (cs.nodeOf(p) >= 0) {
          EXPECT_EQ(Fn[2 * p], F[2 * p]);
          EXPECT_EQ(Fn[2 * p + 1], F[2 * p + 1]);
        } else {
          EXPECT_EQ(Fn.segment<2>(2 * p).norm(), 0.0);
        }
        nodal += Fn.segment<2>(2 * p);
      }
      EXPECT_LE((nodal - r.contactForce.head<2>()).norm(), 1e-12 * std::max(1.0, r.contactForce.norm()));
      maxImbalance = std::max(maxImbalance, total.norm() / std::max(magnitude, 1e-300));
      const Eigen::Vector3d pk = redistributed ? r.momentumRedistributed : r.momentum;
      maxMomentumError = std::max(maxMomentumError, (pk - p0).norm() / p0.norm());
      maxPenetration = std::max(maxPenetration, r.maxPenetration);
      maxGain = std::max(maxGain, (r.energy - previousEnergy) / first.energy);
      previousEnergy = r.energy;
      contactSteps += r.activeSolution > 0;
    }
    const Eigen::VectorXd& v = st.state().v;
    const double lowerSpeed = meanVelocity(v, 0, c.lowerMesh.numVertices());
    const double upperSpeed = meanVelocity(v, c.lowerMesh.numVertices(), c.vertices());
    if (verbose())
      std::cout << name(scheme) << ": contact steps " << contactSteps << ", max force " << maxForce
                << ", force imbalance " << maxImbalance << ", momentum error " << maxMomentumError
                << ", penetration " << maxPenetration << ", max energy gain per step " << maxGain
                << ", E_end/E_0 " << st.record().energy / first.energy << ", mean v lower " << lowerSpeed
                << " upper " << upperSpeed << "\n";
    EXPECT_GE(contactSteps, 5);
    EXPECT_GT(maxForce, 1.0);
    EXPECT_LT(maxImbalance, 1e-12);      // action = reaction, node by node summed
    EXPECT_LT(maxMomentumError, 1e-11);  // thesis (5.46)
    EXPECT_GT(upperSpeed, lowerSpeed);   // they bounced: the upper body moves up relative to the lower
    if (!persistency) {
      EXPECT_LT(maxPenetration, 1e-9);
    }
    if (scheme == NewmarkScheme::ContactImplicit || scheme == NewmarkScheme::ContactStabilized ||
        scheme == NewmarkScheme::ImprovedContactStabilized) {
      EXPECT_LT(maxGain, 1e-10);  // dissipative (Prop. 5.3.1 with the mortar projection)
    }
  }
}

TEST(NewmarkTwoBody, PersistencySchemeConservesEnergyAndClassicalSatisfiesItsIdentity) {
  const double tau = 1e-3;
  {
    Collision c;
    NewmarkFamily<2> st(c.grids(), c.model, opts(NewmarkScheme::LaursenChawla, tau));
    st.initialize(Eigen::VectorXd::Zero(2 * c.vertices()), c.velocity());
    const double e0 = st.record().energy;
    double drift = 0;
    for (int k = 0; k < 120; ++k) drift = std::max(drift, std::abs(st.step().energy - e0) / e0);
    EXPECT_LT(drift, 1e-9);
  }
  {
    // E^{n+1} - E^n = -1/2 (F^n + F^{n+1}).(u^{n+1} - u^n), F the physical nodal forces on both sides
    Collision c;
    NewmarkFamily<2> st(c.grids(), c.model, opts(NewmarkScheme::Classical, tau));
    st.initialize(Eigen::VectorXd::Zero(2 * c.vertices()), c.velocity());
    Eigen::VectorXd F = st.contactForces(), u = st.state().u;
    double e = st.record().energy, worst = 0, work = 0;
    for (int k = 0; k < 120; ++k) {
      const StepRecord r = st.step();
      const Eigen::VectorXd Fn = st.contactForces();
      const double w = -0.5 * (F + Fn).dot(st.state().u - u);
      worst = std::max(worst, std::abs(r.energy - e - w) / st.record().energy);
      work = std::max(work, std::abs(w));
      F = Fn;
      u = st.state().u;
      e = r.energy;
    }
    EXPECT_GT(work, 1e-3);
    EXPECT_LT(worst, 1e-10);
  }
}

TEST(NewmarkTwoBody, OneBodyModelIsTheOneBodyStepper) {
  // one body against a plane through a ContactModel: the same states, bitwise
  mesh::Grid grid(mesh::boxMesh(CellType::Quadrilateral, {4, 2, 1}, P(0, 0.02), P(1, 0.52)));
  grid.refineUniformly();
  const mesh::Mesh m = grid.leafView().mesh;
  PlaneObstacle plane(P(0, 0), P(0, -1));
  ContactSet contact(m, mesh::kBottom, plane);
  const Material mat = material(1e3, 0.3, 1);
  ContactModel<2> model;
  model.addBody("block", m, mat, {});
  model.addObstacleContact(0, contact, "bottom");
  for (NewmarkScheme scheme : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::Classical,
                               NewmarkScheme::KhenousLabordeRenard}) {
    NewmarkFamily<2> a(grid, mat, {}, contact, opts(scheme, 1e-3));
    NewmarkFamily<2> b({&grid}, model, opts(scheme, 1e-3));
    Eigen::VectorXd v0 = Eigen::VectorXd::Zero(2 * m.numVertices());
    for (Index p = 0; p < m.numVertices(); ++p) v0[2 * p + 1] = -1;
    a.initialize(Eigen::VectorXd::Zero(v0.size()), v0);
    b.initialize(Eigen::VectorXd::Zero(v0.size()), v0);
    int contactSteps = 0;
    double maxForce = 0;
    for (int k = 0; k < 60; ++k) {
      contactSteps += a.step().activeSolution > 0;
      b.step();
      // without mortar pairs the nodal forces are the vertex forces, bitwise
      const Eigen::VectorXd F = a.contactForces();
      EXPECT_EQ((a.nodalContactForces() - F).lpNorm<Eigen::Infinity>(), 0.0) << name(scheme);
      maxForce = std::max(maxForce, F.lpNorm<Eigen::Infinity>());
    }
    EXPECT_EQ((a.state().u - b.state().u).lpNorm<Eigen::Infinity>(), 0.0) << name(scheme);
    EXPECT_EQ((a.state().v - b.state().v).lpNorm<Eigen::Infinity>(), 0.0) << name(scheme);
    EXPECT_GT(maxForce, 0.0) << name(scheme);
    EXPECT_GT(contactSteps, 5) << name(scheme);
  }
}

TEST(NewmarkTwoBody, BadInput) {
  Collision c;
  // grids that do not belong to the bodies
  EXPECT_THROW(NewmarkFamily<2>({&c.lower}, c.model, opts(NewmarkScheme::ContactImplicit, 1e-3)), Error);
  EXPECT_THROW(NewmarkFamily<2>({&c.upper, &c.lower}, c.model, opts(NewmarkScheme::ContactImplicit, 1e-3)), Error);
  // an initial state that violates the mortar constraint: the upper block moved into the lower one
  NewmarkFamily<2> st(c.grids(), c.model, opts(NewmarkScheme::ContactImplicit, 1e-3));
  Eigen::VectorXd u0 = Eigen::VectorXd::Zero(2 * c.vertices());
  for (Index p = c.lowerMesh.numVertices(); p < c.vertices(); ++p) u0[2 * p + 1] = -0.1;
  EXPECT_THROW(st.initialize(u0, c.velocity()), Error);
}
