// Red refinement: rule tables (points, children, orientation, tiling and face conformity on the
// reference cell, all tetrahedron variants), the shortest-diagonal choice, and refineUniformly
// applied 1-3 times to box meshes of every type and the mixed mesh (exact counts, volume,
// conformity, orientation, boundary ids and measures, tetrahedron quality), also on distorted
// (non-affine) meshes.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <functional>
#include <set>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/RedRefinement.hpp"
#include "obs/mesh/ReferenceElement.hpp"

using namespace obs::mesh;

namespace {

std::vector<Point> referenceCorners(CellType t) { return referenceElement(t).vertices; }

/// Applies `rule` to a parent with corners x: the children as a Mesh whose boundary faces are the
/// parent's faces refined by the face rules (points matched through their parent vertex sets).
Mesh applyRule(const RefinementRule& rule, const std::vector<Point>& x) {
  Mesh m(dimension(rule.type));
  std::map<std::vector<int>, Index> byParents;
  for (const auto& set : rule.points) {
    Point p = Point::Zero();
    for (int v : set) p += x[v];
    byParents[set] = m.addVertex(p / static_cast<double>(set.size()));
  }
  for (const auto& c : rule.children) {
    std::vector<Index> v(c.points.begin(), c.points.end());
    m.addCell(c.type, v);
  }
  for (const LocalFace& f : localFaces(rule.type)) {
    const RefinementRule& fr = redRefinementRule(f.type);
    for (const auto& c : fr.children) {
      std::vector<Index> v;
      for (int p : c.points) {
        std::vector<int> set;
        for (int k : fr.points[p]) set.push_back(f.vertices[k]);
        std::sort(set.begin(), set.end());
        v.push_back(byParents.at(set));
      }
      m.addBoundaryFace(v, 1);
    }
  }
  return m;
}

struct RuleCase {
  CellType type;
  int variant;
};
/// Prints the case by name (otherwise GoogleTest dumps its bytes into every test's listing).
void PrintTo(const RuleCase& c, std::ostream* os) { *os << name(c.type) << " variant " << c.variant; }

std::vector<RuleCase> ruleCases() {
  std::vector<RuleCase> out;
  for (CellType t : kVolumeCellTypes)
    for (int v = 0; v < numRedRuleVariants(t); ++v) out.push_back({t, v});
  return out;
}

class RuleTest : public ::testing::TestWithParam<RuleCase> {};

TEST_P(RuleTest, PointsInDocumentedOrder) {
  const RefinementRule& r = redRefinementRule(GetParam().type, GetParam().variant);
  const CellType t = r.type;
  EXPECT_EQ(t, GetParam().type);
  EXPECT_EQ(r.variant, GetParam().variant);
  const int n = numVertices(t);
  for (int i = 0; i < n; ++i) EXPECT_EQ(r.points[i], std::vector<int>{i});
  const auto edges = localEdges(t);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    std::vector<int> s = {edges[e][0], edges[e][1]};
    std::sort(s.begin(), s.end());
    EXPECT_EQ(r.points[n + e], s);
  }
  std::size_t next = n + edges.size();
  if (t == CellType::Quadrilateral) {
    EXPECT_EQ(r.points[next++], (std::vector<int>{0, 1, 2, 3}));
  }
  for (const LocalFace& f : localFaces(t))
    if (f.type == CellType::Quadrilateral) {
      std::vector<int> s(f.vertices.begin(), f.vertices.end());
      std::sort(s.begin(), s.end());
      EXPECT_EQ(r.points[next++], s);
    }
  if (t == CellType::Hexahedron) {
    EXPECT_EQ(r.points[next++].size(), 8u);
  }
  EXPECT_EQ(r.points.size(), next);
  const std::map<CellType, std::size_t> expected = {
      {CellType::Triangle, 6},    {CellType::Quadrilateral, 9}, {CellType::Tetrahedron, 10},
      {CellType::Hexahedron, 27}, {CellType::Prism, 18},        {CellType::Pyramid, 14}};
  EXPECT_EQ(r.points.size(), expected.at(t));
}

TEST_P(RuleTest, ChildrenTilePositivelyAndConform) {
  const RefinementRule& r = redRefinementRule(GetParam().type, GetParam().variant);
  const std::map<CellType, std::array<Index, 7>> children = {
      {CellType::Triangle, {0, 4, 0, 0, 0, 0, 0}},
      {CellType::Quadrilateral, {0, 0, 4, 0, 0, 0, 0}},
      {CellType::Tetrahedron, {0, 0, 0, 8, 0, 0, 0}},
      {CellType::Hexahedron, {0, 0, 0, 0, 8, 0, 0}},
      {CellType::Prism, {0, 0, 0, 0, 0, 8, 0}},
      {CellType::Pyramid, {0, 0, 0, 4, 0, 0, 6}}};
  // On the reference cell and on a distorted copy of it.
  auto x = referenceCorners(r.type);
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1)
      for (std::size_t i = 0; i < x.size(); ++i)
        x[i] += 0.07 * Point(std::sin(3.0 * i), std::cos(5.0 * i),
                             dimension(r.type) == 2 ? 0.0 : std::sin(7.0 * i));
    const Mesh m = applyRule(r, x);
    EXPECT_EQ(m.cellCounts(), children.at(r.type));
    for (Index c = 0; c < m.numCells(); ++c) EXPECT_TRUE(isPositivelyOriented(m, c)) << c;
    // Children tile the parent exactly: their union is bounded by the parent's faces (bilinear
    // quadrilaterals restrict to bilinear quarters), also for the non-planar distorted parent.
    EXPECT_NEAR(totalVolume(m), signedMeasure(r.type, x), 1e-14);
    // Conformity: child faces match each other, and on the parent boundary exactly the faces
    // refined by the face rules.
    const ConformityReport rep = checkConformity(m);
    EXPECT_TRUE(rep.conforming());
    EXPECT_EQ(rep.boundaryFaces, m.numBoundaryFaces());
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, RuleTest, ::testing::ValuesIn(ruleCases()),
                         [](const auto& info) {
                           return std::string(name(info.param.type)) + "_" +
                                  std::to_string(info.param.variant);
                         });

TEST(Rule, FaceRules) {
  const RefinementRule& s = redRefinementRule(CellType::Segment);
  ASSERT_EQ(s.children.size(), 2u);
  EXPECT_EQ(s.children[0].points, (std::vector<int>{0, 2}));
  EXPECT_EQ(s.children[1].points, (std::vector<int>{2, 1}));
  EXPECT_EQ(redRefinementRule(CellType::Triangle).children.size(), 4u);
  EXPECT_EQ(redRefinementRule(CellType::Quadrilateral).children.size(), 4u);
  EXPECT_THROW(redRefinementRule(CellType::Tetrahedron, 3), obs::Error);
  EXPECT_THROW(redRefinementRule(CellType::Hexahedron, 1), obs::Error);
}

TEST(Rule, ShortestDiagonalIsChosen) {
  // Stretch the reference tetrahedron so that each diagonal in turn is the shortest.
  for (int want = 0; want < 3; ++want) {
    // Diagonal d joins the midpoints of an opposite edge pair; make the pair's edges long and
    // close together by moving the corners towards the common midpoint of the diagonal.
    const std::array<std::array<int, 4>, 3> pairs = {{{0, 1, 2, 3}, {1, 2, 0, 3}, {0, 2, 1, 3}}};
    const auto& p = pairs[want];
    std::vector<Point> x(4);
    x[p[0]] = Point(-1, 0, -0.1);
    x[p[1]] = Point(1, 0, -0.1);
    x[p[2]] = Point(0, -1, 0.1);
    x[p[3]] = Point(0, 1, 0.1);
    if (signedMeasure(CellType::Tetrahedron, x) < 0) std::swap(x[p[2]], x[p[3]]);
    EXPECT_EQ(shortestTetDiagonal(x), want);
    EXPECT_EQ(redRefinementRule(CellType::Tetrahedron, x).variant, want);
  }
  EXPECT_EQ(redRefinementRule(CellType::Hexahedron, referenceCorners(CellType::Hexahedron)).type,
            CellType::Hexahedron);
}

// --- uniform refinement of meshes
// ------------------------------------------------------------------

struct MeshCase {
  std::string name;
  std::function<Mesh()> make;
};
/// Prints the case by name (otherwise GoogleTest dumps its bytes into every test's listing).
void PrintTo(const MeshCase& c, std::ostream* os) { *os << c.name; }

std::vector<MeshCase> meshCases() {
  std::vector<MeshCase> out;
  for (CellType t : kVolumeCellTypes)
    out.push_back({std::string(name(t)), [t] {
                     return boxMesh(t, {2, 2, 2}, Point(0, 0, 0), Point(2, 1.5, 1));
                   }});
  out.push_back({"mixed", [] { return mixedBoxMesh3D({2, 2, 4}, Point::Zero(), Point(1, 1, 2)); }});
  return out;
}

using Edge = std::array<Index, 2>;

/// Number of distinct edges, of distinct quadrilateral faces of 3D cells, and of hexahedra and
/// 2D quadrilaterals: the new vertices of one red refinement.
Index newVertexCount(const Mesh& m) {
  std::set<Edge> edges;
  std::set<FaceKey> quads;
  Index centres = 0;
  for (Index c = 0; c < m.numCells(); ++c) {
    const auto cv = m.cellVertices(c);
    const CellType t = m.cellType(c);
    for (const auto& e : localEdges(t))
      edges.insert({std::min(cv[e[0]], cv[e[1]]), std::max(cv[e[0]], cv[e[1]])});
    if (t == CellType::Quadrilateral || t == CellType::Hexahedron) ++centres;
    if (m.dimension() == 3)
      for (const LocalFace& f : localFaces(t))
        if (f.size == 4) {
          std::vector<Index> v;
          for (int i = 0; i < 4; ++i) v.push_back(cv[f.vertices[i]]);
          quads.insert(makeFaceKey(v));
        }
  }
  return static_cast<Index>(edges.size() + quads.size()) + centres;
}

/// Mean-ratio quality of a tetrahedron, 1 for the regular one.
double tetQuality(const Mesh& m, Index c) {
  const double v = cellVolume(m, c);
  double s = 0;
  const auto cv = m.cellVertices(c);
  for (const auto& e : localEdges(CellType::Tetrahedron))
    s += (m.vertex(cv[e[0]]) - m.vertex(cv[e[1]])).squaredNorm();
  return 12.0 * std::pow(3.0 * v, 2.0 / 3.0) / s;
}

double minTetQuality(const Mesh& m) {
  double q = 1;
  for (Index c = 0; c < m.numCells(); ++c)
    if (m.cellType(c) == CellType::Tetrahedron) q = std::min(q, tetQuality(m, c));
  return q;
}

class RefineTest : public ::testing::TestWithParam<MeshCase> {};

TEST_P(RefineTest, ThreeUniformRefinements) {
  Mesh m = GetParam().make();
  const double volume = totalVolume(m);
  const auto area = boundaryMeasureById(m);
  const auto names = m.boundaryNames();
  const int dim = m.dimension();
  const double q0 = minTetQuality(m);
  for (int level = 1; level <= 3; ++level) {
    const auto counts = m.cellCounts();
    const Index expectedVertices = m.numVertices() + newVertexCount(m);
    const Index faces = m.numBoundaryFaces();
    m = refineUniformly(m);

    // Exact counts: 4 (2D) or 8 children per cell; a pyramid gives 6 pyramids + 4 tetrahedra.
    auto at = [&](CellType t) { return counts[static_cast<int>(t)]; };
    std::array<Index, 7> expected{};
    expected[static_cast<int>(CellType::Triangle)] = 4 * at(CellType::Triangle);
    expected[static_cast<int>(CellType::Quadrilateral)] = 4 * at(CellType::Quadrilateral);
    expected[static_cast<int>(CellType::Tetrahedron)] =
        8 * at(CellType::Tetrahedron) + 4 * at(CellType::Pyramid);
    expected[static_cast<int>(CellType::Hexahedron)] = 8 * at(CellType::Hexahedron);
    expected[static_cast<int>(CellType::Prism)] = 8 * at(CellType::Prism);
    expected[static_cast<int>(CellType::Pyramid)] = 6 * at(CellType::Pyramid);
    EXPECT_EQ(m.cellCounts(), expected) << "level " << level;
    EXPECT_EQ(m.numVertices(), expectedVertices);
    EXPECT_EQ(m.numBoundaryFaces(), faces * (dim == 2 ? 2 : 4));

    EXPECT_NEAR(totalVolume(m), volume, 1e-12 * volume);
    for (Index c = 0; c < m.numCells(); ++c) ASSERT_TRUE(isPositivelyOriented(m, c)) << c;
    const ConformityReport r = checkConformity(m);
    EXPECT_TRUE(r.conforming()) << "level " << level;
    EXPECT_EQ(r.boundaryFaces, m.numBoundaryFaces());

    EXPECT_EQ(m.boundaryNames(), names);
    const auto a = boundaryMeasureById(m);
    ASSERT_EQ(a.size(), area.size());
    for (const auto& [id, value] : area) EXPECT_NEAR(a.at(id), value, 1e-12 * value) << id;
  }
  // Shortest-diagonal refinement keeps the tetrahedra shape regular (finitely many similarity
  // classes): the worst mean ratio stays within 10% of the coarse one (measured: 0.93 for the
  // Kuhn tetrahedra of these boxes, constant after the first refinement).
  if (q0 < 1) {
    EXPECT_GT(minTetQuality(m), 0.9 * q0);
  }
}

TEST_P(RefineTest, DistortedMeshKeepsVolumeAndOrientation) {
  Mesh m = GetParam().make();
  perturbInteriorVertices(m, 0.25, 17);
  const double volume = totalVolume(m);
  for (int level = 1; level <= 2; ++level) {
    m = refineUniformly(m);
    for (Index c = 0; c < m.numCells(); ++c) ASSERT_TRUE(isPositivelyOriented(m, c)) << c;
    EXPECT_TRUE(checkConformity(m).conforming());
    // Conforming children whose boundary faces refine the parents' (bilinear) faces exactly.
    EXPECT_NEAR(totalVolume(m), volume, 1e-12 * volume);
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, RefineTest, ::testing::ValuesIn(meshCases()),
                         [](const auto& info) { return info.param.name; });

TEST(Refine, StretchedTetrahedronQualityStaysBounded) {
  Mesh m(3);
  for (const Point& p : {Point(0, 0, 0), Point(4, 0, 0), Point(0.5, 1, 0), Point(1, 0.3, 0.8)})
    m.addVertex(p);
  m.addCell(CellType::Tetrahedron, {0, 1, 2, 3});
  const double q0 = minTetQuality(m);
  for (int level = 1; level <= 4; ++level) {
    m = refineUniformly(m);
    EXPECT_GT(minTetQuality(m), 0.8 * q0) << "level " << level;  // measured 0.86
  }
  EXPECT_EQ(m.numCells(), 4096);
}

TEST(Refine, NewVerticesAreSharedAndOldKeepTheirNumbers) {
  const Mesh m = boxMesh(CellType::Quadrilateral, 2);
  const Mesh r = refineUniformly(m);
  for (Index v = 0; v < m.numVertices(); ++v) EXPECT_EQ(r.vertex(v), m.vertex(v));
  EXPECT_EQ(r.numVertices(), 25);  // the 5 x 5 grid
  for (Index v = 0; v < r.numVertices(); ++v)
    for (Index w = v + 1; w < r.numVertices(); ++w)
      EXPECT_GT((r.vertex(v) - r.vertex(w)).norm(), 1e-12);
}

TEST(Refine, BoundaryFaceChildrenKeepOrientation) {
  const Mesh m = refineUniformly(boxMesh(CellType::Prism, 1));
  // Children of a boundary face have the outward normal of the parent face: with the box sides
  // axis-aligned, the normal of every face with id kTop points along +z, etc.
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
    const auto fv = m.boundaryFaceVertices(f);
    Point n = Point::Zero();
    for (std::size_t i = 0; i < fv.size(); ++i)
      n += m.vertex(fv[i]).cross(m.vertex(fv[(i + 1) % fv.size()]));
    const int id = m.boundaryFaceId(f);
    const int axis = id <= 2 ? 0 : id <= 4 ? 2 : 1;
    EXPECT_GT(n[axis] * (id % 2 == 0 ? 1 : -1), 0) << "face " << f << " id " << id;
  }
}

}  // namespace
