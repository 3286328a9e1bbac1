#pragma once
/// \file ForestPartition.hpp
/// How a hierarchical grid is split over the ranks of a distributed run (docs/architecture.md#forest-partition).
/// These functions compute, in one process, what each rank holds; DistributedGrid.hpp builds it on
/// the ranks.
///
/// The coarse levels 0 .. L_p (the *partition level*) are replicated on every rank. The cells of the
/// level view L_p (its elements plus the leaves of coarser levels) are the *partition cells*; each
/// belongs to one part, and a part owns the whole refinement subtree of each of its partition cells.
/// METIS splits the face graph of the partition cells into parts balanced in the number of leaves
/// below each cell, so that the fine work is balanced, not the coarse cells.
///
/// On a view (the leaf view, or a level view of level >= L_p) a part holds
///   - its *owned* cells: those whose partition cell is its own;
///   - its *ghost* cells: the cells of other parts that share a vertex with an owned cell (one layer);
///   - the vertices of both. A vertex is owned by the smallest part among the cells containing it;
///     the global numbering numbers the vertices part by part (owner, then view vertex index), so
///     that each part's owned vertices are one contiguous range (offsets: prefix sums).
/// Everything depends on the grid and the number of parts only, not on any thread count.
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs {

using mesh::Index;

struct ForestPartitionOptions {
  /// The partition level L_p; -1: the coarsest level whose view has at least cellsPerPart x parts
  /// cells (or the finest level if none has).
  int level = -1;
  int cellsPerPart = 8;
  /// Balance the parts as if every leaf were refined uniformly (red) this many more times: each
  /// leaf weighs its red children count to this power (a distributed grid partitions before it
  /// refines, DistributedGrid.hpp). 0: the leaves as they are.
  int refinementsBelow = 0;
  /// The part of each partition cell (in the order of the level view's elements), if given: no
  /// METIS (a repartition, DistributedGrid::rebalance). Empty: METIS decides.
  std::vector<int> cellParts;
};

struct ForestPartition {
  int parts = 1;
  int level = 0;                ///< the partition level L_p
  std::vector<Index> cells;     ///< the partition cells (grid elements: the elements of levelView(level))
  std::vector<int> cellPart;    ///< the part of each
  std::vector<Index> cellLeaves;///< leaves below each (itself if it is a leaf)
  /// Per grid element: the index of its partition cell in `cells`, or -1 for an element of a
  /// replicated level that is not a partition cell (it belongs to every part).
  std::vector<Index> elementCell;
  std::vector<Index> partLeaves;  ///< leaves owned by each part

  /// Recomputes elementCell, cellLeaves and partLeaves for the grid's current state: the partition
  /// cells and their parts stay (the grid was refined below the partition level, or it is a rank's
  /// part of a distributed grid, whose leaves are only those it holds). Throws obs::Error if the
  /// grid does not have the partition cells.
  void follow(const mesh::Grid& grid);
  /// The part owning grid element e, -1 if e is replicated.
  int partOf(Index e) const { return elementCell[e] < 0 ? -1 : cellPart[elementCell[e]]; }
  /// max part leaves / mean part leaves (1: perfect balance).
  double imbalance() const;
};

/// Partitions the grid's refinement forest into `parts` (>= 1) parts. Throws obs::Error for
/// parts < 1, a level out of range, or fewer partition cells than parts.
ForestPartition partitionForest(const mesh::Grid& grid, int parts, const ForestPartitionOptions& options = {});

/// METIS' split of the face graph of the partition cells into partition.parts parts balanced in
/// `weights` (one per partition cell, or ncon per cell, cell-major, to balance ncon kinds of work
/// at once); the same on every process for the same input. Throws obs::Error for a weight count
/// that is not a multiple of the cell count or a grid without the partition cells.
std::vector<int> splitPartitionCells(const mesh::Grid& grid, const ForestPartition& partition,
                                     const std::vector<Index>& weights);

/// The global vertex numbering of a view: per view vertex its owner and its global index, and the
/// first global index of each part (parts + 1 entries).
struct ViewNumbering {
  std::vector<int> owner;
  std::vector<Index> global;
  std::vector<Index> offsets;
};

/// What one part holds of a view (view cell and vertex indices, ascending).
struct PartView {
  std::vector<Index> owned, ghosts;                ///< cells
  std::vector<Index> ownedVertices, ghostVertices;  ///< vertices of those cells: owned here / elsewhere
};

/// The numbering of `view` (the leaf view or a level view of level >= partition.level of the same
/// grid). Throws obs::Error for a view of a replicated level or of another grid state.
ViewNumbering numberView(const mesh::Grid& grid, const mesh::GridView& view, const ForestPartition& partition);

/// What part `part` holds of `view` (as numberView; `numbering` its result).
PartView partView(const mesh::Grid& grid, const mesh::GridView& view, const ForestPartition& partition,
                  const ViewNumbering& numbering, int part);

}  // namespace obs
