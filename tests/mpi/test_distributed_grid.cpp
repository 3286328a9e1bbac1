// The distributed grid under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks): every rank refines
// only its near subtrees (DistributedGrid.hpp), and what it then holds of the leaf view and of the
// level views below it must be what the serial partition of the uniformly refined grid gives its
// part: the same owned and ghost cells and vertices (compared by position), the ghosts' global
// indices those of their owners (their positions arrive through the halo exchange), every vertex
// owned once, and the owned rows of the stiffness product those of the serial product
// (docs/architecture.md#distributed-grid). After adaptive refinement (each rank marking its
// owned leaves, DistributedGrid::adapt) the same holds for the serially adapted grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Material.hpp"

#include "Positions.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::test::Position;
using obs::test::quantise;

std::vector<Position> positions(const obs::mesh::Mesh& m, const std::vector<Index>& vertices) {
  std::vector<Position> p;
  for (Index v : vertices) p.push_back(quantise(m.vertex(v)));
  std::sort(p.begin(), p.end());
  return p;
}

/// The cells' centroids (sums of corner positions: exact on the lattice), sorted.
std::vector<Position> cellPositions(const obs::mesh::Mesh& m, const std::vector<Index>& cells) {
  std::vector<Position> p;
  for (Index c : cells) {
    Position s{0, 0, 0};
    for (Index v : m.cellVertices(c)) {
      const Position q = quantise(m.vertex(v));
      for (int k = 0; k < 3; ++k) s[k] += q[k];
    }
    p.push_back(s);
  }
  std::sort(p.begin(), p.end());
  return p;
}

double field(const obs::mesh::Point& x, int component) {
  return std::sin(3.1 * x[0] + 1.7 * x[1] - 0.9 * x[2] + 1.3 * component) + 0.1 * component;
}

/// Every distributed view of `dist` holds what the serial partition `sp` of `serial` gives this
/// rank: cells and vertices (by position), the ghosts' global indices (positions through the
/// halo), the owned rows of the stiffness product.
template <int d>
void expectSerialViews(const obs::DistributedGrid& dist, const obs::mesh::Grid& serial, const obs::ForestPartition& sp) {
  const obs::Communicator& comm = dist.communicator();
  for (int level = -1; level <= dist.maxLevel(); ++level) {
    if (level >= 0 && level < dist.partition().level) {
      EXPECT_THROW(dist.view(level), obs::Error);
      continue;
    }
    SCOPED_TRACE("level " + std::to_string(level));
    const obs::DistributedView dv = dist.view(level);
    const obs::mesh::GridView sv = level < 0 ? serial.leafView() : serial.levelView(level);
    const obs::ViewNumbering sn = obs::numberView(serial, sv, sp);
    const obs::PartView spv = obs::partView(serial, sv, sp, sn, comm.rank());
    const obs::mesh::Mesh& m = dv.view.mesh;
    EXPECT_EQ(cellPositions(m, dv.part.owned), cellPositions(sv.mesh, spv.owned));
    EXPECT_EQ(cellPositions(m, dv.part.ghosts), cellPositions(sv.mesh, spv.ghosts));
    EXPECT_EQ(positions(m, dv.part.ownedVertices), positions(sv.mesh, spv.ownedVertices));
    EXPECT_EQ(positions(m, dv.part.ghostVertices), positions(sv.mesh, spv.ghostVertices));
    EXPECT_EQ(dv.globalVertices(), sv.mesh.numVertices());
    EXPECT_EQ(comm.sum(static_cast<long long>(dv.halo.numOwned())), static_cast<long long>(sv.mesh.numVertices()));

    // the ghosts' positions from their owners: the global indices asked by key are the right ones
    const Index nl = dv.halo.numLocal();
    Eigen::VectorXd x = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(nl) * d, -1e300);
    for (Index i = 0; i < dv.halo.numOwned(); ++i)
      for (int c = 0; c < d; ++c) x[i * d + c] = dv.local.vertex(i)[c];
    dv.halo.update(x, d);
    for (Index i = dv.halo.numOwned(); i < nl; ++i)
      for (int c = 0; c < d; ++c) ASSERT_NEAR(x[i * d + c], dv.local.vertex(i)[c], 1e-14) << "ghost " << i;

    // every held vertex is on the boundaries its owner finds it on: a Dirichlet condition on each
    // side prescribes a ghost as it prescribes the owned vertex (ghosts at the edge of the ghost
    // layer whose boundary faces are not all held included)
    for (int side = obs::mesh::kLeft; side <= (d == 3 ? obs::mesh::kBack : obs::mesh::kTop); ++side) {
      const obs::DirichletValues g = obs::collectDirichlet(
          dv.local, {obs::DirichletCondition{side, {true, false, false}, [](const obs::mesh::Point& p) { return p; }}});
      Eigen::VectorXd flags(static_cast<Eigen::Index>(nl));
      for (Index i = 0; i < nl; ++i) flags[i] = g.constrained[static_cast<std::size_t>(i) * d];
      const Eigen::VectorXd mine = flags;
      dv.halo.update(flags, 1);
      long long differ = 0;
      for (Index i = dv.halo.numOwned(); i < nl; ++i) differ += flags[i] != mine[i] ? 1 : 0;
      EXPECT_EQ(differ, 0) << "side " << side;
      // and it is a contact vertex of a contact boundary there exactly when its owner's is
      const obs::PlaneObstacle plane(obs::mesh::Point(0, 0, -1), obs::mesh::Point(0, -1, -1));
      const obs::ContactSet set(dv.local, side, plane, true);
      for (Index i = 0; i < nl; ++i) flags[i] = set.nodeOf(i) >= 0 ? 1 : 0;
      const Eigen::VectorXd held = flags;
      dv.halo.update(flags, 1);
      differ = 0;
      for (Index i = dv.halo.numOwned(); i < nl; ++i) differ += flags[i] != held[i] ? 1 : 0;
      EXPECT_EQ(differ, 0) << "contact side " << side;
    }

    // the owned rows of the distributed product are the serial ones
    for (Index i = 0; i < nl; ++i)
      for (int c = 0; c < d; ++c) x[i * d + c] = field(dv.local.vertex(i), c);
    const obs::Material material{1.0, 0.3};
    const Eigen::VectorXd y = obs::assembleStiffness<d>(dv.local, material) * x;
    const Index ns = sv.mesh.numVertices();
    Eigen::VectorXd xs(static_cast<Eigen::Index>(ns) * d);
    std::map<Position, Index> serialVertex;
    for (Index v = 0; v < ns; ++v) {
      serialVertex[quantise(sv.mesh.vertex(v))] = v;
      for (int c = 0; c < d; ++c) xs[v * d + c] = field(sv.mesh.vertex(v), c);
    }
    const Eigen::VectorXd ys = obs::assembleStiffness<d>(sv.mesh, material) * xs;
    const double scale = ys.cwiseAbs().maxCoeff();
    for (Index i = 0; i < dv.halo.numOwned(); ++i) {
      const Index v = serialVertex.at(quantise(dv.local.vertex(i)));
      for (int c = 0; c < d; ++c) ASSERT_NEAR(y[i * d + c], ys[v * d + c], 1e-12 * scale) << "vertex " << i;
    }
  }
}

template <int d>
void expectSerialPartView(CellType type, int cells, int refinements) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)));
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(type, cells));
  const obs::DistributedGrid dist(coarse, refinements, comm);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < refinements; ++l) serial.refineUniformly();
  ASSERT_EQ(dist.maxLevel(), serial.maxLevel());
  obs::ForestPartitionOptions options;
  options.level = dist.partition().level;
  const obs::ForestPartition sp = obs::partitionForest(serial, comm.size(), options);
  EXPECT_EQ(dist.partition().cellPart, sp.cellPart);
  EXPECT_EQ(dist.globalLeaves(), static_cast<long long>(serial.numLeafElements()));
  // no rank holds the whole fine level: red leaves of the finest level (the graded closure around
  // its near cells is coarser or green)
  Index fine = 0;
  for (Index e : dist.grid().leafElements()) fine += dist.grid().level(e) == dist.maxLevel() && !dist.grid().isGreen(e) ? 1 : 0;
  if (comm.size() > 1) {
    EXPECT_LT(fine, serial.numLeafElements());
  }

  expectSerialViews<d>(dist, serial, sp);
}

TEST(DistributedGrid, HoldsTheSerialPartViewTriangles) { expectSerialPartView<2>(CellType::Triangle, 8, 3); }
TEST(DistributedGrid, HoldsTheSerialPartViewQuadrilaterals) { expectSerialPartView<2>(CellType::Quadrilateral, 8, 3); }
TEST(DistributedGrid, HoldsTheSerialPartViewTetrahedra) { expectSerialPartView<3>(CellType::Tetrahedron, 2, 2); }
TEST(DistributedGrid, HoldsTheSerialPartViewHexahedra) { expectSerialPartView<3>(CellType::Hexahedron, 4, 2); }

/// Leaves within `width` times their size of a sphere (circle) whose radius shrinks with the step, and one in `sparse` leaves by
/// a hash of its centroid: graded fronts with cascades of the closure and irregular green patterns.
bool marksNearSphere(const obs::mesh::Grid& grid, Index e, int step, unsigned long long sparse, double width) {
  obs::mesh::Point c = obs::mesh::Point::Zero(), lo = grid.vertex(grid.vertices(e)[0]), hi = lo;
  for (Index v : grid.vertices(e)) {
    c += grid.vertex(v);
    lo = lo.cwiseMin(grid.vertex(v));
    hi = hi.cwiseMax(grid.vertex(v));
  }
  c /= static_cast<double>(grid.vertices(e).size());
  const double h = (hi - lo).maxCoeff(), radius = 0.45 - 0.08 * step;
  const Position q = quantise(c);
  const auto hash = static_cast<unsigned long long>(q[0] * 73856093LL ^ q[1] * 19349663LL ^ q[2] * 83492791LL);
  return std::abs((c - obs::mesh::Point(0.3, 0.4, 0.35)).norm() - radius) < width * h || hash % sparse == 0;
}

/// The leaves whose closure contains the point p: refined step after step, they grade the grid
/// towards p, and each new mark at the finest level pushes rule 1 of the closure out level by level.
bool marksPoint(const obs::mesh::Grid& grid, Index e, const obs::mesh::Point& p) {
  obs::mesh::Point lo = grid.vertex(grid.vertices(e)[0]), hi = lo;
  for (Index v : grid.vertices(e)) {
    lo = lo.cwiseMin(grid.vertex(v));
    hi = hi.cwiseMax(grid.vertex(v));
  }
  return (p.array() >= lo.array() - 1e-12).all() && (p.array() <= hi.array() + 1e-12).all();
}

using Marker = std::function<bool(const obs::mesh::Grid&, Index, int)>;

Marker nearSphere(unsigned long long sparse, double width) {
  return [=](const obs::mesh::Grid& g, Index e, int step) { return marksNearSphere(g, e, step, sparse, width); };
}

/// Adaptive refinement on the ranks (DistributedGrid::adapt): each rank marks its owned leaves
/// of the serial marking; after every step the views are those of the serially adapted grid.
/// With an imbalance tolerance, DistributedGrid::rebalance after every step: the views are then
/// those of the serial grid on the new parts, and a field carried through the rebalance is the
/// field at the new leaves' vertices; `moves` counts the rebalances that moved cells.
template <int d>
void expectSerialAdaptation(CellType type, int cells, int refinements, int steps, const Marker& marks,
                            obs::mesh::ClosureRule rule = obs::mesh::ClosureRule::MoreThanHalfEdges,
                            int* mostRounds = nullptr, double imbalanceTolerance = 0, int* moves = nullptr) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)));
  const obs::Communicator comm = obs::Communicator::world();
  obs::mesh::Grid coarse(obs::mesh::boxMesh(type, cells));
  coarse.setClosureRule(rule);  // copied into both grids
  obs::DistributedGrid dist(coarse, refinements, comm);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < refinements; ++l) serial.refineUniformly();
  obs::ForestPartitionOptions options;
  options.level = dist.partition().level;
  obs::ForestPartition sp = obs::partitionForest(serial, comm.size(), options);
  for (int step = 0; step < steps; ++step) {
    SCOPED_TRACE("step " + std::to_string(step));
    std::vector<Index> own;
    for (Index e : dist.grid().leafElements())
      if (dist.partition().partOf(e) == comm.rank() && marks(dist.grid(), e, step)) own.push_back(e);
    for (Index e : serial.leafElements())
      if (marks(serial, e, step)) serial.mark(e);
    const obs::mesh::AdaptResult sr = serial.adapt();
    sp.follow(serial);
    int rounds = 0;
    const obs::mesh::AdaptResult dr = dist.adapt(own, &rounds);
    EXPECT_EQ(dr.marked, sr.marked);
    EXPECT_EQ(dr.redRefined, sr.redRefined);
    EXPECT_EQ(dr.propagated, sr.propagated);
    EXPECT_EQ(dr.greenClosed, sr.greenClosed);
    EXPECT_GE(rounds, 1);
    if (mostRounds) *mostRounds = std::max(*mostRounds, rounds);
    ASSERT_EQ(dist.globalLeaves(), static_cast<long long>(serial.numLeafElements()));
    ASSERT_EQ(dist.maxLevel(), serial.maxLevel());
    if (rule == obs::mesh::ClosureRule::AllEdges || type != CellType::Hexahedron) {
      EXPECT_GT(sr.greenClosed, 0);
      if (comm.size() > 1 && step + 1 == steps) {  // not every rank holds the whole grid
        const bool fewer = dist.grid().numLeafElements() < serial.numLeafElements();
        EXPECT_GE(comm.sum(fewer ? 1LL : 0LL), 1);
      }
    }
    if (imbalanceTolerance >= 1) {
      // the field at the vertices of the leaf view (exact at those of the owned leaves)
      const obs::mesh::GridView before = dist.grid().leafView();
      std::vector<double> values(before.vertices.size() * d, -1e300);
      for (std::size_t i = 0; i < before.vertices.size(); ++i)
        for (int c = 0; c < d; ++c) values[i * d + c] = field(dist.grid().vertex(before.vertices[i]), c);
      const double expected = sp.imbalance();
      const std::vector<int> oldParts = dist.partition().cellPart;
      const obs::RebalanceReport report = dist.rebalance(imbalanceTolerance, &values, d);
      EXPECT_DOUBLE_EQ(report.before, expected);
      sp.cellPart = dist.partition().cellPart;
      sp.follow(serial);
      EXPECT_DOUBLE_EQ(report.after, sp.imbalance());
      if (report.moved) {
        if (moves) ++*moves;
        EXPECT_GT(report.before, imbalanceTolerance);
        EXPECT_LT(report.after, report.before);
        EXPECT_EQ(report.replayedSteps, step + 1);
        EXPECT_NE(oldParts, dist.partition().cellPart);
      } else {
        EXPECT_EQ(oldParts, dist.partition().cellPart);
      }
      ASSERT_EQ(dist.globalLeaves(), static_cast<long long>(serial.numLeafElements()));
      const obs::mesh::GridView after = dist.grid().leafView();
      ASSERT_EQ(values.size(), after.vertices.size() * d);
      std::vector<Index> at(static_cast<std::size_t>(dist.grid().numVertices()), -1);
      for (std::size_t i = 0; i < after.vertices.size(); ++i) at[after.vertices[i]] = static_cast<Index>(i);
      for (Index e : after.elements) {
        if (dist.partition().partOf(e) != comm.rank()) continue;
        for (Index v : dist.grid().vertices(e))
          for (int c = 0; c < d; ++c) {
            ASSERT_EQ(values[static_cast<std::size_t>(at[v]) * d + c], field(dist.grid().vertex(v), c)) << "vertex " << v;
          }
      }
    }
    expectSerialViews<d>(dist, serial, sp);
  }
}

TEST(DistributedGrid, AdaptsAsOneProcessTriangles) { expectSerialAdaptation<2>(CellType::Triangle, 6, 2, 4, nearSphere(7, 0.5)); }
TEST(DistributedGrid, AdaptsAsOneProcessQuadrilaterals) { expectSerialAdaptation<2>(CellType::Quadrilateral, 6, 2, 4, nearSphere(7, 0.5)); }
TEST(DistributedGrid, AdaptsAsOneProcessTetrahedra) { expectSerialAdaptation<3>(CellType::Tetrahedron, 2, 1, 3, nearSphere(13, 0.2)); }
// (hexahedra with more than half of their edges refined go red and refine this grid uniformly)
TEST(DistributedGrid, AdaptsAsOneProcessHexahedra) {
  expectSerialAdaptation<3>(CellType::Hexahedron, 4, 1, 3, nearSphere(31, 0.0), obs::mesh::ClosureRule::AllEdges);
}

// A cascade of rule 2 through the whole grid (hexahedra with more than half of their edges
// refined go red: 21 marks refine all 512 cells) crosses the ranks: the reports of the closure
// of the first exchanged marks need a second round.
TEST(DistributedGrid, ClosureCascadesAcrossRanks) {
  int rounds = 0;
  expectSerialAdaptation<3>(CellType::Hexahedron, 4, 1, 1, nearSphere(31, 0.0), obs::mesh::ClosureRule::MoreThanHalfEdges,
                            &rounds);
  if (obs::Communicator::world().size() > 1) {
    EXPECT_GE(rounds, 2);
  }
}

// Refinement towards a point for many steps: rule 1 carries each new finest mark out through the
// coarser rings, across the ranks.
TEST(DistributedGrid, GradingTowardsAPointCrossesRanks) {
  const obs::mesh::Point p(0.3, 0.45, 0);
  expectSerialAdaptation<2>(CellType::Triangle, 8, 1, 8, [&](const obs::mesh::Grid& g, Index e, int) { return marksPoint(g, e, p); });
}

// The same grading with load balancing after every step: the refinement near the point unbalances
// the parts; rebalanced, each step's grid is the serial one on the new parts, and the next steps
// refine it (marks recorded again by the new owners) as one process does.
TEST(DistributedGrid, RebalancesAsOneProcessTriangles) {
  const obs::mesh::Point p(0.3, 0.45, 0);
  int moves = 0;
  expectSerialAdaptation<2>(CellType::Triangle, 8, 1, 8, [&](const obs::mesh::Grid& g, Index e, int) { return marksPoint(g, e, p); },
                            obs::mesh::ClosureRule::MoreThanHalfEdges, nullptr, 1.05, &moves);
  if (obs::Communicator::world().size() > 1) {
    EXPECT_GE(moves, 2);
  }
}

TEST(DistributedGrid, RebalancesAsOneProcessHexahedra) {
  int moves = 0;
  expectSerialAdaptation<3>(CellType::Hexahedron, 4, 1, 3, nearSphere(31, 0.0), obs::mesh::ClosureRule::AllEdges, nullptr,
                            1.02, &moves);
  if (obs::Communicator::world().size() > 1) {
    EXPECT_GE(moves, 1);
  }
}

/// The faces of a boundary as a second weight of the balance (setBalancedBoundary): the reported
/// imbalances of the faces are those of the parts, a move lowers the larger imbalance, the grid is
/// the serial one on the new parts, and the boundary ends better balanced than when only the leaves
/// count (grading towards a point inside, the bottom boundary balanced).
TEST(DistributedGrid, BalancesABoundaryWithTheLeaves) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Point p(0.3, 0.45, 0);
  double finalBoundary[2] = {0, 0};
  for (int balanced = 0; balanced < 2; ++balanced) {
    SCOPED_TRACE(balanced ? "leaves and boundary faces" : "leaves");
    const obs::mesh::Grid coarse(obs::mesh::boxMesh(CellType::Triangle, 8));
    obs::DistributedGrid dist(coarse, 1, comm);
    if (balanced) dist.setBalancedBoundary(obs::mesh::kBottom);
    obs::mesh::Grid serial = coarse;
    serial.refineUniformly();
    obs::ForestPartitionOptions options;
    options.level = dist.partition().level;
    obs::ForestPartition sp = obs::partitionForest(serial, comm.size(), options);
    const auto boundaryImbalance = [&](const obs::ForestPartition& part) {  // of the serial grid's leaves
      std::vector<double> faces(static_cast<std::size_t>(comm.size()), 0.0);
      double total = 0;
      for (Index e : serial.leafElements())
        for (int f = 0; f < static_cast<int>(obs::mesh::localFaces(serial.type(e)).size()); ++f)
          if (serial.boundaryId(e, f) == obs::mesh::kBottom) {
            faces[static_cast<std::size_t>(part.partOf(e))] += 1;
            total += 1;
          }
      return *std::max_element(faces.begin(), faces.end()) * comm.size() / total;
    };
    for (int step = 0; step < 6; ++step) {
      SCOPED_TRACE("step " + std::to_string(step));
      std::vector<Index> own;
      for (Index e : dist.grid().leafElements())
        if (dist.partition().partOf(e) == comm.rank() && marksPoint(dist.grid(), e, p)) own.push_back(e);
      for (Index e : serial.leafElements())
        if (marksPoint(serial, e, p)) serial.mark(e);
      serial.adapt();
      sp.follow(serial);
      dist.adapt(own);
      const double before = boundaryImbalance(sp);
      const obs::RebalanceReport r = dist.rebalance(1.05);
      EXPECT_DOUBLE_EQ(r.boundaryBefore, balanced ? before : 1.0);
      sp.cellPart = dist.partition().cellPart;
      sp.follow(serial);
      EXPECT_DOUBLE_EQ(r.after, sp.imbalance());
      EXPECT_DOUBLE_EQ(r.boundaryAfter, balanced ? boundaryImbalance(sp) : 1.0);
      if (r.moved) {
        EXPECT_LT(std::max(r.after, r.boundaryAfter), std::max(r.before, r.boundaryBefore));
      }
      expectSerialViews<2>(dist, serial, sp);
      finalBoundary[balanced] = boundaryImbalance(sp);
    }
  }
  if (comm.size() > 1) {
    EXPECT_LE(finalBoundary[1], finalBoundary[0]);
  }
}

TEST(DistributedGrid, ErrorsReachEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(CellType::Triangle, 2));
  EXPECT_THROW(obs::DistributedGrid(coarse, -1, comm), obs::Error);
  obs::ForestPartitionOptions options;
  options.level = 5;  // beyond the refinements
  EXPECT_THROW(obs::DistributedGrid(coarse, 2, comm, options), obs::Error);
  const obs::DistributedGrid dist(coarse, 2, comm);
  EXPECT_THROW(dist.view(dist.maxLevel() + 1), obs::Error);
  // only owned leaves can be marked: rank 0 marks an element it does not own (or a non-leaf)
  obs::DistributedGrid copy = dist;
  std::vector<Index> wrong;
  if (comm.rank() == 0) {
    for (Index e = 0; e < copy.grid().numElements() && wrong.empty(); ++e)
      if (!copy.grid().isLeaf(e) || copy.partition().partOf(e) != 0) wrong.push_back(e);
  }
  EXPECT_THROW(copy.adapt(wrong), obs::Error);
  // a rebalance: a tolerance below 1, values of the wrong size on rank 0 only
  EXPECT_THROW(copy.rebalance(0.9), obs::Error);
  std::vector<double> values(copy.grid().leafView().vertices.size() * 2 + (comm.rank() == 0 ? 1 : 0), 0.0);
  EXPECT_THROW(copy.rebalance(1.0, &values, 2), obs::Error);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
