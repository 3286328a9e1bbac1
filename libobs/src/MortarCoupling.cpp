#include "obs/obs/MortarCoupling.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs {
namespace {

using Vec2 = Eigen::Vector2d;
using Box = Eigen::AlignedBox3d;

// Gauss rules on the clipped pieces. Where both faces are affine (segments, triangles,
// parallelograms), psi_p phi_q is a polynomial of degree <= 4 in the plane coordinates and degree 6
// integrates it exactly. Where one is not (a quadrilateral that is no parallelogram: its reference
// coordinates are not polynomial in the plane coordinates), no rule is exact; see quadratureDegree.
constexpr int kClipDegree = 6;
constexpr int kFaceDegree = 4;        // face mass matrices M_e (exact: phi_i phi_j |J| is Q3 at most)

/// One boundary face of a mortar surface with its geometry.
struct SurfaceFace {
  mesh::CellType type;
  std::array<Index, 4> v{};  ///< mesh vertices
  int n = 0;
  Point centre, normal;      ///< outward unit normal at the centre
  double measure = 0, diameter = 0;
  /// |x0 - x1 + x2 - x3| / diameter of a quadrilateral (the bilinear term of its map from the unit
  /// square), 0 for segments, triangles and parallelograms (affine maps)
  double nonAffinity = 0;
  Box box;
};

std::string pointString(const Point& x, int dim) {
  std::ostringstream os;
  os << "(" << x[0] << ", " << x[1];
  if (dim == 3) os << ", " << x[2];
  os << ")";
  return os.str();
}

/// The faces with the surface's id, outward normals (orientation from the adjacent cell), measures.
std::vector<SurfaceFace> collectFaces(const MortarSurface& s) {
  const mesh::Mesh& m = *s.mesh;
  const int dim = m.dimension();
  std::vector<Index> faces;
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    if (m.boundaryFaceId(f) == s.boundaryId) faces.push_back(f);
  if (faces.empty()) throw Error("mortar surface " + s.label + ": no boundary face has this id");

  // vertex -> cells, only for the vertices of the surface
  std::vector<char> onSurface(m.numVertices(), 0);
  for (Index f : faces)
    for (Index v : m.boundaryFaceVertices(f)) onSurface[v] = 1;
  std::vector<std::vector<Index>> cellsOf(m.numVertices());
  for (Index c = 0; c < m.numCells(); ++c)
    for (Index v : m.cellVertices(c))
      if (onSurface[v]) cellsOf[v].push_back(c);

  std::vector<SurfaceFace> out;
  out.reserve(faces.size());
  for (Index f : faces) {
    const auto fv = m.boundaryFaceVertices(f);
    SurfaceFace sf;
    sf.type = m.boundaryFaceType(f);
    sf.n = static_cast<int>(fv.size());
    sf.centre.setZero();
    for (int i = 0; i < sf.n; ++i) {
      sf.v[i] = fv[i];
      const Point& x = m.vertex(fv[i]);
      if (!x.allFinite())
        throw Error("mortar surface " + s.label + ": vertex " + std::to_string(fv[i]) + " has a non-finite coordinate");
      sf.centre += x;
      sf.box.extend(x);
    }
    sf.centre /= sf.n;
    sf.diameter = sf.box.diagonal().norm();
    if (sf.n == 4) {
      // x0 - x1 + x2 - x3 is the coefficient of the bilinear term of the map from the unit square
      const Point bilinear = m.vertex(fv[0]) - m.vertex(fv[1]) + m.vertex(fv[2]) - m.vertex(fv[3]);
      sf.nonAffinity = bilinear.norm() / sf.diameter;
      if (sf.nonAffinity <= 1e-12) sf.nonAffinity = 0;  // a parallelogram up to the rounding of its vertices
    }
    const Point& x0 = m.vertex(fv[0]);
    Point n;
    if (dim == 2) {
      const Point t = m.vertex(fv[1]) - x0;
      n = Point(t[1], -t[0], 0);
      sf.measure = t.norm();
    } else if (sf.n == 3) {
      n = (m.vertex(fv[1]) - x0).cross(m.vertex(fv[2]) - x0);
      sf.measure = 0.5 * n.norm();
    } else {
      n = (m.vertex(fv[2]) - x0).cross(m.vertex(fv[3]) - m.vertex(fv[1]));
      sf.measure = 0.5 * n.norm();
    }
    const double len = n.norm();
    if (!(len > 1e-12 * std::pow(sf.diameter, dim - 1)) || !(sf.diameter > 0))
      throw Error("mortar surface " + s.label + ": the face with vertices " + std::to_string(fv[0]) + ", " +
                  std::to_string(fv[1]) + ", ... at " + pointString(sf.centre, dim) + " is degenerate");
    n /= len;
    // orientation: away from the centroid of the adjacent cell
    bool found = false;
    for (Index c : cellsOf[fv[0]]) {
      const auto cv = m.cellVertices(c);
      if (!std::all_of(fv.begin(), fv.end(), [&](Index v) { return std::find(cv.begin(), cv.end(), v) != cv.end(); }))
        continue;
      Point cc = Point::Zero();
      for (Index v : cv) cc += m.vertex(v);
      cc /= static_cast<double>(cv.size());
      if (n.dot(sf.centre - cc) < 0) n = -n;
      found = true;
      break;
    }
    if (!found)
      throw Error("mortar surface " + s.label + ": the boundary face with first vertex " + std::to_string(fv[0]) +
                  " is not a face of any cell");
    sf.normal = n;
    out.push_back(sf);
  }
  return out;
}

/// A uniform bucket grid over boxes (the master faces), queried with a box.
class BoxGrid {
public:
  BoxGrid(const std::vector<SurfaceFace>& faces, int dim) : dim_(dim) {
    double h = 0;
    for (const auto& f : faces) {
      all_.extend(f.box);
      h += f.diameter;
    }
    h /= static_cast<double>(faces.size());
    const Point ext = all_.sizes();
    for (int a = 0; a < 3; ++a) {
      n_[a] = a < dim ? std::clamp(static_cast<int>(ext[a] / h) + 1, 1, 512) : 1;
      h_[a] = std::max(ext[a] / n_[a], 1e-300);
    }
    cells_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
    for (std::size_t i = 0; i < faces.size(); ++i) visit(faces[i].box, [&](std::size_t c) { cells_[c].push_back(static_cast<Index>(i)); });
    mark_.assign(faces.size(), -1);
  }
  /// Faces whose box intersects `box` (each once).
  void query(const Box& box, Index stamp, std::vector<Index>& out) {
    out.clear();
    if (!all_.intersects(box)) return;
    visit(box, [&](std::size_t c) {
      for (Index f : cells_[c])
        if (mark_[f] != stamp) {
          mark_[f] = stamp;
          out.push_back(f);
        }
    });
  }

private:
  template <class F>
  void visit(const Box& box, F&& f) const {
    std::array<int, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::clamp(static_cast<int>(std::floor((box.min()[a] - all_.min()[a]) / h_[a])), 0, n_[a] - 1);
      hi[a] = std::clamp(static_cast<int>(std::floor((box.max()[a] - all_.min()[a]) / h_[a])), 0, n_[a] - 1);
    }
    for (int k = lo[2]; k <= hi[2]; ++k)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int i = lo[0]; i <= hi[0]; ++i) f((static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i);
  }
  int dim_;
  Box all_;
  std::array<int, 3> n_{};
  std::array<double, 3> h_{};
  std::vector<std::vector<Index>> cells_;
  std::vector<Index> mark_;
};

/// Degree of the rule on the clipped pieces of two faces with the larger non-affinity delta
/// (SurfaceFace::nonAffinity). The integrand is analytic on the faces and the error falls
/// geometrically with the degree and grows with delta. Calibrated on the patch test with
/// quadrilaterals distorted within the interface plane (test MortarPatchDistorted, seven face-type
/// cases; docs/theory.md#dual-mortar); largest relative pressure error with one degree for all pairs:
///   faces moved by up to 0.3 h (delta up to 0.50): degree 6 1.2e-6, 8 6.3e-8, 10 3.8e-9, 12 2.5e-10,
///   14 2.1e-11, 16 3e-12;  by 0.1 h (delta up to 0.16): degree 6 9e-10, 8 6e-12;  by 0.03 h
///   (delta up to 0.05): 4e-12 with degree 6.
/// 3e-12 is the round-off floor of these solves. With the bands below every case is at the floor
/// for moves of 0.01 .. 0.3 h and at 4e-11 for 0.4 h (delta up to 0.66). Cost: 25, 49, 81, 121 and
/// 169 points per piece for degrees 8 .. 24 against 16 for degree 6.
int quadratureDegree(double delta) {
  if (delta == 0) return kClipDegree;  // exact
  if (delta <= 0.02) return 8;
  if (delta <= 0.1) return 12;
  if (delta <= 0.3) return 16;
  if (delta <= 0.6) return 20;
  return 24;
}

double cross2(const Vec2& a, const Vec2& b) { return a[0] * b[1] - a[1] * b[0]; }

double signedArea(const std::vector<Vec2>& p) {
  double a = 0;
  for (std::size_t i = 0; i < p.size(); ++i) a += cross2(p[i], p[(i + 1) % p.size()]);
  return 0.5 * a;
}

/// Sutherland-Hodgman: the part of `subject` inside the convex counter-clockwise polygon `clip`.
std::vector<Vec2> clipPolygon(std::vector<Vec2> subject, const std::vector<Vec2>& clip) {
  std::vector<Vec2> in;
  for (std::size_t e = 0; e < clip.size() && !subject.empty(); ++e) {
    const Vec2 a = clip[e], b = clip[(e + 1) % clip.size()];
    const Vec2 t = b - a;
    in.swap(subject);
    subject.clear();
    for (std::size_t i = 0; i < in.size(); ++i) {
      const Vec2& p = in[i];
      const Vec2& q = in[(i + 1) % in.size()];
      const double sp = cross2(t, p - a), sq = cross2(t, q - a);
      if (sp >= 0) subject.push_back(p);
      if ((sp >= 0) != (sq >= 0)) subject.push_back(p + (sp / (sp - sq)) * (q - p));
    }
  }
  return subject;
}

/// Reference coordinates of X in a face whose vertices (projected to the plane) are Y: linear on
/// segments and triangles, Newton's method on quadrilaterals.
Point localCoordinates(mesh::CellType type, const std::vector<Vec2>& Y, const Vec2& X, int dim) {
  if (dim == 2) {
    const double t = (X[0] - Y[0][0]) / (Y[1][0] - Y[0][0]);
    return Point(t, 0, 0);
  }
  if (type == mesh::CellType::Triangle) {
    Eigen::Matrix2d J;
    J << Y[1] - Y[0], Y[2] - Y[0];
    const Vec2 xi = J.partialPivLu().solve(X - Y[0]);
    return Point(xi[0], xi[1], 0);
  }
  const auto& ref = mesh::referenceElement(mesh::CellType::Quadrilateral);
  Point xi(0.5, 0.5, 0);
  double phi[4], grad[8];
  for (int it = 0; it < 30; ++it) {
    ref.values(xi, phi);
    ref.gradients(xi, grad);
    Vec2 r = -X;
    Eigen::Matrix2d J = Eigen::Matrix2d::Zero();
    for (int i = 0; i < 4; ++i) {
      r += phi[i] * Y[i];
      J.col(0) += grad[2 * i] * Y[i];
      J.col(1) += grad[2 * i + 1] * Y[i];
    }
    const Vec2 step = J.partialPivLu().solve(r);
    xi[0] -= step[0];
    xi[1] -= step[1];
    if (step.norm() < 1e-14) break;
  }
  return xi;
}

/// Dual-basis coefficients A_e = D_e M_e^{-1} of a slave face (row i: psi_i = sum_j A_ij phi_j) and
/// the integrals int_e phi_i.
void dualBasis(const mesh::Mesh& m, const SurfaceFace& f, Eigen::Matrix4d& A, std::array<double, 4>& mass) {
  const auto& ref = mesh::referenceElement(f.type);
  const auto& rule = mesh::quadratureRule(f.type, kFaceDegree);
  const int n = f.n;
  Eigen::MatrixXd Me = Eigen::MatrixXd::Zero(n, n);
  double phi[4], grad[8];
  for (std::size_t q = 0; q < rule.size(); ++q) {
    ref.values(rule.points[q], phi);
    ref.gradients(rule.points[q], grad);
    Point ds = Point::Zero(), dt = Point::Zero();
    for (int i = 0; i < n; ++i) {
      ds += grad[i * ref.dim] * m.vertex(f.v[i]);
      if (ref.dim == 2) dt += grad[i * ref.dim + 1] * m.vertex(f.v[i]);
    }
    const double J = ref.dim == 1 ? ds.norm() : ds.cross(dt).norm();
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) Me(i, j) += rule.weights[q] * J * phi[i] * phi[j];
  }
  const Eigen::MatrixXd Ae = Me.rowwise().sum().asDiagonal() * Me.inverse();
  A.setZero();
  A.topLeftCorner(n, n) = Ae;
  for (int i = 0; i < n; ++i) mass[i] = Me.row(i).sum();
}

}  // namespace

MortarCoupling::MortarCoupling(const MortarSurface& slave, const MortarSurface& master, Index numStackedVertices,
                               const MortarOptions& options)
    : numStacked_(numStackedVertices), label_(slave.label + " / " + master.label) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!slave.mesh || !master.mesh) throw Error("mortar coupling " + label_ + ": missing mesh");
  dim_ = slave.mesh->dimension();
  if (master.mesh->dimension() != dim_)
    throw Error("mortar coupling " + label_ + ": the slave mesh has dimension " + std::to_string(dim_) +
                ", the master mesh " + std::to_string(master.mesh->dimension()));
  if (slave.mesh == master.mesh && slave.vertexOffset == master.vertexOffset)
    throw Error("mortar coupling " + label_ + ": slave and master belong to the same body (self-contact is not supported)");
  if (slave.vertexOffset < 0 || slave.vertexOffset + slave.mesh->numVertices() > numStacked_ || master.vertexOffset < 0 ||
      master.vertexOffset + master.mesh->numVertices() > numStacked_)
    throw Error("mortar coupling " + label_ + ": vertex offsets outside the stacked numbering");
  if (!(options.minCoverage > 0 && options.minCoverage <= 1))
    throw Error("mortar coupling " + label_ + ": minCoverage must be in (0, 1]");

  const mesh::Mesh& sm = *slave.mesh;
  const mesh::Mesh& mm = *master.mesh;
  const std::vector<SurfaceFace> sf = collectFaces(slave);
  const std::vector<SurfaceFace> mf = collectFaces(master);
  stats_.slaveFaces = static_cast<Index>(sf.size());
  stats_.masterFaces = static_cast<Index>(mf.size());

  // slave vertices, nodal normals, masses
  std::vector<Index> local(sm.numVertices(), -1);  // slave mesh vertex -> slave node
  std::vector<Index> verts;
  for (const auto& f : sf)
    for (int i = 0; i < f.n; ++i) local[f.v[i]] = 0;
  for (Index v = 0; v < sm.numVertices(); ++v)
    if (local[v] == 0) {
      local[v] = static_cast<Index>(verts.size());
      verts.push_back(v);
    }
  const std::size_t ns = verts.size();
  std::vector<Point> nodal(ns, Point::Zero());
  for (const auto& f : sf)
    for (int i = 0; i < f.n; ++i) nodal[local[f.v[i]]] += f.measure * f.normal;
  for (auto& n : nodal) n.normalize();
  std::vector<double> mass(ns, 0.0), Dsum(ns, 0.0), gap(ns, 0.0);
  std::vector<std::vector<Entry>> rows(ns);

  // the potential contact zone: master faces within the search distance of a slave face (default:
  // a tenth of the slave surface's extent, at least its largest face; independent of the refinement)
  double search = options.searchDistance;
  if (!(search > 0)) {
    Box extent;
    double largest = 0;
    for (const auto& f : sf) {
      extent.extend(f.box);
      largest = std::max(largest, f.diameter);
    }
    search = defaultMortarSearchDistance(extent.diagonal().norm(), largest);
  }

  BoxGrid grid(mf, dim_);
  std::vector<Index> candidates;
  const mesh::CellType pieceType = dim_ == 2 ? mesh::CellType::Segment : mesh::CellType::Triangle;
  double phiS[4], phiM[4], psi[4];
  Eigen::Matrix4d A;
  std::array<double, 4> faceMass{};
  std::vector<Vec2> S, Mp, MpCcw, Sccw;

  for (std::size_t e = 0; e < sf.size(); ++e) {
    const SurfaceFace& f = sf[e];
    dualBasis(sm, f, A, faceMass);
    for (int i = 0; i < f.n; ++i) mass[local[f.v[i]]] += faceMass[i];

    // plane of the face: origin at the centre, axes t1 (, t2) orthogonal to the normal
    const Point& ne = f.normal;
    Point t1, t2;
    if (dim_ == 2) {
      t1 = Point(-ne[1], ne[0], 0);
      t2 = Point::Zero();
    } else {
      t1 = (std::abs(ne[0]) < 0.9 ? Point::UnitX() : Point::UnitY()).cross(ne).normalized();
      t2 = ne.cross(t1);
    }
    auto project = [&](const Point& x) { return Vec2((x - f.centre).dot(t1), (x - f.centre).dot(t2)); };
    S.clear();
    for (int i = 0; i < f.n; ++i) S.push_back(project(sm.vertex(f.v[i])));
    Sccw = S;
    if (dim_ == 3 && signedArea(Sccw) < 0) std::reverse(Sccw.begin(), Sccw.end());

    Box query = f.box;
    query.min().array() -= search;
    query.max().array() += search;
    grid.query(query, static_cast<Index>(e), candidates);
    for (Index c : candidates) {
      const SurfaceFace& g = mf[c];
      if (g.normal.dot(ne) >= 0) continue;  // not facing the slave face
      ++stats_.candidatePairs;
      const mesh::QuadratureRule& slaveRule =
          mesh::quadratureRule(pieceType, quadratureDegree(std::max(f.nonAffinity, g.nonAffinity)));
      Mp.clear();
      for (int j = 0; j < g.n; ++j) Mp.push_back(project(mm.vertex(g.v[j])));

      // the overlap, as quadrature points in plane coordinates with weights
      std::vector<std::pair<Vec2, double>> qp;
      if (dim_ == 2) {
        const double s0 = std::min(S[0][0], S[1][0]), s1 = std::max(S[0][0], S[1][0]);
        const double m0 = std::min(Mp[0][0], Mp[1][0]), m1 = std::max(Mp[0][0], Mp[1][0]);
        const double lo = std::max(s0, m0), hi = std::min(s1, m1);
        if (!(hi - lo > 1e-12 * (s1 - s0))) continue;
        for (std::size_t q = 0; q < slaveRule.size(); ++q)
          qp.push_back({Vec2(lo + slaveRule.points[q][0] * (hi - lo), 0), slaveRule.weights[q] * (hi - lo)});
      } else {
        MpCcw = Mp;
        const double am = signedArea(MpCcw);
        if (std::abs(am) <= 1e-12 * g.measure) continue;  // master face seen edge-on
        if (am < 0) std::reverse(MpCcw.begin(), MpCcw.end());
        const std::vector<Vec2> P = clipPolygon(Sccw, MpCcw);
        if (P.size() < 3) continue;
        const double area = signedArea(P);
        if (!(area > 1e-12 * f.measure)) continue;
        Vec2 c0 = Vec2::Zero();
        for (const Vec2& p : P) c0 += p;
        c0 /= static_cast<double>(P.size());
        for (std::size_t i = 0; i < P.size(); ++i) {
          const Vec2 a = P[i] - c0, b = P[(i + 1) % P.size()] - c0;
          const double ta = 0.5 * cross2(a, b);
          if (ta <= 0) continue;
          for (std::size_t q = 0; q < slaveRule.size(); ++q)
            qp.push_back({c0 + slaveRule.points[q][0] * a + slaveRule.points[q][1] * b, 2 * ta * slaveRule.weights[q]});
        }
      }
      if (qp.empty()) continue;
      ++stats_.segments;
      stats_.quadraturePoints += static_cast<Index>(qp.size());

      const auto& refS = mesh::referenceElement(f.type);
      const auto& refM = mesh::referenceElement(g.type);
      for (const auto& [X, w] : qp) {
        const Point xs = localCoordinates(f.type, S, X, dim_);
        const Point xm = localCoordinates(g.type, Mp, X, dim_);
        refS.values(xs, phiS);
        refM.values(xm, phiM);
        Point xS = Point::Zero(), xM = Point::Zero();
        for (int i = 0; i < f.n; ++i) xS += phiS[i] * sm.vertex(f.v[i]);
        for (int j = 0; j < g.n; ++j) xM += phiM[j] * mm.vertex(g.v[j]);
        for (int i = 0; i < f.n; ++i) {
          psi[i] = 0;
          for (int j = 0; j < f.n; ++j) psi[i] += A(i, j) * phiS[j];
        }
        for (int i = 0; i < f.n; ++i) {
          const Index k = local[f.v[i]];
          const double wp = w * psi[i];
          gap[k] += wp * nodal[k].dot(xM - xS);
          for (int j = 0; j < g.n; ++j) {
            const Index q = master.vertexOffset + g.v[j];
            auto it = std::find_if(rows[k].begin(), rows[k].end(), [q](const Entry& en) { return en.vertex == q; });
            if (it == rows[k].end())
              rows[k].push_back({q, wp * phiM[j]});
            else
              it->value += wp * phiM[j];
          }
        }
      }
    }
  }

  // The weighted gap integrates n_p.(x^M - x^S) from coordinates that carry their rounding, about
  // eps |x| each: surfaces that touch get gaps of +-1e-17 instead of zero, and a start at rest then
  // "penetrates" by round-off, which the solver pushes apart with round-off forces. A weighted gap
  // within 16 eps X D_pp of zero (X the largest coordinate of either surface; |psi_p| integrates to
  // at most a few D_pp) is zero within the accuracy of its data, and is set to zero.
  double X = options.coordinateScale;
  if (!(X > 0)) {
    X = 0;
    for (const auto& f : sf) X = std::max({X, f.box.min().cwiseAbs().maxCoeff(), f.box.max().cwiseAbs().maxCoeff()});
    for (const auto& g : mf) X = std::max({X, g.box.min().cwiseAbs().maxCoeff(), g.box.max().cwiseAbs().maxCoeff()});
  }
  const double gapRounding = 16 * std::numeric_limits<double>::epsilon() * X;

  // constrained nodes: D_pp = sum_q M_pq, coverage D_pp / int phi_p
  std::vector<Index> node(ns, -1);
  for (std::size_t k = 0; k < ns; ++k) {
    double s = 0;
    for (const Entry& en : rows[k]) s += en.value;
    if (!(s >= options.minCoverage * mass[k])) {
      ++stats_.uncoveredNodes;
      continue;
    }
    std::sort(rows[k].begin(), rows[k].end(), [](const Entry& a, const Entry& b) { return a.vertex < b.vertex; });
    node[k] = static_cast<Index>(nodes_.size());
    nodes_.push_back(slave.vertexOffset + verts[k]);
    normals_.push_back(nodal[k]);
    positions_.push_back(sm.vertex(verts[k]));
    D_.push_back(s);
    mass_.push_back(mass[k]);
    gap_.push_back(std::abs(gap[k]) <= gapRounding * s ? 0.0 : gap[k]);
    M_.push_back(std::move(rows[k]));
  }
  if (nodes_.empty() && options.requireCoverage) {
    Box bs, bm;
    for (const auto& f : sf) bs.extend(f.box);
    for (const auto& g : mf) bm.extend(g.box);
    std::ostringstream os;
    os << "mortar coupling " << label_ << ": the master surface covers no slave node (the surfaces do not overlap;"
       << " distance between their bounding boxes " << bs.exteriorDistance(bm) << ", search distance " << search << ")";
    throw Error(os.str());
  }
  for (const auto& f : sf) {
    ContactSet::Face face;
    bool all = true;
    for (int i = 0; i < f.n && all; ++i) {
      const Index k = node[local[f.v[i]]];
      all = k >= 0;
      face.nodes.push_back(k);
    }
    if (!all) continue;
    face.measure = f.measure;
    faces_.push_back(std::move(face));
  }
  stats_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

ContactSet MortarCoupling::contactSet() const {
  ContactSet::Data data;
  data.dimension = dim_;
  data.label = label_;
  data.obstacleName = "mortar";
  data.numMeshVertices = numStacked_;
  data.vertices = nodes_;
  data.positions = positions_;
  data.directions = normals_;
  data.masses = D_;
  data.gaps.resize(nodes_.size());
  for (std::size_t k = 0; k < nodes_.size(); ++k) data.gaps[k] = gap_[k] / D_[k];
  data.faces = faces_;
  return ContactSet(std::move(data));
}

mesh::CsrMatrix MortarCoupling::transformation() const {
  mesh::CsrMatrix C;
  C.rows = C.cols = numStacked_;
  C.rowStart.assign(numStacked_ + 1, 0);
  for (std::size_t k = 0; k < nodes_.size(); ++k) C.rowStart[nodes_[k] + 1] = static_cast<Index>(M_[k].size());
  for (Index r = 0; r < numStacked_; ++r) C.rowStart[r + 1] += C.rowStart[r];
  C.columns.resize(C.rowStart.back());
  C.values.resize(C.rowStart.back());
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    Index pos = C.rowStart[nodes_[k]];
    for (const Entry& en : M_[k]) {
      C.columns[pos] = en.vertex;
      C.values[pos++] = en.value / D_[k];
    }
  }
  return C;
}

Eigen::VectorXd MortarCoupling::masterForces(const Eigen::VectorXd& multipliers) const {
  if (multipliers.size() != static_cast<Eigen::Index>(nodes_.size()))
    throw Error("mortar coupling " + label_ + ": " + std::to_string(multipliers.size()) + " multipliers for " +
                std::to_string(nodes_.size()) + " slave nodes");
  Eigen::VectorXd f = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(numStacked_) * dim_);
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const double lambda = multipliers[static_cast<Eigen::Index>(k)] / D_[k];
    for (const Entry& en : M_[k])
      for (int a = 0; a < dim_; ++a) f[static_cast<Eigen::Index>(en.vertex) * dim_ + a] += lambda * en.value * normals_[k][a];
  }
  return f;
}

Eigen::VectorXd MortarCoupling::masterForces(const std::vector<Point>& forces) const {
  if (forces.size() != nodes_.size())
    throw Error("mortar coupling " + label_ + ": " + std::to_string(forces.size()) + " nodal forces for " +
                std::to_string(nodes_.size()) + " slave nodes");
  Eigen::VectorXd f = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(numStacked_) * dim_);
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const Point lambda = forces[k] / D_[k];
    for (const Entry& en : M_[k])
      for (int a = 0; a < dim_; ++a) f[static_cast<Eigen::Index>(en.vertex) * dim_ + a] += en.value * lambda[a];
  }
  return f;
}

}  // namespace obs
