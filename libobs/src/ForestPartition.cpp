#include "obs/obs/ForestPartition.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/RedRefinement.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {

double ForestPartition::imbalance() const {
  Index total = 0, most = 0;
  for (Index n : partLeaves) {
    total += n;
    most = std::max(most, n);
  }
  return total > 0 ? static_cast<double>(most) * static_cast<double>(parts) / static_cast<double>(total) : 1.0;
}

ForestPartition partitionForest(const mesh::Grid& grid, int parts, const ForestPartitionOptions& options) {
  if (parts < 1) throw Error("forest partition: " + std::to_string(parts) + " parts (at least 1)");
  if (options.cellsPerPart < 1) throw Error("forest partition: cellsPerPart must be at least 1");
  if (options.level > grid.maxLevel())
    throw Error("forest partition: partition level " + std::to_string(options.level) + ", the grid has levels 0.." +
                std::to_string(grid.maxLevel()));
  ForestPartition p;
  p.parts = parts;
  mesh::GridView view;
  if (options.level >= 0) {
    p.level = options.level;
    view = grid.levelView(p.level);
  } else {  // the coarsest level with enough cells
    for (int l = 0; l <= grid.maxLevel(); ++l) {
      view = grid.levelView(l);
      p.level = l;
      if (static_cast<Index>(view.elements.size()) >= static_cast<Index>(options.cellsPerPart) * parts) break;
    }
  }
  p.cells = view.elements;
  const auto nc = static_cast<Index>(p.cells.size());
  if (nc < parts)
    throw Error("forest partition: " + std::to_string(nc) + " partition cells on level " + std::to_string(p.level) +
                " for " + std::to_string(parts) + " parts (refine the coarse mesh, or choose a finer partition level)");

  p.cellPart.assign(static_cast<std::size_t>(nc), 0);
  p.follow(grid);

  if (!options.cellParts.empty()) {  // given parts
    if (options.cellParts.size() != static_cast<std::size_t>(nc))
      throw Error("forest partition: " + std::to_string(options.cellParts.size()) + " given parts for " +
                  std::to_string(nc) + " partition cells");
    for (int q : options.cellParts)
      if (q < 0 || q >= parts) throw Error("forest partition: given part " + std::to_string(q) + " of " + std::to_string(parts));
    p.cellPart = options.cellParts;
  } else if (parts > 1) {
    // weights: the leaves below each cell, each counted as the leaves its future uniform
    // refinements will give it (children^k: the weights METIS gets from the refined grid), scaled
    // down by the fewest children^k where their sum would not fit METIS' integers
    std::vector<Index> weights = p.cellLeaves;
    if (options.refinementsBelow > 0) {
      const std::vector<mesh::Index> leaves = grid.leafElements();
      const auto children = [&](Index e) { return static_cast<double>(mesh::redRefinementRule(grid.type(e)).children.size()); };
      double fewest = 1e300, total = 0;
      for (Index e : leaves) {
        fewest = std::min(fewest, children(e));
        total += std::pow(children(e), options.refinementsBelow);
      }
      const double unit = total > 1e9 ? std::pow(fewest, options.refinementsBelow) : 1.0;
      if (total / unit > 1e9)
        throw Error("forest partition: " + std::to_string(options.refinementsBelow) +
                    " refinements below the partition level are too many to weigh the cells (choose a finer partition level)");
      std::vector<double> w(weights.size(), 0.0);
      for (Index e : leaves) w[p.elementCell[e]] += std::round(std::pow(children(e), options.refinementsBelow) / unit);
      for (std::size_t c = 0; c < w.size(); ++c) weights[c] = static_cast<Index>(w[c]);
    }
    p.cellPart = splitPartitionCells(grid, p, weights);
  }
  p.follow(grid);
  return p;
}

std::vector<int> splitPartitionCells(const mesh::Grid& grid, const ForestPartition& partition,
                                     const std::vector<Index>& weights) {
  const auto nc = static_cast<Index>(partition.cells.size());
  if (nc == 0 || weights.size() < static_cast<std::size_t>(nc) || weights.size() % static_cast<std::size_t>(nc) != 0)
    throw Error("forest partition: " + std::to_string(weights.size()) + " weights for " + std::to_string(nc) + " partition cells");
  if (partition.parts == 1) return std::vector<int>(static_cast<std::size_t>(nc), 0);
  // the face graph of the partition cells (the elements of the partition level's view)
  const mesh::GridView view = grid.levelView(partition.level);
  if (view.elements != partition.cells) throw Error("forest partition: the grid does not have the partition cells of this partition");
  const mesh::GridView::Neighbours nb = view.faceNeighbours();
  std::vector<Index> rowStart(static_cast<std::size_t>(nc) + 1, 0), columns;
  for (Index c = 0; c < nc; ++c) {
    for (Index k = nb.offsets[c]; k < nb.offsets[c + 1]; ++k)
      if (nb.cells[k] >= 0) columns.push_back(nb.cells[k]);
    rowStart[c + 1] = static_cast<Index>(columns.size());
  }
  std::vector<int> part = partitionPattern(rowStart, columns, partition.parts, weights);
  if (part.size() != static_cast<std::size_t>(nc)) throw Error("forest partition: METIS failed");
  return part;
}

void ForestPartition::follow(const mesh::Grid& grid) {
  // each element's partition cell: itself, or its father's (fathers precede their children)
  const Index ne = grid.numElements(), nc = static_cast<Index>(cells.size());
  elementCell.assign(static_cast<std::size_t>(ne), -1);
  for (Index i = 0; i < nc; ++i) {
    if (cells[i] >= ne || grid.isRemoved(cells[i]) || grid.level(cells[i]) > level)
      throw Error("forest partition: the grid does not have the partition cells of this partition");
    elementCell[cells[i]] = i;
  }
  for (Index e = 0; e < ne; ++e) {
    if (grid.isRemoved(e) || elementCell[e] >= 0) continue;
    const Index f = grid.father(e);
    if (f >= e) throw Error("forest partition: element " + std::to_string(e) + " precedes its father");
    if (f >= 0) elementCell[e] = elementCell[f];
  }
  cellLeaves.assign(static_cast<std::size_t>(nc), 0);
  for (Index e = 0; e < ne; ++e)
    if (grid.isLeaf(e)) {
      if (elementCell[e] < 0) throw Error("forest partition: leaf " + std::to_string(e) + " below no partition cell");
      ++cellLeaves[elementCell[e]];
    }
  partLeaves.assign(static_cast<std::size_t>(parts), 0);
  for (Index c = 0; c < nc; ++c) partLeaves[cellPart[c]] += cellLeaves[c];
}

namespace {

/// The owning part of every cell of the view (checks that the view belongs to the partition).
std::vector<int> cellOwners(const mesh::Grid& grid, const mesh::GridView& view, const ForestPartition& partition) {
  if (partition.elementCell.size() != static_cast<std::size_t>(grid.numElements()))
    throw Error("forest partition: computed for a grid of " + std::to_string(partition.elementCell.size()) +
                " elements, this grid has " + std::to_string(grid.numElements()) + " (partition it again after adapting)");
  if (view.level >= 0 && view.level < partition.level)
    throw Error("forest partition: level " + std::to_string(view.level) + " is below the partition level " +
                std::to_string(partition.level) + ", replicated on every part");
  std::vector<int> owner(view.elements.size());
  for (std::size_t c = 0; c < owner.size(); ++c) {
    owner[c] = partition.partOf(view.elements[c]);
    if (owner[c] < 0) throw Error("forest partition: view cell " + std::to_string(c) + " has no owner");
  }
  return owner;
}

}  // namespace

ViewNumbering numberView(const mesh::Grid& grid, const mesh::GridView& view, const ForestPartition& partition) {
  const std::vector<int> cell = cellOwners(grid, view, partition);
  const mesh::Mesh& m = view.mesh;
  ViewNumbering n;
  n.owner.assign(static_cast<std::size_t>(m.numVertices()), partition.parts);
  for (Index c = 0; c < m.numCells(); ++c)
    for (Index v : m.cellVertices(c)) n.owner[v] = std::min(n.owner[v], cell[c]);
  n.offsets.assign(static_cast<std::size_t>(partition.parts) + 1, 0);
  for (int o : n.owner) {
    if (o >= partition.parts) throw Error("forest partition: a view vertex in no cell");
    ++n.offsets[o + 1];
  }
  for (int k = 0; k < partition.parts; ++k) n.offsets[k + 1] += n.offsets[k];
  std::vector<Index> next(n.offsets.begin(), n.offsets.end() - 1);
  n.global.resize(n.owner.size());
  for (std::size_t v = 0; v < n.owner.size(); ++v) n.global[v] = next[n.owner[v]]++;
  return n;
}

PartView partView(const mesh::Grid& grid, const mesh::GridView& view, const ForestPartition& partition,
                  const ViewNumbering& numbering, int part) {
  if (part < 0 || part >= partition.parts)
    throw Error("forest partition: part " + std::to_string(part) + " of " + std::to_string(partition.parts));
  const std::vector<int> cell = cellOwners(grid, view, partition);
  const mesh::Mesh& m = view.mesh;
  if (numbering.owner.size() != static_cast<std::size_t>(m.numVertices()))
    throw Error("forest partition: a vertex numbering of another view");
  PartView pv;
  std::vector<char> touched(static_cast<std::size_t>(m.numVertices()), 0), held(touched.size(), 0);
  for (Index c = 0; c < m.numCells(); ++c)
    if (cell[c] == part) {
      pv.owned.push_back(c);
      for (Index v : m.cellVertices(c)) touched[v] = held[v] = 1;
    }
  for (Index c = 0; c < m.numCells(); ++c) {
    if (cell[c] == part) continue;
    const auto vs = m.cellVertices(c);
    if (std::none_of(vs.begin(), vs.end(), [&](Index v) { return touched[v] != 0; })) continue;
    pv.ghosts.push_back(c);
    for (Index v : vs) held[v] = 1;
  }
  for (Index v = 0; v < m.numVertices(); ++v)
    if (held[v]) (numbering.owner[v] == part ? pv.ownedVertices : pv.ghostVertices).push_back(v);
  return pv;
}

}  // namespace obs
