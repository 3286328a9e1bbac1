// A communicator of one is the serial code (docs/architecture.md#one-path): a DistributedGrid on
// one process is the grid one process refines (any grid: no refinement, green leaves), its views
// are the serial views with their own numbering and no ghosts, and the solvers built on it
// (MultigridHierarchy, LinearMultigrid, TNNMG) compute bit for bit what the serial ones compute.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;
using mesh::Point;

namespace {

const Communicator kOne = Communicator::world();  // this test runs without mpirun: one process

/// Two meshes are the same: vertices (bitwise), cells, boundary faces with their ids and names.
void expectSameMesh(const mesh::Mesh& a, const mesh::Mesh& b) {
  ASSERT_EQ(a.dimension(), b.dimension());
  ASSERT_EQ(a.numVertices(), b.numVertices());
  ASSERT_EQ(a.numCells(), b.numCells());
  ASSERT_EQ(a.numBoundaryFaces(), b.numBoundaryFaces());
  for (Index v = 0; v < a.numVertices(); ++v) ASSERT_EQ(a.vertex(v), b.vertex(v)) << "vertex " << v;
  for (Index c = 0; c < a.numCells(); ++c) {
    ASSERT_EQ(a.cellType(c), b.cellType(c)) << "cell " << c;
    const auto va = a.cellVertices(c), vb = b.cellVertices(c);
    ASSERT_TRUE(std::equal(va.begin(), va.end(), vb.begin(), vb.end())) << "cell " << c;
  }
  for (Index f = 0; f < a.numBoundaryFaces(); ++f) {
    ASSERT_EQ(a.boundaryFaceId(f), b.boundaryFaceId(f)) << "face " << f;
    const auto fa = a.boundaryFaceVertices(f), fb = b.boundaryFaceVertices(f);
    ASSERT_TRUE(std::equal(fa.begin(), fa.end(), fb.begin(), fb.end())) << "face " << f;
  }
  EXPECT_EQ(a.boundaryNames(), b.boundaryNames());
}

/// The distributed grid of one rank on `coarse` refined `k` times against the serial grid refined
/// so: the grid, the leaf view and every level view at or above the partition level.
void expectSerialGrid(const mesh::Grid& coarse, int k) {
  mesh::Grid serial = coarse;
  for (int i = 0; i < k; ++i) serial.refineUniformly();
  const DistributedGrid dg(coarse, k, kOne);
  ASSERT_EQ(dg.grid().numElements(), serial.numElements());
  ASSERT_EQ(dg.grid().numVertices(), serial.numVertices());
  EXPECT_EQ(dg.maxLevel(), serial.maxLevel());
  EXPECT_EQ(dg.globalLeaves(), serial.numLeafElements());
  EXPECT_EQ(dg.grid().leafElements(), serial.leafElements());
  for (int level = -1; level <= dg.maxLevel(); ++level) {
    if (level >= 0 && level < dg.partition().level) continue;
    const DistributedView v = dg.view(level);
    const mesh::GridView s = level < 0 || level == serial.maxLevel() ? serial.leafView() : serial.levelView(level);
    expectSameMesh(v.local, s.mesh);
    EXPECT_EQ(v.view.elements, s.elements);
    EXPECT_EQ(v.halo.numOwned(), v.halo.numLocal());
    EXPECT_EQ(v.globalVertices(), s.mesh.numVertices());
    for (Index i = 0; i < s.mesh.numVertices(); ++i) ASSERT_EQ(v.numbering.global[i], i);
  }
}

}  // namespace

TEST(OneRank, DistributedGridIsTheSerialGrid) {
  ASSERT_EQ(kOne.size(), 1);
  for (CellType t : {CellType::Triangle, CellType::Quadrilateral})
    for (int k : {0, 1, 3}) expectSerialGrid(mesh::Grid(mesh::boxMesh(t, 2)), k);
  for (CellType t : {CellType::Tetrahedron, CellType::Hexahedron, CellType::Prism, CellType::Pyramid})
    expectSerialGrid(mesh::Grid(mesh::boxMesh(t, 1)), 2);
}

// A grid with green leaves (refined near a corner) and one without any refinement: both refused
// on ranks, both the serial grid on one process.
TEST(OneRank, GreenLeavesAndUnrefinedGrids) {
  mesh::Grid graded(mesh::boxMesh(CellType::Quadrilateral, 4));
  for (int step = 0; step < 2; ++step) {
    for (Index e : graded.leafElements())
      if (graded.vertex(graded.vertices(e)[0]).norm() < 0.3) graded.mark(e);
    graded.adapt();
  }
  bool green = false;
  for (Index e : graded.leafElements()) green = green || graded.isGreen(e);
  ASSERT_TRUE(green);
  expectSerialGrid(graded, 0);
  expectSerialGrid(graded, 1);
  expectSerialGrid(mesh::Grid(mesh::boxMesh(CellType::Hexahedron, 2)), 0);
}

// The partition level is the one ranks would choose (the coarsest level from 1 on with 8 cells),
// and a level outside the grid's levels is refused as on ranks.
TEST(OneRank, PartitionLevelAsOnRanks) {
  const mesh::Grid coarse(mesh::boxMesh(CellType::Quadrilateral, 1));  // 1 cell: 4, 16, 64 leaves
  EXPECT_EQ(DistributedGrid(coarse, 3, kOne).partition().level, 2);
  EXPECT_EQ(DistributedGrid(coarse, 1, kOne).partition().level, 1);
  EXPECT_EQ(DistributedGrid(coarse, 0, kOne).partition().level, 0);
  ForestPartitionOptions at;
  at.level = 3;
  EXPECT_EQ(DistributedGrid(coarse, 3, kOne, at).partition().level, 3);
  at.level = 4;
  EXPECT_THROW(DistributedGrid(coarse, 3, kOne, at), Error);
  EXPECT_THROW(DistributedGrid(coarse, -1, kOne), Error);
}

// TNNMG on the distributed grid of one rank: the serial TNNMG's iterations and solution, bit for
// bit, on a Signorini problem (a ball pressed into a cube of hexahedra); linear multigrid with the
// vertex-patch smoother, which ranks do not run, on one process.
TEST(OneRank, SolversAreTheSerialOnes) {
  const mesh::Grid coarse(mesh::boxMesh(CellType::Hexahedron, 2));
  const DistributedGrid dg(coarse, 2, kOne);
  const DistributedView leaf = dg.view();
  const Material material{3e5, 0.25};
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, 0, -0.03); }});
  const BallObstacle ball(Point(0.5, 0.5, -0.75), 0.75);
  const ContactSet set(leaf.local, mesh::kBottom, ball);
  const ContactProblem<3> problem(leaf.local, material, bc, set);
  TNNMG<3>::Options o;
  o.tolerance = 1e-10;
  TNNMG<3> serial(dg.grid(), o), one(dg, o);
  Eigen::VectorXd us = Eigen::VectorXd::Zero(problem.numDofs()), uo = us;
  const ContactResult rs = serial.solve(problem, us), ro = one.solve(problem, uo);
  EXPECT_TRUE(rs.converged);
  EXPECT_EQ(ro.iterations, rs.iterations);
  EXPECT_EQ(uo, us);

  LinearMultigridOptions patch;
  patch.smoother = LinearSmoother::VertexPatch;
  EXPECT_NO_THROW(LinearMultigrid<3>(dg, patch));
}
