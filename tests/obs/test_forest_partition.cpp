// The partition of a grid's refinement forest over the ranks of a distributed run
// (libobs/include/obs/obs/ForestPartition.hpp, docs/architecture.md#forest-partition): every leaf
// owned by exactly one part, ghost layers exactly the vertex neighbours of the owned cells, the
// global vertex numbering a bijection with contiguous ranges per part, balance in leaves, and the
// same result when computed twice.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/ForestPartition.hpp"

namespace {

using obs::ForestPartition;
using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Grid;
using obs::mesh::GridView;

Grid uniform(CellType type, int cells, int levels) {
  Grid g(obs::mesh::boxMesh(type, cells));
  for (int l = 0; l < levels; ++l) g.refineUniformly();
  return g;
}

/// Refines the leaves near the corner x = 0 twice more (an adaptive, graded grid with green closures).
Grid graded(CellType type) {
  Grid g = uniform(type, 4, 1);
  for (int round = 0; round < 2; ++round) {
    for (Index e : g.leafElements()) {
      const auto vs = g.vertices(e);
      const bool near = std::any_of(vs.begin(), vs.end(), [&](Index v) { return g.vertex(v).norm() < 0.3; });
      if (near) g.mark(e);
    }
    g.adapt();
  }
  return g;
}

/// The invariants of one view of a partitioned grid.
void expectConsistent(const Grid& grid, const GridView& view, const ForestPartition& p) {
  const obs::ViewNumbering n = obs::numberView(grid, view, p);
  const Index nv = view.mesh.numVertices(), nc = view.mesh.numCells();
  // the global numbering: a bijection onto 0..nv-1, each part's owned vertices one range
  std::vector<Index> sorted = n.global;
  std::sort(sorted.begin(), sorted.end());
  for (Index v = 0; v < nv; ++v) ASSERT_EQ(sorted[v], v);
  ASSERT_EQ(n.offsets.back(), nv);
  for (Index v = 0; v < nv; ++v) {
    EXPECT_GE(n.global[v], n.offsets[n.owner[v]]);
    EXPECT_LT(n.global[v], n.offsets[n.owner[v] + 1]);
  }
  std::vector<int> ownedBy(static_cast<std::size_t>(nc), -1);
  const obs::mesh::VertexCells around = obs::mesh::vertexCells(view.mesh);
  for (int k = 0; k < p.parts; ++k) {
    SCOPED_TRACE("part " + std::to_string(k));
    const obs::PartView pv = obs::partView(grid, view, p, n, k);
    for (Index c : pv.owned) {
      EXPECT_EQ(ownedBy[c], -1) << "cell " << c << " owned twice";
      ownedBy[c] = k;
    }
    // ghosts: exactly the cells of other parts that share a vertex with an owned cell
    std::set<Index> ownedVertexSet;
    for (Index c : pv.owned)
      for (Index v : view.mesh.cellVertices(c)) ownedVertexSet.insert(v);
    std::vector<Index> expected;
    for (Index c = 0; c < nc; ++c) {
      if (std::find(pv.owned.begin(), pv.owned.end(), c) != pv.owned.end()) continue;
      const auto vs = view.mesh.cellVertices(c);
      if (std::any_of(vs.begin(), vs.end(), [&](Index v) { return ownedVertexSet.count(v) != 0; })) expected.push_back(c);
    }
    EXPECT_EQ(pv.ghosts, expected);
    // the part holds every vertex of its cells, split by the owner of each
    std::set<Index> held(pv.ownedVertices.begin(), pv.ownedVertices.end());
    held.insert(pv.ghostVertices.begin(), pv.ghostVertices.end());
    for (const std::vector<Index>* cells : {&pv.owned, &pv.ghosts})
      for (Index c : *cells)
        for (Index v : view.mesh.cellVertices(c)) EXPECT_TRUE(held.count(v)) << "vertex " << v;
    for (Index v : pv.ownedVertices) EXPECT_EQ(n.owner[v], k);
    for (Index v : pv.ghostVertices) EXPECT_NE(n.owner[v], k);
    // a vertex is owned by the smallest part among its cells: a part owns no vertex of a cell of a smaller part
    for (Index v : pv.ownedVertices)
      for (Index c : around.cellsOf(v)) EXPECT_GE(p.partOf(view.elements[c]), k);
  }
  for (Index c = 0; c < nc; ++c) EXPECT_GE(ownedBy[c], 0) << "cell " << c << " owned by no part";
}

TEST(ForestPartition, EveryLeafOnceGhostLayersAndNumbering) {
  for (CellType type : {CellType::Quadrilateral, CellType::Triangle, CellType::Tetrahedron, CellType::Hexahedron}) {
    SCOPED_TRACE(std::string(obs::mesh::name(type)));
    const Grid grid = obs::mesh::dimension(type) == 2 ? uniform(type, 4, 3) : uniform(type, 2, 2);
    for (int parts : {1, 2, 3, 4}) {
      SCOPED_TRACE(std::to_string(parts) + " parts");
      const ForestPartition p = obs::partitionForest(grid, parts);
      Index leaves = 0;
      for (Index n : p.partLeaves) leaves += n;
      EXPECT_EQ(leaves, grid.numLeafElements());
      expectConsistent(grid, grid.leafView(), p);
      for (int l = p.level; l <= grid.maxLevel(); ++l) expectConsistent(grid, grid.levelView(l), p);
      if (parts == 1) {
        const GridView leaf = grid.leafView();
        const obs::ViewNumbering n = obs::numberView(grid, leaf, p);
        EXPECT_TRUE(obs::partView(grid, leaf, p, n, 0).ghosts.empty());
      }
    }
  }
}

TEST(ForestPartition, BalancesLeavesOnGradedGrids) {
  for (CellType type : {CellType::Triangle, CellType::Tetrahedron}) {
    SCOPED_TRACE(std::string(obs::mesh::name(type)));
    const Grid grid = graded(type);
    for (int parts : {2, 3, 4}) {
      SCOPED_TRACE(std::to_string(parts) + " parts");
      obs::ForestPartitionOptions o;
      o.cellsPerPart = 16;
      const ForestPartition p = obs::partitionForest(grid, parts, o);
      // balanced in leaves (METIS' default tolerance is 3 %; the partition cells are indivisible)
      Index biggest = *std::max_element(p.cellLeaves.begin(), p.cellLeaves.end()), total = 0;
      for (Index n : p.partLeaves) total += n;
      EXPECT_LE(p.imbalance(), 1.03 + static_cast<double>(biggest * parts) / static_cast<double>(total));
      expectConsistent(grid, grid.leafView(), p);
      // reproducible
      const ForestPartition q = obs::partitionForest(grid, parts, o);
      EXPECT_EQ(p.cellPart, q.cellPart);
    }
  }
}

TEST(ForestPartition, BadInputIsAnError) {
  const Grid grid = uniform(CellType::Quadrilateral, 2, 1);
  EXPECT_THROW(obs::partitionForest(grid, 0), obs::Error);
  obs::ForestPartitionOptions o;
  o.level = 0;
  EXPECT_THROW(obs::partitionForest(grid, 5, o), obs::Error);  // 4 partition cells for 5 parts
  o.level = 2;
  EXPECT_THROW(obs::partitionForest(grid, 2, o), obs::Error);  // no level 2
  o.level = 1;
  const ForestPartition p = obs::partitionForest(grid, 2, o);
  EXPECT_THROW(obs::numberView(grid, grid.levelView(0), p), obs::Error);  // replicated level
  Grid finer = grid;
  finer.refineUniformly();
  EXPECT_THROW(obs::numberView(finer, finer.leafView(), p), obs::Error);  // another grid state
}

}  // namespace
