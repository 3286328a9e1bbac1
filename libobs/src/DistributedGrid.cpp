#include "obs/obs/DistributedGrid.hpp"

#include <algorithm>
#include <limits>
#include <string>
#include <unordered_map>

#include "obs/mesh/Error.hpp"

namespace obs {
namespace {

std::uint64_t mix(std::uint64_t h) {  // splitmix64 finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}

constexpr std::uint64_t kHashed = std::uint64_t{1} << 63;  ///< keys of vertices below the replicated levels
constexpr std::uint64_t kUnknown = std::numeric_limits<std::uint64_t>::max();

/// The keys of the grid's vertices: index for the first `replicated` ones, else the hash of the
/// sorted keys of the corners that span the vertex's point in its creating element.
std::vector<std::uint64_t> computeVertexKeys(const mesh::Grid& grid, Index replicated) {
  const Index n = grid.numVertices();
  std::vector<std::uint64_t> keys(static_cast<std::size_t>(n));
  std::vector<std::uint64_t> corners;
  for (Index v = 0; v < n; ++v) {
    if (v < replicated) {
      keys[v] = static_cast<std::uint64_t>(v);
      continue;
    }
    const mesh::Grid::Origin origin = grid.vertexOrigin(v);
    if (origin.element < 0) throw Error("distributed grid: vertex " + std::to_string(v) + " has no origin");
    const mesh::LocalPoints& points = mesh::LocalPoints::of(grid.type(origin.element));
    const auto weights = points.weights(origin.point);
    const auto vs = grid.vertices(origin.element);
    corners.clear();
    for (std::size_t i = 0; i < weights.size(); ++i)
      if (weights[i] != 0) corners.push_back(keys[vs[i]]);
    std::sort(corners.begin(), corners.end());
    std::uint64_t h = mix(corners.size() + 0x9e3779b97f4a7c15ULL);
    for (std::uint64_t k : corners) h = mix(h ^ (k + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2)));
    keys[v] = h | kHashed;
  }
  return keys;
}

}  // namespace

DistributedGrid::DistributedGrid(mesh::Grid coarse, int refinements, const Communicator& comm,
                                 const ForestPartitionOptions& options)
    : grid_(std::move(coarse)), comm_(comm) {
  Index replicated = 0;
  long long owned = 0;
  comm.collective([&] {
    if (refinements < 0) throw Error("distributed grid: " + std::to_string(refinements) + " refinements");
    for (Index e : grid_.leafElements())
      if (grid_.isGreen(e))
        throw Error("distributed grid: the coarse grid has green (locally refined) leaves; only uniformly refined grids are distributed");
    const int parts = comm.size();
    // the replicated levels, up to the partition level
    int left = refinements;
    if (options.level >= 0) {
      if (options.level < grid_.maxLevel() || options.level > grid_.maxLevel() + refinements)
        throw Error("distributed grid: partition level " + std::to_string(options.level) + ", the grid will have levels " +
                    std::to_string(grid_.maxLevel()) + ".." + std::to_string(grid_.maxLevel() + refinements));
      for (; grid_.maxLevel() < options.level; --left) grid_.refineUniformly();
    } else {
      const auto wanted = static_cast<long long>(options.cellsPerPart) * parts;
      // at least level 1 (level 0 stays replicated: the coarse problem of multigrid)
      for (; left > 0 && (grid_.maxLevel() == 0 || grid_.numLeafElements() < wanted); --left) grid_.refineUniformly();
    }
    replicated = grid_.numVertices();
    ForestPartitionOptions po = options;
    po.level = grid_.maxLevel();
    po.refinementsBelow = left;
    partition_ = partitionForest(grid_, parts, po);

    // the remaining rounds: this part's leaves and the leaves sharing a vertex with one of them
    // refined red (the ghost layer of the next level lies in their children)
    const int me = comm.rank();
    std::vector<char> touched;
    for (; left > 0; --left) {
      const std::vector<Index> leaves = grid_.leafElements();
      touched.assign(static_cast<std::size_t>(grid_.numVertices()), 0);
      for (Index e : leaves)
        if (partition_.partOf(e) == me)
          for (Index v : grid_.vertices(e)) touched[v] = 1;
      for (Index e : leaves) {
        const auto vs = grid_.vertices(e);
        if (std::any_of(vs.begin(), vs.end(), [&](Index v) { return touched[v] != 0; })) grid_.mark(e);
      }
      grid_.adapt();
      partition_.follow(grid_);
    }
    keys_ = computeVertexKeys(grid_, replicated);
    for (Index e : grid_.leafElements())
      if (partition_.partOf(e) == me) ++owned;
  });
  globalLeaves_ = comm.sum(owned);
}

DistributedView DistributedGrid::view(int level) const {
  if (level < -1 || level > maxLevel() || (level >= 0 && level < partition_.level))
    throw Error("distributed grid: no distributed view of level " + std::to_string(level) + " (levels " +
                std::to_string(partition_.level) + ".." + std::to_string(maxLevel()) + " and the leaf view -1)");
  const int me = comm_.rank(), ranks = comm_.size();
  mesh::GridView v = level < 0 ? grid_.leafView() : grid_.levelView(level);
  ViewNumbering numbering;
  PartView part;
  comm_.collective([&] {
    numbering = numberView(grid_, v, partition_);
    part = partView(grid_, v, partition_, numbering, me);
  });
  // offsets from the parts' owned counts; owned vertices numbered in ascending view order
  const std::vector<long long> counts = comm_.allGather(static_cast<long long>(part.ownedVertices.size()));
  numbering.offsets.assign(static_cast<std::size_t>(ranks) + 1, 0);
  for (int r = 0; r < ranks; ++r) {
    const long long next = static_cast<long long>(numbering.offsets[r]) + counts[r];
    if (next > std::numeric_limits<Index>::max()) throw Error("distributed grid: more vertices than 32-bit indices hold");
    numbering.offsets[r + 1] = static_cast<Index>(next);
  }
  std::fill(numbering.global.begin(), numbering.global.end(), -1);
  for (std::size_t i = 0; i < part.ownedVertices.size(); ++i)
    numbering.global[part.ownedVertices[i]] = numbering.offsets[me] + static_cast<Index>(i);
  // the ghosts' global indices from their owners, asked by key
  std::vector<std::vector<std::uint64_t>> ask(static_cast<std::size_t>(ranks));
  for (Index g : part.ghostVertices) ask[numbering.owner[g]].push_back(keys_[v.vertices[g]]);
  const std::vector<std::vector<std::uint64_t>> asked = comm_.exchange(ask);
  std::unordered_map<std::uint64_t, Index> ownedByKey;
  ownedByKey.reserve(part.ownedVertices.size());
  bool collision = false;
  for (Index o : part.ownedVertices)
    collision |= !ownedByKey.emplace(keys_[v.vertices[o]], numbering.global[o]).second;
  std::vector<std::vector<std::uint64_t>> answer(static_cast<std::size_t>(ranks));
  for (int r = 0; r < ranks; ++r)
    for (std::uint64_t key : asked[r]) {
      const auto it = ownedByKey.find(key);
      answer[r].push_back(it == ownedByKey.end() ? kUnknown : static_cast<std::uint64_t>(it->second));
    }
  const std::vector<std::vector<std::uint64_t>> answers = comm_.exchange(answer);
  comm_.collective([&] {
    if (collision) throw Error("distributed grid: two owned vertices with the same key");
    std::vector<std::size_t> next(static_cast<std::size_t>(ranks), 0);
    for (Index g : part.ghostVertices) {
      const int o = numbering.owner[g];
      const std::uint64_t global = answers[o][next[o]++];
      if (global == kUnknown)
        throw Error("distributed grid: rank " + std::to_string(o) + " does not own ghost vertex " + std::to_string(g) +
                    " of rank " + std::to_string(me));
      numbering.global[g] = static_cast<Index>(global);
    }
  });
  HaloExchange halo(numbering, part, comm_);
  mesh::Mesh local = localMesh(v, part, halo);
  return DistributedView{std::move(v), std::move(numbering), std::move(part), std::move(halo), std::move(local)};
}

}  // namespace obs
