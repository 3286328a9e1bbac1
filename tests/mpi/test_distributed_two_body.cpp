// Two-body contact on ranks (tests/CMakeLists.txt: 1, 2 and 3 ranks; docs/architecture.md#distributed-two-body):
// two slabs with non-matching grids, each distributed over all ranks and coupled by dual mortar, the
// upper one pressed onto part of the lower one (its top moved down by a tilted displacement). Against one process's problem on the uniformly refined grids
// (vertices matched by body and position):
//  * the transformed operator: the rotated matrix times a smooth field, and the rotated right-hand
//    side, on every owned row (T'AT, T'b, the Dirichlet elimination and the rotations at once);
//  * the solve: distributed TNNMG with the hypre correction against one process's TNNMG with the
//    CHOLMOD correction, the same algorithm: iterations within one, the same active set, the
//    displacements u = (I + C) x to the solver tolerance.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/DistributedCoarseSolver.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/DistributedMultiBody.hpp"
#include "obs/obs/LinearCorrection.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/TNNMG.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Point;

/// Positions on the 2^-20 lattice (the coordinates are multiples of 2^-k / 3, far from the
/// rounding boundary), with the body: the interface vertices of the two bodies share positions.
using Key = std::array<long long, 4>;
Key key(int body, const Point& x) {
  return {body, std::llround(std::ldexp(x[0], 20)), std::llround(std::ldexp(x[1], 20)), std::llround(std::ldexp(x[2], 20))};
}

struct Case {
  CellType lower, upper;
  int nLower, nUpper, refinements;
  int partitionLevel = -1;  ///< 0: the coarse levels distributed too (hypre on level 0)
};

template <int d>
struct Slabs {
  static constexpr double lift = 1.0 / 64, push = 0.03;
  obs::mesh::Mesh coarse[2];  // lower, upper
  obs::Material material[2] = {{2e5, 0.3}, {1e5, 0.25}};
  obs::BoundaryConditions bc[2];

  explicit Slabs(const Case& c) {
    const int a = d - 1;  // the normal axis
    auto slab = [&](CellType type, int n, double bottom) {
      std::array<int, 3> cells{n, n, n};
      cells[static_cast<std::size_t>(a)] = 1;
      Point lo = Point::Zero(), hi = Point::Ones();
      lo[a] = bottom;
      hi[a] = bottom + 0.25;
      return obs::mesh::boxMesh(type, cells, lo, hi);
    };
    coarse[0] = slab(c.lower, c.nLower, 0.75);
    coarse[1] = slab(c.upper, c.nUpper, 1 + lift);
    bc[0].dirichlet.push_back({obs::mesh::kBottom, {true, true, true}});
    obs::DirichletCondition top{obs::mesh::kTop, {true, true, true}};
    top.value = [](const Point& x) {  // tilted: the gap closes on part of the interface only
      Point v = Point::Zero();
      v[d - 1] = -push * (0.25 + x[0]);
      return v;
    };
    bc[1].dirichlet.push_back(top);
  }
};

template <int d>
void compareWithOneProcess(const Case& c) {
  const obs::Communicator comm = obs::Communicator::world();
  const Slabs<d> s(c);

  // one process
  obs::mesh::Grid grid[2] = {obs::mesh::Grid(s.coarse[0]), obs::mesh::Grid(s.coarse[1])};
  for (auto& g : grid)
    for (int l = 0; l < c.refinements; ++l) g.refineUniformly();
  const obs::mesh::GridView leaf[2] = {grid[0].leafView(), grid[1].leafView()};
  const obs::mesh::Mesh* mesh[2] = {&leaf[0].mesh, &leaf[1].mesh};
  std::vector<Index> offsets;
  const obs::BodySystem<d> system = obs::stackBodies<d>(
      {obs::assembleBody<d>(*mesh[0], s.material[0], s.bc[0]), obs::assembleBody<d>(*mesh[1], s.material[1], s.bc[1])},
      &offsets);
  const obs::MortarCoupling coupling({mesh[1], obs::mesh::kBottom, offsets[1], "upper bottom"},
                                     {mesh[0], obs::mesh::kTop, offsets[0], "lower top"}, system.numVertices());
  const obs::ContactProblem<d> serial(system.stiffness, system.load, system.dirichlet, coupling.contactSet(),
                                      coupling.transformation());
  std::map<Key, Index> serialVertex;
  for (int b = 0; b < 2; ++b)
    for (Index v = 0; v < mesh[b]->numVertices(); ++v) serialVertex[key(b, mesh[b]->vertex(v))] = offsets[b] + v;

  // ranks
  obs::ForestPartitionOptions partition;
  partition.level = c.partitionLevel;
  const obs::DistributedGrid dgrid[2] = {
      obs::DistributedGrid(obs::mesh::Grid(s.coarse[0]), c.refinements, comm, partition),
      obs::DistributedGrid(obs::mesh::Grid(s.coarse[1]), c.refinements, comm, partition)};
  const obs::DistributedView view[2] = {dgrid[0].view(), dgrid[1].view()};
  const obs::BodySystem<d> body[2] = {obs::assembleBody<d>(view[0].local, s.material[0], s.bc[0]),
                                      obs::assembleBody<d>(view[1].local, s.material[1], s.bc[1])};
  const obs::DistributedMortar mortar({&view[1], obs::mesh::kBottom, view[0].globalVertices(), "upper bottom"},
                                      {&view[0], obs::mesh::kTop, 0, "lower top"});
  const obs::DistributedMultiBody<d> multi({{&view[0], &body[0]}, {&view[1], &body[1]}}, mortar, 1, 0);
  const obs::ContactProblem<d>& problem = multi.problem();
  ASSERT_EQ(comm.sum(static_cast<long long>(multi.numOwned())), static_cast<long long>(system.numVertices()));
  ASSERT_EQ(multi.globalVertices(), system.numVertices());
  // the serial index of every owned vertex
  std::vector<Index> serialOf(static_cast<std::size_t>(multi.numOwned()), -1);
  for (int b = 0; b < 2; ++b)
    for (Index v = 0; v < view[b].halo.numOwned(); ++v)
      serialOf[static_cast<std::size_t>(multi.local(b, v))] = serialVertex.at(key(b, view[b].local.vertex(v)));

  // 1. the operator: A~ x of a smooth field (given by the owners, the ghosts through the halo) and
  // the rotated right-hand side
  auto field = [](Index serialVertex, int a) { return std::sin(0.37 * static_cast<double>(serialVertex) + a); };
  Eigen::VectorXd xs(serial.numDofs());
  for (Index v = 0; v < serial.numVertices(); ++v)
    for (int a = 0; a < d; ++a) xs[v * d + a] = field(v, a);
  const Eigen::VectorXd ys = serial.rotatedMatrix() * xs, bs = serial.toRotated(serial.rhs());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(problem.numDofs());
  for (Index l = 0; l < multi.numOwned(); ++l)
    for (int a = 0; a < d; ++a) x[l * d + a] = field(serialOf[l], a);
  multi.halo().update(x, d);
  const Eigen::VectorXd y = problem.rotatedMatrix() * x, rhs = problem.toRotated(problem.rhs());
  const double yScale = ys.cwiseAbs().maxCoeff(), bScale = bs.cwiseAbs().maxCoeff();
  for (Index l = 0; l < multi.numOwned(); ++l)
    for (int a = 0; a < d; ++a) {
      const Index i = serialOf[l] * d + a;
      EXPECT_NEAR(y[l * d + a], ys[i], 1e-12 * yScale) << "row of serial vertex " << serialOf[l] << ", component " << a;
      EXPECT_NEAR(rhs[l * d + a], bs[i], 1e-12 * bScale) << "rhs of serial vertex " << serialOf[l];
    }
  EXPECT_EQ(comm.sum(static_cast<long long>(problem.contactSet().size() > 0 ? 1 : 0)) >= 1, true);

  // 2. the solve: the same TNNMG, with the CHOLMOD correction on one process and hypre on ranks
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  typename obs::TNNMG<d>::Options options;
  options.tolerance = 1e-10;
  obs::TNNMG<d> one({&grid[0], &grid[1]}, options, std::make_unique<obs::DirectCorrection<d>>());
  Eigen::VectorXd us = Eigen::VectorXd::Zero(serial.numDofs());
  const obs::ContactResult rs = one.solve(serial, us);
  ASSERT_TRUE(rs.converged);
  const Eigen::VectorXd displacementSerial = serial.toDisplacement(us);

  obs::TNNMG<d> ranks(multi.halo(), options, std::make_unique<obs::DirectCorrection<d>>(multi.halo(), multi.global()));
  Eigen::VectorXd u = Eigen::VectorXd::Zero(problem.numDofs());
  const obs::ContactResult r = ranks.solve(problem, u);
  ASSERT_TRUE(r.converged);
  EXPECT_LE(std::abs(r.iterations - rs.iterations), 1) << "ranks " << r.iterations << ", one process " << rs.iterations;
  EXPECT_EQ(r.activeSetSize, rs.activeSetSize);
  EXPECT_GT(rs.activeSetSize, 0);
  EXPECT_LT(rs.activeSetSize, coupling.size());  // part of the interface open
  EXPECT_GT(ranks.statistics().coarseIterations, 0);
  multi.halo().update(u, d);
  const Eigen::VectorXd displacement = multi.toDisplacement(u);
  const double uScale = displacementSerial.cwiseAbs().maxCoeff();
  for (Index l = 0; l < multi.numOwned(); ++l)
    for (int a = 0; a < d; ++a)
      EXPECT_NEAR(displacement[l * d + a], displacementSerial[serialOf[l] * d + a], 1e-7 * uScale)
          << "serial vertex " << serialOf[l] << ", component " << a;
  if (comm.size() > 1) {
    EXPECT_GT(comm.sum(static_cast<long long>(multi.extraGhosts())), 0);
    EXPECT_GT(comm.sum(static_cast<long long>(multi.receivedTerms())), 0);
  }

  // 3. the multigrid correction: the stacked distributed hierarchy with (I - C) P on the ranks
  // against the serial stacked hierarchy, the same TNNMG with the same V-cycle
  obs::TNNMG<d> oneMg({&grid[0], &grid[1]}, options);
  Eigen::VectorXd usMg = Eigen::VectorXd::Zero(serial.numDofs());
  const obs::ContactResult rsMg = oneMg.solve(serial, usMg);
  ASSERT_TRUE(rsMg.converged);
  auto mg = std::make_unique<obs::LinearMultigrid<d>>(std::vector<const obs::DistributedGrid*>{&dgrid[0], &dgrid[1]},
                                                      multi.extraGhostGlobals(), options.multigrid);
  const obs::MultigridHierarchy<d>& h = mg->hierarchy();
  if (h.distributed()) {
    ASSERT_EQ(h.globalVertices(h.maxLevel()), multi.global());  // DistributedMultiBody's numbering
  } else {  // one rank: the serial stacked hierarchy, whose numbering is the bodies' stacked one
    for (std::size_t i = 0; i < multi.global().size(); ++i) ASSERT_EQ(multi.global()[i], static_cast<Index>(i));
  }
  obs::TNNMG<d> ranksMg(multi.halo(), options, std::move(mg));
  Eigen::VectorXd uMg = Eigen::VectorXd::Zero(problem.numDofs());
  const obs::ContactResult rMg = ranksMg.solve(problem, uMg);
  ASSERT_TRUE(rMg.converged);
  EXPECT_LE(std::abs(rMg.iterations - rsMg.iterations), 1) << "ranks " << rMg.iterations << ", one process " << rsMg.iterations;
  EXPECT_EQ(rMg.activeSetSize, rsMg.activeSetSize);
  multi.halo().update(uMg, d);
  const Eigen::VectorXd displacementMg = multi.toDisplacement(uMg);
  for (Index l = 0; l < multi.numOwned(); ++l)
    for (int a = 0; a < d; ++a)
      EXPECT_NEAR(displacementMg[l * d + a], displacementSerial[serialOf[l] * d + a], 1e-7 * uScale)
          << "multigrid: serial vertex " << serialOf[l] << ", component " << a;
  const obs::MultigridHierarchy<d>& hr = h;  // (the correction lives on in ranksMg)
  long long coarseExtras = 0;  // on the distributed levels below the fine one
  for (int l = 0; l < hr.maxLevel(); ++l) coarseExtras += hr.extraGhosts(l);
  coarseExtras = comm.sum(coarseExtras);
  if (comm.size() > 1 && hr.halo(hr.maxLevel() - 1)) {
    EXPECT_GT(coarseExtras, 0) << "the coarse levels widen for the couplings between the bodies";
  }
  if (std::getenv("OBS_TEST_VERBOSE") && comm.rank() == 0)
    std::printf("multigrid: iterations %d (one process %d), coarse extra ghosts %lld\n", rMg.iterations,
                rsMg.iterations, coarseExtras);
  if (std::getenv("OBS_TEST_VERBOSE") && comm.rank() == 0)
    std::printf("d = %d, %d ranks: %lld vertices, %lld constrained; iterations %d (one process %d), active %lld "
                "(%lld), hypre CG iterations %lld; rank 0: %lld extra ghosts, %lld terms received\n",
                d, comm.size(), static_cast<long long>(system.numVertices()), static_cast<long long>(coupling.size()),
                r.iterations, rs.iterations, static_cast<long long>(r.activeSetSize),
                static_cast<long long>(rs.activeSetSize), ranks.statistics().coarseIterations,
                static_cast<long long>(multi.extraGhosts()), static_cast<long long>(multi.receivedTerms()));
}

TEST(DistributedTwoBody, TrianglesOnQuadrilaterals2D) {
  compareWithOneProcess<2>({CellType::Quadrilateral, CellType::Triangle, 3, 2, 3});
}

TEST(DistributedTwoBody, TetrahedraOnHexahedra3D) {
  compareWithOneProcess<3>({CellType::Hexahedron, CellType::Tetrahedron, 3, 2, 2});
}

/// Partition level 0: every level of the stacked hierarchy distributed, level 0 too (its extra
/// ghosts in hypre's coarse solve, DistributedCoarseSolver).
TEST(DistributedTwoBody, TrianglesOnQuadrilateralsEveryLevelDistributed2D) {
  compareWithOneProcess<2>({CellType::Quadrilateral, CellType::Triangle, 6, 4, 3, 0});
}

/// The stacked multigrid correction with threads inside the ranks: a second solve on the same rank
/// and thread count repeats the first bit for bit; one thread per rank gives the same solution in
/// the same iteration count +-1.
TEST(DistributedTwoBody, StackedMultigridThreadsAndBitwiseRepeats) {
  const obs::Communicator comm = obs::Communicator::world();
  const Slabs<2> s({CellType::Quadrilateral, CellType::Triangle, 3, 2, 6});
  const obs::DistributedGrid dgrid[2] = {obs::DistributedGrid(obs::mesh::Grid(s.coarse[0]), 6, comm),
                                         obs::DistributedGrid(obs::mesh::Grid(s.coarse[1]), 6, comm)};
  const obs::DistributedView view[2] = {dgrid[0].view(), dgrid[1].view()};
  const obs::BodySystem<2> body[2] = {obs::assembleBody<2>(view[0].local, s.material[0], s.bc[0]),
                                      obs::assembleBody<2>(view[1].local, s.material[1], s.bc[1])};
  const obs::DistributedMortar mortar({&view[1], obs::mesh::kBottom, view[0].globalVertices(), "upper bottom"},
                                      {&view[0], obs::mesh::kTop, 0, "lower top"});
  const obs::DistributedMultiBody<2> multi({{&view[0], &body[0]}, {&view[1], &body[1]}}, mortar, 1, 0);
  const auto solve = [&](int threads, Eigen::VectorXd& x) {
    obs::setThreads(threads);
    typename obs::TNNMG<2>::Options options;
    options.tolerance = 1e-10;
    obs::TNNMG<2> solver(multi.halo(), options,
                         std::make_unique<obs::LinearMultigrid<2>>(
                             std::vector<const obs::DistributedGrid*>{&dgrid[0], &dgrid[1]}, multi.extraGhostGlobals(),
                             options.multigrid));
    x = Eigen::VectorXd::Zero(multi.problem().numDofs());
    const obs::ContactResult r = solver.solve(multi.problem(), x);
    obs::setThreads(1);
    return r;
  };
  Eigen::VectorXd x1, x2, x3;
  const obs::ContactResult r1 = solve(2, x1), r2 = solve(2, x2), r3 = solve(1, x3);
  ASSERT_TRUE(r1.converged);
  ASSERT_TRUE(r3.converged);
  EXPECT_EQ(r1.iterations, r2.iterations);
  for (Eigen::Index i = 0; i < x1.size(); ++i) ASSERT_EQ(x1[i], x2[i]) << "entry " << i;  // bitwise
  EXPECT_LE(std::abs(r1.iterations - r3.iterations), 1);
  const double scale = x3.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < x1.size(); ++i) ASSERT_NEAR(x1[i], x3[i], 1e-7 * scale) << "entry " << i;
  EXPECT_GT(multi.numOwned(), obs::kParallelMinRows);  // the threaded orders are used
}

/// A wrong extra ghost list on one rank (an owned vertex) stops every rank with the error, without
/// a hang in the halo construction that follows.
TEST(DistributedTwoBody, StackedHierarchyRefusesAnOwnedExtraGhostOnEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const Slabs<2> s({CellType::Quadrilateral, CellType::Triangle, 3, 2, 2});
  const obs::DistributedGrid dgrid[2] = {obs::DistributedGrid(obs::mesh::Grid(s.coarse[0]), 2, comm),
                                         obs::DistributedGrid(obs::mesh::Grid(s.coarse[1]), 2, comm)};
  const std::vector<const obs::DistributedGrid*> grids{&dgrid[0], &dgrid[1]};
  const obs::MultigridHierarchy<2> h(grids);  // (collective)
  std::vector<Index> extras;
  // owned by rank 0 (a serial hierarchy on one rank numbers its vertices globally: vertex 0 is 0)
  if (comm.rank() == 0) extras.push_back(h.distributed() ? h.globalVertices(h.maxLevel()).front() : 0);
  EXPECT_THROW(obs::MultigridHierarchy<2>(grids, extras), obs::Error);
}

/// The mortar patch test on ranks (docs/verification.md has the serial one): a block of
/// hexahedra (slave) on a block of tetrahedra (master), non-matching, under uniaxial compression by
/// p = 10 (the lower block on rollers, the upper block's top moved with the exact solution): every
/// slave node is in contact and its dual-mortar pressure is p to round-off, on every rank, with the
/// partition cutting the interface.
TEST(DistributedTwoBody, MortarPatchTestIsExact3D) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Mesh coarse[2] = {
      obs::mesh::boxMesh(CellType::Tetrahedron, {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1)),
      obs::mesh::boxMesh(CellType::Hexahedron, {5, 5, 2}, Point(0, 0, 1), Point(1, 1, 2))};
  const obs::Material material[2] = {{2e5, 0.3}, {1e5, 0.25}};
  obs::BoundaryConditions bc[2];
  bc[0].dirichlet.push_back({obs::mesh::kBottom, {false, false, true}});
  bc[0].dirichlet.push_back({obs::mesh::kLeft, {true, false, false}});
  bc[0].dirichlet.push_back({obs::mesh::kFront, {false, true, false}});
  obs::DirichletCondition top{obs::mesh::kTop, {true, true, true}};
  top.value = [](const Point& x) { return Point(2.5e-5 * x[0], 2.5e-5 * x[1], -1.5e-4); };
  bc[1].dirichlet.push_back(top);
  const obs::DistributedGrid dgrid[2] = {obs::DistributedGrid(obs::mesh::Grid(coarse[0]), 1, comm),
                                         obs::DistributedGrid(obs::mesh::Grid(coarse[1]), 1, comm)};
  const obs::DistributedView view[2] = {dgrid[0].view(), dgrid[1].view()};
  const obs::BodySystem<3> body[2] = {obs::assembleBody<3>(view[0].local, material[0], bc[0]),
                                      obs::assembleBody<3>(view[1].local, material[1], bc[1])};
  const obs::DistributedMortar mortar({&view[1], obs::mesh::kBottom, view[0].globalVertices(), "upper bottom"},
                                      {&view[0], obs::mesh::kTop, 0, "lower top"});
  const obs::DistributedMultiBody<3> multi({{&view[0], &body[0]}, {&view[1], &body[1]}}, mortar, 1, 0);
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  typename obs::TNNMG<3>::Options options;
  options.tolerance = 1e-12;
  obs::TNNMG<3> solver(multi.halo(), options, std::make_unique<obs::DirectCorrection<3>>(multi.halo(), multi.global()));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(multi.problem().numDofs());
  const obs::ContactResult r = solver.solve(multi.problem(), x);
  ASSERT_TRUE(r.converged);
  EXPECT_EQ(r.activeSetSize, mortar.globalSize());
  const obs::ContactOutputs out =
      obs::computeContactOutputs(multi.problem(), x, 1e-8, r.kkt.displacementScale, r.kkt.forceScale);
  const obs::ContactSet& cs = multi.problem().contactSet();
  long long owned = 0;
  for (Index k = 0; k < cs.size(); ++k) {
    if (cs.vertex(k) >= multi.numOwned()) continue;
    ++owned;
    EXPECT_TRUE(out.inContact[k]) << "slave node at " << cs.position(k).transpose();
    EXPECT_NEAR(out.pressure[k], 10.0, 1e-9) << "slave node at " << cs.position(k).transpose();
  }
  EXPECT_EQ(comm.sum(owned), mortar.globalSize());
  if (comm.size() > 1) {
    EXPECT_GE(comm.sum(static_cast<long long>(owned > 0 ? 1 : 0)), 2) << "the partition does not cut the interface";
  }
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
