#include "obs/obs/DistributedGrid.hpp"

#include <algorithm>
#include <limits>
#include <optional>
#include <string>
#include <unordered_map>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {
namespace {

std::uint64_t mix(std::uint64_t h) {  // splitmix64 finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}

/// The rank that collects what the ranks know about `key` (cell and vertex keys).
int rendezvousRank(std::uint64_t key, int ranks) { return static_cast<int>(key % static_cast<std::uint64_t>(ranks)); }

constexpr std::uint64_t kHashed = std::uint64_t{1} << 63;  ///< keys of vertices below the replicated levels
constexpr std::uint64_t kUnknown = std::numeric_limits<std::uint64_t>::max();

std::uint64_t hashKeys(std::uint64_t seed, std::vector<std::uint64_t>& keys) {
  std::sort(keys.begin(), keys.end());
  std::uint64_t h = mix(seed + 0x9e3779b97f4a7c15ULL);
  for (std::uint64_t k : keys) h = mix(h ^ (k + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2)));
  return h;
}

/// Extends `keys` to the grid's vertices: the index for the first `replicated` ones, else the hash
/// of the sorted keys of the corners that span the vertex's point in its creating element (the
/// same entity, hence key, whichever element created it).
void extendVertexKeys(const mesh::Grid& grid, Index replicated, std::vector<std::uint64_t>& keys) {
  const Index n = grid.numVertices();
  std::vector<std::uint64_t> corners;
  for (auto v = static_cast<Index>(keys.size()); v < n; ++v) {
    if (v < replicated) {
      keys.push_back(static_cast<std::uint64_t>(v));
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
    keys.push_back(hashKeys(corners.size(), corners) | kHashed);
  }
}

}  // namespace

DistributedGrid::DistributedGrid(mesh::Grid coarse, int refinements, const Communicator& comm,
                                 const ForestPartitionOptions& options)
    : initial_(std::move(coarse)), refinements_(refinements), options_(options), grid_(initial_), comm_(comm) {
  build(refinements, options);
}

void DistributedGrid::build(int refinements, const ForestPartitionOptions& options) {
  const Communicator& comm = comm_;
  long long owned = 0;
  comm.collective([&] {
    grid_ = initial_;
    keys_.clear();
    if (refinements < 0) throw Error("distributed grid: " + std::to_string(refinements) + " refinements");
    const int parts = comm.size();
    if (parts == 1) {  // a communicator of one: the serial grid (docs/architecture.md#one-path)
      buildSerial(refinements, options);
      owned = grid_.numLeafElements();
      return;
    }
    for (Index e : grid_.leafElements())
      if (grid_.isGreen(e))
        throw Error("distributed grid: the coarse grid has green (locally refined) leaves; only uniformly refined grids are distributed");
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
    replicated_ = grid_.numVertices();
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
    extendVertexKeys(grid_, replicated_, keys_);
    for (Index e : grid_.leafElements())
      if (partition_.partOf(e) == me) ++owned;
  });
  globalLeaves_ = comm.sum(owned);
  maxLevel_ = grid_.maxLevel();  // the same on every rank after uniform rounds
}

void DistributedGrid::buildSerial(int refinements, const ForestPartitionOptions& options) {
  // one part: the grid refined uniformly as one process refines it (any grid: green leaves and no
  // refinement included), partitioned at the partition level ranks would choose for it
  const int top = grid_.maxLevel() + refinements;
  if (options.level >= 0 && (options.level < grid_.maxLevel() || options.level > top))
    throw Error("distributed grid: partition level " + std::to_string(options.level) + ", the grid will have levels " +
                std::to_string(grid_.maxLevel()) + ".." + std::to_string(top));
  // the partition level ranks would choose: the coarsest level from 1 on with cellsPerPart leaves
  // (or the finest), found while refining; the vertices up to it are keyed by index, as on ranks
  ForestPartitionOptions po = options;
  replicated_ = -1;
  for (int k = 0;; ++k) {
    if (po.level < 0 && (k == refinements || (grid_.maxLevel() >= 1 && grid_.numLeafElements() >= po.cellsPerPart)))
      po.level = grid_.maxLevel();
    if (replicated_ < 0 && po.level == grid_.maxLevel()) replicated_ = grid_.numVertices();
    if (k == refinements) break;
    grid_.refineUniformly(threads());
  }
  po.refinementsBelow = 0;
  po.cellParts.clear();
  partition_ = partitionForest(grid_, 1, po);
  extendVertexKeys(grid_, replicated_, keys_);
  maxLevel_ = grid_.maxLevel();
}

DistributedView DistributedGrid::view(int level) const {
  if (level < -1 || level > maxLevel() || (level >= 0 && level < partition_.level))
    throw Error("distributed grid: no distributed view of level " + std::to_string(level) + " (levels " +
                std::to_string(partition_.level) + ".." + std::to_string(maxLevel()) + " and the leaf view -1)");
  const int me = comm_.rank(), ranks = comm_.size();
  mesh::GridView v = level < 0 || level >= grid_.maxLevel() ? grid_.leafView() : grid_.levelView(level);
  v.level = level;
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
  // (one rank: every cell owned, the numbering the view's own, so the local mesh is the view's mesh)
  mesh::Mesh local = ranks == 1 ? v.mesh : localMesh(v, part, halo);
  return DistributedView{std::move(v), std::move(numbering), std::move(part), std::move(halo), std::move(local)};
}

}  // namespace obs

namespace obs {

std::uint64_t DistributedGrid::cellKey(Index element) const {
  std::vector<std::uint64_t> corners;
  for (Index v : grid_.vertices(element)) corners.push_back(keys_[v]);
  return hashKeys(static_cast<std::uint64_t>(grid_.level(element)) << 8 | corners.size(), corners);
}

mesh::AdaptResult DistributedGrid::adapt(const std::vector<Index>& marked, int* rounds) {
  const int me = comm_.rank(), ranks = comm_.size();
  const auto rendezvous = [ranks](std::uint64_t key) { return rendezvousRank(key, ranks); };
  // the region: the regular elements over the owned leaves and three leaf layers around them
  std::vector<Index> region;
  std::vector<char> inRegion, known;
  std::unordered_map<std::uint64_t, Index> byKey;
  comm_.collective([&] {
    const Index ne = grid_.numElements();
    for (Index e : marked)
      if (e < 0 || e >= ne || !grid_.isLeaf(e) || partition_.partOf(e) != me)
        throw Error("distributed grid: rank " + std::to_string(me) + " marks element " + std::to_string(e) +
                    ", which is not a leaf it owns");
    const std::vector<Index> leaves = grid_.leafElements();
    std::vector<char> layer(leaves.size(), 0), near(static_cast<std::size_t>(grid_.numVertices()), 0);
    for (std::size_t i = 0; i < leaves.size(); ++i)
      if (partition_.partOf(leaves[i]) == me) layer[i] = 1;
    for (int pass = 0; pass < 3; ++pass) {
      for (std::size_t i = 0; i < leaves.size(); ++i)
        if (layer[i])
          for (Index v : grid_.vertices(leaves[i])) near[v] = 1;
      for (std::size_t i = 0; i < leaves.size(); ++i)
        if (!layer[i]) {
          const auto vs = grid_.vertices(leaves[i]);
          layer[i] = std::any_of(vs.begin(), vs.end(), [&](Index v) { return near[v] != 0; });
        }
    }
    inRegion.assign(static_cast<std::size_t>(ne), 0);
    for (std::size_t i = 0; i < leaves.size(); ++i)
      if (layer[i]) {
        const Index r = grid_.isGreen(leaves[i]) ? grid_.father(leaves[i]) : leaves[i];
        if (!inRegion[r]) {
          inRegion[r] = 1;
          region.push_back(r);
        }
      }
    byKey.reserve(region.size());
    for (Index r : region)
      if (!byKey.emplace(cellKey(r), r).second) throw Error("distributed grid: two elements with the same cell key");
    known.assign(static_cast<std::size_t>(ne), 0);
    for (Index e : marked) known[grid_.isGreen(e) ? grid_.father(e) : e] = 1;
    MarkedStep step{grid_.closureRule(), {}};
    step.marks.reserve(marked.size());
    for (Index e : marked) step.marks.emplace_back(partition_.elementCell[e], cellKey(e));
    history_.push_back(std::move(step));
  });
  // every rank registers its region's keys at their rendezvous ranks, which remember the holders
  std::unordered_map<std::uint64_t, std::vector<int>> holders;
  {
    std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(ranks));
    for (const auto& [key, element] : byKey) send[rendezvous(key)].push_back(key);
    const std::vector<std::vector<std::uint64_t>> got = comm_.exchange(send);
    for (int r = 0; r < ranks; ++r)
      for (std::uint64_t key : got[r]) holders[key].push_back(r);
  }
  // rounds: the closure of what is known; its new red elements of the region reported; the
  // rendezvous ranks pass first reports on to every holder
  std::vector<char> reported(known.size(), 0);
  std::unordered_map<std::uint64_t, char> heard;  // at a rendezvous rank: keys reported red
  int round = 0;
  auto markKnown = [&] {
    grid_.clearMarks();
    for (Index r : region)
      if (known[r]) grid_.mark(grid_.refinement(r) == mesh::Refinement::Green ? grid_.child(r, 0) : r);
    for (Index e : marked) grid_.mark(e);
  };
  for (;; ++round) {
    std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(ranks));
    long long fresh = 0;
    comm_.collective([&] {
      markKnown();
      for (Index r : grid_.redClosure())
        if (inRegion[r] && !reported[r]) {
          reported[r] = 1;
          const std::uint64_t key = cellKey(r);
          send[rendezvous(key)].push_back(key);
          ++fresh;
        }
    });
    if (comm_.sum(fresh) == 0) break;
    const std::vector<std::vector<std::uint64_t>> got = comm_.exchange(send);
    std::vector<std::vector<std::uint64_t>> tell(static_cast<std::size_t>(ranks));
    for (int r = 0; r < ranks; ++r)
      for (std::uint64_t key : got[r])
        if (heard.emplace(key, 1).second)
          for (int h : holders[key]) tell[h].push_back(key);
    const std::vector<std::vector<std::uint64_t>> told = comm_.exchange(tell);
    for (int r = 0; r < ranks; ++r)
      for (std::uint64_t key : told[r]) {
        const Index e = byKey.at(key);
        known[e] = 1;
        reported[e] = 1;
      }
  }
  if (rounds) *rounds = round;
  // the refinement, and its figures over the owned elements (what one process's adapt() reports)
  mesh::AdaptResult result;
  std::vector<double> counts(5, 0.0);  // marked, red, of these marked targets, green closed, leaves
  comm_.collective([&] {
    markKnown();
    std::vector<char> target(known.size(), 0);
    for (Index e : marked) target[grid_.isGreen(e) ? grid_.father(e) : e] = 1;
    for (Index e : grid_.redClosure())
      if (partition_.partOf(e) == me) {
        counts[1] += 1;
        counts[2] += target[e];
      }
    result = grid_.adapt();
    partition_.follow(grid_);
    extendVertexKeys(grid_, replicated_, keys_);
    std::vector<char> closed(static_cast<std::size_t>(result.firstNewElement), 0);
    for (Index x = result.firstNewElement; x < grid_.numElements(); ++x)
      if (grid_.isGreen(x) && !grid_.isRemoved(x)) {
        const Index f = grid_.father(x);
        if (f < result.firstNewElement && !closed[f] && partition_.partOf(f) == me) {
          closed[f] = 1;
          counts[3] += 1;
        } else if (f >= result.firstNewElement && grid_.child(f, 0) == x && partition_.partOf(f) == me) {
          counts[3] += 1;  // a red child closed green in the same adapt (its first green child)
        }
      }
    for (Index e : grid_.leafElements())
      if (partition_.partOf(e) == me) counts[4] += 1;
  });
  counts[0] = static_cast<double>(marked.size());
  comm_.sum(counts);
  result.marked = static_cast<Index>(counts[0]);
  result.redRefined = static_cast<Index>(counts[1]);
  result.propagated = static_cast<Index>(counts[1] - counts[2]);
  result.greenClosed = static_cast<Index>(counts[3]);
  globalLeaves_ = static_cast<long long>(counts[4]);
  maxLevel_ = static_cast<int>(comm_.max(static_cast<double>(grid_.maxLevel())));
  return result;
}

RebalanceReport DistributedGrid::rebalance(double tolerance, std::vector<double>* leafValues, int width) {
  const int me = comm_.rank(), ranks = comm_.size();
  const std::size_t nc = partition_.cells.size();
  RebalanceReport report;
  // the leaves below each partition cell, from its owner (and, with a balanced boundary, the
  // faces of the owned leaves on it: the weights of the second kind, after the leaves)
  const bool second = balancedBoundary_ >= 0;
  std::vector<double> weights(second ? 2 * nc : nc, 0.0);
  std::optional<mesh::GridView> leaf;  // of the current grid, if values move
  comm_.collective([&] {
    if (!(tolerance >= 1.0)) throw Error("distributed grid: imbalance tolerance " + std::to_string(tolerance) + " (at least 1)");
    if (leafValues) leaf = grid_.leafView();
    if (leafValues && (width < 1 || leafValues->size() != leaf->vertices.size() * static_cast<std::size_t>(width)))
      throw Error("distributed grid: rebalance needs " + std::to_string(width) + " values per leaf view vertex");
    for (std::size_t c = 0; c < nc; ++c)
      if (partition_.cellPart[c] == me) weights[c] = static_cast<double>(partition_.cellLeaves[c]);
    if (second)
      for (Index e = 0; e < grid_.numElements(); ++e) {
        if (grid_.isRemoved(e) || !grid_.isLeaf(e) || partition_.partOf(e) != me) continue;
        const auto faces = static_cast<int>(mesh::localFaces(grid_.type(e)).size());
        for (int f = 0; f < faces; ++f)
          if (grid_.boundaryId(e, f) == balancedBoundary_) weights[nc + static_cast<std::size_t>(partition_.elementCell[e])] += 1;
      }
  });
  comm_.sum(weights);
  const auto imbalanceOf = [&](const std::vector<int>& parts, std::size_t kind) {
    std::vector<double> load(static_cast<std::size_t>(ranks), 0.0);
    double total = 0;
    for (std::size_t c = 0; c < nc; ++c) {
      load[parts[c]] += weights[kind * nc + c];
      total += weights[kind * nc + c];
    }
    return total > 0 ? *std::max_element(load.begin(), load.end()) * ranks / total : 1.0;
  };
  report.before = report.after = imbalanceOf(partition_.cellPart, 0);
  if (second) report.boundaryBefore = report.boundaryAfter = imbalanceOf(partition_.cellPart, 1);
  const double worst = std::max(report.before, report.boundaryBefore);
  if (ranks == 1 || worst <= tolerance) return report;
  // a boundary without faces in the grid is no constraint (METIS needs a positive total per kind)
  const std::size_t kinds = second && std::any_of(weights.begin() + static_cast<std::ptrdiff_t>(nc), weights.end(),
                                                  [](double w) { return w > 0; }) ? 2 : 1;
  std::vector<int> parts;
  comm_.collective([&] {  // the same input on every rank, hence the same split
    std::vector<Index> w(kinds * nc);
    for (std::size_t c = 0; c < nc; ++c)  // cell-major: the leaves, then the boundary faces
      for (std::size_t k = 0; k < kinds; ++k) w[c * kinds + k] = static_cast<Index>(weights[k * nc + c]);
    parts = splitPartitionCells(grid_, partition_, w);
  });
  const double after = imbalanceOf(parts, 0), boundaryAfter = second ? imbalanceOf(parts, 1) : 1.0;
  if (std::max(after, boundaryAfter) >= worst) return report;  // METIS found no better split in these cells
  report.after = after;
  report.boundaryAfter = boundaryAfter;
  report.moved = true;
  for (std::size_t c = 0; c < nc; ++c)
    if (parts[c] != partition_.cellPart[c]) report.movedLeaves += static_cast<long long>(weights[c]);
  const auto rendezvous = [ranks](std::uint64_t key) { return rendezvousRank(key, ranks); };

  // the values at the vertices of the owned leaves to the rendezvous ranks of their keys
  std::vector<std::vector<std::uint64_t>> keysOut(static_cast<std::size_t>(ranks));
  std::vector<std::vector<double>> valuesOut(static_cast<std::size_t>(ranks));
  // the marks of every step to the new owners of their partition cells: (step, cell, key)
  std::vector<std::vector<std::uint64_t>> marksOut(static_cast<std::size_t>(ranks));
  comm_.collective([&] {
    if (leafValues) {
      std::vector<Index> at(static_cast<std::size_t>(grid_.numVertices()), -1);
      for (std::size_t i = 0; i < leaf->vertices.size(); ++i) at[leaf->vertices[i]] = static_cast<Index>(i);
      std::vector<char> sent(leaf->vertices.size(), 0);
      for (Index e : leaf->elements)
        if (partition_.partOf(e) == me)
          for (Index v : grid_.vertices(e))
            if (const Index i = at[v]; !sent[i]) {
              sent[i] = 1;
              const int r = rendezvous(keys_[v]);
              keysOut[r].push_back(keys_[v]);
              for (int c = 0; c < width; ++c) valuesOut[r].push_back((*leafValues)[static_cast<std::size_t>(i) * width + c]);
            }
    }
    for (std::size_t s = 0; s < history_.size(); ++s)
      for (const auto& [cell, key] : history_[s].marks) {
        auto& out = marksOut[parts[cell]];
        out.insert(out.end(), {static_cast<std::uint64_t>(s), static_cast<std::uint64_t>(cell), key});
      }
  });
  std::unordered_map<std::uint64_t, std::vector<double>> stored;  // at a rendezvous rank (first sender wins)
  if (leafValues) {
    const auto keysIn = comm_.exchange(keysOut);
    const auto valuesIn = comm_.exchange(valuesOut);
    for (int r = 0; r < ranks; ++r)
      for (std::size_t i = 0; i < keysIn[r].size(); ++i)
        stored.emplace(keysIn[r][i], std::vector<double>(valuesIn[r].begin() + static_cast<std::ptrdiff_t>(i * width),
                                                          valuesIn[r].begin() + static_cast<std::ptrdiff_t>((i + 1) * width)));
  }
  const auto marksIn = comm_.exchange(marksOut);
  leaf.reset();

  // the rebuild on the new parts, then the steps replayed
  const std::vector<MarkedStep> steps = std::move(history_);
  history_.clear();
  const mesh::ClosureRule rule = grid_.closureRule();
  ForestPartitionOptions po = options_;
  po.level = partition_.level;
  po.cellParts = parts;
  build(refinements_, po);
  std::vector<std::vector<std::pair<Index, std::uint64_t>>> replay(steps.size());
  for (int r = 0; r < ranks; ++r)
    for (std::size_t i = 0; i + 2 < marksIn[r].size(); i += 3)
      replay[marksIn[r][i]].emplace_back(static_cast<Index>(marksIn[r][i + 1]), marksIn[r][i + 2]);
  for (std::size_t s = 0; s < steps.size(); ++s) {
    std::vector<Index> marked;
    comm_.collective([&] {
      grid_.setClosureRule(steps[s].rule);
      std::unordered_map<std::uint64_t, Index> owned;
      for (Index e : grid_.leafElements())
        if (partition_.partOf(e) == me) owned.emplace(cellKey(e), e);
      std::sort(replay[s].begin(), replay[s].end());  // a fixed order, whatever the senders
      for (const auto& [cell, key] : replay[s]) {
        const auto it = owned.find(key);
        if (it == owned.end() || partition_.elementCell[it->second] != cell)
          throw Error("distributed grid: rank " + std::to_string(me) + " does not hold a leaf marked in step " +
                      std::to_string(s) + " of partition cell " + std::to_string(cell));
        marked.push_back(it->second);
      }
    });
    adapt(marked);
    ++report.replayedSteps;
  }
  grid_.setClosureRule(rule);

  // the values at the new leaf view's vertices, asked from the rendezvous ranks by key
  if (leafValues) {
    std::vector<std::vector<std::uint64_t>> ask(static_cast<std::size_t>(ranks));
    leaf = grid_.leafView();
    for (Index v : leaf->vertices) ask[rendezvous(keys_[v])].push_back(keys_[v]);
    const auto asked = comm_.exchange(ask);
    std::vector<std::vector<double>> answer(static_cast<std::size_t>(ranks));
    for (int r = 0; r < ranks; ++r)
      for (std::uint64_t key : asked[r]) {
        const auto it = stored.find(key);
        for (int c = 0; c < width; ++c) answer[r].push_back(it == stored.end() ? 0.0 : it->second[c]);
      }
    const auto answers = comm_.exchange(answer);
    leafValues->assign(leaf->vertices.size() * static_cast<std::size_t>(width), 0.0);
    std::vector<std::size_t> next(static_cast<std::size_t>(ranks), 0);
    for (std::size_t i = 0; i < leaf->vertices.size(); ++i) {
      const int r = rendezvous(keys_[leaf->vertices[i]]);
      for (int c = 0; c < width; ++c) (*leafValues)[i * width + c] = answers[r][next[r]++];
    }
  }
  return report;
}

}  // namespace obs
