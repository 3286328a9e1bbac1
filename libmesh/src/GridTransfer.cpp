// Transfer operators between grid views (Prolongation.hpp): locating fine vertices in the coarse
// view through the hierarchy, Newton inversion of the reference maps, CSR products.
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs::mesh {

// ------------------------------------------------------------------------------------------------
void CsrMatrix::multiply(std::span<const double> x, std::span<double> y) const {
  for (Index r = 0; r < rows; ++r) {
    double s = 0;
    for (Index k = rowStart[r]; k < rowStart[r + 1]; ++k) s += values[k] * x[columns[k]];
    y[r] = s;
  }
}

std::vector<double> CsrMatrix::operator*(std::span<const double> x) const {
  std::vector<double> y(rows);
  multiply(x, y);
  return y;
}

void CsrMatrix::multiplyTransposed(std::span<const double> y, std::span<double> x) const {
  std::fill(x.begin(), x.end(), 0.0);
  for (Index r = 0; r < rows; ++r)
    for (Index k = rowStart[r]; k < rowStart[r + 1]; ++k) x[columns[k]] += values[k] * y[r];
}

// ------------------------------------------------------------------------------------------------
std::optional<Point> referenceCoordinates(CellType type, std::span<const Point> corners,
                                          const Point& x, double tol, int maxIterations) {
  const ReferenceElement& ref = referenceElement(type);
  const int n = ref.numVertices, d = ref.dim;
  std::array<double, 8> phi{};
  std::array<double, 24> grad{};
  Point xi = ref.centroid;
  double previousStep = std::numeric_limits<double>::infinity();
  for (int it = 0; it < maxIterations; ++it) {
    ref.values(xi, std::span<double>(phi.data(), n));
    ref.gradients(xi, std::span<double>(grad.data(), n * d));
    Point f = -x;
    Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
    for (int i = 0; i < n; ++i) {
      f += phi[i] * corners[i];
      for (int k = 0; k < d; ++k) J.col(k) += grad[i * d + k] * corners[i];
    }
    Point step = Point::Zero();
    if (d == 2) {
      const Eigen::Matrix2d J2 = J.topLeftCorner<2, 2>();
      if (!(std::abs(J2.determinant()) > 0)) return std::nullopt;
      step.head<2>() = J2.partialPivLu().solve(f.head<2>());
    } else {
      if (!(std::abs(J.determinant()) > 0)) return std::nullopt;
      step = J.partialPivLu().solve(f);
    }
    xi -= step;
    if (!xi.allFinite()) return std::nullopt;
    const double size = step.norm();
    if (size <= tol) return xi;
    // Converged to round-off: on small cells (|x| / diameter large) the attainable accuracy in
    // reference coordinates is about eps |x| / diameter, which can exceed tol; Newton then stops
    // contracting at a tiny step.
    if (size < 1e-8 && size > 0.5 * previousStep) return xi;
    previousStep = size;
  }
  return std::nullopt;
}

bool insideReferenceElement(CellType type, const Point& p, double tol) {
  const double x = p[0], y = p[1], z = p[2];
  auto in01 = [&](double t) { return t >= -tol && t <= 1 + tol; };
  switch (type) {
    case CellType::Segment: return in01(x);
    case CellType::Triangle: return x >= -tol && y >= -tol && x + y <= 1 + tol;
    case CellType::Quadrilateral: return in01(x) && in01(y);
    case CellType::Tetrahedron: return x >= -tol && y >= -tol && z >= -tol && x + y + z <= 1 + tol;
    case CellType::Hexahedron: return in01(x) && in01(y) && in01(z);
    case CellType::Prism: return x >= -tol && y >= -tol && x + y <= 1 + tol && in01(z);
    case CellType::Pyramid:
      return in01(z) && x >= -tol && y >= -tol && x <= 1 - z + tol && y <= 1 - z + tol;
  }
  return false;
}

// ------------------------------------------------------------------------------------------------
namespace {

/// How far reference coordinates lie outside the reference element (<= 0 inside).
double outside(CellType type, const Point& p) {
  const double x = p[0], y = p[1], z = p[2];
  switch (type) {
    case CellType::Triangle: return std::max({-x, -y, x + y - 1});
    case CellType::Quadrilateral: return std::max({-x, -y, x - 1, y - 1});
    case CellType::Tetrahedron: return std::max({-x, -y, -z, x + y + z - 1});
    case CellType::Hexahedron: return std::max({-x, -y, -z, x - 1, y - 1, z - 1});
    case CellType::Prism: return std::max({-x, -y, x + y - 1, -z, z - 1});
    case CellType::Pyramid: return std::max({-z, z - 1, -x, -y, x + z - 1, y + z - 1});
    default: return 0;
  }
}

std::optional<Point> locate(const Grid& grid, Index e, const Point& x) {
  std::array<Point, 8> y{};
  const auto v = grid.vertices(e);
  for (std::size_t i = 0; i < v.size(); ++i) y[i] = grid.vertex(v[i]);
  return referenceCoordinates(grid.type(e), std::span<const Point>(y.data(), v.size()), x);
}

}  // namespace

CsrMatrix transferMatrix(const Grid& grid, const GridView& coarse, const GridView& fine) {
  const Index ne = grid.numElements();
  std::vector<char> inCoarse(ne, 0);
  for (Index e : coarse.elements) {
    if (e < 0 || e >= ne) throw Error("transferMatrix: the coarse view is not a view of this grid");
    inCoarse[e] = 1;
  }
  // Coarse elements whose father is not coarse, grouped by father: where to descend to (this
  // includes green elements removed after the coarse view was taken).
  std::vector<std::pair<Index, Index>> byFather;
  for (Index e : coarse.elements)
    if (grid.level(e) > 0 && !inCoarse[grid.father(e)]) byFather.push_back({grid.father(e), e});
  std::sort(byFather.begin(), byFather.end());
  std::vector<Index> kids;
  // Position of a local point of an element, from its corners.
  auto position = [&](Index e, int point) {
    const auto w = LocalPoints::of(grid.type(e)).weights(point);
    const auto ev = grid.vertices(e);
    Point x = Point::Zero();
    for (std::size_t i = 0; i < ev.size(); ++i) x += w[i] * grid.vertex(ev[i]);
    return x;
  };
  auto coarseChildren = [&](Index e) {
    kids.clear();
    auto it = std::lower_bound(byFather.begin(), byFather.end(), std::pair<Index, Index>{e, -1});
    for (; it != byFather.end() && it->first == e; ++it) kids.push_back(it->second);
    // then the current children not in the coarse view (a red child created after the coarse view
    // was taken may cover x while its father's old green children are in the coarse view)
    for (int k = 0; k < grid.numChildren(e); ++k)
      if (!inCoarse[grid.child(e, k)]) kids.push_back(grid.child(e, k));
  };

  // The coarse element below e (inclusive) that contains x (within `tol` in reference
  // coordinates), with the reference coordinates of x.
  std::function<std::optional<std::pair<Index, Point>>(Index, const Point&, double)> descend =
      [&](Index e, const Point& x, double tol) -> std::optional<std::pair<Index, Point>> {
    if (inCoarse[e]) {
      const auto eta = locate(grid, e, x);
      if (!eta || outside(grid.type(e), *eta) > tol) return std::nullopt;
      return std::make_pair(e, *eta);
    }
    std::vector<std::pair<double, Index>> candidates;  // (distance outside, child), nearest first
    coarseChildren(e);
    for (Index c : kids) {
      const auto eta = locate(grid, c, x);
      if (!eta) continue;
      const double out = outside(grid.type(c), *eta);
      if (out <= tol) candidates.push_back({std::max(out, 0.0), c});
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [out, c] : candidates)
      if (auto r = descend(c, x, tol)) return r;
    return std::nullopt;
  };
  // Level-0 elements sharing a vertex with a level-0 element (built on first use). Green closures
  // of non-affine cells approximate curved faces by flat pieces, so a vertex created on a face of
  // one level-0 cell can lie in a coarse element below the neighbouring level-0 cell.
  std::vector<std::vector<Index>> rootsAtVertex;
  auto neighbourRoots = [&](Index root) {
    if (rootsAtVertex.empty()) {
      rootsAtVertex.resize(grid.numVertices());
      for (Index e = 0; e < ne; ++e)
        if (grid.level(e) == 0)
          for (Index w : grid.vertices(e)) rootsAtVertex[w].push_back(e);
    }
    std::vector<Index> out;
    for (Index w : grid.vertices(root))
      for (Index r : rootsAtVertex[w])
        if (r != root && std::find(out.begin(), out.end(), r) == out.end()) out.push_back(r);
    return out;
  };

  // Exact search first; then, for a vertex that lies outside every coarse element (on a curved
  // boundary with a projection: the corners of the element that created it were moved onto the
  // curve in the same adapt()), the nearest coarse element, extrapolated.
  auto locateInCoarse = [&](Index e, const Point& x) {
    for (const double tol : {1e-6, std::numeric_limits<double>::infinity()}) {
      auto found = descend(e, x, tol);
      if (!found && grid.level(e) == 0)
        for (Index r : neighbourRoots(e))
          if ((found = descend(r, x, tol))) break;
      if (found) return found;
    }
    return std::optional<std::pair<Index, Point>>{};
  };

  CsrMatrix P;
  P.rows = static_cast<Index>(fine.vertices.size());
  P.cols = static_cast<Index>(coarse.vertices.size());
  P.rowStart.reserve(P.rows + 1);
  P.columns.reserve(P.rows * 2);
  P.values.reserve(P.rows * 2);
  std::array<double, 8> phi{};
  std::vector<std::pair<Index, double>> row;
  for (Index i = 0; i < P.rows; ++i) {
    const Index v = fine.vertices[i];
    const Index cv = coarse.viewVertex(v);
    if (cv >= 0) {
      P.columns.push_back(cv);
      P.values.push_back(1.0);
      P.rowStart.push_back(P.nonZeros());
      continue;
    }
    const Grid::Origin o = grid.vertexOrigin(v);
    if (o.element < 0)
      throw Error("transferMatrix: fine vertex " + std::to_string(v) +
                  " is a coarse-grid vertex missing from the coarse view (views not nested)");
    Index e = o.element;
    Point xi = LocalPoints::of(grid.type(e)).reference(o.point);
    if (!inCoarse[e]) {
      // The (unprojected) position of the vertex, located in the coarse view: in a coarse
      // ancestor of the creating element, or else among its descendants in the coarse view.
      const Point x = position(e, o.point);
      Index a = e;
      while (!inCoarse[a] && grid.level(a) > 0) a = grid.father(a);
      if (inCoarse[a]) {
        const auto eta = locate(grid, a, x);
        if (!eta) throw Error("transferMatrix: cannot locate fine vertex " + std::to_string(v));
        e = a;
        xi = *eta;
      } else {
        e = a;  // no coarse ancestor: descend from the level-0 ancestor (e itself may be new)
      }
      // Depth-first descent to the coarse element containing x. Several children may contain x
      // (x on a shared face, old green and new red children of one father); a branch can end in
      // new leaves that are not in the coarse view, so the search backtracks.
      if (!inCoarse[e]) {
        const auto found = locateInCoarse(e, x);
        if (!found)
          throw Error("transferMatrix: fine vertex " + std::to_string(v) +
                      " is not covered by the coarse view (views not nested)");
        e = found->first;
        xi = found->second;
      }
    }
    const ReferenceElement& ref = referenceElement(grid.type(e));
    ref.values(xi, std::span<double>(phi.data(), ref.numVertices));
    row.clear();
    const auto ev = grid.vertices(e);
    for (int k = 0; k < ref.numVertices; ++k)
      if (std::abs(phi[k]) > 1e-14) row.push_back({coarse.vertexIndex[ev[k]], phi[k]});
    std::sort(row.begin(), row.end());
    for (const auto& [c, w] : row) {
      P.columns.push_back(c);
      P.values.push_back(w);
    }
    P.rowStart.push_back(P.nonZeros());
  }
  return P;
}

CsrMatrix prolongation(const Grid& grid, int coarseLevel) {
  if (coarseLevel < 0 || coarseLevel >= grid.maxLevel())
    throw Error("prolongation: coarse level " + std::to_string(coarseLevel) + " not in [0, " +
                std::to_string(grid.maxLevel()) + ")");
  return transferMatrix(grid, grid.levelView(coarseLevel), grid.levelView(coarseLevel + 1));
}

}  // namespace obs::mesh
