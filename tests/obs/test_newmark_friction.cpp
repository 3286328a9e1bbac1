// Friction in time stepping (docs/theory.md#friction-dynamics): a block sliding on a rigid plane under
// gravity decelerates at mu g and stops after v0^2 / (2 mu g); the energy dissipated by friction
// accounts for the kinetic energy lost; mu = 0 is the frictionless run bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <numbers>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/Newmark.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

constexpr double kG = 10, kRho = 1, kMu = 0.2, kV0 = 1;
constexpr double kWidth = 1, kHeight = 0.25;

struct SlidingBlock {
  mesh::Grid grid{mesh::boxMesh(CellType::Quadrilateral, {8, 2, 1}, Point(0, 0, 0), Point(kWidth, kHeight, 0))};
  mesh::Mesh leaf = grid.leafView().mesh;
  PlaneObstacle plane{Point::Zero(), Point(0, -1, 0)};
  Material material{1e4, 0.3};
  BoundaryConditions bc;
  SlidingBlock() {
    material.density = kRho;
    bc.bodyForce = [](const Point&) { return Eigen::Vector3d(0, -kRho * kG, 0); };
  }
  ContactModel<2> model(double mu) const {
    ContactModel<2> m;
    m.addBody("block", leaf, material, bc);
    m.addObstacleContact(0, ContactSet(leaf, mesh::kBottom, plane), "plane");
    if (mu > 0) m.setFriction(0, {FrictionLaw::Type::Coulomb, mu});
    return m;
  }
  /// The block at rest under gravity (static contact problem; a roller on the left face removes the
  /// horizontal rigid motion and carries no force), the start of the slide.
  Eigen::VectorXd restingState() const {
    BoundaryConditions held = bc;
    held.dirichlet.push_back({mesh::kLeft, {true, false, false}});
    ContactModel<2> m;
    m.addBody("block", leaf, material, held);
    m.addObstacleContact(0, ContactSet(leaf, mesh::kBottom, plane), "plane");
    ContactProblem<2> problem = m.assemble();
    TNNMG<2>::Options o;
    o.tolerance = 1e-12;
    TNNMG<2> tnnmg(grid, o);
    Eigen::VectorXd u;
    tnnmg.solve(problem, u);
    return u;
  }
};

NewmarkOptions options(NewmarkScheme scheme, double tau) {
  NewmarkOptions o;
  o.scheme = scheme;
  o.timeStep = tau;
  o.solver.tolerance = 1e-11;
  return o;
}

Eigen::VectorXd slidingVelocity(Index n) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(2 * n);
  for (Index p = 0; p < n; ++p) v[2 * p] = kV0;
  return v;
}

TEST(NewmarkFriction, SlidingBlockDeceleratesAtMuGAndStops) {
  const SlidingBlock block;
  const Eigen::VectorXd u0 = block.restingState();
  const Index n = block.leaf.numVertices();
  const double mass = kRho * kWidth * kHeight, tStop = kV0 / (kMu * kG);
  for (NewmarkScheme scheme : {NewmarkScheme::ContactImplicit, NewmarkScheme::ContactStabilized,
                               NewmarkScheme::ImprovedContactStabilized}) {
    SCOPED_TRACE(std::string(name(scheme)));
    const double tau = 0.01;
    ContactModel<2> model = block.model(kMu);
    NewmarkFamily<2> stepper({&block.grid}, model, options(scheme, tau));
    stepper.initialize(u0, slidingVelocity(n));
    const StepRecord first = stepper.record();
    const double x0 = u0.segment(0, 2 * n).reshaped(2, n).row(0).mean();
    double maxError = 0;
    StepRecord last = first;
    int steps = 0;
    while (last.time < 1.5 * tStop) {
      last = stepper.step();
      ++steps;
      const double v = last.momentum[0] / mass, expected = std::max(0.0, kV0 - kMu * kG * last.time);
      maxError = std::max(maxError, std::abs(v - expected));
    }
    const Eigen::VectorXd& u = stepper.state().u;
    const double travelled = u.reshaped(2, n).row(0).mean() - x0;
    if (verbose())
      std::cout << "  " << name(scheme) << ": " << steps << " steps, max |v - (v0 - mu g t)| = " << maxError
                << ", travelled " << travelled << " (exact " << kV0 * kV0 / (2 * kMu * kG) << "), dissipated "
                << last.frictionDissipation << " of " << first.kineticEnergy << ", final stick " << last.stickNodes
                << " slip " << last.slipNodes << "\n";
    // the mean velocity follows v0 - mu g t to the time step (the stop is resolved to one step)
    EXPECT_LT(maxError, kMu * kG * tau + 1e-3 * kV0);
    EXPECT_NEAR(travelled, kV0 * kV0 / (2 * kMu * kG), kV0 * tau);
    // at rest up to the shear vibration the stop excites: the friction force mu m g vanishes within a
    // step, which leaves a velocity amplitude of about mu g / omega, omega = (pi / 2) c_s / h the
    // lowest shear frequency of the block clamped at its bottom (c_s = sqrt(G / rho))
    const double omega = 0.5 * std::numbers::pi * std::sqrt(block.material.mu() / kRho) / kHeight;
    EXPECT_LT(std::abs(last.momentum[0]) / mass, 1.5 * kMu * kG / omega);
    EXPECT_EQ(last.slipNodes, 0);
    // friction dissipated the kinetic energy of the slide (the elastic energy barely changes)
    EXPECT_NEAR(last.frictionDissipation, first.kineticEnergy - last.kineticEnergy, 0.02 * first.kineticEnergy);
  }
}

TEST(NewmarkFriction, ZeroCoefficientIsTheFrictionlessRun) {
  const SlidingBlock block;
  const Eigen::VectorXd u0 = block.restingState();
  const Index n = block.leaf.numVertices();
  ContactModel<2> a = block.model(0), b = block.model(0);
  b.setFriction(0, {FrictionLaw::Type::Coulomb, 0.0});
  NewmarkFamily<2> sa({&block.grid}, a, options(NewmarkScheme::ContactStabilized, 0.01));
  NewmarkFamily<2> sb({&block.grid}, b, options(NewmarkScheme::ContactStabilized, 0.01));
  sa.initialize(u0, slidingVelocity(n));
  sb.initialize(u0, slidingVelocity(n));
  for (int k = 0; k < 20; ++k) {
    sa.step();
    sb.step();
  }
  EXPECT_TRUE(sa.state().u == sb.state().u);
  EXPECT_TRUE(sa.state().v == sb.state().v);
  EXPECT_EQ(sb.record().frictionDissipation, 0.0);
}

}  // namespace
