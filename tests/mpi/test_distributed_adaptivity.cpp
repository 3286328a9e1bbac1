// The adaptive loop on ranks (tests/CMakeLists.txt: 1, 2 and 3 ranks;
// libestimators/include/obs/estimators/DistributedAdaptiveLoop.hpp,
// docs/architecture.md#distributed-adaptivity): on a flat punch (quadrilaterals, Example 1A's
// problem), a body pressed onto a ball (hexahedra, Example 3A's) and two bodies in mortar contact
// (a half-cylinder of triangles on a block of quadrilaterals; a half ball of hexahedra on a box of
// tetrahedra), every step's grids (cells, vertices, marked cells, red, closure and green
// refinements) are the one-process AdaptiveLoop's, and eta, its contributions and the contact load
// agree within the solver tolerance's effect.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/estimators/DistributedAdaptiveLoop.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Obstacle.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Point;
namespace est = obs::estimators;

/// The records of a distributed run against the serial run's, step by step (see the file comment).
void expectSameSteps(const std::vector<est::AdaptiveStep>& r, const std::vector<est::AdaptiveStep>& s) {
  ASSERT_EQ(r.size(), s.size());
  for (std::size_t k = 0; k < s.size(); ++k) {
    SCOPED_TRACE("step " + std::to_string(k));
    EXPECT_EQ(r[k].cells, s[k].cells);
    EXPECT_EQ(r[k].vertices, s[k].vertices);
    EXPECT_EQ(r[k].marked, s[k].marked);
    EXPECT_EQ(r[k].refinedRed, s[k].refinedRed);
    EXPECT_EQ(r[k].closureRed, s[k].closureRed);
    EXPECT_EQ(r[k].greenClosed, s[k].greenClosed);
    EXPECT_EQ(r[k].potentialContact, s[k].potentialContact);
    EXPECT_EQ(r[k].actualContact, s[k].actualContact);
    EXPECT_EQ(r[k].fullContact, s[k].fullContact);
    EXPECT_TRUE(r[k].converged);
    // the warm start moves with the vertices: the iterations of one process (the sweep order differs)
    EXPECT_NEAR(r[k].solverIterations, s[k].solverIterations, 1);
    // the solutions differ within the solver tolerance (1e-10 relative); eta and the load far less
    // than 1e-8 (observed: 1e-12)
    EXPECT_NEAR(r[k].eta, s[k].eta, 1e-8 * s[k].eta);
    ASSERT_EQ(r[k].contributions.size(), s[k].contributions.size());
    for (std::size_t c = 0; c < s[k].contributions.size(); ++c)
      EXPECT_NEAR(r[k].contributions[c].value, s[k].contributions[c].value, 1e-8 * s[k].eta) << s[k].contributions[c].name;
    EXPECT_NEAR(r[k].load, s[k].load, 1e-8 * std::abs(s[k].load));
    if (k > 0) {
      EXPECT_NEAR(r[k].eoc, s[k].eoc, 1e-4);
    }
    ASSERT_EQ(r[k].bodies.size(), s[k].bodies.size());
    for (std::size_t b = 0; b < s[k].bodies.size(); ++b) {
      EXPECT_EQ(r[k].bodies[b].cells, s[k].bodies[b].cells) << "body " << b;
      EXPECT_EQ(r[k].bodies[b].vertices, s[k].bodies[b].vertices) << "body " << b;
      EXPECT_EQ(r[k].bodies[b].marked, s[k].bodies[b].marked) << "body " << b;
      EXPECT_NEAR(r[k].bodies[b].eta, s[k].bodies[b].eta, 1e-8 * s[k].eta) << "body " << b;
    }
    ASSERT_EQ(r[k].couplings.size(), s[k].couplings.size());
    for (std::size_t c = 0; c < s[k].couplings.size(); ++c) {
      const obs::CouplingRecord &a = r[k].couplings[c], &b = s[k].couplings[c];
      EXPECT_EQ(a.label, b.label);
      EXPECT_EQ(a.slaveVertices, b.slaveVertices);
      EXPECT_EQ(a.potentialVertices, b.potentialVertices);
      EXPECT_EQ(a.actualVertices, b.actualVertices);
      EXPECT_EQ(a.uncovered, b.uncovered);
      EXPECT_NEAR(a.load, b.load, 1e-8 * std::abs(b.load));
      EXPECT_NEAR(a.area, b.area, 1e-12 * std::max(1.0, b.area));
      EXPECT_NEAR(a.pressureMax, b.pressureMax, 1e-7 * b.pressureMax);
      EXPECT_NEAR(a.pressureMin, b.pressureMin, 1e-7 * b.pressureMax);
      EXPECT_LE(a.maxViolation, 1e-9);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(a.forceSlave[i], b.forceSlave[i], 1e-8 * std::abs(b.load));
        EXPECT_NEAR(a.forceMaster[i], b.forceMaster[i], 1e-8 * std::abs(b.load));
      }
    }
  }
}

/// The distributed loop against the serial one, step by step; with load balancing at
/// `imbalanceTolerance` (infinity: the partition stays), of which at least `leastMoves` on ranks.
void expectSerialSteps(const obs::mesh::Mesh& coarse, int refinements, const obs::BoundaryConditions& bc,
                       const obs::Obstacle& obstacle, est::AdaptiveLoopOptions options,
                       double imbalanceTolerance = std::numeric_limits<double>::infinity(), int leastMoves = 0) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::Material material{3e5, 0.25};
  obs::mesh::Grid serialGrid(coarse);
  for (int l = 0; l < refinements; ++l) serialGrid.refineUniformly();
  est::AdaptiveLoop serial(serialGrid, material, bc, options);
  serial.setContact(obstacle, obs::mesh::kBottom);
  const std::vector<est::AdaptiveStep> s = serial.run();

  obs::DistributedGrid grid(obs::mesh::Grid(coarse), refinements, comm);
  est::DistributedAdaptiveLoop loop(grid, material, bc, obstacle, obs::mesh::kBottom, options);
  loop.setImbalanceTolerance(imbalanceTolerance);
  long long heldOwned = 0;
  int moves = 0;
  loop.setCallback([&](const est::DistributedAdaptiveStepView& v) {
    ASSERT_EQ(v.bodies.size(), 1u);
    heldOwned = static_cast<long long>(v.bodies[0].leaf.part.owned.size());
    if (v.bodies[0].balance.moved) {
      ++moves;
      EXPECT_LT(v.bodies[0].balance.after, v.bodies[0].balance.before);
    }
  });
  const std::vector<est::AdaptiveStep> r = loop.run();
  expectSameSteps(r, s);
  EXPECT_GT(s.back().cells, s.front().cells);
  EXPECT_GT(s[1].greenClosed, 0);
  if (comm.size() > 1) {  // the owned cells are a part of the whole
    EXPECT_LT(heldOwned, static_cast<long long>(s.back().cells));
    EXPECT_GE(moves, leastMoves);
  } else {
    EXPECT_EQ(moves, 0);
  }
}

TEST(DistributedAdaptivity, FlatPunchQuadrilateralsAsOneProcess) {
  obs::BoundaryConditions bc;
  bc.dirichlet.push_back({obs::mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, -0.01, 0); }});
  const obs::StripObstacle punch(Point(0.5, 0, 0), 0.0625, Point(0, -1, 0));
  est::AdaptiveLoopOptions o;
  o.maxSteps = 6;
  o.solver.tolerance = 1e-10;
  expectSerialSteps(obs::mesh::boxMesh(CellType::Quadrilateral, 4), 2, bc, punch, o);
  // an off-centre punch, balanced whenever the parts differ at all: the refinement at the punch's
  // edges unbalances the parts on 2 and 3 ranks
  SCOPED_TRACE("rebalanced");
  const obs::StripObstacle offCentre(Point(0.3, 0, 0), 0.0625, Point(0, -1, 0));
  expectSerialSteps(obs::mesh::boxMesh(CellType::Quadrilateral, 4), 2, bc, offCentre, o, 1.0, 2);
}

TEST(DistributedAdaptivity, BallHexahedraAsOneProcess) {
  obs::BoundaryConditions bc;
  bc.dirichlet.push_back({obs::mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, 0, -0.005); }});
  const obs::BallObstacle ball(Point(0.5, 0.5, -0.75), 0.75, Point(0, 0, -1));
  est::AdaptiveLoopOptions o;
  o.maxSteps = 3;
  o.solver.tolerance = 1e-10;
  expectSerialSteps(obs::mesh::boxMesh(CellType::Hexahedron, 4), 1, bc, ball, o);
}

/// Two bodies in mortar contact: a curved body (halfDiskMesh or halfBallMesh; the slave, its curved
/// surface) pressed by the displacement `press` of its flat top onto `lower` (the master, its top;
/// its bottom fixed), serially and on the ranks from the same coarse grids (with their boundary
/// projections), refined uniformly `refinements` times first; both bodies are refined at the
/// contact zone.
void expectSerialTwoBodySteps(const obs::mesh::Grid& lower, const obs::mesh::CurvedMesh& curved, int refinements,
                              const Point& press, const est::AdaptiveLoopOptions& options, double imbalanceTolerance,
                              int leastMoves) {
  obs::mesh::Grid upper(curved.mesh);
  for (const auto& [id, projection] : curved.projections) upper.setBoundaryProjection(id, projection);
  obs::BoundaryConditions lowerBc, upperBc;
  lowerBc.dirichlet.push_back({obs::mesh::kBottom});
  obs::DirichletCondition top{obs::mesh::kHalfDiskTop};
  top.value = [press](const Point&) { return press; };
  upperBc.dirichlet.push_back(top);
  const int slaveId = obs::mesh::kCurvedSurface;
  const obs::Communicator comm = obs::Communicator::world();
  const obs::Material material{1.0, 0.3};
  obs::mesh::Grid serialLower(lower), serialUpper(upper);
  for (int l = 0; l < refinements; ++l) {
    serialLower.refineUniformly();
    serialUpper.refineUniformly();
  }
  const std::string label = "upper / lower";
  est::AdaptiveLoop serial({est::AdaptiveBody{"lower", &serialLower, &material, &lowerBc},
                            est::AdaptiveBody{"upper", &serialUpper, &material, &upperBc}},
                           options);
  serial.addMortarContact(1, slaveId, 0, obs::mesh::kTop, label);
  const std::vector<est::AdaptiveStep> s = serial.run();

  obs::DistributedGrid gridLower(obs::mesh::Grid(lower), refinements, comm);
  obs::DistributedGrid gridUpper(obs::mesh::Grid(upper), refinements, comm);
  est::DistributedAdaptiveLoop loop({est::DistributedAdaptiveBody{"lower", &gridLower, &material, &lowerBc},
                                     est::DistributedAdaptiveBody{"upper", &gridUpper, &material, &upperBc}},
                                    options);
  loop.addMortarContact(1, slaveId, 0, obs::mesh::kTop, label);
  loop.setImbalanceTolerance(imbalanceTolerance);
  int moves = 0;
  loop.setCallback([&](const est::DistributedAdaptiveStepView& v) {
    ASSERT_EQ(v.bodies.size(), 2u);
    EXPECT_TRUE(v.bodies[0].contactSet == nullptr);  // the master side has no constraints
    ASSERT_TRUE(v.bodies[1].contactSet != nullptr);  // the slave side: its nodes on its local mesh
    EXPECT_EQ(v.bodies[1].contactSet->numMeshVertices(), v.bodies[1].leaf.local.numVertices());
    for (const est::DistributedAdaptiveBodyView& b : v.bodies) moves += b.balance.moved ? 1 : 0;
  });
  const std::vector<est::AdaptiveStep> r = loop.run();
  expectSameSteps(r, s);
  ASSERT_GE(s.size(), 2u);
  for (std::size_t b = 0; b < 2; ++b) EXPECT_GT(s.back().bodies[b].cells, s.front().bodies[b].cells) << "body " << b;
  EXPECT_GT(s.back().actualContact, 0);
  EXPECT_GT(s.back().couplings.at(0).area, 0);
  if (comm.size() > 1) {
    EXPECT_GE(moves, leastMoves);
  } else {
    EXPECT_EQ(moves, 0);
  }
}

TEST(DistributedAdaptivity, TwoBodiesCylinderOnBlockAsOneProcess) {
  const obs::mesh::Grid block(obs::mesh::boxMesh(CellType::Quadrilateral, {8, 4}, Point(-2, -2, 0), Point(2, 0, 0)));
  est::AdaptiveLoopOptions o;
  o.maxSteps = 5;
  o.solver.tolerance = 1e-10;
  expectSerialTwoBodySteps(block, obs::mesh::halfDiskMesh(Point(0, 1, 0), 1.0, CellType::Triangle, 2), 2,
                           Point(0, -0.05, 0), o, est::DistributedAdaptiveLoop::kDefaultImbalanceTolerance, 0);
}

TEST(DistributedAdaptivity, TwoBodiesHalfBallOnBoxAsOneProcess) {
  const obs::mesh::Grid box(obs::mesh::boxMesh(CellType::Tetrahedron, {4, 4, 2}, Point(-1, -1, -1), Point(1, 1, 0)));
  est::AdaptiveLoopOptions o;
  o.maxSteps = 3;
  o.solver.tolerance = 1e-10;
  // balanced whenever the parts differ at all: the grids move on 2 and 3 ranks
  expectSerialTwoBodySteps(box, obs::mesh::halfBallMesh(Point(0, 0, 1), 1.0, CellType::Hexahedron, 1), 1,
                           Point(0, 0, -0.02), o, 1.0, 1);
}

TEST(DistributedAdaptivity, RefusesWhatIsNotDistributed) {
  const obs::Communicator comm = obs::Communicator::world();
  obs::DistributedGrid grid(obs::mesh::Grid(obs::mesh::boxMesh(CellType::Quadrilateral, 4)), 1, comm);
  const obs::Material material{1, 0.3};
  const obs::BoundaryConditions bc;
  const obs::StripObstacle punch(Point(0.5, 0, 0), 0.0625, Point(0, -1, 0));
  est::AdaptiveLoopOptions o;
  o.inexactFraction = 0.1;
  EXPECT_THROW(est::DistributedAdaptiveLoop(grid, material, bc, punch, obs::mesh::kBottom, o), obs::Error);
  o.inexactFraction = 0;
  o.marking = "nonsense";
  EXPECT_THROW(est::DistributedAdaptiveLoop(grid, material, bc, punch, obs::mesh::kBottom, o), obs::Error);
  // several bodies: one mortar pair of two bodies only, and some contact
  o.marking = "mean";
  obs::DistributedGrid other(obs::mesh::Grid(obs::mesh::boxMesh(CellType::Quadrilateral, 4)), 1, comm);
  est::DistributedAdaptiveLoop two({{"a", &grid, &material, &bc}, {"b", &other, &material, &bc}}, o);
  EXPECT_THROW(two.run(), obs::Error);  // no contact
  EXPECT_THROW(two.addMortarContact(0, obs::mesh::kTop, 0, obs::mesh::kBottom, "same body"), obs::Error);
  EXPECT_THROW(two.addMortarContact(2, obs::mesh::kTop, 0, obs::mesh::kBottom, "no body 2"), obs::Error);
  two.addMortarContact(1, obs::mesh::kBottom, 0, obs::mesh::kTop, "b / a");
  EXPECT_THROW(two.addMortarContact(1, obs::mesh::kBottom, 0, obs::mesh::kTop, "a second pair"), obs::Error);
  est::DistributedAdaptiveLoop one(grid, material, bc, punch, obs::mesh::kBottom, o);
  EXPECT_THROW(one.addMortarContact(0, obs::mesh::kTop, 0, obs::mesh::kBottom, "one body"), obs::Error);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
