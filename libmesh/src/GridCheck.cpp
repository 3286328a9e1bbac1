// Grid construction: checks of the coarse mesh, reorientation of mirrored cells, and loading of
// level 0 (vertices, cells, boundary ids of the coarse cell faces).
#include <algorithm>
#include <cmath>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"

namespace obs::mesh {
namespace {

/// Vertex permutation that mirrors a cell (reverses its orientation): a reflection of the
/// reference element (x <-> y, or of the single edge of a segment-like order).
std::span<const int> mirror(CellType t) {
  static constexpr int tri[] = {0, 2, 1}, quad[] = {0, 3, 2, 1}, tet[] = {0, 2, 1, 3},
                       hex[] = {0, 3, 2, 1, 4, 7, 6, 5}, prism[] = {0, 2, 1, 3, 5, 4},
                       pyr[] = {0, 3, 2, 1, 4};
  switch (t) {
    case CellType::Triangle: return tri;
    case CellType::Quadrilateral: return quad;
    case CellType::Tetrahedron: return tet;
    case CellType::Hexahedron: return hex;
    case CellType::Prism: return prism;
    case CellType::Pyramid: return pyr;
    default: return {};
  }
}

std::string cellName(Index c, CellType t) {
  return "coarse cell " + std::to_string(c) + " (" + std::string(name(t)) + ")";
}

std::string list(std::span<const Index> v) {
  std::string s = "{";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "}";
}

/// True if the cyclic sequences a and b (same vertices) run in opposite directions.
bool opposite(std::span<const Index> a, std::span<const Index> b) {
  const std::size_t n = a.size();
  if (n == 2) return a[0] == b[1] && a[1] == b[0];  // segments: no rotation
  const auto it = std::find(b.begin(), b.end(), a[0]);
  if (it == b.end()) return false;
  const std::size_t k = static_cast<std::size_t>(it - b.begin());
  for (std::size_t i = 1; i < n; ++i)
    if (a[i] != b[(k + n - i) % n]) return false;
  return true;
}

}  // namespace

Grid::Grid(const Mesh& coarse) : dim_(coarse.dimension()) { checkAndLoad(coarse); }

void Grid::checkAndLoad(const Mesh& in) {
  const Index nc = in.numCells(), nv = in.numVertices();
  if (nc == 0) throw Error("Grid: the coarse mesh has no cells");
  Mesh m(dim_);  // the coarse mesh with reoriented cells
  m.reserve(nv, nc, static_cast<std::size_t>(nc) * 8);
  for (const Point& x : in.vertices()) m.addVertex(x);
  std::array<Index, 8> cv{};
  std::array<Point, 8> x{}, y{};
  for (Index c = 0; c < nc; ++c) {
    const CellType t = in.cellType(c);
    const auto v = in.cellVertices(c);
    const int n = static_cast<int>(v.size());
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if (v[i] == v[j])
          throw Error("Grid: " + cellName(c, t) + " has vertex " + std::to_string(v[i]) +
                      " twice: " + list(v));
    double h = 0;
    for (int i = 0; i < n; ++i) x[i] = in.vertex(v[i]);
    for (const auto& e : localEdges(t)) h = std::max(h, (x[e[0]] - x[e[1]]).norm());
    const std::span<const Point> corners(x.data(), n);
    const double vol = signedMeasure(t, corners);
    if (!std::isfinite(vol) || std::abs(vol) <= 1e-12 * std::pow(h, dim_))
      throw Error("Grid: " + cellName(c, t) + " is degenerate (volume " + std::to_string(vol) +
                  ", vertices " + list(v) + ")");
    std::copy(v.begin(), v.end(), cv.begin());
    if (!isPositivelyOriented(t, corners)) {
      const auto p = mirror(t);
      for (int i = 0; i < n; ++i) {
        cv[i] = v[p[i]];
        y[i] = x[p[i]];
      }
      if (!isPositivelyOriented(t, std::span<const Point>(y.data(), n)))
        throw Error("Grid: " + cellName(c, t) +
                    " is inverted or self-intersecting: its Jacobian changes sign (vertices " +
                    list(v) + ")");
      report_.reorientedCells.push_back(c);
    }
    m.addCell(t, std::span<const Index>(cv.data(), n));
  }

  // Duplicate cells: equal sorted vertex lists.
  {
    std::vector<std::pair<std::array<Index, 8>, Index>> keys(nc);
    for (Index c = 0; c < nc; ++c) {
      const auto v = m.cellVertices(c);
      keys[c].first.fill(-1);
      std::copy(v.begin(), v.end(), keys[c].first.begin());
      std::sort(keys[c].first.begin(), keys[c].first.begin() + v.size());
      keys[c].second = c;
    }
    std::sort(keys.begin(), keys.end());
    for (Index i = 1; i < nc; ++i)
      if (keys[i].first == keys[i - 1].first)
        throw Error("Grid: " + cellName(keys[i].second, m.cellType(keys[i].second)) +
                    " duplicates coarse cell " + std::to_string(keys[i - 1].second) +
                    " (vertices " + list(in.cellVertices(keys[i].second)) + ")");
  }

  // Faces: manifold, and the two cells of an interior face on opposite sides.
  const FaceTable faces(m);
  std::array<Index, 4> a{}, b{};
  auto sideVertices = [&](const FaceTable::Side& s, std::array<Index, 4>& out) {
    const LocalFace& f = localFaces(m.cellType(s.cell))[s.localFace];
    const auto v = m.cellVertices(s.cell);
    for (int i = 0; i < f.size; ++i) out[i] = v[f.vertices[i]];
    return std::span<const Index>(out.data(), f.size);
  };
  auto keyList = [&](Index f) {
    const FaceKey& k = faces.key(f);
    return list(std::span<const Index>(k.data(), faces.size(f)));
  };
  for (Index f = 0; f < faces.numFaces(); ++f) {
    const auto& s0 = faces.side(f, 0);
    const auto& s1 = faces.side(f, 1);
    if (faces.numCells(f) > 2)
      throw Error("Grid: the face " + keyList(f) + " is shared by " +
                  std::to_string(faces.numCells(f)) + " cells (non-manifold), e.g. coarse cells " +
                  std::to_string(s0.cell) + " and " + std::to_string(s1.cell));
    if (faces.numCells(f) == 2 && !opposite(sideVertices(s0, a), sideVertices(s1, b)))
      throw Error("Grid: coarse cells " + std::to_string(s0.cell) + " and " +
                  std::to_string(s1.cell) + " overlap: both lie on the same side of their face " +
                  keyList(f));
  }

  // Boundary ids of the coarse cell faces: listed id, kUnlistedBoundaryId for unlisted one-cell
  // faces, -1 for interior faces.
  coarseFaceOffset_.assign(nc + 1, 0);
  for (Index c = 0; c < nc; ++c)
    coarseFaceOffset_[c + 1] =
        coarseFaceOffset_[c] + static_cast<Index>(localFaces(m.cellType(c)).size());
  coarseFaceId_.assign(coarseFaceOffset_[nc], -1);
  std::vector<Index> listedBy(coarseFaceOffset_[nc], -1);
  for (Index bf = 0; bf < in.numBoundaryFaces(); ++bf) {
    const auto fv = in.boundaryFaceVertices(bf);
    const Index f = faces.find(fv);
    if (f < 0 || faces.numCells(f) != 1)
      throw Error("Grid: boundary face " + std::to_string(bf) + " (vertices " + list(fv) +
                  ", id " + std::to_string(in.boundaryFaceId(bf)) + ") is " +
                  (f < 0 ? "not a face of any cell" : "an interior face"));
    const auto& s = faces.side(f, 0);
    const Index slot = coarseFaceOffset_[s.cell] + s.localFace;
    if (listedBy[slot] >= 0 && coarseFaceId_[slot] != in.boundaryFaceId(bf))
      throw Error("Grid: boundary face " + std::to_string(bf) + " (vertices " + list(fv) +
                  ") repeats boundary face " + std::to_string(listedBy[slot]) +
                  " with another id");
    listedBy[slot] = bf;
    coarseFaceId_[slot] = in.boundaryFaceId(bf);
  }
  std::vector<char> boundary(nv, 0);
  for (Index f = 0; f < faces.numFaces(); ++f) {
    if (faces.numCells(f) != 1) continue;
    const auto& s = faces.side(f, 0);
    const Index slot = coarseFaceOffset_[s.cell] + s.localFace;
    if (listedBy[slot] < 0) {
      coarseFaceId_[slot] = kUnlistedBoundaryId;
      ++report_.unlistedBoundaryFaces;
    }
    for (Index v : faces.key(f))
      if (v >= 0) boundary[v] = 1;
  }

  // Boundary ids of the coarse edges on the boundary (of the faces containing them).
  for (Index c = 0; c < nc; ++c) {
    const auto cv = m.cellVertices(c);
    const auto cf = localFaces(m.cellType(c));
    for (std::size_t f = 0; f < cf.size(); ++f) {
      const int id = coarseFaceId_[coarseFaceOffset_[c] + f];
      if (id < 0) continue;
      for (int j = 0; j < cf[f].size; ++j)
        coarseEdgeIds_.push_back(
            {edgeKey(cv[cf[f].vertices[j]], cv[cf[f].vertices[(j + 1) % cf[f].size]]), id});
    }
  }
  std::sort(coarseEdgeIds_.begin(), coarseEdgeIds_.end());
  coarseEdgeIds_.erase(std::unique(coarseEdgeIds_.begin(), coarseEdgeIds_.end()),
                       coarseEdgeIds_.end());

  // Level 0.
  x_.reserve(nv);
  for (Index v = 0; v < nv; ++v) addVertex(m.vertex(v), -1, -1, boundary[v] != 0);
  for (Index c = 0; c < nc; ++c) addElement(m.cellType(c), m.cellVertices(c), -1, 0, {}, false);
  names_ = in.boundaryNames();
}

}  // namespace obs::mesh
