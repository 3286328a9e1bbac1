// Meshes of curved domains (ball, disk, half disk, rounded block) with boundary projections.
#include "obs/mesh/CurvedMeshes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"

namespace obs::mesh {
namespace {

// --- argument checks ---------------------------------------------------------------------------

void checkPositive(const char* who, const char* what, double value) {
  if (!(std::isfinite(value) && value > 0.0))
    throw Error(std::string(who) + ": " + what + " must be positive and finite, got " +
                std::to_string(value));
}

void checkBall(const char* who, int dim, const Point& centre, double radius, int n) {
  if (!centre.allFinite()) throw Error(std::string(who) + ": the centre must be finite");
  checkPositive(who, "the radius", radius);
  if (n < 1)
    throw Error(std::string(who) + ": need at least one cell per direction, got " +
                std::to_string(n));
  // A generous bound of the cells of the finest split (3D: 12 tetrahedra per block cell, about
  // 4 n^3 block cells; 2D: 2 triangles per block cell, at most 12 n^2 block cells (half disk)).
  if (64.0 * std::pow(n, dim) > std::numeric_limits<Index>::max())
    throw Error(std::string(who) + ": too many cells for 32-bit indices");
}

void checkType(const char* who, CellType type, int dim) {
  if (type == CellType::Segment || dimension(type) != dim)
    throw Error(std::string(who) + ": cell type " + std::string(name(type)) +
                " is not supported, need a " + std::to_string(dim) + "D cell type");
}

// --- cells -------------------------------------------------------------------------------------

/// Adds a cell; if the given vertex order is negatively oriented, it is mirrored first (the same
/// swaps as BoxMesh). A cell that is not positively oriented either way is degenerate in floating
/// point (an obs::Error).
void addOriented(Mesh& mesh, CellType type, std::array<Index, 8> v) {
  const int n = numVertices(type);
  auto oriented = [&] {
    std::array<Point, 8> x;
    for (int i = 0; i < n; ++i) x[i] = mesh.vertex(v[i]);
    return isPositivelyOriented(type, std::span<const Point>(x.data(), n));
  };
  if (!oriented()) {
    int p = 1, q = 2, r = 0, s = 0;  // triangle, tetrahedron
    if (type == CellType::Quadrilateral || type == CellType::Pyramid) q = 3;
    if (type == CellType::Hexahedron) q = 3, r = 5, s = 7;
    if (type == CellType::Prism) r = 4, s = 5;
    std::swap(v[p], v[q]);
    if (s < n) std::swap(v[r], v[s]);
    if (!oriented())  // e.g. a ball of radius 1 centred at 1e19: the coordinates cannot resolve it
      throw Error("curved mesh: a cell is degenerate in floating point (the size is too small "
                  "relative to the coordinates of the centre, or the cells too many)");
  }
  mesh.addCell(type, std::span<const Index>(v.data(), n));
}

/// Adds a quadrilateral given in lattice order (corner (a, b) at index a + 2b) as one
/// quadrilateral or as 2 triangles split along the diagonal through its smallest vertex number.
void addQuad(Mesh& mesh, CellType type, const std::array<Index, 4>& lattice) {
  const std::array<Index, 4> q = {lattice[0], lattice[1], lattice[3], lattice[2]};  // cycle
  if (type == CellType::Quadrilateral) {
    addOriented(mesh, type, {q[0], q[1], q[2], q[3]});
    return;
  }
  const int k = static_cast<int>(std::min_element(q.begin(), q.end()) - q.begin());
  addOriented(mesh, type, {q[k], q[(k + 1) % 4], q[(k + 2) % 4]});
  addOriented(mesh, type, {q[k], q[(k + 2) % 4], q[(k + 3) % 4]});
}

/// Adds a hexahedron given in lattice order (corner (a, b, c) at index a + 2b + 4c of its local
/// axes) as one hexahedron, 2 prisms with axis `prismAxis` (local), 6 pyramids or 12 tetrahedra.
void addHex(Mesh& mesh, CellType type, const std::array<Index, 8>& lattice, int prismAxis) {
  if (type == CellType::Prism) {
    // Triangles in the other two local axes B < C, split along the (0,0)-(1,1) diagonal.
    const int A = 1 << prismAxis, B = prismAxis == 0 ? 2 : 1, C = prismAxis == 2 ? 2 : 4;
    const int tri[2][3] = {{0, B, B + C}, {0, B + C, C}};
    for (const auto& t : tri)
      addOriented(mesh, type,
                  {lattice[t[0]], lattice[t[1]], lattice[t[2]], lattice[A + t[0]],
                   lattice[A + t[1]], lattice[A + t[2]]});
    return;
  }
  std::array<Index, 8> hex;  // reference order: bottom cycle, then top cycle
  const int order[8] = {0, 1, 3, 2, 4, 5, 7, 6};
  for (int i = 0; i < 8; ++i) hex[i] = lattice[order[i]];
  if (type == CellType::Hexahedron) {
    addOriented(mesh, type, hex);
    return;
  }
  // Orient the hexahedron first, so that reversed outward face cycles face the centre.
  Point centre = Point::Zero();
  std::array<Point, 8> x;
  for (int i = 0; i < 8; ++i) centre += (x[i] = mesh.vertex(hex[i]));
  if (!isPositivelyOriented(CellType::Hexahedron, x)) {
    std::swap(hex[1], hex[3]);
    std::swap(hex[5], hex[7]);
  }
  const Index apex = mesh.addVertex(centre / 8.0);
  for (const LocalFace& f : localFaces(CellType::Hexahedron)) {
    const std::array<Index, 4> b = {hex[f.vertices[3]], hex[f.vertices[2]], hex[f.vertices[1]],
                                    hex[f.vertices[0]]};
    if (type == CellType::Pyramid) {
      addOriented(mesh, type, {b[0], b[1], b[2], b[3], apex});
      continue;
    }
    const int k = static_cast<int>(std::min_element(b.begin(), b.end()) - b.begin());
    addOriented(mesh, type, {b[k], b[(k + 1) % 4], b[(k + 2) % 4], apex});
    addOriented(mesh, type, {b[k], b[(k + 2) % 4], b[(k + 3) % 4], apex});
  }
}

/// Lists every one-cell face as a boundary face (outward orientation, as in its cell) with the id
/// classify(AND of the vertex tags of the face).
template <class Classify>
void addBoundaryFaces(Mesh& mesh, const std::vector<unsigned>& tags, Classify classify) {
  const FaceTable faces(mesh);
  std::array<Index, 4> fv{};
  for (Index f = 0; f < faces.numFaces(); ++f) {
    if (faces.numCells(f) != 1) continue;
    const auto& side = faces.side(f, 0);
    const LocalFace& lf = localFaces(mesh.cellType(side.cell))[side.localFace];
    const auto cv = mesh.cellVertices(side.cell);
    unsigned common = ~0u;
    for (int i = 0; i < lf.size; ++i) {
      fv[i] = cv[lf.vertices[i]];
      common &= fv[i] < static_cast<Index>(tags.size()) ? tags[fv[i]] : 0u;
    }
    mesh.addBoundaryFace({fv.data(), static_cast<std::size_t>(lf.size)}, classify(common));
  }
}

// --- cubed-sphere blocks -----------------------------------------------------------------------

constexpr unsigned kOnSphere = 1;  // vertex tag: outermost layer
constexpr unsigned kOnCut = 2;     // vertex tag: on the cut plane x[cutAxis] = centre[cutAxis] (half disk/ball)

/// A mesh with kOnSphere/kOnCut tags of its vertices (block vertices first, in vertex order).
struct TaggedMesh {
  Mesh mesh;
  std::vector<unsigned> tags;
};

/// Mesh of a ball (dim 3) or disk (dim 2) from the cubed-sphere blocks with N cells per direction
/// of the inner cube, restricted to the block cells whose centroid satisfies `keep` (all if empty).
/// Vertices on the plane x[cutAxis] = centre[cutAxis] (a mesh plane for even N) are tagged kOnCut.
TaggedMesh cubedBall(int dim, const Point& centre, double radius, int N, CellType type,
                     const std::function<bool(const Point&)>& keep = {}, int cutAxis = 1) {
  const int m = (N + 1) / 2;  // radial layers
  const double a = radius / (2.0 * std::sqrt(static_cast<double>(dim)));
  const std::int64_t side = N + 1, lattice = dim == 3 ? side * side * side : side * side;
  Point c = centre;
  if (dim == 2) c[2] = 0.0;

  // A vertex is identified by its layer l and inner-lattice point p; key = l * lattice + index(p).
  using Key = std::array<int, 4>;  // l, p0, p1, p2
  auto keyIndex = [&](const Key& k) { return k[0] * lattice + k[1] + side * (k[2] + side * k[3]); };
  auto position = [&](const Key& k) -> Point {
    Point q = Point::Zero(), w = Point::Zero();
    for (int i = 0; i < dim; ++i) {
      q[i] = 2.0 * k[i + 1] / N - 1.0;
      w[i] = std::tan(std::numbers::pi / 4.0 * q[i]);  // exact +-1 on the cube faces
    }
    if (k[0] == 0) return c + a * q;  // inner cube (w may vanish at its centre)
    const double t = static_cast<double>(k[0]) / m;
    return c + (1.0 - t) * a * q + t * radius * w.normalized();  // t = 1: exactly on the sphere
  };

  // Collect the block cells as lattice-ordered corner keys and their prism axis.
  struct BlockCell {
    std::array<Key, 8> corners;
    int prismAxis;
  };
  std::vector<BlockCell> cells;
  const int nc = 1 << dim;
  auto consider = [&](const BlockCell& cell) {
    Point centroid = Point::Zero();
    for (int i = 0; i < nc; ++i) centroid += position(cell.corners[i]);
    if (!keep || keep(Point(centroid / nc))) cells.push_back(cell);
  };
  const int nz = dim == 3 ? N : 1;
  for (int k = 0; k < nz; ++k)  // inner cube, local axes = x, y, z; prisms along z
    for (int j = 0; j < N; ++j)
      for (int i = 0; i < N; ++i) {
        BlockCell cell{{}, 2};
        for (int v = 0; v < nc; ++v)
          cell.corners[v] = {0, i + (v & 1), j + (v >> 1 & 1), k + (v >> 2 & 1)};
        consider(cell);
      }
  // Shell block on face p[d] = s N: local axes e (< f) along the face, then the layer. Prisms run
  // along e for x and y blocks, radially for z blocks (see the header for why this conforms).
  for (int d = 0; d < dim; ++d)
    for (int s = 0; s < 2; ++s) {
      const int e = d == 0 ? 1 : 0, f = d == 2 ? 1 : 2;
      for (int l = 0; l < m; ++l)
        for (int jf = 0; jf < nz; ++jf)
          for (int ie = 0; ie < N; ++ie) {
            BlockCell cell{{}, d == 2 ? 2 : 0};
            for (int v = 0; v < nc; ++v) {
              const int be = v & 1, bf = dim == 3 ? v >> 1 & 1 : 0, bl = v >> (dim - 1) & 1;
              Key& key = cell.corners[v];
              key = {l + bl, 0, 0, 0};
              key[d + 1] = s * N;
              key[e + 1] = ie + be;
              if (dim == 3) key[f + 1] = jf + bf;
            }
            consider(cell);
          }
    }

  // Number the used vertices in key order: the inner lattice, then layer by layer.
  std::vector<std::int64_t> used;
  for (const auto& cell : cells)
    for (int v = 0; v < nc; ++v) used.push_back(keyIndex(cell.corners[v]));
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  TaggedMesh out{Mesh(dim), {}};
  for (const std::int64_t k : used) {
    const auto l = static_cast<int>(k / lattice), r = static_cast<int>(k % lattice);
    const int s = static_cast<int>(side);
    const Key key = {l, r % s, r / s % s, r / s / s};
    out.mesh.addVertex(position(key));
    out.tags.push_back((l == m ? kOnSphere : 0u) | (2 * key[cutAxis + 1] == N ? kOnCut : 0u));
  }
  auto id = [&](const Key& key) {
    return static_cast<Index>(std::lower_bound(used.begin(), used.end(), keyIndex(key)) -
                              used.begin());
  };

  for (const auto& cell : cells) {
    std::array<Index, 8> v{};
    for (int i = 0; i < nc; ++i) v[i] = id(cell.corners[i]);
    if (dim == 2)
      addQuad(out.mesh, type, {v[0], v[1], v[2], v[3]});
    else
      addHex(out.mesh, type, v, cell.prismAxis);
  }
  return out;
}

/// Projection onto the sphere (3D) or the circle in the x-y plane (2D) of radius r around c.
BoundaryProjection sphereProjection(int dim, Point c, double r) {
  if (dim == 2) c[2] = 0.0;
  return [dim, c, r](const Point& x) -> Point {
    Point d = x - c;
    if (dim == 2) d[2] = 0.0;
    const double len = d.norm();
    if (len == 0.0) return c + Point(r, 0.0, 0.0);  // every direction is closest; pick +x
    return c + (r / len) * d;
  };
}

}  // namespace

CurvedMesh ballMesh(const Point& centre, double radius, CellType type, int level0Cells) {
  checkType("ballMesh", type, 3);
  checkBall("ballMesh", 3, centre, radius, level0Cells);
  auto [mesh, tags] = cubedBall(3, centre, radius, level0Cells, type);
  CurvedMesh out{std::move(mesh), {}};
  addBoundaryFaces(out.mesh, tags, [](unsigned common) {
    if (!(common & kOnSphere)) throw std::logic_error("ballMesh: a boundary face off the sphere");
    return int(kCurvedSurface);
  });
  out.mesh.setBoundaryName(kCurvedSurface, "surface");
  out.projections[kCurvedSurface] = sphereProjection(3, centre, radius);
  return out;
}

CurvedMesh diskMesh(const Point& centre, double radius, CellType type, int n) {
  checkType("diskMesh", type, 2);
  checkBall("diskMesh", 2, centre, radius, n);
  auto [mesh, tags] = cubedBall(2, centre, radius, n, type);
  CurvedMesh out{std::move(mesh), {}};
  addBoundaryFaces(out.mesh, tags, [](unsigned common) {
    if (!(common & kOnSphere)) throw std::logic_error("diskMesh: a boundary face off the circle");
    return int(kCurvedSurface);
  });
  out.mesh.setBoundaryName(kCurvedSurface, "circle");
  out.projections[kCurvedSurface] = sphereProjection(2, centre, radius);
  return out;
}

CurvedMesh halfDiskMesh(const Point& centre, double radius, CellType type, int n) {
  checkType("halfDiskMesh", type, 2);
  checkBall("halfDiskMesh", 2, centre, radius, n);
  // The diameter is a mesh line of the disk with 2n cells; keep the cells below it.
  const double cy = centre[1];
  auto [mesh, tags] =
      cubedBall(2, centre, radius, 2 * n, type, [cy](const Point& x) { return x[1] < cy; });
  CurvedMesh out{std::move(mesh), {}};
  addBoundaryFaces(out.mesh, tags, [](unsigned common) {
    if (common & kOnCut) return int(kHalfDiskTop);
    if (common & kOnSphere) return int(kCurvedSurface);
    throw std::logic_error("halfDiskMesh: a boundary face off the arc and the diameter");
  });
  out.mesh.setBoundaryName(kCurvedSurface, "arc");
  out.mesh.setBoundaryName(kHalfDiskTop, "top");
  out.projections[kCurvedSurface] = sphereProjection(2, centre, radius);
  return out;
}

CurvedMesh halfBallMesh(const Point& centre, double radius, CellType type, int n) {
  checkType("halfBallMesh", type, 3);
  checkBall("halfBallMesh", 3, centre, radius, n);
  // The equator plane z = centre.z is a mesh plane of the ball with 2n cells; keep the cells below.
  const double cz = centre[2];
  auto [mesh, tags] =
      cubedBall(3, centre, radius, 2 * n, type, [cz](const Point& x) { return x[2] < cz; }, 2);
  CurvedMesh out{std::move(mesh), {}};
  addBoundaryFaces(out.mesh, tags, [](unsigned common) {
    if (common & kOnCut) return int(kHalfDiskTop);
    if (common & kOnSphere) return int(kCurvedSurface);
    throw std::logic_error("halfBallMesh: a boundary face off the sphere and the equator plane");
  });
  out.mesh.setBoundaryName(kCurvedSurface, "surface");
  out.mesh.setBoundaryName(kHalfDiskTop, "top");
  out.projections[kCurvedSurface] = sphereProjection(3, centre, radius);
  return out;
}

CurvedMesh roundedBlockMesh(double width, double height, double depth, double arcRadius,
                            CellType type, std::array<int, 3> cells) {
  const char* who = "roundedBlockMesh";
  if (type == CellType::Segment) throw Error("roundedBlockMesh: segments are not a cell type");
  const int dim = dimension(type);
  checkPositive(who, "the width", width);
  checkPositive(who, "the height", height);
  checkPositive(who, "the arc radius", arcRadius);
  if (dim == 3) checkPositive(who, "the depth", depth);
  for (int d = 0; d < dim; ++d)
    if (cells[d] < 1)
      throw Error("roundedBlockMesh: need at least one cell in direction " + std::to_string(d) +
                  ", got " + std::to_string(cells[d]));
  const double R = arcRadius, half = 0.5 * width;
  if (R < half)
    throw Error("roundedBlockMesh: the arc radius " + std::to_string(R) +
                " is smaller than half the width " + std::to_string(half));
  // Height of the bottom arc above its lowest point (at x = width/2).
  auto bottom = [R, half](double x) {
    const double u = x - half;
    return R - std::sqrt(std::max(R * R - u * u, 0.0));
  };
  if (height <= bottom(0.0))
    throw Error("roundedBlockMesh: the height " + std::to_string(height) +
                " does not exceed the rise of the bottom arc " + std::to_string(bottom(0.0)));

  // Unit-height box, then every vertical line [0, 1] mapped linearly onto [bottom(x), height].
  const int up = dim == 3 ? 2 : 1;  // vertical direction
  Point upper(width, dim == 3 ? depth : 1.0, 1.0);
  if (dim == 2) upper[2] = 0.0;
  CurvedMesh out{boxMesh(type, cells, Point::Zero(), upper), {}};
  for (Index v = 0; v < out.mesh.numVertices(); ++v) {
    Point& x = out.mesh.vertex(v);
    const double s = x[up];
    x[up] = (1.0 - s) * bottom(x[0]) + s * height;  // exact at s = 0 and s = 1
  }
  // Pyramid apexes (the block centres, numbered after the grid vertices) move to the average of
  // the mapped block corners; the image of the box centre can lie below a steep bottom face.
  if (type == CellType::Pyramid) {
    const Index grid = (cells[0] + 1) * (cells[1] + 1) * (cells[2] + 1);
    std::vector<Point> sum(out.mesh.numVertices() - grid, Point::Zero());
    for (Index c = 0; c < out.mesh.numCells(); ++c) {
      const auto v = out.mesh.cellVertices(c);
      for (int i = 0; i < 4; ++i) sum[v[4] - grid] += out.mesh.vertex(v[i]);
    }
    // Each block corner is a base vertex of 3 of the 6 pyramids: 24 summands, 8 corners.
    for (Index v = grid; v < out.mesh.numVertices(); ++v) out.mesh.vertex(v) = sum[v - grid] / 24.0;
  }
  // Closest point on the cylinder (2D: circle) with axis through (width/2, R) in the x-up plane.
  out.projections[kBottom] = [R, half, up](const Point& x) -> Point {
    const double dx = x[0] - half, dz = x[up] - R, len = std::hypot(dx, dz);
    Point p = x;
    if (len == 0.0) {  // on the axis: every direction is closest; pick the lowest point
      p[up] = 0.0;
      return p;
    }
    p[0] = half + R * dx / len;
    p[up] = R + R * dz / len;
    return p;
  };
  return out;
}

}  // namespace obs::mesh
