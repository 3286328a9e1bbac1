// Grid: local point tables, element/vertex storage, hierarchy queries, boundary ids, marks, and
// the leaf and level views (GridAdapt.cpp refines, GridClosure.cpp holds the closure rules,
// GridCheck.cpp checks the coarse mesh, GridTransfer.cpp builds transfer operators).
#include "obs/mesh/Grid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs::mesh {

// ------------------------------------------------------------------------------------------------
// Local points.
struct LocalPointTables {
  std::array<LocalPoints, 7> tables;

  LocalPointTables() {
    for (int t = 0; t < 7; ++t) build(tables[t], static_cast<CellType>(t));
  }

  static void build(LocalPoints& p, CellType type) {
    const ReferenceElement& ref = referenceElement(type);
    const auto edges = localEdges(type);
    const auto faces = type == CellType::Segment ? std::span<const LocalFace>{} : localFaces(type);
    p.type = type;
    p.numCorners = ref.numVertices;
    p.numEdges = static_cast<int>(edges.size());
    p.numFaces = static_cast<int>(faces.size());
    p.size = p.numCorners + p.numEdges + p.numFaces + 1;
    for (auto& row : p.edgeOf_) row.fill(-1);
    for (auto& row : p.faceEdges_) row.fill(-1);
    for (int e = 0; e < p.numEdges; ++e) {
      p.edgeOf_[edges[e][0]][edges[e][1]] = p.edgeOf_[edges[e][1]][edges[e][0]] = e;
    }
    // Supports: the corners each point averages (the centroid: all; its reference point is the
    // reference centroid, which is not the corner average for pyramids).
    std::vector<std::vector<int>> support;
    for (int i = 0; i < p.numCorners; ++i) support.push_back({i});
    for (const auto& e : edges) support.push_back({e[0], e[1]});
    for (const LocalFace& f : faces) support.emplace_back(f.span().begin(), f.span().end());
    for (int f = 0; f < p.numFaces; ++f)
      for (int j = 0; j < faces[f].size; ++j)
        p.faceEdges_[f][j] = p.edgeOf_[faces[f].vertices[j]][faces[f].vertices[(j + 1) % faces[f].size]];
    for (int k = 0; k + 1 < p.size; ++k) {
      Point x = Point::Zero();
      for (int i : support[k]) x += ref.vertices[i];
      p.ref_[k] = x / static_cast<double>(support[k].size());
      unsigned mask = 0;
      for (int f = 0; f < p.numFaces; ++f) {
        const auto fv = faces[f].span();
        if (std::all_of(support[k].begin(), support[k].end(),
                        [&](int i) { return std::find(fv.begin(), fv.end(), i) != fv.end(); }))
          mask |= 1u << f;
      }
      p.faceMask_[k] = mask;
    }
    p.ref_[p.size - 1] = ref.centroid;
    p.faceMask_[p.size - 1] = 0;
    // Weights: exact averages for corners, edge midpoints and face centres; at the centroid the
    // shape function values (1/n except for the pyramid: 3/16 at the base corners, 1/4 at the apex).
    for (int k = 0; k < p.size; ++k) {
      if (k == p.size - 1) {
        if (type == CellType::Pyramid)
          ref.values(p.ref_[k], std::span<double>(p.weights_[k].data(), p.numCorners));
        else
          std::fill_n(p.weights_[k].begin(), p.numCorners, 1.0 / p.numCorners);
        continue;
      }
      for (int i : support[k]) p.weights_[k][i] = 1.0 / static_cast<double>(support[k].size());
    }
  }
};

const LocalPoints& LocalPoints::of(CellType type) {
  static const LocalPointTables t;
  return t.tables[static_cast<int>(type)];
}

// ------------------------------------------------------------------------------------------------
// Storage.
Index Grid::addElement(CellType type, std::span<const Index> vertices, Index father, int level,
                       std::span<const std::uint8_t> pointsInFather, bool green) {
  if (level > 255) throw Error("Grid: more than 255 refinement levels");
  const Index e = numElements();
  type_.push_back(type);
  level_.push_back(static_cast<std::uint8_t>(level));
  flags_.push_back(green ? kGreen : 0);
  refinement_.push_back(Refinement::None);
  father_.push_back(father);
  firstChild_.push_back(-1);
  numChildren_.push_back(0);
  connOffset_.push_back(static_cast<Index>(conn_.size()));
  conn_.insert(conn_.end(), vertices.begin(), vertices.end());
  std::array<std::uint8_t, 8> p{};
  std::copy(pointsInFather.begin(), pointsInFather.end(), p.begin());
  inFather_.push_back(p);
  greenPattern_.push_back(0);
  marks_.push_back(0);
  maxLevel_ = std::max(maxLevel_, level);
  return e;
}

Index Grid::addVertex(const Point& x, Index creator, int point, bool boundary) {
  x_.push_back(x);
  vertexCreator_.push_back(creator);
  vertexPoint_.push_back(static_cast<std::uint8_t>(point < 0 ? 255 : point));
  boundaryVertex_.push_back(boundary ? 1 : 0);
  return numVertices() - 1;
}

void Grid::reserve(Index elements, std::size_t connectivity, Index vertices) {
  // Geometric growth, so that many small adapt() calls do not copy the arrays each time.
  auto grow = [](auto& v, std::size_t n) {
    if (n > v.capacity()) v.reserve(std::max(n, v.capacity() + v.capacity() / 2));
  };
  const auto ne = static_cast<std::size_t>(elements), nv = static_cast<std::size_t>(vertices);
  grow(type_, ne);
  grow(level_, ne);
  grow(flags_, ne);
  grow(refinement_, ne);
  grow(father_, ne);
  grow(firstChild_, ne);
  grow(numChildren_, ne);
  grow(connOffset_, ne);
  grow(conn_, connectivity);
  grow(inFather_, ne);
  grow(greenPattern_, ne);
  grow(marks_, ne);
  grow(x_, nv);
  grow(vertexCreator_, nv);
  grow(vertexPoint_, nv);
  grow(boundaryVertex_, nv);
}

Point Grid::pointPosition(Index e, int point) const {
  const auto w = LocalPoints::of(type_[e]).weights(point);
  const auto v = vertices(e);
  Point x = Point::Zero();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (w[i] != 0) x += w[i] * x_[v[i]];
  return x;
}

void Grid::interpolateNewVertices(std::vector<double>& values, Index firstNewVertex,
                                  int components) const {
  if (components < 1 || firstNewVertex < 0 || firstNewVertex > numVertices() ||
      values.size() < static_cast<std::size_t>(firstNewVertex) * components)
    throw Error("Grid::interpolateNewVertices: need " + std::to_string(components) +
                " values for each of the first " + std::to_string(firstNewVertex) + " vertices");
  values.resize(static_cast<std::size_t>(numVertices()) * components);
  for (Index v = firstNewVertex; v < numVertices(); ++v) {
    const Index e = vertexCreator_[v];
    const auto w = LocalPoints::of(type_[e]).weights(vertexPoint_[v]);
    const auto ev = vertices(e);
    for (int c = 0; c < components; ++c) {
      double s = 0;
      for (std::size_t i = 0; i < ev.size(); ++i)
        if (w[i] != 0) s += w[i] * values[static_cast<std::size_t>(ev[i]) * components + c];
      values[static_cast<std::size_t>(v) * components + c] = s;
    }
  }
}

std::vector<Point> Grid::geometryInFather(Index e) const {
  if (level_[e] == 0)
    throw Error("Grid::geometryInFather: element " + std::to_string(e) + " is on level 0");
  const LocalPoints& lp = LocalPoints::of(type_[father_[e]]);
  std::vector<Point> out;
  for (std::uint8_t p : pointsInFather(e)) out.push_back(lp.reference(p));
  return out;
}

int Grid::boundaryId(Index e, int f) const {
  while (level_[e] > 0) {
    const LocalFace& lf = localFaces(type_[e])[f];
    const LocalPoints& lp = LocalPoints::of(type_[father_[e]]);
    unsigned m = ~0u;
    for (int k = 0; k < lf.size; ++k) m &= lp.faceMask(inFather_[e][lf.vertices[k]]);
    if (m == 0) return -1;  // inside the father
    f = std::countr_zero(m);
    e = father_[e];
  }
  return coarseFaceId_[coarseFaceOffset_[e] + f];
}

void Grid::setBoundaryProjection(int id, Projection projection) {
  if (projection)
    projections_[id] = std::move(projection);
  else
    projections_.erase(id);
}

Point Grid::project(const Point& x, const std::vector<int>& ids) const {
  Point y = x;
  for (const auto& [id, f] : projections_)  // increasing id order
    if (std::find(ids.begin(), ids.end(), id) != ids.end()) y = f(y);
  return y;
}

// ------------------------------------------------------------------------------------------------
// Marks.
void Grid::mark(Index e) {
  if (e < 0 || e >= numElements())
    throw Error("Grid::mark: element " + std::to_string(e) + " does not exist");
  if (!isLeaf(e))
    throw Error("Grid::mark: element " + std::to_string(e) + " is not a leaf" +
                (isRemoved(e) ? " (a removed green element)" : ""));
  marks_[e] = 1;
}

void Grid::markAll() {
  for (Index e = 0; e < numElements(); ++e)
    if (isLeaf(e)) marks_[e] = 1;
}

void Grid::clearMarks() { std::fill(marks_.begin(), marks_.end(), 0); }

AdaptResult Grid::refineUniformly(int threads) {
  markAll();
  return adapt(threads);
}

// ------------------------------------------------------------------------------------------------
// Views.
std::vector<Index> Grid::leafElements() const {
  std::vector<Index> out;
  out.reserve(numElements());
  for (Index e = 0; e < numElements(); ++e)
    if (isLeaf(e)) out.push_back(e);
  return out;
}

Index Grid::numLeafElements() const {
  Index n = 0;
  for (Index e = 0; e < numElements(); ++e) n += isLeaf(e);
  return n;
}

GridView Grid::levelView(int level) const {
  if (level < 0 || level > maxLevel_)
    throw Error("Grid::levelView: level " + std::to_string(level) + " not in [0, " +
                std::to_string(maxLevel_) + "]");
  return makeView(level);
}

GridView Grid::makeView(int level) const {
  GridView view{level, Mesh(dim_), {}, {}, {}};
  std::size_t connectivity = 0;
  for (Index e = 0; e < numElements(); ++e) {
    if (isRemoved(e)) continue;
    const bool in = level < 0 ? isLeaf(e)
                              : (level_[e] == level || (level_[e] < level && isLeaf(e)));
    if (!in) continue;
    view.elements.push_back(e);
    connectivity += mesh::numVertices(type_[e]);
  }
  view.vertexIndex.assign(numVertices(), -1);
  for (Index e : view.elements)
    for (Index v : vertices(e)) view.vertexIndex[v] = 0;
  for (Index v = 0; v < numVertices(); ++v)
    if (view.vertexIndex[v] == 0) {
      view.vertexIndex[v] = static_cast<Index>(view.vertices.size());
      view.vertices.push_back(v);
    }
  Mesh& m = view.mesh;
  m.reserve(static_cast<Index>(view.vertices.size()), static_cast<Index>(view.elements.size()),
            connectivity);
  for (Index v : view.vertices) m.addVertex(x_[v]);
  std::array<Index, 8> cv{};
  for (Index e : view.elements) {
    const auto ev = vertices(e);
    for (std::size_t i = 0; i < ev.size(); ++i) cv[i] = view.vertexIndex[ev[i]];
    m.addCell(type_[e], std::span<const Index>(cv.data(), ev.size()));
  }
  // Boundary faces: cell faces on the coarse boundary, outward as in the cell.
  for (Index e : view.elements) {
    const auto ev = vertices(e);
    const auto faces = localFaces(type_[e]);
    for (int f = 0; f < static_cast<int>(faces.size()); ++f) {
      bool onBoundary = true;
      for (int k = 0; k < faces[f].size && onBoundary; ++k)
        onBoundary = boundaryVertex_[ev[faces[f].vertices[k]]] != 0;
      if (!onBoundary) continue;
      const int id = boundaryId(e, f);
      if (id < 0) continue;
      for (int k = 0; k < faces[f].size; ++k) cv[k] = view.vertexIndex[ev[faces[f].vertices[k]]];
      m.addBoundaryFace(std::span<const Index>(cv.data(), faces[f].size), id);
    }
  }
  for (const auto& [id, n] : names_) m.setBoundaryName(id, n);
  return view;
}

GridView::Neighbours GridView::faceNeighbours() const {
  const FaceTable faces(mesh);
  Neighbours n;
  n.offsets.reserve(mesh.numCells() + 1);
  n.offsets.push_back(0);
  for (Index c = 0; c < mesh.numCells(); ++c)
    n.offsets.push_back(n.offsets.back() + static_cast<Index>(localFaces(mesh.cellType(c)).size()));
  n.cells.assign(n.offsets.back(), -1);
  for (Index c = 0; c < mesh.numCells(); ++c)
    for (Index f = 0; f < n.offsets[c + 1] - n.offsets[c]; ++f) {
      const Index id = faces.face(c, static_cast<int>(f));
      if (faces.numCells(id) != 2) continue;
      const auto& s0 = faces.side(id, 0);
      const auto& s1 = faces.side(id, 1);
      n.cells[n.offsets[c] + f] = s0.cell == c ? s1.cell : s0.cell;
    }
  return n;
}

// ------------------------------------------------------------------------------------------------
// Shape quality.
namespace {
struct CornerTable {
  // For each type and corner: the corners joined to it by an edge, ordered so that the corner
  // Jacobian of the reference element has positive determinant; count 0 for the pyramid apex.
  std::array<std::array<std::array<int, 3>, 8>, 7> next{};
  std::array<std::array<int, 8>, 7> count{};
  CornerTable() {
    for (CellType t : kVolumeCellTypes) {
      const int ti = static_cast<int>(t), d = dimension(t);
      const ReferenceElement& ref = referenceElement(t);
      for (int c = 0; c < ref.numVertices; ++c) {
        std::vector<int> nb;
        for (const auto& e : localEdges(t))
          if (e[0] == c || e[1] == c) nb.push_back(e[0] == c ? e[1] : e[0]);
        if (static_cast<int>(nb.size()) != d) continue;  // pyramid apex
        Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
        for (int k = 0; k < d; ++k) J.col(k) = ref.vertices[nb[k]] - ref.vertices[c];
        if (d == 2) J(2, 2) = 1;
        if (J.determinant() < 0) std::swap(nb[0], nb[1]);
        for (int k = 0; k < d; ++k) next[ti][c][k] = nb[k];
        count[ti][c] = d;
      }
    }
  }
};
}  // namespace

double shapeQuality(CellType type, std::span<const Point> x) {
  static const CornerTable table;
  const int ti = static_cast<int>(type), d = dimension(type);
  double q = 1;
  for (std::size_t c = 0; c < x.size(); ++c) {
    if (table.count[ti][c] == 0) continue;
    const auto& nb = table.next[ti][c];
    double det, frob = 0;
    if (d == 2) {
      const Point a = x[nb[0]] - x[c], b = x[nb[1]] - x[c];
      det = a[0] * b[1] - a[1] * b[0];
      frob = a.head<2>().squaredNorm() + b.head<2>().squaredNorm();
    } else {
      const Point a = x[nb[0]] - x[c], b = x[nb[1]] - x[c], e = x[nb[2]] - x[c];
      det = a.dot(b.cross(e));
      frob = a.squaredNorm() + b.squaredNorm() + e.squaredNorm();
    }
    if (!(det > 0) || !(frob > 0)) return 0;
    q = std::min(q, d * std::pow(det, 2.0 / d) / frob);
  }
  return q;
}

}  // namespace obs::mesh
