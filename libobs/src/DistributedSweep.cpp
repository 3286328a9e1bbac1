#include "obs/obs/DistributedSweep.hpp"

#include <algorithm>

#include "obs/mesh/Error.hpp"

namespace obs {

DistributedSweep::DistributedSweep(std::span<const Index> rowStart, std::span<const Index> columns,
                                   const SweepOrder& order, const HaloExchange& halo)
    : halo_(&halo) {
  const Index n = static_cast<Index>(rowStart.size()) - 1, owned = halo.numOwned();
  if (n != halo.numLocal()) throw Error("distributed sweep: a matrix of " + std::to_string(n) + " rows for " +
                                        std::to_string(halo.numLocal()) + " local vertices");
  std::vector<char> inner(static_cast<std::size_t>(n), 0), outer(inner.size(), 0);
  for (Index p = 0; p < owned; ++p) {
    bool coupled = false;
    for (Index k = rowStart[p]; k < rowStart[p + 1]; ++k) coupled = coupled || columns[k] >= owned;
    (coupled ? outer : inner)[p] = 1;
    interfaceCount_ += coupled ? 1 : 0;
  }
  // the owned vertices that are ghosts elsewhere join the interface, so that the updates after the
  // colours carry their final values (sweeping them there keeps the order a valid Gauss-Seidel order)
  for (Index p : halo.sharedOwned())
    if (inner[p]) {
      inner[p] = 0;
      outer[p] = 1;
      ++interfaceCount_;
    }
  interior_ = order.subset(inner);
  interface_ = order.subset(outer);
  // greedy colouring of the ranks' neighbour graph, in rank order (every rank computes the same)
  const Communicator& comm = halo.communicator();
  const int ranks = comm.size();
  const std::vector<int> mine = halo.neighbours();
  std::vector<std::vector<double>> send(static_cast<std::size_t>(ranks), std::vector<double>(mine.begin(), mine.end()));
  const std::vector<std::vector<double>> graph = comm.exchange(send);
  std::vector<int> colour(static_cast<std::size_t>(ranks), -1);
  colours_ = 1;
  for (int r = 0; r < ranks; ++r) {
    std::vector<char> used(static_cast<std::size_t>(ranks) + 1, 0);
    for (double q : graph[r])
      if (colour[static_cast<std::size_t>(q)] >= 0) used[colour[static_cast<std::size_t>(q)]] = 1;
    int c = 0;
    while (used[c]) ++c;
    colour[r] = c;
    colours_ = std::max(colours_, c + 1);
  }
  colour_ = colour[comm.rank()];
  ofColour_.assign(static_cast<std::size_t>(colours_), std::vector<char>(static_cast<std::size_t>(ranks), 0));
  for (int r = 0; r < ranks; ++r) ofColour_[static_cast<std::size_t>(colour[r])][static_cast<std::size_t>(r)] = 1;
}

}  // namespace obs
