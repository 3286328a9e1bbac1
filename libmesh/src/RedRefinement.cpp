// Red refinement rules (built once from vertex-set descriptions) and uniform refinement of a Mesh.
#include "obs/mesh/RedRefinement.hpp"
#include "obs/mesh/ReferenceElement.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"

namespace obs::mesh {
namespace {

using Set = std::vector<int>;  // a refinement point given by the parent corners it averages

/// Reference corner coordinates (ReferenceElement.hpp), used to orient and check the children.
std::vector<Point> referenceCorners(CellType t) { return referenceElement(t).vertices; }

/// Assembles one rule: points are registered as vertex sets, children as lists of vertex sets.
class RuleBuilder {
public:
  explicit RuleBuilder(CellType type, int variant = 0) : ref_(referenceCorners(type)) {
    rule_.type = type;
    rule_.variant = variant;
    const int n = numVertices(type);
    for (int i = 0; i < n; ++i) add({i});
    for (const auto& e : localEdges(type)) add({e[0], e[1]});
    if (type == CellType::Quadrilateral) add({0, 1, 2, 3});
    for (const LocalFace& f : localFaces(type))
      if (f.type == CellType::Quadrilateral) add({f.vertices.begin(), f.vertices.end()});
    if (type == CellType::Hexahedron) add({0, 1, 2, 3, 4, 5, 6, 7});
  }

  int index(Set s) const {
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
    const auto it = index_.find(s);
    if (it == index_.end()) throw std::logic_error("RedRefinement: unknown refinement point");
    return it->second;
  }

  /// Adds a child; a tetrahedron or pyramid given with negative orientation is flipped (swap of
  /// two vertices / reversal of the base), any other orientation error is a bug in the tables.
  void child(CellType type, const std::vector<Set>& sets) {
    RefinementChild c{type, {}};
    for (const Set& s : sets) c.points.push_back(index(s));
    if (!positive(c)) {
      if (type == CellType::Tetrahedron) std::swap(c.points[1], c.points[2]);
      if (type == CellType::Pyramid) std::swap(c.points[1], c.points[3]);
    }
    if (!positive(c)) throw std::logic_error("RedRefinement: negatively oriented child");
    rule_.children.push_back(std::move(c));
  }

  RefinementRule finish() {
    // Parent entity of each point.
    const auto edges = localEdges(rule_.type);
    const auto faces = localFaces(rule_.type);
    for (const Set& set : rule_.points) {
      PointSite site{PointLocation::Cell, 0};
      if (set.size() == 1) site = {PointLocation::Corner, set[0]};
      for (std::size_t e = 0; e < edges.size() && set.size() == 2; ++e)
        if (std::min(edges[e][0], edges[e][1]) == set[0] &&
            std::max(edges[e][0], edges[e][1]) == set[1])
          site = {PointLocation::Edge, static_cast<int>(e)};
      for (std::size_t f = 0; f < faces.size() && set.size() == 4 && dimension(rule_.type) == 3;
           ++f)
        if (faces[f].size == 4 &&
            std::is_permutation(set.begin(), set.end(), faces[f].vertices.begin()))
          site = {PointLocation::Face, static_cast<int>(f)};
      rule_.sites.push_back(site);
    }
    // The children must tile the parent: their reference measures add up to the parent's.
    double sum = 0;
    for (const auto& c : rule_.children) sum += measure(c);
    if (std::abs(sum - signedMeasure(rule_.type, ref_)) > 1e-12)
      throw std::logic_error("RedRefinement: children do not tile the parent");
    return std::move(rule_);
  }

private:
  void add(Set s) {
    std::sort(s.begin(), s.end());
    index_.emplace(s, static_cast<int>(rule_.points.size()));
    rule_.points.push_back(std::move(s));
  }
  std::vector<Point> coords(const RefinementChild& c) const {
    std::vector<Point> x;
    for (int p : c.points) {
      Point s = Point::Zero();
      for (int v : rule_.points[p]) s += ref_[v];
      x.push_back(s / static_cast<double>(rule_.points[p].size()));
    }
    return x;
  }
  bool positive(const RefinementChild& c) const {
    const auto x = coords(c);
    return c.type == CellType::Segment ? x[1][0] > x[0][0] : isPositivelyOriented(c.type, x);
  }
  double measure(const RefinementChild& c) const {
    const auto x = coords(c);
    return c.type == CellType::Segment ? x[1][0] - x[0][0] : signedMeasure(c.type, x);
  }

  std::vector<Point> ref_;
  RefinementRule rule_;
  std::map<Set, int> index_;
};

/// Vertex set of the point with "doubled" grid coordinate g in {0,1,2} along one axis:
/// 0 -> corner side 0 only, 1 -> both sides (midpoint), 2 -> side 1 only.
std::vector<int> sides(int g) {
  return g == 0 ? std::vector<int>{0} : g == 2 ? std::vector<int>{1} : std::vector<int>{0, 1};
}

constexpr int quadCorner(int a, int b) { return a ? (b ? 2 : 1) : (b ? 3 : 0); }

RefinementRule segmentRule() {
  RuleBuilder b(CellType::Segment);
  b.child(CellType::Segment, {{0}, {0, 1}});
  b.child(CellType::Segment, {{0, 1}, {1}});
  return b.finish();
}

/// Triangle children: corner triangles (child i at corner i) and the middle one.
const std::vector<std::vector<Set>> kTriangleChildren = {
    {{0}, {0, 1}, {0, 2}}, {{0, 1}, {1}, {1, 2}}, {{0, 2}, {1, 2}, {2}}, {{1, 2}, {0, 2}, {0, 1}}};

RefinementRule triangleRule() {
  RuleBuilder b(CellType::Triangle);
  for (const auto& c : kTriangleChildren) b.child(CellType::Triangle, c);
  return b.finish();
}

RefinementRule quadRule() {
  RuleBuilder b(CellType::Quadrilateral);
  auto grid = [](int p, int q) {
    Set s;
    for (int a : sides(p))
      for (int c : sides(q)) s.push_back(quadCorner(a, c));
    return s;
  };
  for (int k = 0; k < 4; ++k) {  // child k contains parent corner k
    const int a = (k == 1 || k == 2), c = (k >= 2);
    b.child(CellType::Quadrilateral,
            {grid(a, c), grid(a + 1, c), grid(a + 1, c + 1), grid(a, c + 1)});
  }
  return b.finish();
}

RefinementRule hexRule() {
  RuleBuilder b(CellType::Hexahedron);
  auto grid = [](int p, int q, int r) {
    Set s;
    for (int a : sides(p))
      for (int c : sides(q))
        for (int d : sides(r)) s.push_back(quadCorner(a, c) + 4 * d);
    return s;
  };
  for (int k = 0; k < 8; ++k) {  // child k contains parent corner k
    const int a = (k % 4 == 1 || k % 4 == 2), c = (k % 4 >= 2), d = k / 4;
    std::vector<Set> v;
    for (int l = 0; l < 8; ++l) {
      const int da = (l % 4 == 1 || l % 4 == 2), dc = (l % 4 >= 2), dd = l / 4;
      v.push_back(grid(a + da, c + dc, d + dd));
    }
    b.child(CellType::Hexahedron, v);
  }
  return b.finish();
}

/// Tetrahedron: corner tetrahedra (homotheties about each corner) and the inner octahedron split
/// into four tetrahedra around the diagonal joining the midpoints of two opposite edges.
RefinementRule tetRule(int variant) {
  RuleBuilder b(CellType::Tetrahedron, variant);
  for (int k = 0; k < 4; ++k) {
    std::vector<Set> v;
    for (int j = 0; j < 4; ++j) v.push_back(j == k ? Set{k} : Set{k, j});
    b.child(CellType::Tetrahedron, v);
  }
  // Opposite edge pairs; diagonal `variant` joins the midpoints of pair `variant`.
  const std::array<std::array<Set, 2>, 3> opposite = {
      {{Set{0, 1}, Set{2, 3}}, {Set{1, 2}, Set{0, 3}}, {Set{0, 2}, Set{1, 3}}}};
  const auto& diag = opposite[variant];
  // Equator: the other four midpoints in cyclic order (opposite ones are not consecutive).
  const auto& p = opposite[(variant + 1) % 3];
  const auto& q = opposite[(variant + 2) % 3];
  const std::array<Set, 4> ring = {p[0], q[0], p[1], q[1]};
  for (int i = 0; i < 4; ++i)
    b.child(CellType::Tetrahedron, {diag[0], diag[1], ring[i], ring[(i + 1) % 4]});
  return b.finish();
}

RefinementRule prismRule() {
  RuleBuilder b(CellType::Prism);
  // lift(S, L): triangle point S at height L/2 (L = 0 bottom, 1 middle, 2 top).
  auto lift = [](const Set& s, int level) {
    Set out;
    for (int v : s) {
      if (level <= 1) out.push_back(v);
      if (level >= 1) out.push_back(v + 3);
    }
    return out;
  };
  for (int layer = 0; layer < 2; ++layer)
    for (const auto& t : kTriangleChildren) {
      std::vector<Set> v;
      for (int l = 0; l < 2; ++l)
        for (const Set& s : t) v.push_back(lift(s, layer + l));
      b.child(CellType::Prism, v);
    }
  return b.finish();
}

RefinementRule pyramidRule() {
  RuleBuilder b(CellType::Pyramid);
  const Set centre = {0, 1, 2, 3};
  // Corner pyramids: homothety by 1/2 about base corner k (the opposite corner maps to the centre).
  for (int k = 0; k < 4; ++k) {
    std::vector<Set> v;
    for (int j = 0; j < 5; ++j)
      v.push_back(j == k ? Set{k} : (j < 4 && (j - k + 4) % 4 == 2) ? centre : Set{k, j});
    b.child(CellType::Pyramid, v);
  }
  b.child(CellType::Pyramid, {{0, 4}, {1, 4}, {2, 4}, {3, 4}, {4}});     // apex pyramid
  b.child(CellType::Pyramid, {{0, 4}, {3, 4}, {2, 4}, {1, 4}, centre});  // inverted pyramid
  for (int k = 0; k < 4; ++k)  // one tetrahedron on each base edge
    b.child(CellType::Tetrahedron, {{k, (k + 1) % 4}, centre, {k, 4}, {(k + 1) % 4, 4}});
  return b.finish();
}

struct RuleTable {
  std::array<RefinementRule, 7> rules;  // by CellType; the tetrahedron entry is variant 0
  std::array<RefinementRule, 3> tets;
  RuleTable()
      : rules{segmentRule(), triangleRule(), quadRule(),   tetRule(0),
              hexRule(),     prismRule(),    pyramidRule()},
        tets{tetRule(0), tetRule(1), tetRule(2)} {}
};

const RuleTable& ruleTable() {
  static const RuleTable table;
  return table;
}

// ------------------------------------------------------------------------------------------------
/// Vertices of the refined mesh: the old vertices, edge midpoints, quadrilateral face centres
/// and cell centres, plus (rarely) points of boundary faces that are not cell faces.
class RefinedVertices {
public:
  RefinedVertices(const Mesh& mesh, Mesh& out) : mesh_(mesh), out_(out), edges_(mesh) {
    for (const Point& x : mesh.vertices()) out.addVertex(x);
    edgeBase_ = out.numVertices();
    for (Index e = 0; e < edges_.numEdges(); ++e) {
      const auto& v = edges_.vertices(e);
      out.addVertex(0.5 * (mesh.vertex(v[0]) + mesh.vertex(v[1])));
    }
    if (mesh.dimension() != 3) return;
    bool quads = false;
    for (Index c = 0; c < mesh.numCells() && !quads; ++c)
      quads = mesh.cellType(c) != CellType::Tetrahedron;
    if (!quads) return;
    faces_.emplace(mesh);
    faceVertex_.assign(faces_->numFaces(), -1);
    for (Index f = 0; f < faces_->numFaces(); ++f)
      if (faces_->size(f) == 4) faceVertex_[f] = create(faces_->key(f));
  }

  /// Global vertices of the refinement points of cell c under `rule`.
  void cellPoints(const RefinementRule& rule, Index c, std::vector<Index>& out) {
    const auto pv = mesh_.cellVertices(c);
    out.resize(rule.points.size());
    for (std::size_t i = 0; i < out.size(); ++i) {
      const PointSite& s = rule.sites[i];
      switch (s.location) {
        case PointLocation::Corner: out[i] = pv[s.index]; break;
        case PointLocation::Edge: out[i] = edgeBase_ + edges_.edge(c, s.index); break;
        case PointLocation::Face: out[i] = faceVertex_[faces_->face(c, s.index)]; break;
        case PointLocation::Cell: out[i] = create(pv); break;
      }
    }
  }

  /// Global vertices of the refinement points of a boundary face with vertices fv.
  void facePoints(const RefinementRule& rule, std::span<const Index> fv, std::vector<Index>& out) {
    out.resize(rule.points.size());
    std::array<Index, 4> parents{};
    for (std::size_t i = 0; i < out.size(); ++i) {
      const auto& set = rule.points[i];
      for (std::size_t k = 0; k < set.size(); ++k) parents[k] = fv[set[k]];
      const std::span<const Index> p(parents.data(), set.size());
      Index v = -1;
      if (set.size() == 1) {
        v = p[0];
      } else if (set.size() == 2) {
        const Index e = edges_.find(p[0], p[1]);
        if (e >= 0) v = edgeBase_ + e;
      } else if (set.size() == 4 && faces_) {
        const Index f = faces_->find(p);
        if (f >= 0) v = faceVertex_[f];
      }
      out[i] = v >= 0 ? v : orphan(p);
    }
  }

private:
  /// New vertex at the average of the given old vertices.
  Index create(std::span<const Index> parents) {
    Point x = Point::Zero();
    std::size_t n = 0;
    for (Index v : parents)
      if (v >= 0) x += mesh_.vertex(v), ++n;
    return out_.addVertex(x / static_cast<double>(n));
  }
  /// Vertex of a boundary face point that no cell has (shared among such faces).
  Index orphan(std::span<const Index> parents) {
    std::vector<Index> key(parents.begin(), parents.end());
    std::sort(key.begin(), key.end());
    const auto it = orphans_.find(key);
    if (it != orphans_.end()) return it->second;
    const Index v = create(key);
    orphans_.emplace(std::move(key), v);
    return v;
  }

  const Mesh& mesh_;
  Mesh& out_;
  EdgeTable edges_;
  Index edgeBase_ = 0;
  std::optional<FaceTable> faces_;
  std::vector<Index> faceVertex_;
  std::map<std::vector<Index>, Index> orphans_;
};

}  // namespace

// ------------------------------------------------------------------------------------------------
int numRedRuleVariants(CellType type) { return type == CellType::Tetrahedron ? 3 : 1; }

const RefinementRule& redRefinementRule(CellType type, int variant) {
  if (variant < 0 || variant >= numRedRuleVariants(type))
    throw Error("redRefinementRule: a " + std::string(name(type)) + " has no rule variant " +
                std::to_string(variant));
  const RuleTable& t = ruleTable();
  return type == CellType::Tetrahedron ? t.tets[variant] : t.rules[static_cast<int>(type)];
}

int shortestTetDiagonal(std::span<const Point> x) {
  const double d[3] = {(x[0] + x[1] - x[2] - x[3]).squaredNorm(),
                       (x[1] + x[2] - x[0] - x[3]).squaredNorm(),
                       (x[2] + x[0] - x[1] - x[3]).squaredNorm()};
  int best = 0;
  for (int i = 1; i < 3; ++i)
    if (d[i] < d[best]) best = i;
  return best;
}

const RefinementRule& redRefinementRule(CellType type, std::span<const Point> x) {
  return redRefinementRule(type, type == CellType::Tetrahedron ? shortestTetDiagonal(x) : 0);
}

Mesh refineUniformly(const Mesh& mesh) {
  Mesh out(mesh.dimension());
  {
    // reserve the exact cell storage (all tetrahedron variants have the same sizes)
    std::size_t cells = 0, connectivity = 0;
    for (Index c = 0; c < mesh.numCells(); ++c)
      for (const auto& ch : redRefinementRule(mesh.cellType(c)).children) {
        ++cells;
        connectivity += ch.points.size();
      }
    out.reserve(mesh.numVertices(), static_cast<Index>(cells), connectivity,
                mesh.numBoundaryFaces() * 4);
  }
  RefinedVertices vertices(mesh, out);

  std::vector<Index> global, child;
  std::array<Point, 4> tet;
  for (Index c = 0; c < mesh.numCells(); ++c) {
    const CellType type = mesh.cellType(c);
    int variant = 0;
    if (type == CellType::Tetrahedron) {
      const auto pv = mesh.cellVertices(c);
      for (int i = 0; i < 4; ++i) tet[i] = mesh.vertex(pv[i]);
      variant = shortestTetDiagonal(tet);
    }
    const RefinementRule& rule = redRefinementRule(type, variant);
    vertices.cellPoints(rule, c, global);
    for (const auto& ch : rule.children) {
      child.clear();
      for (int p : ch.points) child.push_back(global[p]);
      out.addCell(ch.type, child);
    }
  }

  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    const RefinementRule& rule = redRefinementRule(mesh.boundaryFaceType(f));
    vertices.facePoints(rule, mesh.boundaryFaceVertices(f), global);
    for (const auto& ch : rule.children) {
      child.clear();
      for (int p : ch.points) child.push_back(global[p]);
      out.addBoundaryFace(child, mesh.boundaryFaceId(f));
    }
  }
  for (const auto& [id, n] : mesh.boundaryNames()) out.setBoundaryName(id, n);
  return out;
}

}  // namespace obs::mesh
