// Distributed time stepping under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks): a body dropped
// onto a rigid plane, integrated by NewmarkFamily on a DistributedGrid (docs/architecture.md#distributed-dynamics),
// must give the serial stepper's time series on the uniformly refined grid: energy, momentum and
// contact force per step within 1e-8 of their scales, the same active node counts, the tracked
// vertex and the final state by position; every rank holds the same records. All ten schemes in
// 2D, three in 3D, and Coulomb friction. Two bodies: test_distributed_two_body_dynamics.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/Newmark.hpp"
#include "obs/obs/Obstacle.hpp"

#include "Positions.hpp"

namespace {

using obs::Index;
using obs::NewmarkScheme;
using obs::mesh::CellType;
using obs::mesh::Point;
using obs::test::Position;
using obs::test::quantise;

struct Case {
  CellType type = CellType::Quadrilateral;
  int cells = 4, refinements = 3, steps = 20;  // the impact after 5 steps
  double tau = 2e-3;
  obs::FrictionLaw friction;
};

/// The unit box (square) above the plane y = -0.01 (z in 3D), moving down (and sideways) at t = 0.
template <int d>
obs::ContactModel<d> droppedBox(const obs::mesh::Mesh& m, const obs::FrictionLaw& friction) {
  obs::ContactModel<d> model;
  model.addBody("box", m, obs::Material{500.0, 0.3, 1.0}, obs::BoundaryConditions{});
  const Point point = d == 2 ? Point(0, -0.01, 0) : Point(0, 0, -0.01);
  const Point down = d == 2 ? Point(0, -1, 0) : Point(0, 0, -1);
  model.addObstacleContact(0, obs::ContactSet(m, obs::mesh::kBottom, obs::PlaneObstacle(point, down), true), "plane");
  if (friction.type != obs::FrictionLaw::Type::None) model.setFriction(0, friction);
  return model;
}

template <int d>
Eigen::VectorXd initialVelocity(const obs::mesh::Mesh& m) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(m.numVertices() * d);
  for (Index p = 0; p < m.numVertices(); ++p) {
    v[p * d] = 0.4;           // sideways (slip with friction)
    v[p * d + d - 1] = -1.0;  // down
  }
  return v;
}

/// The same relative scale for every rank: the largest |value| of a series.
double scaleOf(const std::vector<double>& values) {
  double s = 1e-300;
  for (double x : values) s = std::max(s, std::abs(x));
  return s;
}

template <int d>
void expectSerialSeries(const Case& c, NewmarkScheme scheme) {
  SCOPED_TRACE(std::string(obs::name(scheme)) + " on " + std::string(obs::mesh::name(c.type)));
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(c.type, c.cells));
  const obs::DistributedGrid dg(coarse, c.refinements, comm);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < c.refinements; ++l) serial.refineUniformly();

  obs::NewmarkOptions options;
  options.scheme = scheme;
  options.timeStep = c.tau;
  options.solver.tolerance = 1e-11;
  const Point bottomCentre = d == 2 ? Point(0.5, 0, 0) : Point(0.5, 0.5, 0);

  // serial
  const obs::mesh::Mesh fs = serial.leafView().mesh;
  std::map<Position, Index> serialIndex;
  for (Index v = 0; v < fs.numVertices(); ++v) serialIndex[quantise(fs.vertex(v))] = v;
  obs::NewmarkOptions so = options;
  so.trackedVertices = {serialIndex.at(quantise(bottomCentre))};
  obs::ContactModel<d> serialModel = droppedBox<d>(fs, c.friction);
  obs::NewmarkFamily<d> ss({&serial}, serialModel, so);
  ss.initialize(Eigen::VectorXd::Zero(fs.numVertices() * d), initialVelocity<d>(fs));
  std::vector<obs::StepRecord> rs{ss.record()};
  for (int k = 0; k < c.steps; ++k) rs.push_back(ss.step());

  // distributed
  const obs::DistributedView leaf = dg.view();
  const obs::mesh::Mesh& local = leaf.local;
  const Index owned = leaf.halo.numOwned();
  obs::NewmarkOptions dopt = options;
  Index tracked = -1;
  for (Index i = 0; i < owned; ++i)
    if (quantise(local.vertex(i)) == quantise(bottomCentre)) tracked = i;
  dopt.trackedVertices = {tracked};
  std::optional<obs::ContactModel<d>> model;
  comm.collective([&] { model.emplace(droppedBox<d>(local, c.friction)); });
  obs::NewmarkFamily<d> sd(dg, leaf, *model, dopt);
  sd.initialize(Eigen::VectorXd::Zero(local.numVertices() * d), initialVelocity<d>(local));
  std::vector<obs::StepRecord> rd{sd.record()};
  for (int k = 0; k < c.steps; ++k) rd.push_back(sd.step());

  // the scales of the series
  std::vector<double> energies, forces, momenta;
  long long contactSteps = 0, serialIterations = 0, distributedIterations = 0;
  for (const obs::StepRecord& r : rs) {
    energies.insert(energies.end(), {r.energy, r.kineticEnergy, r.elasticEnergy, r.energyRedistributed});
    forces.push_back(r.contactForce.norm());
    forces.push_back(r.frictionForce.norm());
    momenta.push_back(r.momentum.norm());
    contactSteps += r.activeSolution > 0;
    serialIterations += r.solverIterations;
  }
  for (const obs::StepRecord& r : rd) distributedIterations += r.solverIterations;
  const double E = scaleOf(energies), F = scaleOf(forces), P = scaleOf(momenta);
  EXPECT_GE(contactSteps, c.steps / 4) << "the box must hit the plane";
  double worst = 0;  // the largest relative deviation of the series
  for (std::size_t k = 0; k < rs.size(); ++k) {
    SCOPED_TRACE("step " + std::to_string(k));
    const obs::StepRecord &a = rs[k], &b = rd[k];
    const auto near = [&](double x, double y, double scale, const char* what) {
      worst = std::max(worst, std::abs(x - y) / scale);
      EXPECT_NEAR(x, y, 1e-8 * scale) << what;
    };
    near(a.energy, b.energy, E, "energy");
    near(a.kineticEnergy, b.kineticEnergy, E, "kinetic energy");
    near(a.elasticEnergy, b.elasticEnergy, E, "elastic energy");
    near(a.energyRedistributed, b.energyRedistributed, E, "energy with M~");
    near(a.accelerationEnergy, b.accelerationEnergy, E, "acceleration energy");
    near(a.frictionDissipation, b.frictionDissipation, E, "friction dissipation");
    for (int i = 0; i < 3; ++i) {
      near(a.momentum[i], b.momentum[i], P, "momentum");
      near(a.momentumRedistributed[i], b.momentumRedistributed[i], P, "momentum with M~");
      near(a.contactForce[i], b.contactForce[i], F, "contact force");
      near(a.frictionForce[i], b.frictionForce[i], F, "friction force");
    }
    EXPECT_EQ(a.activeSolution, b.activeSolution);
    EXPECT_EQ(a.activePredictor, b.activePredictor);
    EXPECT_EQ(a.stickNodes + a.slipNodes, b.stickNodes + b.slipNodes);
    EXPECT_NEAR(a.maxPenetration, b.maxPenetration, 1e-8 * 0.01);
    ASSERT_EQ(b.tracked.size(), 1u);
    EXPECT_TRUE(b.tracked[0].contactNode);
    EXPECT_NEAR(a.tracked[0].normalDisplacement, b.tracked[0].normalDisplacement, 1e-8 * 0.02);
    EXPECT_NEAR(a.tracked[0].velocity[d - 1], b.tracked[0].velocity[d - 1], 1e-6);
    // every rank holds the same record
    EXPECT_EQ(comm.max(b.energy), b.energy);
    EXPECT_EQ(comm.max(static_cast<double>(b.solverIterations)), static_cast<double>(b.solverIterations));
  }
  // the sweep order differs: the iterations may differ slightly, not systematically
  EXPECT_LE(std::abs(distributedIterations - serialIterations), 2 + serialIterations / 20);
  // the final state by position, ghosts included (they are their owners' values)
  const Eigen::VectorXd &us = ss.state().u, &vs = ss.state().v, &ud = sd.state().u, &vd = sd.state().v;
  const double U = us.cwiseAbs().maxCoeff(), V = vs.cwiseAbs().maxCoeff();
  for (Index i = 0; i < local.numVertices(); ++i) {
    const Index v = serialIndex.at(quantise(local.vertex(i)));
    for (int a = 0; a < d; ++a) {
      ASSERT_NEAR(ud[i * d + a], us[v * d + a], 1e-7 * U) << "vertex " << i;
      ASSERT_NEAR(vd[i * d + a], vs[v * d + a], 1e-5 * V) << "vertex " << i;
    }
  }
  if (comm.rank() == 0 && std::getenv("OBS_TEST_VERBOSE"))
    std::cout << obs::name(scheme) << " (" << obs::mesh::name(c.type) << ") on " << comm.size() << " ranks: "
              << distributedIterations << " TNNMG iterations (serial " << serialIterations
              << "), largest relative deviation " << worst << "\n";
}

TEST(DistributedDynamics, EveryScheme2dFollowsTheSerialSeries) {
  for (NewmarkScheme s : obs::allNewmarkSchemes()) expectSerialSeries<2>(Case{}, s);
}

TEST(DistributedDynamics, Hexahedra3dFollowTheSerialSeries) {
  Case c;
  c.type = CellType::Hexahedron;
  c.cells = 2;
  c.refinements = 2;
  c.steps = 12;
  for (NewmarkScheme s : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::Classical,
                          NewmarkScheme::KhenousLabordeRenard})
    expectSerialSeries<3>(c, s);
}

TEST(DistributedDynamics, CoulombFrictionFollowsTheSerialSeries) {
  Case c;
  c.friction = {obs::FrictionLaw::Type::Coulomb, 0.3};
  expectSerialSeries<2>(c, NewmarkScheme::ContactStabilized);
}


/// A tracked vertex list that is wrong on one rank stops every rank with the same error.
TEST(DistributedDynamics, RefusesOnEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::DistributedGrid dg(obs::mesh::Grid(obs::mesh::boxMesh(CellType::Quadrilateral, 4)), 2, comm);
  const obs::DistributedView leaf = dg.view();
  std::optional<obs::ContactModel<2>> model;
  comm.collective([&] { model.emplace(droppedBox<2>(leaf.local, {})); });
  obs::NewmarkOptions o;
  o.timeStep = 1e-3;
  o.trackedVertices = {comm.rank() == comm.size() - 1 ? leaf.local.numVertices() : -1};  // a ghost or beyond
  EXPECT_THROW(obs::NewmarkFamily<2>(dg, leaf, *model, o), obs::Error);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
