// Estimation and marking on ranks (tests/CMakeLists.txt: 1, 2 and 3 ranks;
// libestimators/include/obs/estimators/DistributedEstimation.hpp, docs/architecture.md#distributed-estimation):
//  * the residual estimator on each rank's local mesh gives the owned cells the indicators of one
//    process on the whole mesh (the same displacement, given by the vertices' positions), and the
//    contributions and the total summed over the ranks are one process's;
//  * every marking strategy marks on the ranks the cells one process marks for the same
//    indicators and cell keys (ties by increasing key), with many ties among the indicators.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "obs/estimators/DistributedEstimation.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Marking.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/TNNMG.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Point;

/// A cell's centroid on the 2^-20 lattice (the vertices of the refined unit box lie on it).
std::array<long long, 3> centroidKey(const obs::mesh::Mesh& m, Index c) {
  Point x = Point::Zero();
  const auto v = m.cellVertices(c);
  for (Index p : v) x += m.vertex(p);
  x /= static_cast<double>(v.size());
  return {std::llround(std::ldexp(x[0], 24)), std::llround(std::ldexp(x[1], 24)), std::llround(std::ldexp(x[2], 24))};
}

/// A smooth displacement that is not a finite element solution, so that every term is non-zero.
Eigen::VectorXd displacementOn(const obs::mesh::Mesh& m, int d) {
  Eigen::VectorXd u(m.numVertices() * d);
  for (Index v = 0; v < m.numVertices(); ++v) {
    const Point& x = m.vertex(v);
    for (int a = 0; a < d; ++a) u[v * d + a] = 1e-3 * std::sin(1.7 * x[0] + 0.9 * a) * std::cos(2.3 * x[1] - 0.4 * x[2]);
  }
  return u;
}

void estimatorOnRanks(CellType type, int refinements) {
  const obs::Communicator comm = obs::Communicator::world();
  const int d = obs::mesh::dimension(type);
  const obs::mesh::Mesh coarse = obs::mesh::boxMesh(type, {3, 3, d == 3 ? 3 : 1}, Point::Zero(), Point::Ones());
  const obs::Material material{1e3, 0.3};
  obs::BoundaryConditions bc;
  bc.dirichlet.push_back({obs::mesh::kBottom, {true, true, true}});
  bc.neumann.push_back({obs::mesh::kTop, [](const Point& x) { return Point(1 + x[0], -2, 0.5); }, {}});
  bc.bodyForce = [](const Point& x) { return Point(0.3, -1 - x[1], 0.2); };
  const auto estimator = obs::estimators::EstimatorRegistry::global().create("residual");

  // one process
  obs::mesh::Grid grid(coarse);
  for (int l = 0; l < refinements; ++l) grid.refineUniformly();
  const obs::mesh::Mesh serialMesh = grid.leafMesh();
  const Eigen::VectorXd us = displacementOn(serialMesh, d);
  const obs::estimators::EstimatorResult rs =
      estimator->estimate(obs::estimators::EstimatorInput(serialMesh, material, bc, us));
  std::map<std::array<long long, 3>, Index> serialCell;
  for (Index c = 0; c < serialMesh.numCells(); ++c) serialCell[centroidKey(serialMesh, c)] = c;

  // ranks
  const obs::DistributedGrid dg(obs::mesh::Grid(coarse), refinements, comm);
  const obs::DistributedView leaf = dg.view();
  const Eigen::VectorXd u = displacementOn(leaf.local, d);
  const auto owned = static_cast<Index>(leaf.part.owned.size());
  const obs::estimators::EstimatorResult r = obs::estimators::estimateOwned(
      *estimator, obs::estimators::EstimatorInput(leaf.local, material, bc, u), owned, comm);
  ASSERT_EQ(static_cast<Index>(r.indicators.size()), owned);
  EXPECT_EQ(comm.sum(static_cast<long long>(owned)), static_cast<long long>(serialMesh.numCells()));
  const double scale = *std::max_element(rs.indicators.begin(), rs.indicators.end());
  ASSERT_GT(scale, 0);
  for (Index c = 0; c < owned; ++c) {
    const Index s = serialCell.at(centroidKey(leaf.local, c));
    ASSERT_NEAR(r.indicators[c], rs.indicators[s], 1e-12 * scale) << "owned cell " << c << ", one process's " << s;
  }
  EXPECT_NEAR(r.total, rs.total, 1e-12 * rs.total);
  ASSERT_EQ(r.contributions.size(), rs.contributions.size());
  for (std::size_t k = 0; k < rs.contributions.size(); ++k)
    EXPECT_NEAR(r.contributions[k].value, rs.contributions[k].value, 1e-12 * rs.total) << rs.contributions[k].name;
}

TEST(DistributedEstimation, ResidualEstimatorOnOwnedCells2D) { estimatorOnRanks(CellType::Quadrilateral, 3); }
TEST(DistributedEstimation, ResidualEstimatorOnOwnedCells3D) { estimatorOnRanks(CellType::Tetrahedron, 2); }

/// The contact estimator (eta_1 .. eta_8) of a body pressed onto a ball: one process's solution,
/// given to each rank's local mesh by the vertices' positions, and the contact outputs of each
/// rank's problem (its rows at the vertices of owned cells are complete: every cell around such a
/// vertex is held) give the owned cells one process's indicators.
template <int d>
void contactEstimatorOnRanks(CellType type, int cells, int refinements) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Mesh coarse = obs::mesh::boxMesh(type, cells);
  const obs::Material material{1.0, 0.3};
  obs::BoundaryConditions bc;
  const Point top = d == 2 ? Point(0.002, -0.02, 0) : Point(0.002, 0.001, -0.02);
  bc.dirichlet.push_back({obs::mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  const double radius = 0.75;
  const Point centre = d == 2 ? Point(0.5, -radius, 0) : Point(0.5, 0.5, -radius);
  const obs::DiskObstacle disk(centre, radius);
  const obs::BallObstacle ball(centre, radius);
  const obs::Obstacle& obstacle = d == 2 ? static_cast<const obs::Obstacle&>(disk) : ball;
  const auto estimator = obs::estimators::EstimatorRegistry::global().create("contact-residual");
  const auto estimate = [&](const obs::mesh::Mesh& m, const Eigen::VectorXd& u, const obs::ContactProblem<d>& problem,
                            double U, double F, Index owned) {
    const obs::ContactOutputs out = obs::computeContactOutputs(problem, u, 1e-8, U, F);
    obs::estimators::ContactData data;
    data.set = &problem.contactSet();
    data.outputs = &out;
    data.obstacle = &obstacle;
    obs::estimators::EstimatorInput in(m, material, bc, u);
    in.contact = &data;
    return owned < 0 ? estimator->estimate(in) : obs::estimators::estimateOwned(*estimator, in, owned, comm);
  };

  // one process: the solution and the estimate
  obs::mesh::Grid grid(coarse);
  for (int l = 0; l < refinements; ++l) grid.refineUniformly();
  const obs::mesh::Mesh serialMesh = grid.leafMesh();
  const obs::ContactProblem<d> ps(serialMesh, material, bc, obs::ContactSet(serialMesh, obs::mesh::kBottom, obstacle));
  typename obs::TNNMG<d>::Options options;
  options.tolerance = 1e-10;
  obs::TNNMG<d> solver(grid, options);
  Eigen::VectorXd us = Eigen::VectorXd::Zero(ps.numDofs());
  ASSERT_TRUE(solver.solve(ps, us).converged);
  const double U = us.cwiseAbs().maxCoeff(), F = ps.rhs().cwiseAbs().maxCoeff() + U;  // fixed scales for both
  const obs::estimators::EstimatorResult rs = estimate(serialMesh, us, ps, U, F, -1);
  std::map<std::array<long long, 3>, Index> serialCell, serialVertex;
  for (Index c = 0; c < serialMesh.numCells(); ++c) serialCell[centroidKey(serialMesh, c)] = c;
  for (Index v = 0; v < serialMesh.numVertices(); ++v) {
    const Point& x = serialMesh.vertex(v);
    serialVertex[{std::llround(std::ldexp(x[0], 24)), std::llround(std::ldexp(x[1], 24)), std::llround(std::ldexp(x[2], 24))}] = v;
  }

  // ranks: the same displacement on the local mesh
  const obs::DistributedGrid dg(obs::mesh::Grid(coarse), refinements, comm);
  const obs::DistributedView leaf = dg.view();
  std::optional<obs::ContactProblem<d>> pd;
  comm.collective([&] {
    pd.emplace(leaf.local, material, bc, obs::ContactSet(leaf.local, obs::mesh::kBottom, obstacle, true));
  });
  Eigen::VectorXd u(pd->numDofs());
  for (Index v = 0; v < leaf.local.numVertices(); ++v) {
    const Point& x = leaf.local.vertex(v);
    const Index s = serialVertex.at({std::llround(std::ldexp(x[0], 24)), std::llround(std::ldexp(x[1], 24)),
                                     std::llround(std::ldexp(x[2], 24))});
    u.template segment<d>(v * d) = us.template segment<d>(s * d);
  }
  const auto owned = static_cast<Index>(leaf.part.owned.size());
  const obs::estimators::EstimatorResult r = estimate(leaf.local, u, *pd, U, F, owned);
  const double scale = *std::max_element(rs.indicators.begin(), rs.indicators.end());
  for (Index c = 0; c < owned; ++c) {
    const Index s = serialCell.at(centroidKey(leaf.local, c));
    ASSERT_NEAR(r.indicators[c], rs.indicators[s], 1e-12 * scale) << "owned cell " << c << ", one process's " << s;
  }
  EXPECT_NEAR(r.total, rs.total, 1e-12 * rs.total);
  for (std::size_t k = 0; k < rs.contributions.size(); ++k)
    EXPECT_NEAR(r.contributions[k].value, rs.contributions[k].value, 1e-12 * rs.total) << rs.contributions[k].name;
  EXPECT_GT(rs.contribution("eta_6") + rs.contribution("eta_7"), 0);  // contact terms present
}

TEST(DistributedEstimation, ContactEstimatorOnOwnedCells2D) {
  contactEstimatorOnRanks<2>(CellType::Quadrilateral, 4, 3);
}
TEST(DistributedEstimation, ContactEstimatorOnOwnedCells3D) {
  contactEstimatorOnRanks<3>(CellType::Hexahedron, 3, 2);
}

/// N cells in global order, owned in uneven consecutive blocks; indicators with many ties (dyadic
/// values, whose squares and sums are exact) or without (sines); keys a scrambled numbering. The
/// one-process reference: the serial strategy on the cells renumbered by key, so that its ties by
/// increasing cell number are ties by increasing key.
TEST(DistributedEstimation, MarkingOnRanksIsTheOneProcessMarking) {
  const obs::Communicator comm = obs::Communicator::world();
  const Index N = 997;
  std::vector<Index> offsets{0};
  for (int r = 0; r < comm.size(); ++r) offsets.push_back(N * (r + 1) * (r + 2) / (comm.size() * (comm.size() + 1)));
  const Index first = offsets[comm.rank()], last = offsets[comm.rank() + 1];
  const auto key = [](Index g) { return (static_cast<std::uint64_t>(g) * 0x9E3779B97F4A7C15ULL) ^ 0x5bd1e995ULL; };
  for (const bool ties : {true, false}) {
    std::vector<double> all(static_cast<std::size_t>(N));
    for (Index g = 0; g < N; ++g) {
      const double s = std::abs(std::sin(0.731 * static_cast<double>(g) + 0.2));
      all[g] = ties ? std::floor(8 * s) / 8 : s;
    }
    // the reference, on the cells by increasing key
    std::vector<Index> byKey(static_cast<std::size_t>(N));
    std::iota(byKey.begin(), byKey.end(), Index(0));
    std::sort(byKey.begin(), byKey.end(), [&](Index a, Index b) { return key(a) < key(b); });
    std::vector<double> sortedEta;
    for (Index g : byKey) sortedEta.push_back(all[g]);
    const std::vector<double> mine(all.begin() + first, all.begin() + last);
    std::vector<std::uint64_t> keys;
    for (Index g = first; g < last; ++g) keys.push_back(key(g));
    const std::vector<std::pair<std::string, double>> strategies = {
        {"mean", 1.1}, {"mean", 0.0}, {"maximum", 0.5}, {"maximum", 1.0}, {"fraction", 0.2}, {"fraction", 0.37},
        {"fraction", 1.0}, {"doerfler", 0.5}, {"doerfler", 0.3}, {"doerfler", 0.999}, {"doerfler", 1.0}};
    for (const auto& [name, theta] : strategies) {
      const obs::estimators::MarkingStrategy strategy(name, theta);
      std::vector<char> expected(static_cast<std::size_t>(N), 0);
      for (Index i : strategy.mark(sortedEta)) expected[byKey[i]] = 1;
      const std::vector<Index> marked = obs::estimators::markOwned(strategy, mine, keys, comm);
      std::vector<char> got(static_cast<std::size_t>(last - first), 0);
      for (Index i : marked) got[i] = 1;
      long long wrong = 0, count = 0;
      for (Index g = first; g < last; ++g) {
        wrong += got[g - first] != expected[g] ? 1 : 0;
        count += got[g - first];
      }
      const long long expectedCount = std::count(expected.begin(), expected.end(), 1);
      EXPECT_EQ(comm.sum(wrong), 0) << name << " " << theta << (ties ? " with ties" : "");
      EXPECT_EQ(comm.sum(count), expectedCount) << name << " " << theta << (ties ? " with ties" : "");
      EXPECT_TRUE(std::is_sorted(marked.begin(), marked.end()));
    }
  }
  // every indicator zero: nothing marked; a negative one is an error on every rank
  const std::vector<double> zeros(static_cast<std::size_t>(last - first), 0.0);
  std::vector<std::uint64_t> keys(zeros.size());
  std::iota(keys.begin(), keys.end(), static_cast<std::uint64_t>(first));
  EXPECT_TRUE(obs::estimators::markOwned(obs::estimators::MarkingStrategy("doerfler"), zeros, keys, comm).empty());
  std::vector<double> bad = zeros;
  if (comm.rank() == comm.size() - 1 && !bad.empty()) bad.back() = -1;
  EXPECT_THROW(obs::estimators::markOwned(obs::estimators::MarkingStrategy("mean"), bad, keys, comm), obs::Error);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
