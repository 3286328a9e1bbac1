#pragma once
/// \file DistributedGrid.hpp
/// A hierarchical grid distributed over the ranks of a run (docs/architecture.md#distributed-grid):
/// no rank refines, or holds, the whole fine grid.
///
/// Construction (collective). Every rank starts from the same coarse grid and refines it uniformly,
/// all of it, up to the partition level L_p (the coarsest level from 1 on with cellsPerPart x ranks
/// cells, or the level asked for): these levels are replicated. Level 0 is always among them: it
/// is the coarse problem of multigrid, solved directly on every rank (MultigridHierarchy). Then every rank
/// computes the same ForestPartition of the level-L_p cells (METIS, weighted by the leaves the
/// remaining refinements will give them) and refines red, in each remaining round, only its own
/// leaves and the leaves that share a vertex with one of them. The grid's closure grades the
/// refinement outside that region (green closures, rule 1 of Grid.hpp). Every cell of level l that
/// shares a vertex with an owned cell of level l is then a red child of a cell refined in round l
/// (its parent shares a point, hence a corner, with the owned cell's parent), so a rank's owned
/// cells and their one-layer ghosts on the leaf view and on every level view >= L_p are exactly the
/// cells the serial partition (partView) gives this part. The marked region is the own one plus two
/// fine layers; the closure's rules (1-irregularity, more than half of the edges refined) refine
/// some cells beyond it red as well, then grade the refinement down.
///
/// Vertices across ranks. A vertex has a *key*, the same on every rank that holds it: the grid
/// vertex index for vertices of the replicated levels (created in the same order everywhere), and
/// for later ones a hash of the keys of the corners of the entity it is the centre of (an edge
/// midpoint: its two end points; a face or cell centre: its corners). A vertex is owned by the
/// smallest part among the cells containing it (as in numberView); in a rank's local grid, which is
/// conforming and covers the domain, these are the cells of the partition cells whose closure
/// contains the vertex, so every rank computes the same owner for every vertex it holds. Global
/// indices: each part numbers its owned vertices in ascending local view order from its offset
/// (the prefix sums of the parts' counts); a ghost vertex gets its index from its owner, asked by
/// key (one all-to-all).
///
/// Adaptive refinement (adapt()). Every rank marks leaves it owns; the grid must then be what one
/// process gets when it marks the union of the marks on the whole grid and calls Grid::adapt(), as
/// far as a rank's owned cells and their ghost layer go. The closure's rules look one cell around
/// an element (an element is refined red because of the red refinement of elements that share part
/// of an edge or face with it, hence a corner point), so they are run to agreement:
///   - a rank's *region* is the regular elements (leaves that are not green, fathers of green
///     leaves) over its owned leaves and three leaf layers around them (leaves sharing a vertex
///     with the previous layer); a rank holds the serial refinement tree exactly on the first
///     layers (the invariant kept by every adapt(), below);
///   - each round, every rank computes the closure of what it knows to be refined red
///     (Grid::redClosure: its own marks and what it was told) and reports the elements of its region
///     that are newly red, by *cell key* (the level and the keys of the corners), to the rank
///     key mod P, which tells every rank whose region has that key; the rounds end when no rank
///     reports anything new. The closure of a rank's local grid, which is coarser than the serial
///     grid away from its region, refines a subset of what the serial closure refines (the rules
///     are monotone), so every report is a serial decision; an element's owner holds all elements
///     around it, so every serial decision in a region is reached by a chain of owners;
///   - then one Grid::adapt() refines what is known; a region's new leaves are red children of
///     exactly refined elements, or leaves of its regular elements closed green by their exact edge
///     patterns, so the next region is exact again. The green closures' ties depend on positions
///     only (Grid.hpp), not on the local vertex numbers.
///
/// Load balancing (rebalance()). Refinement below the partition cells never moves a cell between
/// parts, so adaptive refinement unbalances the parts. rebalance() weighs each partition cell by the
/// leaves below it (the sum over the ranks of the owners' counts), and if the largest part's leaves
/// exceed the mean by more than a tolerance, METIS splits the partition cells anew in these
/// weights. Every rank then rebuilds its grid for its new part: the construction above with the new
/// parts, then the adapt() steps so far replayed. Each rank records the leaves it marked in every
/// step by (partition cell, cell key); a replay sends them to the partition cell's new owner, which
/// finds them among its leaves by key (they are leaves of its exact region at that step). Because
/// adapt() gives one process's grid for any partition, the rebuilt grid is the same grid, on new
/// parts. Vertex data (a warm start) moves by vertex key through rendezvous ranks. The cost is one
/// construction and all adapt() steps again; METIS' new split does not try to keep cells in place,
/// since nothing migrates but the marks.
///
/// Input: uniformly refined grids (scenes' `refine = k`) from any coarse mesh the serial grid
/// accepts; on more than one rank the replicated grid must have no green leaves. Boundary
/// projections set on the grid apply in every rank's refinement.
///
/// A communicator of one (docs/architecture.md#one-path) is the serial grid: the coarse grid is
/// refined uniformly as one process refines it (Grid::refineUniformly; any grid, green leaves and
/// no refinement included), one part owns every cell at the partition level ranks would choose,
/// a view's numbering is the view's own (no ghosts) and its local mesh the view's mesh, so code
/// written for the ranks computes on one process what the serial code computes. The solvers built
/// on it (MultigridHierarchy, LinearMultigrid, TNNMG) are the serial ones on grid().
#include <cstdint>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ForestPartition.hpp"
#include "obs/obs/HaloExchange.hpp"

namespace obs {

/// A view (leaf view or a level view >= the partition level) of a distributed grid on one rank.
struct DistributedView {
  mesh::GridView view;      ///< of the rank's local grid (it also has cells outside its part and ghosts)
  /// owner: of every view vertex; global: of the vertices this rank holds (owned and ghost), -1 for
  /// the others; offsets: the first global index of each part (ranks + 1 entries).
  ViewNumbering numbering;
  PartView part;            ///< this rank's owned and ghost cells and vertices (view indices)
  HaloExchange halo;        ///< local numbering (owned first) and the ghost exchange
  mesh::Mesh local;         ///< the owned cells, then the ghost cells, on the local vertices
  Index globalVertices() const { return numbering.offsets.back(); }
};

/// What rebalance() found and did.
struct RebalanceReport {
  double before = 1.0;  ///< owned leaves of the largest part over the mean, before
  double after = 1.0;   ///< and after (before, if nothing moved)
  bool moved = false;   ///< the grid was rebuilt on new parts
  int replayedSteps = 0;
  long long movedLeaves = 0;  ///< leaves whose partition cell changed its part
  /// With a balanced boundary (DistributedGrid::setBalancedBoundary): the faces with its id of the
  /// owned leaves of the largest part over the mean, before and after (1 without)
  double boundaryBefore = 1.0, boundaryAfter = 1.0;
};

class DistributedGrid {
public:
  /// Collective (see the file comment): `coarse` the same on every rank, refined `refinements`
  /// times in all. Throws obs::Error (on every rank) for negative refinements, a partition level
  /// outside the grid's levels, and on more than one rank for a coarse grid with green leaves or
  /// fewer partition cells than ranks after all refinements.
  DistributedGrid(mesh::Grid coarse, int refinements, const Communicator& comm,
                  const ForestPartitionOptions& options = {});

  /// This rank's grid: the replicated levels, its own subtrees with two fine layers around them, what
  /// the closure refines beyond, and the graded closure.
  const mesh::Grid& grid() const { return grid_; }
  const ForestPartition& partition() const { return partition_; }
  const Communicator& communicator() const { return comm_; }
  /// The finest level over all ranks (a rank's own grid may stop below it after adapt(): its
  /// level views beyond its own finest level are its leaf view).
  int maxLevel() const { return maxLevel_; }
  /// Per vertex of grid(): its key (see the file comment).
  const std::vector<std::uint64_t>& vertexKeys() const { return keys_; }
  /// Leaves of the uniformly refined grid (the sum over the parts; what one process would hold).
  long long globalLeaves() const { return globalLeaves_; }

  /// Refines the leaves `marked` (elements of grid() that are leaves owned by this rank; the other
  /// ranks pass theirs) and what the closure adds, as one process refining the whole grid with all
  /// ranks' marks would on this rank's owned cells and ghost layers (see the file comment); the
  /// partition cells and their parts do not change. Collective. Returns what one process's adapt()
  /// would report: marked, redRefined, propagated and greenClosed summed over the owned elements
  /// of all ranks (firstNewElement, firstNewVertex and invertedElements are the local grid's), and
  /// the number of closure rounds in `rounds` (if given). Throws obs::Error (on every rank) for an
  /// element that is not an owned leaf.
  mesh::AdaptResult adapt(const std::vector<Index>& marked, int* rounds = nullptr);
  /// Rule 2 of the closure (Grid::setClosureRule) for later adapt() calls; the same on every rank.
  void setClosureRule(mesh::ClosureRule rule) { grid_.setClosureRule(rule); }
  /// A key of a grid element, the same on every rank that holds it: a hash of its level and the
  /// keys of its corners.
  std::uint64_t cellKey(Index element) const;

  /// The leaf view (level -1) or level view `level` (partition level <= level <= maxLevel()),
  /// numbered and with its halo. Collective. Throws obs::Error for a level out of range.
  DistributedView view(int level = -1) const;

  /// Load balancing (see the file comment). Collective. If the leaves of the largest part exceed
  /// the mean by more than the factor `tolerance` (>= 1) and METIS' split of the partition cells
  /// in their leaves is better balanced, rebuilds this rank's grid for its new part. `leafValues`
  /// (if given): `width` numbers per vertex of the leaf view of grid() (leafView() order), read at
  /// the vertices of the owned leaves; on return, the same numbers per vertex of the new leaf
  /// view, at the vertices of every part's owned leaves (0 at the others). Throws obs::Error (on
  /// every rank) for a tolerance below 1 or values of the wrong size.
  RebalanceReport rebalance(double tolerance, std::vector<double>* leafValues = nullptr, int width = 1);
  /// The boundary faces with this id (e.g. the contact boundary, whose nodes cost more work) as a
  /// second weight of rebalance(): the partition cells are then split by METIS balancing the leaves
  /// and these faces at once (multi-constraint), and the parts move if either imbalance exceeds the
  /// tolerance and the split lowers the larger of the two. -1 (default): the leaves alone.
  void setBalancedBoundary(int id) { balancedBoundary_ = id; }
  int balancedBoundary() const { return balancedBoundary_; }

private:
  /// The construction (see the file comment) on the parts `partition` gives (METIS if it has none).
  void build(int refinements, const ForestPartitionOptions& partition);
  /// build() on a communicator of one (see the file comment).
  void buildSerial(int refinements, const ForestPartitionOptions& partition);

  /// The marks of one adapt() of this rank: the closure rule, and (partition cell, cell key) of
  /// each marked leaf.
  struct MarkedStep {
    mesh::ClosureRule rule;
    std::vector<std::pair<Index, std::uint64_t>> marks;
  };

  mesh::Grid initial_;  ///< the coarse grid, for rebuilds
  int refinements_ = 0;
  ForestPartitionOptions options_;
  std::vector<MarkedStep> history_;
  mesh::Grid grid_;
  ForestPartition partition_;
  Communicator comm_;
  std::vector<std::uint64_t> keys_;
  Index replicated_ = 0;
  int maxLevel_ = 0;  ///< vertices of the replicated levels (keyed by index)
  long long globalLeaves_ = 0;
  int balancedBoundary_ = -1;  ///< setBalancedBoundary
};

}  // namespace obs
