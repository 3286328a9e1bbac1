// Structured box meshes of every cell type and a mixed-type 3D box mesh.
#include "obs/mesh/BoxMesh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"

namespace obs::mesh {
namespace {

/// Block-grid vertices of a box and cell insertion with automatic orientation.
class BoxBuilder {
public:
  BoxBuilder(const char* who, int dim, std::array<int, 3> cells, const Point& lower,
             const Point& upper)
      : mesh_(dim), dim_(dim), lower_(lower), upper_(upper) {
    std::int64_t count = 1;
    for (int d = 0; d < 3; ++d) {
      n_[d] = d < dim ? cells[d] : 0;
      if (d >= dim) continue;
      if (cells[d] < 1)
        throw Error(std::string(who) + ": need at least one cell in direction " +
                    std::to_string(d) + ", got " + std::to_string(cells[d]));
      if (!(std::isfinite(lower[d]) && std::isfinite(upper[d]) && upper[d] > lower[d]))
        throw Error(std::string(who) + ": the box needs lower < upper in direction " +
                    std::to_string(d) + ", got [" + std::to_string(lower[d]) + ", " +
                    std::to_string(upper[d]) + "]");
      count *= cells[d] + 1;
    }
    if (2 * count > std::numeric_limits<Index>::max())
      throw Error(std::string(who) + ": too many cells for 32-bit indices");
    // The grid coordinates must be finite and distinct in floating point (a box 1e-320 wide or
    // 1e308 long is not, whatever the cell count).
    for (int d = 0; d < dim; ++d)
      for (int i = 0; i < n_[d]; ++i)
        if (!(std::isfinite(coord(d, i + 1)) && coord(d, i) < coord(d, i + 1)))
          throw Error(std::string(who) + ": the box [" + std::to_string(lower[d]) + ", " +
                      std::to_string(upper[d]) + "] in direction " + std::to_string(d) +
                      " cannot be divided into " + std::to_string(cells[d]) +
                      " cells in floating point (grid coordinates coincide or overflow)");
    for (int k = 0; k <= n_[2]; ++k)
      for (int j = 0; j <= n_[1]; ++j)
        for (int i = 0; i <= n_[0]; ++i)
          mesh_.addVertex(Point(coord(0, i), coord(1, j), dim == 3 ? coord(2, k) : 0.0));
  }

  Mesh& mesh() { return mesh_; }
  const std::array<int, 3>& n() const { return n_; }

  /// Grid vertex (i, j, k) (k = 0 in 2D).
  Index vertex(int i, int j, int k = 0) const { return i + (n_[0] + 1) * (j + (n_[1] + 1) * k); }

  /// Adds a cell; if the given vertex order is negatively oriented, it is mirrored first.
  void addCell(CellType type, std::vector<Index> v) {
    if (!oriented(type, v)) {
      // Mirror: swap positions (p, q) (and (r, s)) of the vertex list.
      int p = 1, q = 2, r = 0, s = 0;  // triangle, tetrahedron
      if (type == CellType::Quadrilateral || type == CellType::Pyramid) q = 3;
      if (type == CellType::Hexahedron) q = 3, r = 5, s = 7;
      if (type == CellType::Prism) r = 4, s = 5;
      const auto n = static_cast<int>(v.size());
      if (q < n) std::swap(v[p], v[q]);
      if (s < n) std::swap(v[r], v[s]);
      if (!oriented(type, v))  // a cell of zero volume in floating point (e.g. 1e-200 x 1e-200)
        throw Error("boxMesh: a cell of the box is degenerate in floating point (its volume "
                    "underflows); scale the box or use fewer cells");
    }
    mesh_.addCell(type, v);
  }

  /// Lists every one-cell face as a boundary face (in the cell's outward orientation) with the id
  /// of the box side it lies on, and names the sides.
  Mesh finish() {
    const FaceTable faces(mesh_);
    const double tol = 1e-10 * (upper_ - lower_).head(dim_).cwiseAbs().maxCoeff();
    std::array<Index, 4> fv{};
    for (Index f = 0; f < faces.numFaces(); ++f) {
      if (faces.numCells(f) != 1) continue;
      const auto& side = faces.side(f, 0);
      const LocalFace& lf = localFaces(mesh_.cellType(side.cell))[side.localFace];
      const auto cv = mesh_.cellVertices(side.cell);
      Point centre = Point::Zero();
      for (int i = 0; i < lf.size; ++i) {
        fv[i] = cv[lf.vertices[i]];
        centre += mesh_.vertex(fv[i]);
      }
      centre /= lf.size;
      const int id = sideId(centre, tol);
      if (id == 0) throw std::logic_error("boxMesh: a boundary face off the box sides");
      mesh_.addBoundaryFace({fv.data(), static_cast<std::size_t>(lf.size)}, id);
    }
    mesh_.setBoundaryName(kLeft, "left");
    mesh_.setBoundaryName(kRight, "right");
    mesh_.setBoundaryName(kBottom, "bottom");
    mesh_.setBoundaryName(kTop, "top");
    if (dim_ == 3) {
      mesh_.setBoundaryName(kFront, "front");
      mesh_.setBoundaryName(kBack, "back");
    }
    return std::move(mesh_);
  }

private:
  double coord(int d, int i) const {  // exact at both ends
    return (lower_[d] * (n_[d] - i) + upper_[d] * i) / n_[d];
  }
  bool oriented(CellType type, const std::vector<Index>& v) const {
    std::array<Point, 8> x;
    for (std::size_t i = 0; i < v.size(); ++i) x[i] = mesh_.vertex(v[i]);
    return isPositivelyOriented(type, std::span<const Point>(x.data(), v.size()));
  }
  int sideId(const Point& c, double tol) const {
    if (std::abs(c[0] - lower_[0]) <= tol) return kLeft;
    if (std::abs(c[0] - upper_[0]) <= tol) return kRight;
    const int vertical = dim_ == 2 ? 1 : 2;  // bottom/top direction
    if (std::abs(c[vertical] - lower_[vertical]) <= tol) return kBottom;
    if (std::abs(c[vertical] - upper_[vertical]) <= tol) return kTop;
    if (dim_ == 3 && std::abs(c[1] - lower_[1]) <= tol) return kFront;
    if (dim_ == 3 && std::abs(c[1] - upper_[1]) <= tol) return kBack;
    return 0;
  }

  Mesh mesh_;
  int dim_;
  Point lower_, upper_;
  std::array<int, 3> n_{};
};

/// Corner (a, b, c) in {0,1}^3 of block (i, j, k), mirrored along the axes with r[d] = 1.
Index corner(const BoxBuilder& b, int i, int j, int k, int a, int c, int d,
             std::array<int, 3> r = {0, 0, 0}) {
  return b.vertex(i + (a ^ r[0]), j + (c ^ r[1]), k + (d ^ r[2]));
}

/// The 6 Kuhn tetrahedra of block (i, j, k) around its (mirrored) main diagonal: one per
/// permutation of the axes, along the monotone corner path from (0,0,0) to (1,1,1).
void addKuhnTets(BoxBuilder& b, int i, int j, int k, std::array<int, 3> mirror) {
  std::array<int, 3> axes = {0, 1, 2};
  do {
    std::array<int, 3> p = {0, 0, 0};
    std::vector<Index> v = {corner(b, i, j, k, 0, 0, 0, mirror)};
    for (int axis : axes) {
      p[axis] = 1;
      v.push_back(corner(b, i, j, k, p[0], p[1], p[2], mirror));
    }
    b.addCell(CellType::Tetrahedron, v);
  } while (std::next_permutation(axes.begin(), axes.end()));
}

void addHex(BoxBuilder& b, int i, int j, int k) {
  b.addCell(CellType::Hexahedron,
            {b.vertex(i, j, k), b.vertex(i + 1, j, k), b.vertex(i + 1, j + 1, k),
             b.vertex(i, j + 1, k), b.vertex(i, j, k + 1), b.vertex(i + 1, j, k + 1),
             b.vertex(i + 1, j + 1, k + 1), b.vertex(i, j + 1, k + 1)});
}

/// Two prisms with axis along z, split along the (x0,y0)-(x1,y1) diagonal.
void addPrismsZ(BoxBuilder& b, int i, int j, int k) {
  for (int t = 0; t < 2; ++t) {
    std::vector<Index> v;
    for (int c = 0; c < 2; ++c) {
      v.push_back(b.vertex(i, j, k + c));
      v.push_back(t == 0 ? b.vertex(i + 1, j, k + c) : b.vertex(i + 1, j + 1, k + c));
      v.push_back(t == 0 ? b.vertex(i + 1, j + 1, k + c) : b.vertex(i, j + 1, k + c));
    }
    b.addCell(CellType::Prism, v);
  }
}

/// Two prisms with axis along x, split along the (y0,z0)-(y1,z1) diagonal.
void addPrismsX(BoxBuilder& b, int i, int j, int k) {
  for (int t = 0; t < 2; ++t) {
    std::vector<Index> v;
    for (int a = 0; a < 2; ++a) {
      v.push_back(b.vertex(i + a, j, k));
      v.push_back(t == 0 ? b.vertex(i + a, j + 1, k) : b.vertex(i + a, j + 1, k + 1));
      v.push_back(t == 0 ? b.vertex(i + a, j + 1, k + 1) : b.vertex(i + a, j, k + 1));
    }
    b.addCell(CellType::Prism, v);
  }
}

/// Six pyramids over the faces of block (i, j, k) with a new apex at the block centre.
void addSixPyramids(BoxBuilder& b, int i, int j, int k) {
  const Index hex[8] = {b.vertex(i, j, k),
                        b.vertex(i + 1, j, k),
                        b.vertex(i + 1, j + 1, k),
                        b.vertex(i, j + 1, k),
                        b.vertex(i, j, k + 1),
                        b.vertex(i + 1, j, k + 1),
                        b.vertex(i + 1, j + 1, k + 1),
                        b.vertex(i, j + 1, k + 1)};
  Point centre = Point::Zero();
  for (Index v : hex) centre += b.mesh().vertex(v);
  const Index apex = b.mesh().addVertex(centre / 8.0);
  for (const LocalFace& f : localFaces(CellType::Hexahedron))
    // The outward face cycle reversed has its normal pointing into the block, towards the apex.
    b.addCell(CellType::Pyramid, {hex[f.vertices[3]], hex[f.vertices[2]], hex[f.vertices[1]],
                                  hex[f.vertices[0]], apex});
}

/// Three pyramids with common apex at block corner (ax, ay, 1); their bases are the block faces
/// x = 1-ax, y = 1-ay and z = 0 (cycle order; addCell fixes the orientation).
void addThreePyramids(BoxBuilder& b, int i, int j, int k, int ax, int ay) {
  const Index apex = corner(b, i, j, k, ax, ay, 1);
  const int cyc[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  std::vector<Index> x, y, z;
  for (const auto& c : cyc) {
    x.push_back(corner(b, i, j, k, 1 - ax, c[0], c[1]));
    y.push_back(corner(b, i, j, k, c[0], 1 - ay, c[1]));
    z.push_back(corner(b, i, j, k, c[0], c[1], 0));
  }
  for (auto* base : {&x, &y, &z}) {
    base->push_back(apex);
    b.addCell(CellType::Pyramid, *base);
  }
}

}  // namespace

Mesh boxMesh(CellType type, std::array<int, 3> cells, const Point& lower, const Point& upper) {
  if (type == CellType::Segment) throw Error("boxMesh: segments are not a cell type of a mesh");
  BoxBuilder b("boxMesh", dimension(type), cells, lower, upper);
  const auto n = b.n();
  if (dimension(type) == 2) {
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        const Index v00 = b.vertex(i, j), v10 = b.vertex(i + 1, j), v11 = b.vertex(i + 1, j + 1),
                    v01 = b.vertex(i, j + 1);
        if (type == CellType::Quadrilateral) {
          b.addCell(type, {v00, v10, v11, v01});
        } else {
          b.addCell(type, {v00, v10, v11});
          b.addCell(type, {v00, v11, v01});
        }
      }
    return b.finish();
  }
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) switch (type) {
          case CellType::Tetrahedron: addKuhnTets(b, i, j, k, {0, 0, 0}); break;
          case CellType::Hexahedron: addHex(b, i, j, k); break;
          case CellType::Prism: addPrismsZ(b, i, j, k); break;
          case CellType::Pyramid: addSixPyramids(b, i, j, k); break;
          default: break;
        }
  return b.finish();
}

Mesh boxMesh(CellType type, int n, const Point& lower, const Point& upper) {
  return boxMesh(type, {n, n, n}, lower, upper);
}

Mesh mixedBoxMesh3D(std::array<int, 3> cells, const Point& lower, const Point& upper) {
  if (cells[2] < 4)
    throw Error("mixedBoxMesh3D: need at least 4 cell layers in z (one per cell type), got " +
                std::to_string(cells[2]));
  BoxBuilder b("mixedBoxMesh3D", 3, cells, lower, upper);
  const auto n = b.n();
  // Slab boundaries: slab s holds layers [first[s], first[s+1]).
  std::array<int, 5> first{};
  for (int s = 0; s < 4; ++s) first[s + 1] = first[s] + n[2] / 4 + (s < n[2] % 4 ? 1 : 0);
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        if (k < first[1]) {
          addHex(b, i, j, k);
        } else if (k < first[2]) {
          addPrismsX(b, i, j, k);
        } else if (k < first[3] - 1) {
          addSixPyramids(b, i, j, k);
        } else if (k == first[3] - 1) {
          addThreePyramids(b, i, j, k, i % 2 == 0 ? 1 : 0, j % 2 == 0 ? 1 : 0);
        } else {
          addKuhnTets(b, i, j, k, {i % 2, j % 2, k % 2});
        }
      }
  return b.finish();
}

}  // namespace obs::mesh
