#pragma once
/// \file HaloExchange.hpp
/// The vertices one part holds of a partitioned view (ForestPartition.hpp), numbered locally, and
/// the exchange that gives its ghost vertices the values of their owners (docs/architecture.md#halo):
/// set up by one all-to-all of the ghosts' global indices, then one message per neighbouring part.
/// Local numbering: the part's owned vertices first, in ascending view order (so local index =
/// global index - numbering.offsets[part]), then its ghost vertices in ascending view order.
/// With `localMesh` (the part's owned and ghost cells on these vertices) a part assembles complete
/// rows for its owned vertices: every cell around an owned vertex is owned or a ghost.
#include <Eigen/Core>

#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ForestPartition.hpp"

namespace obs {

class HaloExchange {
public:
  /// For part `comm.rank()` of a view partitioned into `comm.size()` parts (numbering and the
  /// rank's PartView of that view). A collective call: every rank builds its own. Throws
  /// obs::Error if the sizes do not match.
  HaloExchange(const ViewNumbering& numbering, const PartView& part, const Communicator& comm);
  /// The halo of any distributed numbering whose parts own consecutive global indices: this rank
  /// owns `owned` vertices, global indices offset .. offset + owned - 1 (local 0 .. owned - 1), and
  /// holds the ghosts `ghostGlobal` (local owned, owned + 1, ...) owned by `ghostOwner`. The
  /// local numbering is its own view (viewVertices() is 0, 1, ...). Collective. Throws obs::Error
  /// on inconsistent sizes, an owner out of range or this rank, or a ghost its owner does not own.
  HaloExchange(Index owned, Index offset, const std::vector<Index>& ghostGlobal, const std::vector<int>& ghostOwner,
               const Communicator& comm);

  /// local -> view vertex (owned first, then ghosts)
  const std::vector<Index>& viewVertices() const { return vertices_; }
  Index numOwned() const { return owned_; }
  Index numLocal() const { return static_cast<Index>(vertices_.size()); }
  const Communicator& communicator() const { return comm_; }
  /// The local index of a view vertex, -1 if this part does not hold it.
  Index local(Index viewVertex) const;

  /// Overwrites the ghost entries of x (local numbering, `components` values per vertex) with the
  /// owners' values: one message to and from each neighbouring part only. Every rank must call it.
  void update(Eigen::VectorXd& x, int components = 1) const;
  /// update() from the parts `from` marks only (one entry per rank, the same on every rank): a
  /// marked part sends its shared values, and every part receives from its marked neighbours only.
  /// For values that only the marked parts changed since the ghosts were last current (as after
  /// one colour of DistributedSweep); the other ghosts keep their values. Every rank must call it.
  void update(Eigen::VectorXd& x, int components, const std::vector<char>& from) const;
  /// The reverse of update(): adds the ghost entries of x to their owners' entries (sums of
  /// contributions assembled on several parts, e.g. a restriction from owned fine rows) and sets
  /// the ghost entries to zero. Every rank must call it.
  void accumulate(Eigen::VectorXd& x, int components = 1) const;
  /// The owned vertices (local indices, ascending) that are ghosts of other parts.
  std::vector<Index> sharedOwned() const;
  /// The parts this part exchanges with, ascending (those it sends to or receives from).
  std::vector<int> neighbours() const;
  /// The parts this part exchanges with (messages per update: sends + receives).
  int sendNeighbours() const { return static_cast<int>(sendRanks_.size()); }
  int receiveNeighbours() const { return static_cast<int>(recvRanks_.size()); }
  /// Values this part sends and receives per update with one component (counters for scaling figures).
  Index sentValues() const;
  Index receivedValues() const { return numLocal() - numOwned(); }

private:
  /// The exchange lists from the ghosts' owners and global indices (one all-to-all).
  void connect(const std::vector<int>& ghostOwner, const std::vector<Index>& ghostGlobal, Index offset);
  void exchangeGhosts(Eigen::VectorXd& x, int components, const std::vector<char>* from) const;

  Communicator comm_;
  std::vector<Index> vertices_;
  Index owned_ = 0;
  std::vector<Index> localOf_;                 ///< view vertex -> local, -1
  std::vector<std::vector<Index>> sendOwned_;  ///< per rank: local owned vertices it needs from us
  std::vector<std::vector<Index>> recvGhost_;  ///< per rank: our local ghost vertices it fills, in its order
  std::vector<int> sendRanks_, recvRanks_;     ///< the ranks with a non-empty list above
};

/// The part's local mesh: its owned cells, then its ghost cells, on the local vertices of `halo`
/// (coordinates from the view), and the view's boundary faces whose vertices are all held (ids and
/// names kept). On a DistributedGrid's view these include faces of cells outside the part: in a
/// rank's conforming local grid every held vertex on a boundary lies on one of its faces, so the
/// Dirichlet and contact vertices of the local mesh are those of the whole mesh.
mesh::Mesh localMesh(const mesh::GridView& view, const PartView& part, const HaloExchange& halo);

}  // namespace obs
