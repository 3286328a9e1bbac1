#include "obs/obs/SurfaceObstacle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <utility>

#include "obs/mesh/Error.hpp"

namespace obs {

using mesh::Index;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Barycentric / segment-parameter slack: a line through a shared edge or vertex meets every face
/// around it (the duplicates are merged afterwards), so no line slips between two faces.
constexpr double kParamSlack = 1e-10;

std::string formatPoint(const Point& p, int dim) {
  std::ostringstream os;
  os.precision(10);
  os << "(" << p[0] << ", " << p[1];
  if (dim == 3) os << ", " << p[2];
  os << ")";
  return os.str();
}

double cross2(const Point& a, const Point& b) { return a[0] * b[1] - a[1] * b[0]; }

struct Box {
  Point lo = Point::Constant(kInf);
  Point hi = Point::Constant(-kInf);
  void add(const Point& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
};

/// Union-find over vertex or face numbers (for the topology checks).
class Partition {
public:
  explicit Partition(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), std::size_t{0}); }
  std::size_t find(std::size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void join(std::size_t a, std::size_t b) { parent_[find(a)] = find(b); }

private:
  std::vector<std::size_t> parent_;
};

}  // namespace

struct SurfaceObstacle::Impl {
  /// One planar piece: a triangle (3D) or a segment (2D, c unused), with `entry` telling whether
  /// the line along nu enters the obstacle through it.
  struct Face {
    Point a, b, c;
    bool entry;
    Point normal;  ///< outward unit normal
    std::array<Index, 3> vertices{-1, -1, -1};  ///< surface vertices of a, b, c (c: -1 in 2D)
  };
  struct Node {
    Box box;
    int left = -1, right = -1;  ///< children; -1: leaf
    int begin = 0, end = 0;     ///< leaf: faces order[begin, end)
  };

  int dim = 3;
  Point nu;
  std::vector<Face> faces;
  std::vector<int> order;
  std::vector<Node> nodes;
  double boxSlack = 0;   ///< boxes are enlarged by this (absolute, from the surface's size)
  double mergeSlack = 0; ///< crossings closer than this along the line count once

  int build(int begin, int end) {
    Node node;
    Box centres;
    for (int i = begin; i < end; ++i) {
      const Face& f = faces[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
      node.box.add(f.a);
      node.box.add(f.b);
      if (dim == 3) node.box.add(f.c);
      centres.add(dim == 3 ? Point((f.a + f.b + f.c) / 3) : Point((f.a + f.b) / 2));
    }
    node.box.lo.array() -= boxSlack;
    node.box.hi.array() += boxSlack;
    const int id = static_cast<int>(nodes.size());
    nodes.push_back(node);
    if (end - begin <= 4) {
      nodes[static_cast<std::size_t>(id)].begin = begin;
      nodes[static_cast<std::size_t>(id)].end = end;
      return id;
    }
    int axis = 0;
    const Point extent = centres.hi - centres.lo;
    for (int a = 1; a < dim; ++a)
      if (extent[a] > extent[axis]) axis = a;
    const int mid = begin + (end - begin) / 2;
    auto centre = [&](int i) {
      const Face& f = faces[static_cast<std::size_t>(i)];
      return dim == 3 ? (f.a[axis] + f.b[axis] + f.c[axis]) / 3 : (f.a[axis] + f.b[axis]) / 2;
    };
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](int i, int j) { return centre(i) < centre(j); });
    const int left = build(begin, mid);
    const int right = build(mid, end);
    nodes[static_cast<std::size_t>(id)].left = left;
    nodes[static_cast<std::size_t>(id)].right = right;
    return id;
  }

  /// Does the whole line x + t nu (t in R) meet the box? Slab test.
  bool meets(const Box& box, const Point& x, const Point& nu) const {
    double tmin = -kInf, tmax = kInf;
    for (int a = 0; a < dim; ++a) {
      if (nu[a] == 0) {
        if (x[a] < box.lo[a] || x[a] > box.hi[a]) return false;
        continue;
      }
      double t1 = (box.lo[a] - x[a]) / nu[a], t2 = (box.hi[a] - x[a]) / nu[a];
      if (t1 > t2) std::swap(t1, t2);
      tmin = std::max(tmin, t1);
      tmax = std::min(tmax, t2);
      if (tmin > tmax) return false;
    }
    return true;
  }

  /// The crossing of the line x + t nu with face f, if any (Moeller-Trumbore in 3D, a 2x2 solve
  /// in 2D); an entry if the face's outward normal opposes nu.
  bool cross(const Face& f, const Point& x, const Point& nu, Crossing& out) const {
    if (dim == 2) {
      const Point e = f.b - f.a;
      const double det = cross2(nu, e);  // = n . nu with the outward normal n = (e_y, -e_x)
      if (std::abs(det) <= 1e-14 * e.norm()) return false;  // segment along the line
      const double s = cross2(x - f.a, nu) / cross2(e, nu);
      if (s < -kParamSlack || s > 1 + kParamSlack) return false;
      out = {cross2(f.a - x, e) / det, det < 0, -1};
      return true;
    }
    const Point e1 = f.b - f.a, e2 = f.c - f.a;
    const Point p = nu.cross(e2);
    const double det = e1.dot(p);  // = -n . nu with n = e1 x e2
    if (std::abs(det) <= 1e-14 * e1.norm() * e2.norm()) return false;  // face along the line
    const double inv = 1 / det;
    const Point s = x - f.a;
    const double u = s.dot(p) * inv;
    if (u < -kParamSlack || u > 1 + kParamSlack) return false;
    const Point q = s.cross(e1);
    const double v = nu.dot(q) * inv;
    if (v < -kParamSlack || u + v > 1 + kParamSlack) return false;
    out = {e2.dot(q) * inv, det > 0, -1};
    return true;
  }

  /// Sorts the crossings along the line and merges those of one kind at (nearly) the same t: the
  /// line went through an edge or a vertex shared by several faces. A cluster of coinciding
  /// crossings keeps at most one entry and one exit, the entry first (the line grazes the obstacle).
  std::vector<Crossing> finish(std::vector<Crossing> c) const {
    std::sort(c.begin(), c.end(), [](const Crossing& p, const Crossing& q) { return p.t < q.t; });
    std::vector<Crossing> out;
    for (std::size_t i = 0; i < c.size();) {
      std::size_t j = i;
      bool entry = false, exit = false;
      double tEntry = 0, tExit = 0;
      int pEntry = -1, pExit = -1;
      for (; j < c.size() && c[j].t - c[i].t <= mergeSlack; ++j) {
        if (c[j].entry && !entry) entry = true, tEntry = c[j].t, pEntry = c[j].piece;
        if (!c[j].entry && !exit) exit = true, tExit = c[j].t, pExit = c[j].piece;
      }
      if (entry) out.push_back({tEntry, true, pEntry});
      if (exit) out.push_back({tExit, false, pExit});
      i = j;
    }
    return out;
  }
};

SurfaceObstacle::SurfaceObstacle(const mesh::SurfaceMesh& surface, const Point& direction, bool reverse)
    : impl_(std::make_unique<Impl>()), dimension_(surface.dimension), source_(surface.source) {
  const std::string what = "surface obstacle " + (source_.empty() ? std::string("(in memory)") : source_);
  if (!direction.allFinite() || !(direction.norm() > 0)) throw Error(what + ": direction must be a non-zero finite vector");
  if (dimension_ == 2 && direction[2] != 0) throw Error(what + ": direction of a 2D obstacle must have z = 0");
  nu_ = direction.normalized();
  build(surface, reverse);
}

SurfaceObstacle::SurfaceObstacle(const mesh::SurfaceMesh& surface, ClosestPoint, bool reverse)
    : impl_(std::make_unique<Impl>()), closest_(true), dimension_(surface.dimension), source_(surface.source) {
  nu_ = dimension_ == 2 ? Point(-Point::UnitY()) : Point(-Point::UnitZ());  // only for entry flags, unused
  build(surface, reverse);
}

void SurfaceObstacle::build(const mesh::SurfaceMesh& surface, bool reverse) {
  const std::string what = "surface obstacle " + (source_.empty() ? std::string("(in memory)") : source_);
  auto fail = [&](const std::string& message) -> void { throw Error(what + ": " + message); };
  if (dimension_ != 2 && dimension_ != 3) fail("dimension must be 2 or 3");
  if (surface.numFaces() == 0) fail("has no faces");
  const Index nv = static_cast<Index>(surface.vertices.size());
  if (surface.types.size() != surface.faces.size()) fail("face types and faces differ in number");

  Impl& m = *impl_;
  m.dim = dimension_;
  m.nu = nu_;

  // Vertices: finite, and in the xy-plane for a 2D surface.
  Box all;
  auto cornersOf = [&](Index f) {
    const mesh::CellType type = surface.types[static_cast<std::size_t>(f)];
    const int n = type == mesh::CellType::Segment ? 2 : type == mesh::CellType::Triangle ? 3 : 4;
    std::vector<Index> c(surface.faces[static_cast<std::size_t>(f)].begin(),
                         surface.faces[static_cast<std::size_t>(f)].begin() + n);
    if (reverse) std::reverse(c.begin(), c.end());
    return c;
  };
  for (Index f = 0; f < surface.numFaces(); ++f) {
    const mesh::CellType type = surface.types[static_cast<std::size_t>(f)];
    const bool ok = dimension_ == 2 ? type == mesh::CellType::Segment
                                    : (type == mesh::CellType::Triangle || type == mesh::CellType::Quadrilateral);
    if (!ok)
      fail("face " + std::to_string(f) + " is a " + std::string(mesh::name(type)) + ", expected " +
           (dimension_ == 2 ? "segments (2D)" : "triangles or quadrilaterals (3D)"));
    for (Index v : cornersOf(f)) {
      if (v < 0 || v >= nv) fail("face " + std::to_string(f) + " refers to vertex " + std::to_string(v) + " which does not exist");
      const Point& p = surface.vertices[static_cast<std::size_t>(v)];
      if (!p.allFinite()) fail("vertex " + std::to_string(v) + " has a non-finite coordinate");
      if (dimension_ == 2 && p[2] != 0) fail("vertex " + std::to_string(v) + " of a 2D surface has z != 0");
      all.add(p);
    }
  }
  const double size = std::max((all.hi - all.lo).norm(), 1e-300);
  m.boxSlack = 1e-9 * size;
  m.mergeSlack = 1e-9 * size;

  // Planar pieces; degenerate faces are errors.
  for (Index f = 0; f < surface.numFaces(); ++f) {
    const std::vector<Index> c = cornersOf(f);
    auto at = [&](std::size_t i) { return surface.vertices[static_cast<std::size_t>(c[i])]; };
    auto degenerate = [&]() {
      std::ostringstream os;
      os << "face " << f << " is degenerate (" << (dimension_ == 2 ? "zero length" : "zero area")
         << ") at " << formatPoint(at(0), dimension_);
      fail(os.str());
    };
    if (dimension_ == 2) {
      const Point e = at(1) - at(0);
      if (!(e.norm() > 1e-14 * size)) degenerate();
      m.faces.push_back({at(0), at(1), Point::Zero(), cross2(nu_, e) < 0, Point(e[1], -e[0], 0).normalized(),
                         {c[0], c[1], -1}});
      continue;
    }
    auto addTriangle = [&](std::size_t i, std::size_t j, std::size_t k) {
      const Point a = at(i), b = at(j), cc = at(k);
      const Point n = (b - a).cross(cc - a);
      if (!(n.norm() > 1e-12 * (b - a).norm() * (cc - a).norm()) || !(n.norm() > 0)) degenerate();
      m.faces.push_back({a, b, cc, n.dot(nu_) < 0, n.normalized(), {c[i], c[j], c[k]}});
    };
    addTriangle(0, 1, 2);
    if (c.size() == 4) addTriangle(0, 2, 3);
  }

  // Topology: every edge (3D) / vertex (2D) is shared by at most two faces, which traverse it in
  // opposite directions (consistent orientation); no 3D piece has more than one boundary loop.
  std::map<std::pair<Index, Index>, std::vector<std::pair<Index, bool>>> edges;  // -> (face, forward)
  for (Index f = 0; f < surface.numFaces(); ++f) {
    const std::vector<Index> c = cornersOf(f);
    if (dimension_ == 2) {
      edges[{c[0], c[0]}].push_back({f, true});   // segment starts here
      edges[{c[1], c[1]}].push_back({f, false});  // and ends here
      continue;
    }
    for (std::size_t i = 0; i < c.size(); ++i) {
      const Index a = c[i], b = c[(i + 1) % c.size()];
      edges[{std::min(a, b), std::max(a, b)}].push_back({f, a < b});
    }
  }
  Partition pieces(static_cast<std::size_t>(surface.numFaces()));
  for (const auto& [key, list] : edges) {
    const std::string name = dimension_ == 2
                                 ? "vertex " + std::to_string(key.first) + " at " +
                                       formatPoint(surface.vertices[static_cast<std::size_t>(key.first)], 2)
                                 : "edge (" + std::to_string(key.first) + ", " + std::to_string(key.second) + ")";
    if (list.size() > 2)
      fail(name + " is shared by " + std::to_string(list.size()) +
           " faces (a surface has at most two faces at " + (dimension_ == 2 ? "a vertex" : "an edge") + ")");
    if (list.size() == 2) {
      if (list[0].second == list[1].second)
        fail("faces " + std::to_string(list[0].first) + " and " + std::to_string(list[1].first) +
             " at " + name +
             " are oriented oppositely (flipped normals: all faces must be ordered counterclockwise "
             "seen from outside the obstacle)");
      pieces.join(static_cast<std::size_t>(list[0].first), static_cast<std::size_t>(list[1].first));
    }
  }
  if (dimension_ == 3) {
    Partition loops(static_cast<std::size_t>(nv));
    std::map<std::size_t, Index> pieceOfVertex;  // boundary vertex -> one face of its piece
    for (const auto& [key, list] : edges)
      if (list.size() == 1) {
        loops.join(static_cast<std::size_t>(key.first), static_cast<std::size_t>(key.second));
        pieceOfVertex[static_cast<std::size_t>(key.first)] = list[0].first;
        pieceOfVertex[static_cast<std::size_t>(key.second)] = list[0].first;
      }
    std::map<std::size_t, std::pair<std::size_t, Index>> loopOfPiece;  // piece -> (loop, vertex)
    for (const auto& [v, face] : pieceOfVertex) {
      const std::size_t piece = pieces.find(static_cast<std::size_t>(face));
      const std::size_t loop = loops.find(v);
      const auto it = loopOfPiece.find(piece);
      if (it == loopOfPiece.end()) {
        loopOfPiece[piece] = {loop, static_cast<Index>(v)};
      } else if (it->second.first != loop) {
        fail("the piece of the surface containing face " + std::to_string(face) +
             " has a hole: its boundary consists of more than one closed curve (through vertices " +
             std::to_string(it->second.second) + " and " + std::to_string(v) +
             "); a line through the hole would miss the obstacle. Close the hole, or give a ring-shaped "
             "obstacle as two pieces");
      }
    }
  }

  // A closed surface (no boundary edges) must enclose a positive volume (area in 2D) with its
  // outward normals; a negative one means that all faces are ordered the wrong way round.
  const bool closed = std::none_of(edges.begin(), edges.end(), [](const auto& e) { return e.second.size() == 1; });
  if (closed) {
    double measure = 0;
    for (const Impl::Face& f : m.faces)
      measure += dimension_ == 2 ? cross2(f.a, f.b) / 2 : f.a.dot(f.b.cross(f.c)) / 6;
    if (measure < 0)
      fail(std::string("the closed surface encloses a negative ") + (dimension_ == 2 ? "area" : "volume") +
           ": its faces are ordered clockwise seen from outside the obstacle; set reverse = true (or reorder them)");
  }

  m.order.resize(m.faces.size());
  std::iota(m.order.begin(), m.order.end(), 0);
  m.nodes.reserve(2 * m.faces.size() / 4 + 2);
  m.build(0, static_cast<int>(m.faces.size()));
}

SurfaceObstacle::~SurfaceObstacle() = default;

mesh::Index SurfaceObstacle::numTriangles() const { return static_cast<Index>(impl_->faces.size()); }

std::vector<SurfaceObstacle::Crossing> SurfaceObstacle::crossings(const Point& x) const {
  return crossings(x, nu_);
}

std::vector<SurfaceObstacle::Crossing> SurfaceObstacle::crossings(const Point& x, const Point& direction) const {
  const Impl& m = *impl_;
  std::vector<Crossing> found;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Impl::Node& node = m.nodes[static_cast<std::size_t>(stack[--top])];
    if (!m.meets(node.box, x, direction)) continue;
    if (node.left < 0) {
      for (int i = node.begin; i < node.end; ++i) {
        Crossing c{};
        const int piece = m.order[static_cast<std::size_t>(i)];
        if (m.cross(m.faces[static_cast<std::size_t>(piece)], x, direction, c)) {
          c.piece = piece;
          found.push_back(c);
        }
      }
      continue;
    }
    stack[top++] = node.left;
    stack[top++] = node.right;
  }
  return m.finish(std::move(found));
}

std::vector<SurfaceObstacle::Crossing> SurfaceObstacle::crossingsBruteForce(const Point& x) const {
  const Impl& m = *impl_;
  std::vector<Crossing> found;
  for (const Impl::Face& f : m.faces) {
    Crossing c{};
    if (m.cross(f, x, nu_, c)) found.push_back(c);
  }
  return m.finish(std::move(found));
}

namespace {

/// The point of triangle (a, b, c) nearest to p: the Voronoi regions of the corners, then of the
/// edges, else the interior (barycentric coordinates from the sub-areas).
Point closestOnTriangle(const Point& p, const Point& a, const Point& b, const Point& c) {
  const Point ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Point bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Point cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double scale = 1 / (va + vb + vc);
  return a + ab * (vb * scale) + ac * (vc * scale);
}

Point closestOnSegment(const Point& p, const Point& a, const Point& b) {
  const Point e = b - a;
  const double t = std::clamp((p - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
  return a + t * e;
}

double boxDistance2(const Box& box, const Point& x, int dim) {
  double s = 0;
  for (int a = 0; a < dim; ++a) {
    const double d = std::max({box.lo[a] - x[a], 0.0, x[a] - box.hi[a]});
    s += d * d;
  }
  return s;
}

}  // namespace

SurfaceObstacle::Nearest SurfaceObstacle::nearest(const Point& x) const {
  const Impl& m = *impl_;
  // faces within a relative 1e-9 of the smallest distance count as nearest (edges, vertices)
  double best = kInf;
  struct Candidate {
    double distance2;
    int face;
    Point point;
  };
  std::vector<Candidate> candidates;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  const double slack2 = m.boxSlack * m.boxSlack;
  while (top > 0) {
    const Impl::Node& node = m.nodes[static_cast<std::size_t>(stack[--top])];
    if (boxDistance2(node.box, x, m.dim) > best * (1 + 1e-9) + slack2) continue;
    if (node.left < 0) {
      for (int i = node.begin; i < node.end; ++i) {
        const int f = m.order[static_cast<std::size_t>(i)];
        const Impl::Face& face = m.faces[static_cast<std::size_t>(f)];
        const Point c = m.dim == 2 ? closestOnSegment(x, face.a, face.b) : closestOnTriangle(x, face.a, face.b, face.c);
        const double d2 = (x - c).squaredNorm();
        candidates.push_back({d2, f, c});
        best = std::min(best, d2);
      }
      continue;
    }
    stack[top++] = node.left;
    stack[top++] = node.right;
  }
  Nearest n{Point::Zero(), 0, Point::Zero()};
  for (const Candidate& k : candidates) {
    if (k.distance2 == best) n.point = k.point;
    if (k.distance2 <= best * (1 + 1e-9) + slack2) n.normal += m.faces[static_cast<std::size_t>(k.face)].normal;
  }
  const double distance = std::sqrt(best);
  n.signedDistance = (x - n.point).dot(n.normal) < 0 ? -distance : distance;
  return n;
}

Point SurfaceObstacle::direction(const Point& x) const {
  if (!closest_) return nu_;
  const Nearest n = nearest(x);
  const Point d = n.point - x;  // towards the surface
  // on the surface (to rounding): the inward normal; otherwise along x - c, into the obstacle
  if (!(d.norm() > impl_->boxSlack) || !(n.normal.norm() > 0)) {
    const Point inward = -n.normal;
    return inward.norm() > 0 ? Point(inward.normalized()) : nu_;
  }
  return n.signedDistance >= 0 ? Point(d.normalized()) : Point(-d.normalized());
}

namespace {

/// The crossing that gives the gap of a line: the obstacle occupies [entry, next exit) along it;
/// the entry of the first such interval that does not end behind x (t = 0; the gap is <= 0 if x lies
/// inside it); null if there is none (gap +infinity).
const SurfaceObstacle::Crossing* gapCrossing(const std::vector<SurfaceObstacle::Crossing>& crossings) {
  const SurfaceObstacle::Crossing* entry = nullptr;
  for (const SurfaceObstacle::Crossing& c : crossings) {
    if (c.entry) {
      if (!entry) entry = &c;
    } else if (entry) {
      if (c.t >= 0) return entry;
      entry = nullptr;
    }
  }
  return entry;
}

double gapOfCrossings(const std::vector<SurfaceObstacle::Crossing>& crossings) {
  const SurfaceObstacle::Crossing* c = gapCrossing(crossings);
  return c ? c->t : kInf;
}

}  // namespace

double SurfaceObstacle::gap(const Point& x) const {
  if (closest_) return nearest(x).signedDistance;
  return gapOfCrossings(crossings(x));
}

double SurfaceObstacle::gapAlong(const Point& x, const Point& direction) const {
  const double n = direction.norm();
  if (!(n > 0) || !direction.allFinite()) throw Error("surface obstacle " + source_ + ": gapAlong needs a non-zero direction");
  return gapOfCrossings(crossings(x, direction / n));
}

std::optional<SurfaceObstacle::Hit> SurfaceObstacle::hitAlong(const Point& x, const Point& direction) const {
  const double n = direction.norm();
  if (!(n > 0) || !direction.allFinite()) throw Error("surface obstacle " + source_ + ": hitAlong needs a non-zero direction");
  const Point nu = direction / n;
  const std::vector<Crossing> c = crossings(x, nu);
  const Crossing* k = gapCrossing(c);
  if (!k || k->piece < 0) return std::nullopt;
  const Impl::Face& f = impl_->faces[static_cast<std::size_t>(k->piece)];
  const Point y = x + k->t * nu;
  Hit hit{k->t, f.vertices, {0, 0, 0}};
  if (dimension_ == 2) {
    const Point e = f.b - f.a;
    const double s = std::clamp((y - f.a).dot(e) / e.squaredNorm(), 0.0, 1.0);
    hit.weights = {1 - s, s, 0};
  } else {  // barycentric coordinates in the triangle, clamped to it
    const Point e1 = f.b - f.a, e2 = f.c - f.a, r = y - f.a;
    const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2), b1 = r.dot(e1), b2 = r.dot(e2);
    const double det = a11 * a22 - a12 * a12;
    double u = (a22 * b1 - a12 * b2) / det, v = (a11 * b2 - a12 * b1) / det;
    u = std::clamp(u, 0.0, 1.0);
    v = std::clamp(v, 0.0, 1.0 - u);
    hit.weights = {1 - u - v, u, v};
  }
  return hit;
}

bool SurfaceObstacle::seesOnlyBackFaces(const Point& x) const {
  const std::vector<Crossing> c = crossings(x);
  return !c.empty() && std::none_of(c.begin(), c.end(), [](const Crossing& k) { return k.entry; });
}

}  // namespace obs
