// Coarse-mesh checks of the hierarchical grid: mirrored cells are reoriented and reported, and bad
// input (repeated vertices, zero-volume and inverted cells, duplicates, non-manifold faces,
// overlapping cells, boundary faces that are not one-cell faces) is an obs::Error naming the cell
// or face; unlisted boundary faces get id kUnlistedBoundaryId.
#include <gtest/gtest.h>

#include <string>

#include "../GridCheck.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"

using namespace obs::mesh;

namespace {

/// The error message of constructing a Grid from m ("" if none).
std::string errorOf(const Mesh& m) {
  try {
    Grid g(m);
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "";
}

/// Copy of m with the vertex order of the given cells mirrored (inverted orientation).
Mesh mirrored(const Mesh& m, const std::vector<Index>& cells) {
  Mesh out(m.dimension());
  for (const Point& x : m.vertices()) out.addVertex(x);
  for (Index c = 0; c < m.numCells(); ++c) {
    std::vector<Index> v(m.cellVertices(c).begin(), m.cellVertices(c).end());
    if (std::find(cells.begin(), cells.end(), c) != cells.end()) {
      switch (m.cellType(c)) {
        case CellType::Hexahedron: v = {v[4], v[5], v[6], v[7], v[0], v[1], v[2], v[3]}; break;
        case CellType::Prism: v = {v[3], v[4], v[5], v[0], v[1], v[2]}; break;
        case CellType::Pyramid:
        case CellType::Quadrilateral: std::swap(v[1], v[3]); break;
        default: std::swap(v[0], v[1]); break;
      }
    }
    out.addCell(m.cellType(c), v);
  }
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    out.addBoundaryFace(m.boundaryFaceVertices(f), m.boundaryFaceId(f));
  return out;
}

Mesh twoTriangles() {
  Mesh m(2);
  m.addVertex(Point(0, 0, 0));
  m.addVertex(Point(1, 0, 0));
  m.addVertex(Point(1, 1, 0));
  m.addVertex(Point(0, 1, 0));
  m.addCell(CellType::Triangle, {0, 1, 2});
  m.addCell(CellType::Triangle, {0, 2, 3});
  return m;
}

}  // namespace

TEST(GridInput, MirroredCellsAreReorientedAndReported) {
  for (CellType t : kVolumeCellTypes) {
    const Mesh box = boxMesh(t, 2);
    const Mesh bad = mirrored(box, {0, 3});
    ASSERT_FALSE(isPositivelyOriented(bad, 0));
    Grid g(bad);
    EXPECT_EQ(g.reorientedCells(), 2) << name(t);
    EXPECT_EQ(g.inputReport().reorientedCells, (std::vector<Index>{0, 3})) << name(t);
    for (Index e = 0; e < bad.numCells(); ++e) {
      std::vector<Point> x;
      for (Index v : g.vertices(e)) x.push_back(g.vertex(v));
      EXPECT_TRUE(isPositivelyOriented(t, x)) << name(t);
    }
    g.mark(0);
    g.adapt();
    obs::test::checkGrid(g);
    const Mesh leaf = g.leafMesh();
    EXPECT_TRUE(checkConformity(leaf).conforming()) << name(t);
    EXPECT_NEAR(totalVolume(leaf), totalVolume(box), 1e-12) << name(t);
  }
  Grid mixed(mirrored(mixedBoxMesh3D({2, 2, 4}, Point::Zero(), Point(1, 1, 2)), {1, 10, 20, 30}));
  EXPECT_EQ(mixed.reorientedCells(), 4);
  mixed.refineUniformly();
  EXPECT_TRUE(checkConformity(mixed.leafMesh()).conforming());
}

TEST(GridInput, RepeatedVertexIsAnError) {
  Mesh m(2);
  for (int i = 0; i < 3; ++i) m.addVertex(Point(i, i * i, 0));
  m.addCell(CellType::Triangle, {0, 1, 1});
  const std::string msg = errorOf(m);
  EXPECT_NE(msg.find("coarse cell 0 (triangle)"), std::string::npos) << msg;
  EXPECT_NE(msg.find("vertex 1 twice"), std::string::npos) << msg;
}

TEST(GridInput, DegenerateCellIsAnError) {
  Mesh m = boxMesh(CellType::Tetrahedron, 1);
  Mesh flat(3);
  for (const Point& x : m.vertices()) flat.addVertex(x);
  for (Index c = 0; c < m.numCells(); ++c) flat.addCell(CellType::Tetrahedron, m.cellVertices(c));
  flat.addVertex(Point(0.5, 0.5, 0));
  flat.addVertex(Point(2, 0, 0));
  flat.addCell(CellType::Tetrahedron, {0, 1, 8, 9});  // all in the plane z = 0
  const std::string msg = errorOf(flat);
  EXPECT_NE(msg.find("coarse cell 6 (tetrahedron) is degenerate"), std::string::npos) << msg;
}

TEST(GridInput, InvertedCellIsAnError) {
  // A hexahedron with one top corner pushed below the bottom face: the corner Jacobians have both
  // signs, so neither this vertex order nor the mirrored one is positive.
  Mesh m(3);
  for (const Point& p : {Point(0, 0, 0), Point(1, 0, 0), Point(1, 1, 0), Point(0, 1, 0),
                         Point(0, 0, -1), Point(1, 0, 1), Point(1, 1, 1), Point(0, 1, 1)})
    m.addVertex(p);
  m.addCell(CellType::Hexahedron, {0, 1, 2, 3, 4, 5, 6, 7});
  const std::string msg = errorOf(m);
  EXPECT_NE(msg.find("coarse cell 0 (hexahedron) is inverted"), std::string::npos) << msg;
  // A non-convex quadrilateral (a dart) in 2D.
  Mesh q(2);
  for (const Point& p : {Point(0, 0, 0), Point(2, 0, 0), Point(0.5, 0.5, 0), Point(0, 2, 0)})
    q.addVertex(p);
  q.addCell(CellType::Quadrilateral, {0, 1, 2, 3});
  const std::string qm = errorOf(q);
  EXPECT_NE(qm.find("coarse cell 0 (quadrilateral) is inverted"), std::string::npos) << qm;
}

TEST(GridInput, DuplicateCellIsAnError) {
  Mesh m = twoTriangles();
  m.addCell(CellType::Triangle, {2, 0, 1});
  const std::string msg = errorOf(m);
  EXPECT_NE(msg.find("coarse cell 2 (triangle) duplicates coarse cell 0"), std::string::npos) << msg;
}

TEST(GridInput, NonManifoldFaceIsAnError) {
  Mesh m = twoTriangles();
  m.addVertex(Point(0.5, -1, 0));
  m.addVertex(Point(2, 2, 0));
  m.addCell(CellType::Triangle, {4, 2, 0});  // a third triangle at edge 0-2 (folded over)
  const std::string msg = errorOf(m);
  EXPECT_NE(msg.find("non-manifold"), std::string::npos) << msg;
  EXPECT_NE(msg.find("{0, 2}"), std::string::npos) << msg;
}

TEST(GridInput, OverlappingCellsAreAnError) {
  Mesh m(2);
  m.addVertex(Point(0, 0, 0));
  m.addVertex(Point(1, 0, 0));
  m.addVertex(Point(0, 1, 0));
  m.addVertex(Point(0.2, 0.2, 0));
  m.addCell(CellType::Triangle, {0, 1, 2});
  m.addCell(CellType::Triangle, {0, 1, 3});  // on the same side of edge 0-1
  const std::string msg = errorOf(m);
  EXPECT_NE(msg.find("coarse cells 0 and 1 overlap"), std::string::npos) << msg;
}

TEST(GridInput, BadBoundaryFacesAreErrors) {
  Mesh m = twoTriangles();
  m.addBoundaryFace({0, 2}, 5);  // the interior diagonal
  EXPECT_NE(errorOf(m).find("boundary face 0 (vertices {0, 2}, id 5) is an interior face"),
            std::string::npos)
      << errorOf(m);
  Mesh n = twoTriangles();
  n.addBoundaryFace({1, 3}, 5);  // not a face
  EXPECT_NE(errorOf(n).find("is not a face of any cell"), std::string::npos) << errorOf(n);
  Mesh o = twoTriangles();
  o.addBoundaryFace({0, 1}, 5);
  o.addBoundaryFace({1, 0}, 6);
  EXPECT_NE(errorOf(o).find("repeats boundary face 0 with another id"), std::string::npos)
      << errorOf(o);
  EXPECT_NE(errorOf(Mesh(3)).find("no cells"), std::string::npos);
}

TEST(GridInput, UnlistedBoundaryFacesGetTheDefaultId) {
  Mesh m = twoTriangles();
  m.addBoundaryFace({0, 1}, 7);
  Grid g(m);
  EXPECT_EQ(g.inputReport().unlistedBoundaryFaces, 3);
  g.refineUniformly();
  const Mesh leaf = g.leafMesh();
  EXPECT_TRUE(checkConformity(leaf).conforming());
  const auto area = boundaryMeasureById(leaf);
  EXPECT_NEAR(area.at(7), 1.0, 1e-14);
  EXPECT_NEAR(area.at(kUnlistedBoundaryId), 3.0, 1e-14);
}
