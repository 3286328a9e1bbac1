// Face tables, conformity check, cell measures and orientation, interior perturbation.
#include "obs/mesh/MeshTopology.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs::mesh {
namespace {

// ------------------------------------------------------------------------------------------------
// Local tables (same order and orientation as ReferenceElement.cpp).
using E = std::array<int, 2>;
constexpr CellType S = CellType::Segment, T = CellType::Triangle, Q = CellType::Quadrilateral;

constexpr E kSegmentEdges[] = {{0, 1}};
constexpr E kTriangleEdges[] = {{0, 1}, {1, 2}, {2, 0}};
constexpr E kQuadEdges[] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};
constexpr E kTetEdges[] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
constexpr E kHexEdges[] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                           {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
constexpr E kPrismEdges[] = {{0, 1}, {1, 2}, {2, 0}, {3, 4}, {4, 5},
                             {5, 3}, {0, 3}, {1, 4}, {2, 5}};
constexpr E kPyramidEdges[] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 4}, {1, 4}, {2, 4}, {3, 4}};

constexpr LocalFace kTriangleFaces[] = {{S, 2, {0, 1}}, {S, 2, {1, 2}}, {S, 2, {2, 0}}};
constexpr LocalFace kQuadFaces[] = {{S, 2, {0, 1}}, {S, 2, {1, 2}}, {S, 2, {2, 3}}, {S, 2, {3, 0}}};
constexpr LocalFace kTetFaces[] = {
    {T, 3, {0, 2, 1}}, {T, 3, {0, 1, 3}}, {T, 3, {1, 2, 3}}, {T, 3, {0, 3, 2}}};
constexpr LocalFace kHexFaces[] = {{Q, 4, {0, 3, 2, 1}}, {Q, 4, {0, 1, 5, 4}},
                                   {Q, 4, {1, 2, 6, 5}}, {Q, 4, {2, 3, 7, 6}},
                                   {Q, 4, {0, 4, 7, 3}}, {Q, 4, {4, 5, 6, 7}}};
constexpr LocalFace kPrismFaces[] = {{T, 3, {0, 2, 1}},
                                     {Q, 4, {0, 1, 4, 3}},
                                     {Q, 4, {1, 2, 5, 4}},
                                     {Q, 4, {2, 0, 3, 5}},
                                     {T, 3, {3, 4, 5}}};
constexpr LocalFace kPyramidFaces[] = {{Q, 4, {0, 3, 2, 1}},
                                       {T, 3, {0, 1, 4}},
                                       {T, 3, {1, 2, 4}},
                                       {T, 3, {2, 3, 4}},
                                       {T, 3, {3, 0, 4}}};

// ------------------------------------------------------------------------------------------------
// Small geometric helpers.
inline double cross2(const Point& a, const Point& b) { return a[0] * b[1] - a[1] * b[0]; }
inline double triple(const Point& a, const Point& b, const Point& c) { return a.dot(b.cross(c)); }

constexpr double kGauss2[2] = {0.5 - 0.5 / 1.7320508075688772, 0.5 + 0.5 / 1.7320508075688772};

/// Jacobian determinant of the trilinear hexahedron map at reference point (x, y, z).
double hexDet(std::span<const Point> p, double x, double y, double z) {
  // Derivatives of the trilinear map along each reference direction.
  const double X[2] = {1 - x, x}, Y[2] = {1 - y, y}, Z[2] = {1 - z, z};
  auto at = [&](int a, int b, int c) -> const Point& {
    return p[(a ? (b ? 2 : 1) : (b ? 3 : 0)) + 4 * c];
  };
  Point jx = Point::Zero(), jy = Point::Zero(), jz = Point::Zero();
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      jx += Y[a] * Z[b] * (at(1, a, b) - at(0, a, b));
      jy += X[a] * Z[b] * (at(a, 1, b) - at(a, 0, b));
      jz += X[a] * Y[b] * (at(a, b, 1) - at(a, b, 0));
    }
  return triple(jx, jy, jz);
}

/// Bilinear surface B(u, v) through corners c0 (0,0), c1 (1,0), c2 (1,1), c3 (0,1) and its
/// tangents.
struct Bilinear {
  Point c0, c1, c2, c3;
  Point at(double u, double v) const {
    return (1 - u) * (1 - v) * c0 + u * (1 - v) * c1 + u * v * c2 + (1 - u) * v * c3;
  }
  Point du(double v) const { return (1 - v) * (c1 - c0) + v * (c2 - c3); }
  Point dv(double u) const { return (1 - u) * (c3 - c0) + u * (c2 - c1); }
};

std::uint64_t mix(std::uint64_t h) {  // splitmix64 finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}

/// Sorts the 2-4 vertex numbers of a face (any count up to 4) with a sorting network: min/max
/// pairs compile to conditional moves, where an insertion sort mispredicts on every other face.
void sortSmall(Index* first, Index* last) {
  const auto order = [](Index& a, Index& b) {
    const Index lo = std::min(a, b), hi = std::max(a, b);
    a = lo;
    b = hi;
  };
  Index* v = first;
  switch (last - first) {
    case 2:
      order(v[0], v[1]);
      break;
    case 3:
      order(v[0], v[1]);
      order(v[1], v[2]);
      order(v[0], v[1]);
      break;
    case 4:
      order(v[0], v[1]);
      order(v[2], v[3]);
      order(v[0], v[2]);
      order(v[1], v[3]);
      order(v[1], v[2]);
      break;
    default:  // 0 or 1: already sorted (other counts do not occur)
      break;
  }
}

/// True if the cyclic vertex sequences a and b (same vertex set) run in opposite directions.
bool oppositeCycles(std::span<const Index> a, std::span<const Index> b) {
  const std::size_t n = a.size();
  if (n == 2) return a[0] == b[1] && a[1] == b[0];
  const auto pos = static_cast<std::size_t>(std::find(b.begin(), b.end(), a[0]) - b.begin());
  return a[1] == b[(pos + n - 1) % n];
}

}  // namespace

// ------------------------------------------------------------------------------------------------
std::span<const std::array<int, 2>> localEdges(CellType type) {
  switch (type) {
    case CellType::Segment: return kSegmentEdges;
    case CellType::Triangle: return kTriangleEdges;
    case CellType::Quadrilateral: return kQuadEdges;
    case CellType::Tetrahedron: return kTetEdges;
    case CellType::Hexahedron: return kHexEdges;
    case CellType::Prism: return kPrismEdges;
    case CellType::Pyramid: return kPyramidEdges;
  }
  return {};
}

std::span<const LocalFace> localFaces(CellType type) {
  switch (type) {
    case CellType::Segment: return {};
    case CellType::Triangle: return kTriangleFaces;
    case CellType::Quadrilateral: return kQuadFaces;
    case CellType::Tetrahedron: return kTetFaces;
    case CellType::Hexahedron: return kHexFaces;
    case CellType::Prism: return kPrismFaces;
    case CellType::Pyramid: return kPyramidFaces;
  }
  return {};
}

FaceKey makeFaceKey(std::span<const Index> vertices) {
  FaceKey k{-1, -1, -1, -1};
  const std::size_t n = std::min<std::size_t>(vertices.size(), 4);
  std::copy_n(vertices.begin(), n, k.begin());
  sortSmall(k.data(), k.data() + n);
  return k;
}

std::size_t FaceKeyHash::operator()(const FaceKey& k) const noexcept {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL;
  for (Index v : k) h = mix(h ^ static_cast<std::uint32_t>(v));
  return static_cast<std::size_t>(h);
}

// ------------------------------------------------------------------------------------------------
namespace {

/// Offsets of the per-cell local entities (edges or faces) of every cell.
template <class Count>
std::vector<Index> cellEntityOffsets(const Mesh& mesh, Count count) {
  std::vector<Index> off(mesh.numCells() + 1, 0);
  for (Index c = 0; c < mesh.numCells(); ++c)
    off[c + 1] = off[c] + static_cast<Index>(count(mesh.cellType(c)));
  return off;
}

/// Counting sort of the local entity slots [0, n) by bucket(slot) in [0, numBuckets): returns the
/// bucket offsets and fills `order` with the slots, in increasing slot order within each bucket.
template <class Bucket>
std::vector<Index> bucketSlots(Index n, Index numBuckets, Bucket bucket,
                               std::vector<Index>& order) {
  std::vector<Index> start(numBuckets + 1, 0);
  for (Index s = 0; s < n; ++s) ++start[bucket(s) + 1];
  for (Index b = 0; b < numBuckets; ++b) start[b + 1] += start[b];
  std::vector<Index> fill(start.begin(), start.end() - 1);
  order.resize(n);
  for (Index s = 0; s < n; ++s) order[fill[bucket(s)]++] = s;
  return start;
}

}  // namespace

EdgeTable::EdgeTable(const Mesh& mesh) {
  const Index nc = mesh.numCells(), nv = mesh.numVertices();
  cellOffsets_ = cellEntityOffsets(mesh, [](CellType t) { return localEdges(t).size(); });
  const Index n = cellOffsets_[nc];
  // Slot s -> (cell, local edge) and its two vertices.
  std::vector<Index> slotCell(n);
  for (Index c = 0; c < nc; ++c)
    for (Index s = cellOffsets_[c]; s < cellOffsets_[c + 1]; ++s) slotCell[s] = c;
  auto ends = [&](Index s) {
    const Index c = slotCell[s];
    const auto& e = localEdges(mesh.cellType(c))[s - cellOffsets_[c]];
    const auto cv = mesh.cellVertices(c);
    const Index a = cv[e[0]], b = cv[e[1]];
    return a < b ? std::array<Index, 2>{a, b} : std::array<Index, 2>{b, a};
  };
  auto smaller = [&](Index s) { return ends(s)[0]; };  // bucket of a slot
  std::vector<Index> order;
  const auto bucket = bucketSlots(n, nv, smaller, order);

  cellEdges_.resize(n);
  start_.assign(nv + 1, 0);
  edges_.reserve(n / 3 + 1);
  std::vector<std::pair<Index, Index>> local;  // (larger vertex, slot) in one bucket
  for (Index a = 0; a < nv; ++a) {
    start_[a] = numEdges();
    local.clear();
    for (Index i = bucket[a]; i < bucket[a + 1]; ++i)
      local.push_back({ends(order[i])[1], order[i]});
    std::sort(local.begin(), local.end());
    for (std::size_t i = 0; i < local.size(); ++i) {
      if (i == 0 || local[i].first != local[i - 1].first) edges_.push_back({a, local[i].first});
      cellEdges_[local[i].second] = numEdges() - 1;
    }
  }
  start_[nv] = numEdges();
}

Index EdgeTable::find(Index a, Index b) const {
  if (a > b) std::swap(a, b);
  if (a < 0 || a + 1 >= static_cast<Index>(start_.size())) return -1;
  const auto first = edges_.begin() + start_[a], last = edges_.begin() + start_[a + 1];
  const auto it = std::lower_bound(first, last, std::array<Index, 2>{a, b});
  return it != last && (*it)[1] == b ? static_cast<Index>(it - edges_.begin()) : -1;
}

FaceTable::FaceTable(const Mesh& mesh, int threads) {
  const Index nc = mesh.numCells(), nv = mesh.numVertices();
  cellOffsets_ = cellEntityOffsets(mesh, [](CellType t) { return localFaces(t).size(); });
  const Index n = cellOffsets_[nc];
  // Threads only where the fork pays; every loop below writes what one thread would, so the table
  // is the same for any thread count.
  const int nt = n >= 65536 ? std::max(1, threads) : 1;
  // Ranges of cells (slots) per thread, in cell order.
  std::vector<Index> cellBegin(static_cast<std::size_t>(nt) + 1);
  for (int t = 0; t <= nt; ++t) cellBegin[t] = static_cast<Index>((static_cast<long long>(nc) * t) / nt);

  // The vertices of each cell face are read twice, in streaming passes over the cells: once for
  // the smallest vertex (the bucket), once to store the rest of the sorted key with the cell and
  // local face at its place in the bucket. Buckets are then contiguous and are sorted in place.
  auto forCellFaces = [&](Index c, auto&& visit) {
    const auto cv = mesh.cellVertices(c);
    const auto& faces = localFaces(mesh.cellType(c));
    for (std::size_t f = 0; f < faces.size(); ++f) {
      FaceKey k{-1, -1, -1, -1};
      for (int i = 0; i < faces[f].size; ++i) k[i] = cv[faces[f].vertices[i]];
      sortSmall(k.data(), k.data() + faces[f].size);
      visit(static_cast<int>(f), k);
    }
  };
  // per-thread counts of each bucket, then the place of every thread's first slot in each bucket
  // (thread t after threads < t: slots stay in increasing order within a bucket)
  std::vector<std::vector<Index>> fill(static_cast<std::size_t>(nt), std::vector<Index>(static_cast<std::size_t>(nv), 0));
#pragma omp parallel for schedule(static, 1) num_threads(nt)
  for (int t = 0; t < nt; ++t) {
    std::vector<Index>& count = fill[t];
    for (Index c = cellBegin[t]; c < cellBegin[t + 1]; ++c) {
      const auto cv = mesh.cellVertices(c);
      for (const LocalFace& f : localFaces(mesh.cellType(c))) {
        Index m = cv[f.vertices[0]];
        for (int i = 1; i < f.size; ++i) m = std::min(m, cv[f.vertices[i]]);
        ++count[m];
      }
    }
  }
  std::vector<Index> bucket(static_cast<std::size_t>(nv) + 1, 0);
  for (Index a = 0; a < nv; ++a) {
    Index at = bucket[a];
    for (int t = 0; t < nt; ++t) {
      const Index k = fill[t][a];
      fill[t][a] = at;
      at += k;
    }
    bucket[a + 1] = at;
  }
  // (cell, local face) packed as cell * 8 + local face: ordered like the slots, and the cell
  // without a second array (a local face number is below 6)
  if (nc > std::numeric_limits<Index>::max() / 8)
    throw Error("FaceTable: " + std::to_string(nc) + " cells are more than it can number");
  struct Entry {
    std::array<Index, 3> rest;  ///< the key without its smallest vertex (the bucket)
    Index side;                 ///< cell * 8 + local face
    // (written out: std::array's comparisons call memcmp / lexicographical_compare)
    bool sameFace(const Entry& o) const { return rest[0] == o.rest[0] && rest[1] == o.rest[1] && rest[2] == o.rest[2]; }
    bool operator<(const Entry& o) const {
      if (rest[0] != o.rest[0]) return rest[0] < o.rest[0];
      if (rest[1] != o.rest[1]) return rest[1] < o.rest[1];
      if (rest[2] != o.rest[2]) return rest[2] < o.rest[2];
      return side < o.side;
    }
  };
  std::vector<Entry> entries(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static, 1) num_threads(nt)
  for (int t = 0; t < nt; ++t) {
    std::vector<Index>& at = fill[t];
    for (Index c = cellBegin[t]; c < cellBegin[t + 1]; ++c)
      forCellFaces(c, [&](int localFace, const FaceKey& k) {
        entries[at[k[0]]++] = {{k[1], k[2], k[3]}, c * 8 + localFace};
      });
  }
  fill.clear();
  fill.shrink_to_fit();

  // sort each bucket and count its faces; then the faces are numbered bucket by bucket
  start_.assign(static_cast<std::size_t>(nv) + 1, 0);
#pragma omp parallel for schedule(static) num_threads(nt)
  for (Index a = 0; a < nv; ++a) {
    const auto first = entries.begin() + bucket[a], last = entries.begin() + bucket[a + 1];
    std::sort(first, last);
    Index faces = 0;
    for (auto it = first; it != last; ++it) faces += it == first || !it->sameFace(*(it - 1));
    start_[a + 1] = faces;
  }
  for (Index a = 0; a < nv; ++a) start_[a + 1] += start_[a];
  const Index numFaces = start_[nv];
  keys_.resize(static_cast<std::size_t>(numFaces));
  counts_.assign(static_cast<std::size_t>(numFaces), 0);
  sides_.resize(static_cast<std::size_t>(numFaces));
  cellFaces_.resize(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static) num_threads(nt)
  for (Index a = 0; a < nv; ++a) {
    Index f = start_[a] - 1;
    for (Index i = bucket[a]; i < bucket[a + 1]; ++i) {
      const Entry& e = entries[i];
      if (i == bucket[a] || !e.sameFace(entries[i - 1])) {
        ++f;
        keys_[f] = {a, e.rest[0], e.rest[1], e.rest[2]};
        sides_[f] = {};
      }
      const Index c = e.side / 8;
      const int localFace = e.side % 8;
      if (counts_[f] < 2) sides_[f][counts_[f]] = {c, localFace};
      ++counts_[f];
      cellFaces_[cellOffsets_[c] + localFace] = f;
    }
  }
}

Index FaceTable::find(std::span<const Index> vertices) const {
  if (vertices.size() < 2 || vertices.size() > 4) return -1;
  const FaceKey key = makeFaceKey(vertices);
  if (key[0] < 0 || key[0] + 1 >= static_cast<Index>(start_.size())) return -1;
  const auto first = keys_.begin() + start_[key[0]], last = keys_.begin() + start_[key[0] + 1];
  const auto it = std::lower_bound(first, last, key);
  return it != last && *it == key ? static_cast<Index>(it - keys_.begin()) : -1;
}

// ------------------------------------------------------------------------------------------------
ConformityReport checkConformity(const Mesh& mesh) {
  const FaceTable faces(mesh);
  ConformityReport r;
  std::array<Index, 4> a{}, b{};
  auto sideVertices = [&](const FaceTable::Side& s, std::array<Index, 4>& out) {
    const LocalFace& f = localFaces(mesh.cellType(s.cell))[s.localFace];
    const auto cv = mesh.cellVertices(s.cell);
    for (int i = 0; i < f.size; ++i) out[i] = cv[f.vertices[i]];
    return std::span<const Index>(out.data(), static_cast<std::size_t>(f.size));
  };
  for (Index f = 0; f < faces.numFaces(); ++f) {
    const int n = faces.numCells(f);
    if (n == 1) {
      ++r.boundaryFaces;
    } else if (n == 2) {
      ++r.interiorFaces;
      if (!oppositeCycles(sideVertices(faces.side(f, 0), a), sideVertices(faces.side(f, 1), b)))
        ++r.misorientedFaces;
    } else {
      ++r.nonManifoldFaces;
    }
  }
  // Each one-cell face must be listed exactly once among the Mesh boundary faces.
  std::vector<char> listed(faces.numFaces(), 0);
  for (Index bf = 0; bf < mesh.numBoundaryFaces(); ++bf) {
    const Index f = faces.find(mesh.boundaryFaceVertices(bf));
    if (f < 0 || faces.numCells(f) != 1 || listed[f]) {
      ++r.unmatchedBoundaryFaces;
      continue;
    }
    listed[f] = 1;
  }
  for (Index f = 0; f < faces.numFaces(); ++f)
    if (faces.numCells(f) == 1 && !listed[f]) ++r.hangingFaces;
  return r;
}

// ------------------------------------------------------------------------------------------------
double signedMeasure(CellType type, std::span<const Point> p) {
  if (static_cast<int>(p.size()) != numVertices(type))
    throw Error("signedMeasure: a " + std::string(name(type)) + " needs " +
                std::to_string(numVertices(type)) + " corners");
  switch (type) {
    case CellType::Segment: return (p[1] - p[0]).norm();
    case CellType::Triangle: return 0.5 * cross2(p[1] - p[0], p[2] - p[0]);
    case CellType::Quadrilateral:
      // Area of a bilinear quadrilateral = area of its straight-edged polygon (shoelace formula).
      return 0.5 * cross2(p[2] - p[0], p[3] - p[1]);
    case CellType::Tetrahedron: return triple(p[1] - p[0], p[2] - p[0], p[3] - p[0]) / 6.0;
    case CellType::Hexahedron: {
      // det J has degree <= 2 in each reference coordinate: the 2x2x2 Gauss rule is exact.
      double v = 0;
      for (double x : kGauss2)
        for (double y : kGauss2)
          for (double z : kGauss2) v += hexDet(p, x, y, z);
      return v / 8.0;
    }
    case CellType::Prism: {
      // det J is linear in (x, y) and quadratic in z: triangle centroid rule x 2-point Gauss.
      double v = 0;
      for (double z : kGauss2) {
        const Point jx = (1 - z) * (p[1] - p[0]) + z * (p[4] - p[3]);
        const Point jy = (1 - z) * (p[2] - p[0]) + z * (p[5] - p[3]);
        const Point jz = ((p[3] - p[0]) + (p[4] - p[1]) + (p[5] - p[2])) / 3.0;
        v += triple(jx, jy, jz);
      }
      return 0.5 * v / 2.0;
    }
    case CellType::Pyramid: {
      // The pyramid map is the cone x = (1-z) B(u,v) + z A over the bilinear base B, so
      // V = 1/3 int_[0,1]^2 (A - B) . (B_u x B_v) du dv (degree 2 in u and v: 2x2 Gauss exact).
      const Bilinear B{p[0], p[1], p[2], p[3]};
      double v = 0;
      for (double u : kGauss2)
        for (double w : kGauss2) v += (p[4] - B.at(u, w)).dot(B.du(w).cross(B.dv(u)));
      return v / 12.0;
    }
  }
  return 0;
}

bool isPositivelyOriented(CellType type, std::span<const Point> p) {
  switch (type) {
    case CellType::Segment: return (p[1] - p[0]).norm() > 0;
    case CellType::Triangle:
    case CellType::Tetrahedron: return signedMeasure(type, p) > 0;
    case CellType::Quadrilateral: {
      constexpr int q[2][2] = {{0, 3}, {1, 2}};  // q[a][b]: corner at reference (a, b)
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
          if (cross2(p[q[1][b]] - p[q[0][b]], p[q[a][1]] - p[q[a][0]]) <= 0) return false;
      return true;
    }
    case CellType::Hexahedron: {
      for (int a = 0; a < 2; ++a)
        for (int b = 0; b < 2; ++b)
          for (int c = 0; c < 2; ++c)
            if (hexDet(p, a, b, c) <= 0) return false;
      return true;
    }
    case CellType::Prism: {
      for (int c = 0; c < 2; ++c)
        for (int i = 0; i < 3; ++i) {
          const Point jx = p[1 + 3 * c] - p[3 * c], jy = p[2 + 3 * c] - p[3 * c];
          if (triple(jx, jy, p[i + 3] - p[i]) <= 0) return false;
        }
      return true;
    }
    case CellType::Pyramid: {
      // det J = (B_u x B_v) . (A - B(u,v)), independent of the height; checked at the base corners.
      const Bilinear B{p[0], p[1], p[2], p[3]};
      for (int u = 0; u < 2; ++u)
        for (int v = 0; v < 2; ++v)
          if (B.du(v).cross(B.dv(u)).dot(p[4] - B.at(u, v)) <= 0) return false;
      return true;
    }
  }
  return false;
}

std::vector<Point> cellCorners(const Mesh& mesh, Index cell) {
  std::vector<Point> out;
  for (Index v : mesh.cellVertices(cell)) out.push_back(mesh.vertex(v));
  return out;
}

namespace {
/// Corner coordinates into a fixed buffer (no allocation in loops over cells).
std::span<const Point> corners(const Mesh& mesh, Index cell, std::array<Point, 8>& buf) {
  const auto cv = mesh.cellVertices(cell);
  for (std::size_t i = 0; i < cv.size(); ++i) buf[i] = mesh.vertex(cv[i]);
  return {buf.data(), cv.size()};
}
}  // namespace

double cellVolume(const Mesh& mesh, Index cell) {
  std::array<Point, 8> buf;
  return signedMeasure(mesh.cellType(cell), corners(mesh, cell, buf));
}

double totalVolume(const Mesh& mesh) {
  double v = 0;
  for (Index c = 0; c < mesh.numCells(); ++c) v += cellVolume(mesh, c);
  return v;
}

bool isPositivelyOriented(const Mesh& mesh, Index cell) {
  std::array<Point, 8> buf;
  return isPositivelyOriented(mesh.cellType(cell), corners(mesh, cell, buf));
}

double boundaryFaceMeasure(const Mesh& mesh, Index face) {
  const auto fv = mesh.boundaryFaceVertices(face);
  auto x = [&](int i) -> const Point& { return mesh.vertex(fv[i]); };
  switch (fv.size()) {
    case 2: return (x(1) - x(0)).norm();
    case 3: return 0.5 * (x(1) - x(0)).cross(x(2) - x(0)).norm();
    default: {
      // 4-point Gauss-Legendre rule per direction on [0,1].
      constexpr double g[4] = {0.0694318442029737, 0.3300094782075719, 0.6699905217924281,
                               0.9305681557970263};
      constexpr double w[4] = {0.1739274225687269, 0.3260725774312731, 0.3260725774312731,
                               0.1739274225687269};
      const Bilinear B{x(0), x(1), x(2), x(3)};
      double a = 0;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) a += w[i] * w[j] * B.du(g[j]).cross(B.dv(g[i])).norm();
      return a;
    }
  }
}

std::map<int, double> boundaryMeasureById(const Mesh& mesh) {
  std::map<int, double> m;
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f)
    m[mesh.boundaryFaceId(f)] += boundaryFaceMeasure(mesh, f);
  return m;
}

std::vector<char> boundaryVertexFlags(const Mesh& mesh) {
  std::vector<char> flag(mesh.numVertices(), 0);
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f)
    for (Index v : mesh.boundaryFaceVertices(f)) flag[v] = 1;
  const FaceTable faces(mesh);
  for (Index f = 0; f < faces.numFaces(); ++f)
    if (faces.numCells(f) == 1)
      for (Index v : faces.key(f))
        if (v >= 0) flag[v] = 1;
  return flag;
}

// ------------------------------------------------------------------------------------------------
void perturbInteriorVertices(Mesh& mesh, double relativeAmount, unsigned seed) {
  if (!(relativeAmount >= 0))
    throw Error("perturbInteriorVertices: relativeAmount must be >= 0, got " +
                std::to_string(relativeAmount));
  const Index nv = mesh.numVertices(), nc = mesh.numCells();
  const std::vector<char> fixed = boundaryVertexFlags(mesh);

  // Local mesh size (shortest incident edge) and vertex -> cell adjacency (CSR).
  std::vector<double> h(nv, std::numeric_limits<double>::infinity());
  std::vector<Index> offset(nv + 1, 0);
  for (Index c = 0; c < nc; ++c) {
    const auto cv = mesh.cellVertices(c);
    for (const auto& e : localEdges(mesh.cellType(c))) {
      const double l = (mesh.vertex(cv[e[0]]) - mesh.vertex(cv[e[1]])).norm();
      h[cv[e[0]]] = std::min(h[cv[e[0]]], l);
      h[cv[e[1]]] = std::min(h[cv[e[1]]], l);
    }
    for (Index v : cv) ++offset[v + 1];
  }
  for (Index v = 0; v < nv; ++v) offset[v + 1] += offset[v];
  std::vector<Index> adj(offset[nv]);
  {
    std::vector<Index> fill(offset.begin(), offset.end() - 1);
    for (Index c = 0; c < nc; ++c)
      for (Index v : mesh.cellVertices(c)) adj[fill[v]++] = c;
  }

  // Portable uniform numbers in [-1, 1] from the raw generator output.
  std::mt19937 gen(seed);
  auto uniform = [&] { return (static_cast<double>(gen()) + 0.5) / 2147483648.0 - 1.0; };
  const int dim = mesh.dimension();

  for (Index v = 0; v < nv; ++v) {
    if (fixed[v] || offset[v] == offset[v + 1]) continue;
    Point d = Point::Zero();
    do {  // uniform direction and length in the unit ball
      for (int k = 0; k < dim; ++k) d[k] = uniform();
    } while (d.squaredNorm() > 1.0);
    d *= relativeAmount * h[v];
    const Point original = mesh.vertex(v);
    bool ok = false;
    for (int attempt = 0; attempt < 10 && !ok; ++attempt, d *= 0.5) {
      mesh.vertex(v) = original + d;
      ok = true;
      for (Index i = offset[v]; i < offset[v + 1] && ok; ++i)
        ok = isPositivelyOriented(mesh, adj[i]);
    }
    if (!ok) mesh.vertex(v) = original;
  }
}

}  // namespace obs::mesh
