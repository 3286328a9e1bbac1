// Mesh topology utilities: local tables against ReferenceElement, face table, the conformity
// check on good and deliberately broken meshes, exact volumes of non-affine cells, orientation,
// and the interior perturbation (orientation and volume kept, deterministic).
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <functional>
#include <map>
#include <random>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/ReferenceElement.hpp"

using namespace obs::mesh;

namespace {

std::vector<Point> referenceCorners(CellType t) { return referenceElement(t).vertices; }

/// Same cyclic sequence up to rotation.
bool sameCycle(std::vector<int> a, std::vector<int> b) {
  if (a.size() != b.size()) return false;
  for (std::size_t r = 0; r < a.size(); ++r) {
    if (a == b) return true;
    std::rotate(b.begin(), b.begin() + 1, b.end());
  }
  return false;
}

// --- local tables --------------------------------------------------------------------------------

class LocalTableTest : public ::testing::TestWithParam<CellType> {};

TEST_P(LocalTableTest, AgreesWithReferenceElement) {
  const ReferenceElement& e = referenceElement(GetParam());
  const auto edges = localEdges(GetParam());
  ASSERT_EQ(edges.size(), e.edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) EXPECT_EQ(edges[i], e.edges[i]) << "edge " << i;
  const auto faces = localFaces(GetParam());
  ASSERT_EQ(faces.size(), e.faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    EXPECT_EQ(faces[i].type, e.faces[i].type);
    const auto s = faces[i].span();
    EXPECT_TRUE(sameCycle({s.begin(), s.end()}, e.faces[i].vertices)) << "face " << i;
  }
}

TEST_P(LocalTableTest, FacesPointOutward) {
  const CellType t = GetParam();
  const auto x = referenceCorners(t);
  Point centre = Point::Zero();
  for (const Point& p : x) centre += p;
  centre /= static_cast<double>(x.size());
  for (const LocalFace& f : localFaces(t)) {
    Point fc = Point::Zero(), n = Point::Zero();
    for (int i = 0; i < f.size; ++i) fc += x[f.vertices[i]] / f.size;
    if (dimension(t) == 2) {
      const Point d = x[f.vertices[1]] - x[f.vertices[0]];
      n = Point(d[1], -d[0], 0);
    } else {
      for (int i = 0; i < f.size; ++i) n += x[f.vertices[i]].cross(x[f.vertices[(i + 1) % f.size]]);
    }
    EXPECT_GT(n.dot(fc - centre), 0.0);
  }
}

TEST_P(LocalTableTest, ReferenceMeasureAndOrientation) {
  const CellType t = GetParam();
  auto x = referenceCorners(t);
  EXPECT_NEAR(signedMeasure(t, x), referenceElement(t).volume, 1e-15);
  EXPECT_TRUE(isPositivelyOriented(t, x));
  // A mirrored cell (reflection of all corners) is negatively oriented.
  for (Point& p : x) p[0] = -p[0];
  EXPECT_NEAR(signedMeasure(t, x), -referenceElement(t).volume, 1e-15);
  EXPECT_FALSE(isPositivelyOriented(t, x));
}

TEST_P(LocalTableTest, AffineImageMeasure) {
  const CellType t = GetParam();
  Eigen::Matrix3d A;
  A << 2.0, 0.3, -0.2, 0.1, 1.5, 0.4, 0.2, -0.3, 0.8;
  if (dimension(t) == 2) {  // keep the x-y plane
    A.row(2) = Eigen::RowVector3d(0, 0, 1);
    A.col(2) = Point(0, 0, 1);
  }
  const Point b(0.3, -1.0, 2.0);
  auto x = referenceCorners(t);
  for (Point& p : x) p = A * p + (dimension(t) == 2 ? Point(b[0], b[1], 0) : b);
  EXPECT_NEAR(signedMeasure(t, x), A.determinant() * referenceElement(t).volume, 1e-13);
  EXPECT_TRUE(isPositivelyOriented(t, x));
}

INSTANTIATE_TEST_SUITE_P(AllTypes, LocalTableTest, ::testing::ValuesIn(kVolumeCellTypes),
                         [](const auto& info) { return std::string(name(info.param)); });

// --- exact measures of non-affine cells
// ------------------------------------------------------------

/// Reference-to-physical map of a cell, evaluated directly from the shape functions.
Point mapPoint(CellType t, const std::vector<Point>& x, const Point& xi) {
  const ReferenceElement& e = referenceElement(t);
  std::vector<double> phi(e.numVertices);
  e.values(xi, phi);
  Point p = Point::Zero();
  for (int i = 0; i < e.numVertices; ++i) p += phi[i] * x[i];
  return p;
}

/// Integral of det J by a 6-point Gauss rule per collapsed direction and central differences of
/// the map: independent of the closed formulas in signedMeasure.
double numericalVolume(CellType t, const std::vector<Point>& x) {
  const double g[6] = {0.0337652428984240, 0.1693953067668677, 0.3806904069584015,
                       0.6193095930415985, 0.8306046932331323, 0.9662347571015760};
  const double w[6] = {0.0856622461895852, 0.1803807865240693, 0.2339569672863455,
                       0.2339569672863455, 0.1803807865240693, 0.0856622461895852};
  const double h = 1e-6;
  double v = 0;
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
      for (int c = 0; c < 6; ++c) {
        // (u, s, z) in the unit cube -> reference point, with the Jacobian of the collapse.
        Point xi(g[a], g[b], g[c]);
        double jac = 1;
        if (t == CellType::Prism) {
          xi = Point(g[a] * (1 - g[b]), g[b], g[c]);
          jac = 1 - g[b];
        } else if (t == CellType::Pyramid) {
          xi = Point(g[a] * (1 - g[c]), g[b] * (1 - g[c]), g[c]);
          jac = (1 - g[c]) * (1 - g[c]);
        }
        Eigen::Matrix3d J;
        for (int k = 0; k < 3; ++k) {
          Point d = Point::Zero();
          d[k] = h;
          J.col(k) = (mapPoint(t, x, xi + d) - mapPoint(t, x, xi - d)) / (2 * h);
        }
        v += w[a] * w[b] * w[c] * jac * J.determinant();
      }
  return v;
}

TEST(Measure, NonAffineHexPrismPyramidAreExact) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-0.2, 0.2);
  for (CellType t : {CellType::Hexahedron, CellType::Prism, CellType::Pyramid}) {
    for (int trial = 0; trial < 3; ++trial) {
      auto x = referenceCorners(t);
      for (Point& p : x) p += Point(U(rng), U(rng), U(rng));
      ASSERT_TRUE(isPositivelyOriented(t, x));
      EXPECT_NEAR(signedMeasure(t, x), numericalVolume(t, x), 1e-8) << name(t);
    }
  }
}

TEST(Measure, BilinearQuadrilateralAndBoundaryFace) {
  const std::vector<Point> q = {Point(0, 0, 0), Point(2, 0, 0), Point(1.5, 1, 0),
                                Point(0.2, 1.3, 0)};
  // Shoelace area of the polygon.
  double a = 0;
  for (int i = 0; i < 4; ++i) a += q[i][0] * q[(i + 1) % 4][1] - q[(i + 1) % 4][0] * q[i][1];
  EXPECT_NEAR(signedMeasure(CellType::Quadrilateral, q), 0.5 * a, 1e-15);

  Mesh m(3);
  for (const Point& p : q) m.addVertex(Point(p[0], p[2], p[1]));  // the same quad in the x-z plane
  m.addBoundaryFace({0, 1, 2, 3}, 1);
  EXPECT_NEAR(boundaryFaceMeasure(m, 0), 0.5 * a, 1e-13);
}

// --- face table and conformity
// ---------------------------------------------------------------------

/// Two unit squares side by side (2D), with boundary segments.
Mesh twoQuads() {
  Mesh m(2);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) m.addVertex(Point(i, j, 0));
  m.addCell(CellType::Quadrilateral, {0, 1, 4, 3});
  m.addCell(CellType::Quadrilateral, {1, 2, 5, 4});
  m.addBoundaryFace({0, 1}, 1);
  m.addBoundaryFace({1, 2}, 1);
  m.addBoundaryFace({2, 5}, 2);
  m.addBoundaryFace({5, 4}, 3);
  m.addBoundaryFace({4, 3}, 3);
  m.addBoundaryFace({3, 0}, 4);
  return m;
}

TEST(FaceTable, SharedFaceAndLookup) {
  const Mesh m = twoQuads();
  const FaceTable t(m);
  EXPECT_EQ(t.numFaces(), 7);
  const Index f = t.find(std::vector<Index>{4, 1});
  ASSERT_GE(f, 0);
  EXPECT_EQ(t.numCells(f), 2);
  EXPECT_EQ(t.side(f, 0).cell, 0);
  EXPECT_EQ(t.side(f, 0).localFace, 1);
  EXPECT_EQ(t.side(f, 1).cell, 1);
  EXPECT_EQ(t.side(f, 1).localFace, 3);
  EXPECT_EQ(t.face(0, 1), f);
  EXPECT_EQ(t.face(1, 3), f);
  EXPECT_EQ(t.find(std::vector<Index>{0, 2}), -1);
  EXPECT_EQ(makeFaceKey(std::vector<Index>{5, 2, 9}), (FaceKey{2, 5, 9, -1}));

  const ConformityReport r = checkConformity(m);
  EXPECT_TRUE(r.conforming());
  EXPECT_EQ(r.interiorFaces, 1);
  EXPECT_EQ(r.boundaryFaces, 6);
}

// The table against a plain map from sorted vertex lists to the (cell, local face) sides in cell
// order, on meshes large enough to be built on threads; 1 and 2 threads give the same table.
TEST(FaceTable, AgreesWithAMapOfSortedKeysOnOneAndTwoThreads) {
  for (const auto& [type, n] : std::vector<std::pair<CellType, int>>{{CellType::Tetrahedron, 16},
                                                                    {CellType::Hexahedron, 24},
                                                                    {CellType::Prism, 20},
                                                                    {CellType::Pyramid, 14}}) {
    SCOPED_TRACE(static_cast<int>(type));
    const Mesh m = boxMesh(type, n);
    std::map<FaceKey, std::vector<FaceTable::Side>> expected;
    Index slots = 0;
    for (Index c = 0; c < m.numCells(); ++c) {
      const auto cv = m.cellVertices(c);
      const auto& faces = localFaces(m.cellType(c));
      for (std::size_t f = 0; f < faces.size(); ++f, ++slots) {
        std::vector<Index> v;
        for (int i = 0; i < faces[f].size; ++i) v.push_back(cv[faces[f].vertices[i]]);
        expected[makeFaceKey(v)].push_back({c, static_cast<int>(f)});
      }
    }
    ASSERT_GE(slots, 65536);  // the threaded path
    for (int threads : {1, 2}) {
      SCOPED_TRACE(threads);
      const FaceTable t(m, threads);
      ASSERT_EQ(t.numFaces(), static_cast<Index>(expected.size()));
      Index f = 0;
      for (const auto& [key, sides] : expected) {
        ASSERT_EQ(t.key(f), key) << f;
        ASSERT_EQ(t.numCells(f), static_cast<int>(sides.size())) << f;
        for (std::size_t k = 0; k < sides.size(); ++k) {
          EXPECT_EQ(t.side(f, static_cast<int>(k)).cell, sides[k].cell) << f;
          EXPECT_EQ(t.side(f, static_cast<int>(k)).localFace, sides[k].localFace) << f;
          EXPECT_EQ(t.face(sides[k].cell, sides[k].localFace), f);
        }
        if (sides.size() == 1) {
          EXPECT_EQ(t.side(f, 1).cell, -1);
        }
        std::vector<Index> reversed(key.begin(), key.begin() + t.size(f));
        std::reverse(reversed.begin(), reversed.end());
        EXPECT_EQ(t.find(reversed), f);
        ++f;
      }
    }
  }
}

TEST(EdgeTable, EdgesSortedAndShared) {
  const Mesh m = twoQuads();
  const EdgeTable t(m);
  EXPECT_EQ(t.numEdges(), 7);
  for (Index e = 0; e + 1 < t.numEdges(); ++e) EXPECT_LT(t.vertices(e), t.vertices(e + 1));
  const Index shared = t.find(4, 1);
  ASSERT_GE(shared, 0);
  EXPECT_EQ(t.vertices(shared), (std::array<Index, 2>{1, 4}));
  EXPECT_EQ(t.edge(0, 1), shared);  // local edge (1,2) of cell 0 = global 1-4
  EXPECT_EQ(t.edge(1, 3), shared);  // local edge (3,0) of cell 1 = global 4-1
  EXPECT_EQ(t.find(0, 4), -1);
  EXPECT_EQ(t.find(0, 99), -1);

  // Kuhn cube: 12 cube edges + 6 face diagonals + 1 main diagonal.
  EXPECT_EQ(EdgeTable(boxMesh(CellType::Tetrahedron, 1)).numEdges(), 19);
  // Edge count of a hexahedral grid: 3 n (n+1)^2.
  EXPECT_EQ(EdgeTable(boxMesh(CellType::Hexahedron, 3)).numEdges(), 3 * 3 * 16);
}

TEST(Conformity, DetectsHangingVertex) {
  // One quad on the left, two on the right: vertex 6 hangs on the left quad's right edge.
  Mesh m(2);
  for (const Point& p : {Point(0, 0, 0), Point(1, 0, 0), Point(2, 0, 0), Point(0, 2, 0),
                         Point(1, 2, 0), Point(2, 2, 0), Point(1, 1, 0), Point(2, 1, 0)})
    m.addVertex(p);
  m.addCell(CellType::Quadrilateral, {0, 1, 4, 3});
  m.addCell(CellType::Quadrilateral, {1, 2, 7, 6});
  m.addCell(CellType::Quadrilateral, {6, 7, 5, 4});
  for (auto [a, b] : {std::pair{0, 1}, {1, 2}, {2, 7}, {7, 5}, {5, 4}, {4, 3}, {3, 0}})
    m.addBoundaryFace({a, b}, 1);
  const ConformityReport r = checkConformity(m);
  EXPECT_FALSE(r.conforming());
  EXPECT_EQ(r.hangingFaces, 3);  // 1-4 on the left, 1-6 and 6-4 on the right
  EXPECT_EQ(r.unmatchedBoundaryFaces, 0);
  EXPECT_EQ(r.interiorFaces, 1);
}

TEST(Conformity, DetectsMissingAndBogusBoundaryFaces) {
  Mesh m = twoQuads();
  Mesh missing(2);
  for (const Point& p : m.vertices()) missing.addVertex(p);
  missing.addCell(CellType::Quadrilateral, {0, 1, 4, 3});
  missing.addCell(CellType::Quadrilateral, {1, 2, 5, 4});
  missing.addBoundaryFace({0, 1}, 1);
  EXPECT_EQ(checkConformity(missing).hangingFaces, 5);

  m.addBoundaryFace({1, 4}, 7);  // an interior face
  m.addBoundaryFace({0, 2}, 7);  // not a face at all
  m.addBoundaryFace({1, 0}, 7);  // listed twice
  const ConformityReport r = checkConformity(m);
  EXPECT_EQ(r.unmatchedBoundaryFaces, 3);
  EXPECT_EQ(r.hangingFaces, 0);
  EXPECT_FALSE(r.conforming());
}

TEST(Conformity, DetectsNonManifoldAndMisorientedFaces) {
  Mesh m = boxMesh(CellType::Tetrahedron, 1);
  Mesh bad(3);
  for (const Point& p : m.vertices()) bad.addVertex(p);
  for (Index c = 0; c < m.numCells(); ++c) bad.addCell(m.cellType(c), m.cellVertices(c));
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    bad.addBoundaryFace(m.boundaryFaceVertices(f), m.boundaryFaceId(f));
  ASSERT_TRUE(checkConformity(bad).conforming());

  // Invert one tetrahedron: its three interior faces are now traversed like the neighbours'.
  Mesh inverted = bad;
  auto cv = inverted.cellVertices(0);
  std::swap(cv[1], cv[2]);
  const ConformityReport ri = checkConformity(inverted);
  EXPECT_GT(ri.misorientedFaces, 0);
  EXPECT_FALSE(isPositivelyOriented(inverted, 0));

  // A duplicated cell makes its interior faces non-manifold.
  bad.addCell(CellType::Tetrahedron, m.cellVertices(0));
  const ConformityReport rd = checkConformity(bad);
  EXPECT_GT(rd.nonManifoldFaces, 0);
  EXPECT_FALSE(rd.conforming());
}

TEST(Conformity, DetectsNonConformingHexTetInterface) {
  // A hexahedron next to a Kuhn-split cube: the shared square is one quadrilateral on one side and
  // two triangles on the other.
  Mesh hex = boxMesh(CellType::Hexahedron, {1, 1, 1}, Point(0, 0, 0), Point(1, 1, 1));
  Mesh tet = boxMesh(CellType::Tetrahedron, {1, 1, 1}, Point(1, 0, 0), Point(2, 1, 1));
  Mesh m(3);
  for (const Point& p : hex.vertices()) m.addVertex(p);
  std::vector<Index> map;
  for (const Point& p : tet.vertices()) {
    Index found = -1;
    for (Index v = 0; v < hex.numVertices(); ++v)
      if ((hex.vertex(v) - p).norm() < 1e-14) found = v;
    map.push_back(found >= 0 ? found : m.addVertex(p));
  }
  m.addCell(CellType::Hexahedron, hex.cellVertices(0));
  for (Index c = 0; c < tet.numCells(); ++c) {
    std::vector<Index> v;
    for (Index x : tet.cellVertices(c)) v.push_back(map[x]);
    m.addCell(CellType::Tetrahedron, v);
  }
  for (Index f = 0; f < hex.numBoundaryFaces(); ++f)
    if (hex.boundaryFaceId(f) != kRight) m.addBoundaryFace(hex.boundaryFaceVertices(f), 1);
  for (Index f = 0; f < tet.numBoundaryFaces(); ++f)
    if (tet.boundaryFaceId(f) != kLeft) {
      std::vector<Index> v;
      for (Index x : tet.boundaryFaceVertices(f)) v.push_back(map[x]);
      m.addBoundaryFace(v, 1);
    }
  const ConformityReport r = checkConformity(m);
  EXPECT_EQ(r.hangingFaces, 3);  // the quadrilateral and the two triangles
  EXPECT_FALSE(r.conforming());
}

// --- perturbation
// ----------------------------------------------------------------------------------

struct PerturbCase {
  std::string name;
  std::function<Mesh()> make;
};
/// Prints the case by name (otherwise GoogleTest dumps its bytes into every test's listing).
void PrintTo(const PerturbCase& c, std::ostream* os) { *os << c.name; }

std::vector<PerturbCase> perturbCases() {
  std::vector<PerturbCase> out;
  for (CellType t : kVolumeCellTypes)
    out.push_back({std::string(name(t)), [t] {
                     return boxMesh(t, {4, 3, 3}, Point(0, 0, 0), Point(2, 1.5, 1));
                   }});
  out.push_back({"mixed", [] { return mixedBoxMesh3D({3, 3, 6}, Point::Zero(), Point::Ones()); }});
  return out;
}

class PerturbTest : public ::testing::TestWithParam<PerturbCase> {};

TEST_P(PerturbTest, KeepsOrientationVolumeAndBoundary) {
  const Mesh original = GetParam().make();
  Mesh m = original;
  perturbInteriorVertices(m, 0.3, 1234);
  const auto boundary = boundaryVertexFlags(original);
  Index moved = 0;
  for (Index v = 0; v < m.numVertices(); ++v) {
    const double d = (m.vertex(v) - original.vertex(v)).norm();
    if (boundary[v]) {
      EXPECT_EQ(d, 0.0);
    }
    moved += d > 0;
  }
  EXPECT_GT(moved, 0);
  for (Index c = 0; c < m.numCells(); ++c) EXPECT_TRUE(isPositivelyOriented(m, c)) << c;
  EXPECT_NEAR(totalVolume(m), totalVolume(original), 1e-12);
  EXPECT_TRUE(checkConformity(m).conforming());

  // Deterministic for a seed, different for another seed.
  Mesh again = original, other = original;
  perturbInteriorVertices(again, 0.3, 1234);
  perturbInteriorVertices(other, 0.3, 99);
  EXPECT_EQ(again.vertices(), m.vertices());
  EXPECT_NE(other.vertices(), m.vertices());
}

INSTANTIATE_TEST_SUITE_P(AllTypes, PerturbTest, ::testing::ValuesIn(perturbCases()),
                         [](const auto& info) { return info.param.name; });

TEST(Perturb, MakesHexahedraNonAffine) {
  Mesh m = boxMesh(CellType::Hexahedron, 3);
  perturbInteriorVertices(m, 0.25, 5);
  // Some cell is no longer a parallelepiped: x0 + x2 != x1 + x3 on its bottom face.
  bool nonAffine = false;
  for (Index c = 0; c < m.numCells(); ++c) {
    const auto v = m.cellVertices(c);
    nonAffine |= (m.vertex(v[0]) + m.vertex(v[2]) - m.vertex(v[1]) - m.vertex(v[3])).norm() > 1e-3;
  }
  EXPECT_TRUE(nonAffine);
  EXPECT_THROW(perturbInteriorVertices(m, -0.1, 1), obs::Error);
}

}  // namespace
