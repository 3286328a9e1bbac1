// Distributed time stepping of two bodies under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks;
// docs/architecture.md#distributed-dynamics): two free blocks coupled by dual mortar
// (DistributedMultiBody) collide. NewmarkFamily on the two DistributedGrids must give
// the serial stepper's time series of the two bodies (energies, momentum, contact force within 1e-8
// of their scales, the same active node counts, the tracked slave node), the forces at every held
// vertex after every step (extra ghosts included), equal and opposite forces on the two bodies, the
// conserved momentum of the pair and the final state by position. All ten schemes in 2D
// (quadrilaterals on triangles), improved-contact-stabilized in 3D (hexahedra on tetrahedra); bad
// input throws on every rank.
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
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/DistributedMultiBody.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/Newmark.hpp"

#include "Positions.hpp"

namespace {

using obs::Index;
using obs::NewmarkScheme;
using obs::mesh::CellType;
using obs::mesh::Point;
using obs::test::Position;
using obs::test::quantise;

/// The same relative scale for every rank: the largest |value| of a series.
double scaleOf(const std::vector<double>& values) {
  double s = 1e-300;
  for (double x : values) s = std::max(s, std::abs(x));
  return s;
}

/// Two free blocks flying at each other (gap 0.02, speeds +-1: the impact near t = 0.01), the lower
/// one of quadrilaterals (its top the master side), the upper one of triangles (its bottom the
/// slave side), non-matching; or both of hexahedra / tetrahedra in 3D.
template <int d>
struct Blocks {
  CellType lowerType = d == 2 ? CellType::Quadrilateral : CellType::Hexahedron;
  CellType upperType = d == 2 ? CellType::Triangle : CellType::Tetrahedron;
  int refinements = 2, steps = 20;
  double tau = 1e-3;
  obs::mesh::Mesh lower() const {
    return d == 2 ? obs::mesh::boxMesh(lowerType, {5, 5, 1}, Point(0, 0, 0), Point(1, 1, 0))
                  : obs::mesh::boxMesh(lowerType, {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1));
  }
  obs::mesh::Mesh upper() const {
    return d == 2 ? obs::mesh::boxMesh(upperType, {7, 4, 1}, Point(0.1, 1.02, 0), Point(0.9, 1.52, 0))
                  : obs::mesh::boxMesh(upperType, {2, 2, 1}, Point(0.1, 0.1, 1.02), Point(0.9, 0.9, 1.52));
  }
  /// bottom centre of the upper block: a slave node
  Point tracked() const { return d == 2 ? Point(0.5, 1.02, 0) : Point(0.5, 0.5, 1.02); }
};

template <int d>
obs::ContactModel<d> blocksModel(const obs::mesh::Mesh& lower, const obs::mesh::Mesh& upper) {
  obs::ContactModel<d> model;
  model.addBody("lower", lower, obs::Material{2e3, 0.3, 1.0}, {});
  model.addBody("upper", upper, obs::Material{1e3, 0.25, 2.0}, {});
  model.addMortarPair(1, obs::mesh::kBottom, 0, obs::mesh::kTop, "upper/lower");
  return model;
}

template <int d>
void expectSerialCollision(const Blocks<d>& c, NewmarkScheme scheme) {
  SCOPED_TRACE(std::string(obs::name(scheme)) + " (two bodies, " + std::to_string(d) + "D)");
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarseLower(c.lower()), coarseUpper(c.upper());
  const obs::DistributedGrid dgLower(coarseLower, c.refinements, comm), dgUpper(coarseUpper, c.refinements, comm);
  obs::mesh::Grid serialLower = coarseLower, serialUpper = coarseUpper;
  for (int l = 0; l < c.refinements; ++l) {
    serialLower.refineUniformly();
    serialUpper.refineUniformly();
  }
  obs::NewmarkOptions options;
  options.scheme = scheme;
  options.timeStep = c.tau;
  options.solver.tolerance = 1e-11;

  // serial: the stacked vertices lower, then upper
  const obs::mesh::Mesh sl = serialLower.leafView().mesh, su = serialUpper.leafView().mesh;
  std::map<Position, Index> serialIndex[2];
  for (Index v = 0; v < sl.numVertices(); ++v) serialIndex[0][quantise(sl.vertex(v))] = v;
  for (Index v = 0; v < su.numVertices(); ++v) serialIndex[1][quantise(su.vertex(v))] = sl.numVertices() + v;
  const Index ns = sl.numVertices() + su.numVertices();
  obs::NewmarkOptions so = options;
  so.trackedVertices = {serialIndex[1].at(quantise(c.tracked()))};
  obs::ContactModel<d> serialModel = blocksModel<d>(sl, su);
  obs::NewmarkFamily<d> ss({&serialLower, &serialUpper}, serialModel, so);
  Eigen::VectorXd v0 = Eigen::VectorXd::Zero(ns * d);
  for (Index p = 0; p < ns; ++p) v0[p * d + d - 1] = p < sl.numVertices() ? 1.0 : -1.0;
  ss.initialize(Eigen::VectorXd::Zero(ns * d), v0);

  // distributed: the pair's rows, the coupling (from the bodies' elastic systems), the stepper
  const obs::DistributedView lv = dgLower.view(), uv = dgUpper.view();
  const obs::DistributedView* views[2] = {&lv, &uv};
  const obs::DistributedMortar mortar({&uv, obs::mesh::kBottom, lv.globalVertices(), "upper"},
                                      {&lv, obs::mesh::kTop, 0, "lower"}, obs::MortarOptions{});
  std::optional<obs::ContactModel<d>> model;
  std::vector<obs::BodySystem<d>> systems(2);
  comm.collective([&] {
    model.emplace(blocksModel<d>(lv.local, uv.local));
    for (int b = 0; b < 2; ++b) systems[b] = obs::assembleBody<d>(views[b]->local, model->bodies()[b].material, {});
  });
  const obs::DistributedMultiBody<d> multi({{&lv, &systems[0]}, {&uv, &systems[1]}}, mortar, 1, 0);
  const Index n = multi.numLocal(), owned = multi.numOwned();
  obs::NewmarkOptions dopt = options;
  Index tracked = -1;
  for (Index v = 0; v < uv.halo.numOwned(); ++v)
    if (quantise(uv.local.vertex(v)) == quantise(c.tracked())) tracked = multi.local(1, v);
  dopt.trackedVertices = {tracked};
  obs::NewmarkFamily<d> sd({&dgLower, &dgUpper}, {&lv, &uv}, *model, dopt, &multi);
  Eigen::VectorXd w0 = Eigen::VectorXd::Zero(n * d);  // the extra ghosts' from their owners
  for (int b = 0; b < 2; ++b)
    for (Index v = 0; v < views[b]->local.numVertices(); ++v) w0[multi.local(b, v) * d + d - 1] = b == 0 ? 1.0 : -1.0;
  sd.initialize(Eigen::VectorXd::Zero(n * d), w0);
  // the body and position of every local vertex (the extra ghosts' from their owners)
  Eigen::VectorXd where = Eigen::VectorXd::Zero(4 * n);
  for (int b = 0; b < 2; ++b)
    for (Index v = 0; v < views[b]->local.numVertices(); ++v) {
      const Index l = multi.local(b, v);
      for (int a = 0; a < 3; ++a) where[4 * l + a] = views[b]->local.vertex(v)[a];
      where[4 * l + 3] = b;
    }
  multi.halo().update(where, 4);
  std::vector<Index> serialOf(static_cast<std::size_t>(n));
  for (Index l = 0; l < n; ++l)
    serialOf[l] = serialIndex[static_cast<int>(where[4 * l + 3])].at(quantise(Point(where[4 * l], where[4 * l + 1], where[4 * l + 2])));

  // step by step: the records, and the forces at every held vertex (ghosts and extra ghosts: their
  // owners'): at the constrained nodes F~ and on the vertices (I - C')F~, whose owned sums over the
  // two bodies are equal and opposite
  std::vector<obs::StepRecord> rs{ss.record()}, rd{sd.record()};
  double Fmax = 1e-300, forceDeviation = 0, balance = 0;
  for (int k = 0; k < c.steps; ++k) {
    rs.push_back(ss.step());
    rd.push_back(sd.step());
    const Eigen::VectorXd fs = ss.nodalContactForces(), fd = sd.nodalContactForces();
    const Eigen::VectorXd Fs = ss.contactForces(), Fd = sd.contactForces();  // collective
    Fmax = std::max(Fmax, Fs.cwiseAbs().maxCoeff());
    std::vector<double> sides(6, 0.0);
    for (Index l = 0; l < n; ++l)
      for (int a = 0; a < d; ++a) {
        const Index v = serialOf[l];
        forceDeviation = std::max({forceDeviation, std::abs(fd[l * d + a] - fs[v * d + a]), std::abs(Fd[l * d + a] - Fs[v * d + a])});
        if (l < owned) sides[3 * static_cast<int>(where[4 * l + 3]) + a] += Fd[l * d + a];
      }
    comm.sum(sides);
    for (int a = 0; a < 3; ++a) balance = std::max(balance, std::abs(sides[a] + sides[3 + a]));
  }
  EXPECT_LE(forceDeviation, 1e-8 * Fmax) << "the forces at the held vertices";
  EXPECT_LE(balance, 1e-10 * Fmax) << "the forces on the two bodies are equal and opposite";

  std::vector<double> energies, forces, momenta;
  long long contactSteps = 0, serialIterations = 0, distributedIterations = 0;
  for (const obs::StepRecord& r : rs) {
    energies.insert(energies.end(), {r.energy, r.kineticEnergy, r.elasticEnergy, r.energyRedistributed});
    forces.push_back(r.contactForce.norm());
    momenta.push_back(r.momentum.norm());
    contactSteps += r.activeSolution > 0;
    serialIterations += r.solverIterations;
  }
  for (const obs::StepRecord& r : rd) distributedIterations += r.solverIterations;
  const double E = scaleOf(energies), F = scaleOf(forces), P = scaleOf(momenta);
  EXPECT_GE(contactSteps, 3) << "the blocks must collide";
  double worst = 0;
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
    for (int i = 0; i < 3; ++i) {
      near(a.momentum[i], b.momentum[i], P, "momentum");
      near(a.momentumRedistributed[i], b.momentumRedistributed[i], P, "momentum with M~");
      near(a.contactForce[i], b.contactForce[i], F, "contact force");
    }
    EXPECT_EQ(a.activeSolution, b.activeSolution);
    EXPECT_EQ(a.activePredictor, b.activePredictor);
    EXPECT_EQ(a.predictorOnly, b.predictorOnly);
    EXPECT_EQ(a.solutionOnly, b.solutionOnly);
    EXPECT_NEAR(a.maxPenetration, b.maxPenetration, 1e-8 * 0.02);
    ASSERT_EQ(b.tracked.size(), 1u);
    EXPECT_TRUE(b.tracked[0].contactNode);
    EXPECT_NEAR(a.tracked[0].normalDisplacement, b.tracked[0].normalDisplacement, 1e-8 * 0.02);
    EXPECT_NEAR(a.tracked[0].gap, b.tracked[0].gap, 1e-8 * 0.02);
    EXPECT_EQ(comm.max(b.energy), b.energy);
  }
  EXPECT_LE(std::abs(distributedIterations - serialIterations), 2 + serialIterations / 20);
  // the momentum of the free pair is conserved (with M~ for the redistributed schemes)
  const bool tilde = obs::usesRedistributedMass(scheme);
  const Eigen::Vector3d p0 = tilde ? rd.front().momentumRedistributed : rd.front().momentum;
  const Eigen::Vector3d p1 = tilde ? rd.back().momentumRedistributed : rd.back().momentum;
  EXPECT_LE((p1 - p0).norm(), 1e-10 * P);
  // the final state at every held vertex (ghosts and extra ghosts: their owners')
  const Eigen::VectorXd &us = ss.state().u, &vs = ss.state().v, &ud = sd.state().u, &vd = sd.state().v;
  const double U = us.cwiseAbs().maxCoeff(), V = vs.cwiseAbs().maxCoeff();
  for (Index l = 0; l < n; ++l)
    for (int a = 0; a < d; ++a) {
      ASSERT_NEAR(ud[l * d + a], us[serialOf[l] * d + a], 1e-7 * U) << "vertex " << l << " of " << n;
      ASSERT_NEAR(vd[l * d + a], vs[serialOf[l] * d + a], 1e-5 * V) << "vertex " << l << " of " << n;
    }
  if (comm.rank() == 0 && std::getenv("OBS_TEST_VERBOSE"))
    std::cout << obs::name(scheme) << " (two bodies, " << d << "D) on " << comm.size() << " ranks: "
              << distributedIterations << " TNNMG iterations (serial " << serialIterations
              << "), largest relative deviation " << worst << ", " << multi.extraGhosts() << " extra ghosts, "
              << contactSteps << " steps in contact\n";
}

TEST(DistributedTwoBodyDynamics, EveryScheme2dFollowsTheSerialSeries) {
  for (NewmarkScheme s : obs::allNewmarkSchemes()) expectSerialCollision<2>(Blocks<2>{}, s);
}

TEST(DistributedTwoBodyDynamics, Hexahedra3dOnTetrahedraFollowTheSerialSeries) {
  Blocks<3> c;  // (mass redistribution needs more cells: khenous-laborde-renard in 2D above)
  c.refinements = 1;
  c.steps = 20;
  expectSerialCollision<3>(c, NewmarkScheme::ImprovedContactStabilized);
}

/// Two bodies: a pair without its DistributedMultiBody, friction on the pair, a model of one body
/// with a coupling, and a wrong tracked vertex throw on every rank.
TEST(DistributedTwoBodyDynamics, RefusesOnEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const Blocks<2> c;
  const obs::DistributedGrid dgLower(obs::mesh::Grid(c.lower()), 1, comm), dgUpper(obs::mesh::Grid(c.upper()), 1, comm);
  const obs::DistributedView lv = dgLower.view(), uv = dgUpper.view();
  const obs::DistributedMortar mortar({&uv, obs::mesh::kBottom, lv.globalVertices(), "upper"},
                                      {&lv, obs::mesh::kTop, 0, "lower"}, obs::MortarOptions{});
  std::optional<obs::ContactModel<2>> model, frictional, one;
  std::vector<obs::BodySystem<2>> systems(2);
  comm.collective([&] {
    model.emplace(blocksModel<2>(lv.local, uv.local));
    frictional.emplace(blocksModel<2>(lv.local, uv.local));
    frictional->setFriction(0, {obs::FrictionLaw::Type::Coulomb, 0.3});
    one.emplace();
    one->addBody("lower", lv.local, obs::Material{2e3, 0.3, 1.0}, {});
    systems[0] = obs::assembleBody<2>(lv.local, model->bodies()[0].material, {});
    systems[1] = obs::assembleBody<2>(uv.local, model->bodies()[1].material, {});
  });
  const obs::DistributedMultiBody<2> multi({{&lv, &systems[0]}, {&uv, &systems[1]}}, mortar, 1, 0);
  obs::NewmarkOptions o;
  o.timeStep = 1e-3;
  EXPECT_THROW(obs::NewmarkFamily<2>({&dgLower, &dgUpper}, {&lv, &uv}, *model, o), obs::Error);
  EXPECT_THROW(obs::NewmarkFamily<2>({&dgLower, &dgUpper}, {&lv, &uv}, *frictional, o, &multi), obs::Error);
  EXPECT_THROW(obs::NewmarkFamily<2>({&dgLower}, {&lv}, *one, o, &multi), obs::Error);
  o.trackedVertices = {comm.rank() == comm.size() - 1 ? multi.numOwned() : -1};  // a ghost or beyond
  EXPECT_THROW(obs::NewmarkFamily<2>({&dgLower, &dgUpper}, {&lv, &uv}, *model, o, &multi), obs::Error);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
