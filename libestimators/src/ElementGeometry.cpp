#include "obs/estimators/ElementGeometry.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "ForEachIndex.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/Quadrature.hpp"

namespace obs::estimators {

std::vector<Index> cellFaceVertices(const mesh::Mesh& mesh, Index cell, int localFace) {
  std::vector<Index> fv;
  cellFaceVertices(mesh, cell, localFace, fv);
  return fv;
}

void cellFaceVertices(const mesh::Mesh& mesh, Index cell, int localFace, std::vector<Index>& fv) {
  const auto faces = mesh::localFaces(mesh.cellType(cell));
  if (localFace < 0 || localFace >= static_cast<int>(faces.size()))
    throw Error("cell " + std::to_string(cell) + " has no local face " + std::to_string(localFace));
  const auto verts = mesh.cellVertices(cell);
  fv.clear();
  for (int lv : faces[localFace].span()) fv.push_back(verts[lv]);
}

std::vector<CellFacePoint> cellFaceQuadrature(const mesh::Mesh& mesh, Index cell, int localFace,
                                              int degree) {
  std::vector<CellFacePoint> pts;
  cellFaceQuadrature(mesh, cell, localFace, degree, pts);
  return pts;
}

namespace {

/// Surface element J = |normal| and outward unit normal of local face lf of `cell` at the face
/// reference point s (from the face map's tangents there). Throws obs::Error on a degenerate face.
void faceFrame(const mesh::Mesh& mesh, Index cell, int localFace, const mesh::LocalFace& lf,
               const mesh::ReferenceElement& faceRef, const Point& s, double& J, Point& unitNormal) {
  const auto verts = mesh.cellVertices(cell);
  const int n = lf.size, fd = faceRef.dim;
  double g[4 * 2];
  faceRef.gradients(s, std::span<double>(g, n * fd));
  Point ds = Point::Zero(), dt = Point::Zero();
  for (int j = 0; j < n; ++j) {
    const Point& xj = mesh.vertex(verts[lf.vertices[j]]);
    ds += g[j * fd] * xj;
    if (fd == 2) dt += g[j * fd + 1] * xj;
  }
  // right-hand normal of the face's vertex cycle = outward normal (MeshTopology.hpp)
  const Point normal = fd == 1 ? Point(ds[1], -ds[0], 0) : Point(ds.cross(dt));
  J = normal.norm();
  if (!(J > 0))
    throw Error("face " + std::to_string(localFace) + " of cell " + std::to_string(cell) + " is degenerate");
  unitNormal = normal / J;
}

bool flatFaceType(mesh::CellType t) { return t == mesh::CellType::Segment || t == mesh::CellType::Triangle; }

}  // namespace

void cellFaceQuadrature(const mesh::Mesh& mesh, Index cell, int localFace, int degree,
                        std::vector<CellFacePoint>& pts) {
  const mesh::LocalFace& lf = mesh::localFaces(mesh.cellType(cell))[localFace];
  const auto& cellRef = mesh::referenceElement(mesh.cellType(cell));
  const auto& faceRef = mesh::referenceElement(lf.type);
  const auto& rule = mesh::quadratureRule(lf.type, degree);
  const auto verts = mesh.cellVertices(cell);
  const int n = lf.size;
  pts.assign(rule.size(), CellFacePoint{});
  // segments and triangles are flat with constant reference gradients: the normal and the surface
  // element of the first point hold at all points (the same numbers a re-evaluation would give)
  const bool flat = flatFaceType(lf.type);
  double J = 0;
  Point unitNormal = Point::Zero();
  for (std::size_t q = 0; q < rule.size(); ++q) {
    CellFacePoint& p = pts[q];
    faceRef.values(rule.points[q], std::span<double>(p.shape.data(), n));
    if (q == 0 || !flat) faceFrame(mesh, cell, localFace, lf, faceRef, rule.points[q], J, unitNormal);
    Point x = Point::Zero(), xi = Point::Zero();
    for (int j = 0; j < n; ++j) {
      x += p.shape[j] * mesh.vertex(verts[lf.vertices[j]]);
      xi += p.shape[j] * cellRef.vertices[lf.vertices[j]];
    }
    p.xi = xi;
    p.x = x;
    p.weight = J * rule.weights[q];
    p.normal = unitNormal;
  }
}

bool flatCellFaceQuadrature(const mesh::Mesh& mesh, Index cell, int localFace, int degree,
                            std::vector<double>& weights, Point& normal) {
  const mesh::LocalFace& lf = mesh::localFaces(mesh.cellType(cell))[localFace];
  if (!flatFaceType(lf.type)) return false;
  const auto& faceRef = mesh::referenceElement(lf.type);
  const auto& rule = mesh::quadratureRule(lf.type, degree);
  double J = 0;
  faceFrame(mesh, cell, localFace, lf, faceRef, rule.points[0], J, normal);
  weights.resize(rule.size());
  for (std::size_t q = 0; q < rule.size(); ++q) weights[q] = J * rule.weights[q];
  return true;
}

Point referencePointOnFace(const mesh::Mesh& mesh, Index cell, std::span<const Index> faceVertices,
                           std::span<const double> shape) {
  const auto& ref = mesh::referenceElement(mesh.cellType(cell));
  const auto verts = mesh.cellVertices(cell);
  Point xi = Point::Zero();
  for (std::size_t j = 0; j < faceVertices.size(); ++j) {
    const auto it = std::find(verts.begin(), verts.end(), faceVertices[j]);
    if (it == verts.end())
      throw Error("vertex " + std::to_string(faceVertices[j]) + " is not a vertex of cell " +
                  std::to_string(cell));
    xi += shape[j] * ref.vertices[static_cast<std::size_t>(it - verts.begin())];
  }
  return xi;
}

std::vector<double> patchDiameters(const mesh::Mesh& mesh) {
  const Index nv = mesh.numVertices();
  const mesh::VertexCells around = mesh::vertexCells(mesh);
  // The patches on threads() threads, each vertex's own maximum (the same for any thread count).
  // A pair (a, b) is no farther apart than r_a + r_b, its distances from p (the triangle
  // inequality through x_p), so with the vertices sorted by r descending the pairs of a stop at the
  // first b with r_a + r_b below the best distance found, and the vertices a at the first with
  // 2 r_a below it: once the diameter is found, among the farthest vertices, the rest is skipped.
  // The bound is relaxed by 1e-12 relative, far above the rounding of r_a + r_b, so the pruned
  // pairs are exactly those that cannot be the maximum: the result is bitwise the maximum over all
  // pairs.
  std::vector<double> h(nv, 0.0);
  struct Scratch {
    std::vector<Index> mark;  // mark[v] = the last vertex whose patch listed v
    std::vector<std::array<double, 4>> x;  // coordinates and distance from p, by distance descending
  };
  constexpr double kSlack = 1 + 1e-12;
  forEachIndex<Scratch>(nv, [&](Index p, Scratch& s) {
    if (s.mark.empty()) s.mark.assign(static_cast<std::size_t>(nv), -1);
    s.x.clear();
    const Point& xp = mesh.vertex(p);
    for (const Index c : around.cellsOf(p))
      for (Index v : mesh.cellVertices(c))
        if (s.mark[v] != p) {
          s.mark[v] = p;
          const Point& x = mesh.vertex(v);
          s.x.push_back({x[0], x[1], x[2], (x - xp).norm()});
        }
    std::sort(s.x.begin(), s.x.end(), [](const auto& u, const auto& w) { return u[3] > w[3]; });
    double d2 = 0, d = 0;  // the largest squared distance so far, and its root
    const std::size_t n = s.x.size();
    for (std::size_t a = 0; a < n && 2 * s.x[a][3] * kSlack >= d; ++a) {
      const auto& xa = s.x[a];
      for (std::size_t b = a + 1; b < n && (xa[3] + s.x[b][3]) * kSlack >= d; ++b) {
        const double dx = s.x[b][0] - xa[0], dy = s.x[b][1] - xa[1], dz = s.x[b][2] - xa[2];
        const double e2 = dx * dx + dy * dy + dz * dz;
        if (e2 > d2) {
          d2 = e2;
          d = std::sqrt(d2);
        }
      }
    }
    h[p] = std::sqrt(d2);
  });
  return h;
}

}  // namespace obs::estimators
