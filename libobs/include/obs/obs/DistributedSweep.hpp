#pragma once
/// \file DistributedSweep.hpp
/// The order of a Gauss-Seidel sweep over a distributed level (docs/architecture.md#distributed-sweep),
/// for the linear smoother of multigrid and the nonsmooth smoother of TNNMG alike.
///
/// A rank's owned vertices are *interface* vertices (coupled to a ghost, or a ghost of another
/// rank) or *interior* (the others: coupled only to owned vertices, held by no other rank). The ranks are coloured so that no two that exchange ghosts
/// share a colour (greedy in rank order on the graph of halo neighbours: the same on every rank).
/// A forward sweep is
///   1. every rank sweeps its interior (concurrently: interiors of different ranks are not coupled,
///      and within a rank the threads' SweepOrder restricted to the interior);
///   2. for each colour in turn, the ranks of that colour sweep their interface (ascending, or the
///      threads' order restricted to it), then every rank updates its ghosts (HaloExchange::update).
/// A ghost of one rank is an interface vertex of its owner, changed only in its owner's colour and
/// exchanged right after, so every vertex sees the current values of all its neighbours: the sweep
/// is a sequential Gauss-Seidel sweep in one global order (interiors, then the interfaces colour by
/// colour), with every property of the sequential sweep (energy decrease of the nonsmooth sweep),
/// and it leaves the ghosts current. A backward sweep is the exact reverse (colours in reverse
/// order, then the interiors). Messages per sweep: one halo update per colour.
#include <Eigen/Core>

#include <span>
#include <vector>

#include "obs/obs/Communicator.hpp"
#include "obs/obs/HaloExchange.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {

class DistributedSweep {
public:
  DistributedSweep() = default;
  /// For a level matrix of pattern (rowStart, columns) in the halo's local numbering (owned rows
  /// first; their columns complete), with `order` the matrix's own SweepOrder. Collective (the
  /// colouring). The halo is kept by pointer and must outlive the sweep.
  DistributedSweep(std::span<const Index> rowStart, std::span<const Index> columns, const SweepOrder& order,
                   const HaloExchange& halo);

  const SweepOrder& interior() const { return interior_; }
  const SweepOrder& interface() const { return interface_; }
  Index interfaceVertices() const { return interfaceCount_; }
  int colour() const { return colour_; }
  int colours() const { return colours_; }

  /// One sweep: sweep(order, backward) sweeps the vertices of `order` (SweepOrder::forward or
  /// backward) in x, whose ghosts (d components per vertex) must be current on entry. After each
  /// colour the ranks of that colour send their shared values, the only ones the colour changed
  /// (the interior holds no shared vertex), so the ghosts are current again at the end.
  template <class Sweep>
  void run(Sweep&& sweep, Eigen::VectorXd& x, int components, bool backward) const {
    if (!backward) sweep(interior_, false);
    for (int k = 0; k < colours_; ++k) {
      const int c = backward ? colours_ - 1 - k : k;
      if (c == colour_) sweep(interface_, backward);
      halo_->update(x, components, ofColour_[static_cast<std::size_t>(c)]);
    }
    if (backward) sweep(interior_, true);
  }

private:
  const HaloExchange* halo_ = nullptr;
  SweepOrder interior_, interface_;
  Index interfaceCount_ = 0;
  int colour_ = 0, colours_ = 1;
  std::vector<std::vector<char>> ofColour_;  ///< per colour: which ranks have it
};

}  // namespace obs
