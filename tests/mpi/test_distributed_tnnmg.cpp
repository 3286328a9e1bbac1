// Distributed TNNMG under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks): a Signorini problem
// assembled on each rank's local mesh of a DistributedGrid and solved by TNNMG(const DistributedGrid&)
// must give the serial TNNMG's solution on the uniformly refined grid (vertices matched by
// position), its active set and contact load, in the serial iteration count +-1 (the sweep order
// differs); every rank returns the same result. With Tresca and Coulomb friction (solveFriction
// with the halo) the same stick and slip vertices and Tresca solves (docs/architecture.md#distributed-tnnmg).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedCoarseSolver.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/TNNMG.hpp"

#include "Positions.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Point;
using obs::test::Position;
using obs::test::quantise;

/// The unit box pressed from its top (all components prescribed) onto a ball or disk below. A
/// rank's local mesh may have no contact face (allowEmpty).
template <int d>
obs::ContactProblem<d> pressedOntoBall(const obs::mesh::Mesh& m) {
  obs::BoundaryConditions bc;
  const Point top = d == 2 ? Point(0.002, -0.02, 0) : Point(0.002, 0.001, -0.02);
  bc.dirichlet.push_back({obs::mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  const double r = 0.75;
  const Point centre = d == 2 ? Point(0.5, -r, 0) : Point(0.5, 0.5, -r);
  const obs::ContactSet contact = d == 2 ? obs::ContactSet(m, obs::mesh::kBottom, obs::DiskObstacle(centre, r), true)
                                         : obs::ContactSet(m, obs::mesh::kBottom, obs::BallObstacle(centre, r), true);
  return obs::ContactProblem<d>(m, obs::Material{1.0, 0.3}, bc, contact);
}

/// partitionLevel 0: the coarse level distributed too, solved by hypre (DistributedCoarseSolver).
template <int d>
void expectSerialTnnmg(CellType type, int cells, int refinements, int partitionLevel = -1) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)) + (partitionLevel == 0 ? ", distributed coarse level" : ""));
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(type, cells));
  obs::ForestPartitionOptions partition;
  partition.level = partitionLevel;
  const obs::DistributedGrid dg(coarse, refinements, comm, partition);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < refinements; ++l) serial.refineUniformly();
  typename obs::TNNMG<d>::Options options;
  options.tolerance = 1e-10;

  const obs::mesh::Mesh fs = serial.leafView().mesh;
  const obs::ContactProblem<d> ps = pressedOntoBall<d>(fs);
  obs::TNNMG<d> serialSolver(serial, options);
  Eigen::VectorXd us = Eigen::VectorXd::Zero(ps.numDofs());
  const obs::ContactResult rs = serialSolver.solve(ps, us);

  const obs::DistributedView leaf = dg.view();
  std::optional<obs::ContactProblem<d>> built;
  comm.collective([&] { built.emplace(pressedOntoBall<d>(leaf.local)); });  // an error on one rank reaches all
  const obs::ContactProblem<d>& pd = *built;
  obs::TNNMG<d> solver(dg, options);
  Eigen::VectorXd ud = Eigen::VectorXd::Zero(pd.numDofs());
  const obs::ContactResult rd = solver.solve(pd, ud);
  if (comm.rank() == 0)
    std::cout << obs::mesh::name(type) << " on " << comm.size() << " ranks: " << rd.iterations << " iterations (serial "
              << rs.iterations << "), active " << rd.activeSetSize << " (serial " << rs.activeSetSize << ")"
              << (partitionLevel == 0 ? ", " + std::to_string(solver.statistics().coarseIterations) + " coarse CG iterations"
                                      : "")
              << "\n";
  // (one rank: the serial TNNMG with its direct coarse solve, docs/architecture.md#one-path)
  EXPECT_EQ(solver.statistics().coarseIterations > 0, partitionLevel == 0 && comm.size() > 1);
  ASSERT_TRUE(rs.converged);
  ASSERT_TRUE(rd.converged);
  EXPECT_LE(std::abs(rd.iterations - rs.iterations), 1);
  EXPECT_EQ(rd.activeSetSize, rs.activeSetSize);
  EXPECT_GT(rs.activeSetSize, 0);
  // every rank stops at the same iteration with the same figures
  EXPECT_EQ(comm.max(static_cast<double>(rd.iterations)), static_cast<double>(rd.iterations));
  EXPECT_EQ(comm.max(rd.energy), rd.energy);

  std::map<Position, Index> serialIndex;
  for (Index v = 0; v < fs.numVertices(); ++v) serialIndex[quantise(fs.vertex(v))] = v;
  const double scale = us.cwiseAbs().maxCoeff();
  for (Index i = 0; i < leaf.local.numVertices(); ++i) {  // ghosts included: they are current
    const Index v = serialIndex.at(quantise(leaf.local.vertex(i)));
    for (int c = 0; c < d; ++c) ASSERT_NEAR(ud[i * d + c], us[v * d + c], 1e-7 * scale) << "vertex " << i;
  }
}

TEST(DistributedTnnmg, SolvesTheSerialSignoriniProblemTriangles) { expectSerialTnnmg<2>(CellType::Triangle, 4, 4); }
TEST(DistributedTnnmg, SolvesTheSerialSignoriniProblemQuadrilaterals) { expectSerialTnnmg<2>(CellType::Quadrilateral, 4, 4); }
TEST(DistributedTnnmg, SolvesTheSerialSignoriniProblemHexahedra) { expectSerialTnnmg<3>(CellType::Hexahedron, 2, 3); }
TEST(DistributedTnnmg, SolvesTheSerialSignoriniProblemTetrahedra) { expectSerialTnnmg<3>(CellType::Tetrahedron, 2, 2); }
// partition level 0: no replicated level, the coarse problem by hypre's CG + BoomerAMG
TEST(DistributedTnnmg, DistributedCoarseLevelSolvesTheSerialSignoriniProblemQuadrilaterals) {
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  expectSerialTnnmg<2>(CellType::Quadrilateral, 4, 4, 0);
}
TEST(DistributedTnnmg, DistributedCoarseLevelSolvesTheSerialSignoriniProblemHexahedra) {
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  expectSerialTnnmg<3>(CellType::Hexahedron, 3, 2, 0);
}

/// Friction on the ranks: the pressed box slides (the top moves sideways) against the ball or disk
/// with Tresca (slip bound `bound` per unit area) or Coulomb (coefficient `mu`) friction, solved by
/// solveFriction with the distributed TNNMG. The fixed point takes the serial number of Tresca
/// solves, each solve the serial TNNMG iterations +-1, and the displacement is the serial one (to
/// 1e-7 of its largest entry for Tresca; for Coulomb to 1e-6, the bounds' relative change at the
/// stop being 1e-8); the stick and slip vertices are the serial ones.
template <int d>
void expectSerialFriction(CellType type, int cells, int refinements, double bound, double mu) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)) + (mu > 0 ? ", Coulomb" : ", Tresca"));
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(type, cells));
  const obs::DistributedGrid dg(coarse, refinements, comm);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < refinements; ++l) serial.refineUniformly();
  typename obs::TNNMG<d>::Options options;
  options.tolerance = 1e-10;
  obs::CoulombOptions fixedPoint;
  fixedPoint.tolerance = 1e-8;
  const auto friction = [&](const obs::ContactProblem<d>& p) {
    obs::NodalFriction f;
    f.bound = obs::trescaSlipBounds(p.contactSet(), bound);
    f.mu.assign(f.bound.size(), mu);
    return f;
  };
  const auto counts = [](const obs::ContactOutputs& o, Index owned, const std::vector<Index>& vertexOf) {
    std::array<long long, 2> c{};
    for (std::size_t k = 0; k < o.state.size(); ++k)
      if (vertexOf[k] < owned && o.state[k] > 0) ++c[static_cast<std::size_t>(o.state[k] - 1)];
    return c;
  };

  const obs::mesh::Mesh fs = serial.leafView().mesh;
  obs::ContactProblem<d> ps = pressedOntoBall<d>(fs);
  obs::TNNMG<d> serialSolver(serial, options);
  Eigen::VectorXd us = Eigen::VectorXd::Zero(ps.numDofs());
  const obs::CoulombResult rs = obs::solveFriction(ps, serialSolver, us, friction(ps), fixedPoint);
  std::vector<Index> serialVertex;
  for (const auto& c : ps.constraints()) serialVertex.push_back(c.vertex);
  const auto cs = counts(obs::computeContactOutputs(ps, us), ps.numVertices(), serialVertex);

  const obs::DistributedView leaf = dg.view();
  std::optional<obs::ContactProblem<d>> built;
  comm.collective([&] { built.emplace(pressedOntoBall<d>(leaf.local)); });
  obs::ContactProblem<d>& pd = *built;
  obs::TNNMG<d> solver(dg, options);
  Eigen::VectorXd ud = Eigen::VectorXd::Zero(pd.numDofs());
  const obs::CoulombResult rd = obs::solveFriction(pd, solver, ud, friction(pd), fixedPoint, {}, &leaf.halo);
  std::vector<Index> localVertex;
  for (const auto& c : pd.constraints()) localVertex.push_back(c.vertex);
  auto cd = counts(obs::computeContactOutputs(pd, ud), leaf.halo.numOwned(), localVertex);
  for (long long& c : cd) c = comm.sum(c);
  if (comm.rank() == 0)
    std::cout << obs::mesh::name(type) << (mu > 0 ? " Coulomb" : " Tresca") << " on " << comm.size() << " ranks: "
              << rd.iterations << " Tresca solves, " << rd.innerIterations << " iterations (serial " << rs.iterations
              << ", " << rs.innerIterations << "); stick " << cd[0] << ", slip " << cd[1] << " (serial " << cs[0]
              << ", " << cs[1] << ")\n";
  ASSERT_TRUE(rs.converged);
  ASSERT_TRUE(rd.converged);
  EXPECT_EQ(rd.iterations, rs.iterations);
  EXPECT_LE(std::abs(rd.innerIterations - rs.innerIterations), rs.iterations);
  EXPECT_EQ(cd, cs);
  EXPECT_GT(cs[0], 0);  // both stick and slip
  EXPECT_GT(cs[1], 0);
  EXPECT_EQ(comm.max(static_cast<double>(rd.innerIterations)), static_cast<double>(rd.innerIterations));
  std::map<Position, Index> serialIndex;
  for (Index v = 0; v < fs.numVertices(); ++v) serialIndex[quantise(fs.vertex(v))] = v;
  const double scale = us.cwiseAbs().maxCoeff();
  const double tolerance = mu > 0 ? 1e-6 : 1e-7;
  for (Index i = 0; i < leaf.local.numVertices(); ++i) {
    const Index v = serialIndex.at(quantise(leaf.local.vertex(i)));
    for (int c = 0; c < d; ++c) ASSERT_NEAR(ud[i * d + c], us[v * d + c], tolerance * scale) << "vertex " << i;
  }
}

TEST(DistributedTnnmg, SolvesTheSerialTrescaProblemTriangles) { expectSerialFriction<2>(CellType::Triangle, 4, 4, 0.01, 0); }
TEST(DistributedTnnmg, SolvesTheSerialCoulombProblemQuadrilaterals) {
  expectSerialFriction<2>(CellType::Quadrilateral, 4, 4, 0, 0.3);
}
TEST(DistributedTnnmg, SolvesTheSerialCoulombProblemHexahedra) { expectSerialFriction<3>(CellType::Hexahedron, 2, 3, 0, 0.3); }

/// An error on one rank only (its problem assembled on another mesh) reaches every rank as the
/// same obs::Error naming that rank: no rank waits for the failed one.
TEST(DistributedTnnmg, AnErrorOnOneRankReachesEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::DistributedGrid dg(obs::mesh::Grid(obs::mesh::boxMesh(CellType::Quadrilateral, 4)), 2, comm);
  const obs::DistributedView leaf = dg.view();
  const int failing = comm.size() - 1;
  const obs::mesh::Mesh wrong = obs::mesh::boxMesh(CellType::Quadrilateral, 3);
  std::optional<obs::ContactProblem<2>> built;
  comm.collective([&] { built.emplace(pressedOntoBall<2>(comm.rank() == failing ? wrong : leaf.local)); });
  obs::TNNMG<2> solver(dg);
  Eigen::VectorXd u;
  try {
    solver.solve(*built, u);
    ADD_FAILURE() << "no error";
  } catch (const obs::Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("vertices"), std::string::npos) << message;
    if (comm.size() > 1) {
      EXPECT_NE(message.find("rank " + std::to_string(failing)), std::string::npos) << message;
    }
  }
  // and the ranks go on together: a correct solve afterwards
  std::optional<obs::ContactProblem<2>> good;
  comm.collective([&] { good.emplace(pressedOntoBall<2>(leaf.local)); });
  EXPECT_TRUE(solver.solve(*good, u).converged);
}

/// Threads inside the ranks (hybrid): with two threads per rank the sweeps of each rank's interior
/// and interface run in the threads' orders (SweepOrder subsets; thousands of rows per rank). A
/// second solve on the same rank and thread count repeats the first bit for bit; one thread per
/// rank gives the same solution in the same iteration count +-1.
TEST(DistributedTnnmg, ThreadsInsideTheRanksAndBitwiseRepeats) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::DistributedGrid dg(obs::mesh::Grid(obs::mesh::boxMesh(CellType::Quadrilateral, 4)), 5, comm);
  const obs::DistributedView leaf = dg.view();
  std::optional<obs::ContactProblem<2>> built;
  comm.collective([&] { built.emplace(pressedOntoBall<2>(leaf.local)); });
  const obs::ContactProblem<2>& problem = *built;
  const auto solve = [&](int threads, Eigen::VectorXd& u) {
    obs::setThreads(threads);
    obs::TNNMG<2> solver(dg);
    u = Eigen::VectorXd::Zero(problem.numDofs());
    const obs::ContactResult r = solver.solve(problem, u);
    obs::setThreads(1);
    return r;
  };
  Eigen::VectorXd u1, u2, u3;
  const obs::ContactResult r1 = solve(2, u1), r2 = solve(2, u2), r3 = solve(1, u3);
  ASSERT_TRUE(r1.converged);
  ASSERT_TRUE(r3.converged);
  EXPECT_EQ(r1.iterations, r2.iterations);
  for (Eigen::Index i = 0; i < u1.size(); ++i) ASSERT_EQ(u1[i], u2[i]) << "entry " << i;  // bitwise
  EXPECT_LE(std::abs(r1.iterations - r3.iterations), 1);
  const double scale = u3.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < u1.size(); ++i) ASSERT_NEAR(u1[i], u3[i], 1e-7 * scale) << "entry " << i;
  EXPECT_GT(leaf.halo.numOwned(), obs::kParallelMinRows);  // the threaded orders are used
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
