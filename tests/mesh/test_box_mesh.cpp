// Box mesh generators: exact counts, volume, orientation, conformity, boundary ids/names/planes,
// for all six cell types and the mixed 3D mesh; invalid arguments.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <functional>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"

using namespace obs::mesh;

namespace {

const Point kLower(-1.0, 0.5, 2.0);
const Point kUpper(1.0, 2.0, 3.5);
constexpr std::array<int, 3> kCells = {3, 2, 4};

struct Expected {
  Index vertices = 0;
  std::array<Index, 7> cells{};     // by CellType
  std::map<int, Index> facesPerId;  // boundary faces of each id
};

struct Case {
  std::string name;
  std::function<Mesh()> make;
  Expected expected;
};
/// Prints the case by name (otherwise GoogleTest dumps its bytes into every test's listing).
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

Expected expectedBox(CellType t, std::array<int, 3> n) {
  const Index nx = n[0], ny = n[1], nz = n[2];
  Expected e;
  if (dimension(t) == 2) {
    e.vertices = (nx + 1) * (ny + 1);
    e.cells[static_cast<int>(t)] = (t == CellType::Triangle ? 2 : 1) * nx * ny;
    e.facesPerId = {{kLeft, ny}, {kRight, ny}, {kBottom, nx}, {kTop, nx}};
    return e;
  }
  const Index blocks = nx * ny * nz;
  e.vertices = (nx + 1) * (ny + 1) * (nz + 1) + (t == CellType::Pyramid ? blocks : 0);
  const Index perBlock = t == CellType::Tetrahedron || t == CellType::Pyramid ? 6
                         : t == CellType::Prism                               ? 2
                                                                              : 1;
  e.cells[static_cast<int>(t)] = perBlock * blocks;
  const Index split = t == CellType::Tetrahedron ? 2 : 1;  // triangles per block face
  const Index splitZ = t == CellType::Tetrahedron || t == CellType::Prism ? 2 : 1;
  e.facesPerId = {{kLeft, split * ny * nz}, {kRight, split * ny * nz}, {kBottom, splitZ * nx * ny},
                  {kTop, splitZ * nx * ny}, {kFront, split * nx * nz}, {kBack, split * nx * nz}};
  return e;
}

std::vector<Case> cases() {
  std::vector<Case> out;
  for (CellType t : kVolumeCellTypes)
    out.push_back({std::string(name(t)), [t] { return boxMesh(t, kCells, kLower, kUpper); },
                   expectedBox(t, kCells)});
  // Mixed mesh, 3 x 2 x 8 blocks: slabs of 2 layers each; per layer 6 blocks.
  //  hexahedra 2*6, prisms 2*2*6, pyramids 6*6 (centre split) + 3*6 (transition), tetrahedra 2*6*6.
  Expected mixed;
  mixed.vertices = 4 * 3 * 9 + 6;
  mixed.cells[static_cast<int>(CellType::Hexahedron)] = 12;
  mixed.cells[static_cast<int>(CellType::Prism)] = 24;
  mixed.cells[static_cast<int>(CellType::Pyramid)] = 54;
  mixed.cells[static_cast<int>(CellType::Tetrahedron)] = 72;
  // Layers k: 0-1 hexahedra, 2-3 prisms along x, 4 centre pyramids, 5 transition pyramids,
  // 6-7 tetrahedra. Faces per block column on the x-sides (2 columns): 2 + 2*2 + 1 + t + 2*2 with
  // t = 1 on the left (base) and t = 2 on the right (i = 2 even: apex side, triangulated); on the
  // y-sides (3 columns): 2 + 2 + 1 + 1 + 2*2 (the prisms along x have whole quadrilaterals there,
  // j = 0 and j = 1 both put a pyramid base on the outer side).
  mixed.facesPerId = {{kLeft, 2 * 12}, {kRight, 2 * 13}, {kBottom, 6},
                      {kTop, 12},      {kFront, 3 * 10}, {kBack, 3 * 10}};
  out.push_back({"mixed", [] { return mixedBoxMesh3D({3, 2, 8}, kLower, kUpper); }, mixed});
  return out;
}

class BoxMeshTest : public ::testing::TestWithParam<Case> {
protected:
  void SetUp() override { mesh_ = GetParam().make(); }
  Mesh mesh_;
};

double boxVolume(int dim) {
  const Point d = kUpper - kLower;
  return dim == 2 ? d[0] * d[1] : d[0] * d[1] * d[2];
}

TEST_P(BoxMeshTest, ExactCounts) {
  const Expected& e = GetParam().expected;
  EXPECT_EQ(mesh_.numVertices(), e.vertices);
  EXPECT_EQ(mesh_.cellCounts(), e.cells);
  std::map<int, Index> faces;
  for (Index f = 0; f < mesh_.numBoundaryFaces(); ++f) ++faces[mesh_.boundaryFaceId(f)];
  EXPECT_EQ(faces, e.facesPerId);
}

TEST_P(BoxMeshTest, VolumeAndOrientation) {
  EXPECT_NEAR(totalVolume(mesh_), boxVolume(mesh_.dimension()), 1e-12);
  for (Index c = 0; c < mesh_.numCells(); ++c) {
    EXPECT_TRUE(isPositivelyOriented(mesh_, c)) << "cell " << c;
    EXPECT_GT(cellVolume(mesh_, c), 0.0);
  }
}

TEST_P(BoxMeshTest, Conforming) {
  const ConformityReport r = checkConformity(mesh_);
  EXPECT_TRUE(r.conforming());
  EXPECT_EQ(r.nonManifoldFaces, 0);
  EXPECT_EQ(r.misorientedFaces, 0);
  EXPECT_EQ(r.hangingFaces, 0);
  EXPECT_EQ(r.unmatchedBoundaryFaces, 0);
  EXPECT_EQ(r.boundaryFaces, mesh_.numBoundaryFaces());
  EXPECT_GT(r.interiorFaces, 0);
}

TEST_P(BoxMeshTest, BoundaryFacesOnNamedPlanesWithOutwardNormals) {
  const int dim = mesh_.dimension();
  // id -> (coordinate direction, lower/upper side)
  std::map<int, std::pair<int, int>> plane = {{kLeft, {0, 0}}, {kRight, {0, 1}}};
  plane[kBottom] = {dim == 2 ? 1 : 2, 0};
  plane[kTop] = {dim == 2 ? 1 : 2, 1};
  if (dim == 3) {
    plane[kFront] = {1, 0};
    plane[kBack] = {1, 1};
    EXPECT_EQ(mesh_.boundaryNames().size(), 6u);
  } else {
    EXPECT_EQ(mesh_.boundaryNames().size(), 4u);
  }
  const char* names[] = {"", "left", "right", "bottom", "top", "front", "back"};
  for (int id = 1; id <= 2 * dim; ++id) EXPECT_EQ(mesh_.boundaryId(names[id]), id);

  for (Index f = 0; f < mesh_.numBoundaryFaces(); ++f) {
    const auto [d, side] = plane.at(mesh_.boundaryFaceId(f));
    const double value = side ? kUpper[d] : kLower[d];
    const auto fv = mesh_.boundaryFaceVertices(f);
    for (Index v : fv) EXPECT_DOUBLE_EQ(mesh_.vertex(v)[d], value);
    // Outward normal: right-hand normal of the vertex cycle (2D: rotated tangent).
    Point n = Point::Zero();
    if (dim == 2) {
      const Point t = mesh_.vertex(fv[1]) - mesh_.vertex(fv[0]);
      n = Point(t[1], -t[0], 0);
    } else {
      for (std::size_t i = 0; i < fv.size(); ++i)
        n += mesh_.vertex(fv[i]).cross(mesh_.vertex(fv[(i + 1) % fv.size()]));
    }
    EXPECT_GT(n[d] * (side ? 1 : -1), 0.0) << "face " << f;
  }
  // Boundary measure per id equals the area (length) of the box side.
  const Point ext = kUpper - kLower;
  for (const auto& [id, m] : boundaryMeasureById(mesh_)) {
    const int d = plane.at(id).first;
    const double expected = dim == 2 ? ext[1 - d] : ext[0] * ext[1] * ext[2] / ext[d];
    EXPECT_NEAR(m, expected, 1e-12) << "id " << id;
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, BoxMeshTest, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

TEST(BoxMesh, ConvenienceOverloadIsTheUnitBox) {
  const Mesh m = boxMesh(CellType::Hexahedron, 2);
  EXPECT_EQ(m.numCells(), 8);
  EXPECT_NEAR(totalVolume(m), 1.0, 1e-14);
  const Mesh t = boxMesh(CellType::Triangle, 3);
  EXPECT_EQ(t.numCells(), 18);
  EXPECT_NEAR(totalVolume(t), 1.0, 1e-14);
}

TEST(BoxMesh, KuhnTetrahedraShareTheMainDiagonal) {
  const Mesh m = boxMesh(CellType::Tetrahedron, 1);
  for (Index c = 0; c < m.numCells(); ++c) {
    const auto cv = m.cellVertices(c);
    EXPECT_NE(std::find(cv.begin(), cv.end(), 0), cv.end());
    EXPECT_NE(std::find(cv.begin(), cv.end(), 7), cv.end());
  }
}

TEST(BoxMesh, MixedMeshSlabsForSmallestLayerCount) {
  const Mesh m = mixedBoxMesh3D({2, 3, 4}, Point::Zero(), Point::Ones());
  const auto counts = m.cellCounts();
  EXPECT_EQ(counts[static_cast<int>(CellType::Hexahedron)], 6);
  EXPECT_EQ(counts[static_cast<int>(CellType::Prism)], 12);
  EXPECT_EQ(counts[static_cast<int>(CellType::Pyramid)], 18);
  EXPECT_EQ(counts[static_cast<int>(CellType::Tetrahedron)], 36);
  EXPECT_TRUE(checkConformity(m).conforming());
  EXPECT_NEAR(totalVolume(m), 1.0, 1e-13);
}

TEST(BoxMesh, InvalidArgumentsThrow) {
  EXPECT_THROW(boxMesh(CellType::Segment, 2), obs::Error);
  EXPECT_THROW(boxMesh(CellType::Hexahedron, {2, 0, 2}, Point::Zero(), Point::Ones()), obs::Error);
  EXPECT_THROW(boxMesh(CellType::Quadrilateral, {2, -1, 0}, Point::Zero(), Point::Ones()),
               obs::Error);
  EXPECT_THROW(boxMesh(CellType::Tetrahedron, 2, Point::Zero(), Point(1, 1, 0)), obs::Error);
  EXPECT_THROW(boxMesh(CellType::Triangle, 2, Point(1, 0, 0), Point(1, 1, 0)), obs::Error);
  // 2D meshes ignore cells[2] and the z extent.
  EXPECT_NO_THROW(boxMesh(CellType::Triangle, {2, 2, 0}, Point::Zero(), Point(1, 1, 0)));
  EXPECT_THROW(mixedBoxMesh3D({2, 2, 3}, Point::Zero(), Point::Ones()), obs::Error);
  EXPECT_THROW(mixedBoxMesh3D({0, 2, 4}, Point::Zero(), Point::Ones()), obs::Error);
}

}  // namespace

// Found by fuzz_parsers (seed 2): a box too thin for its cell count in floating point made boxMesh
// throw std::logic_error ("cannot orient a cell"), which `obs check` does not report as an input
// error. Now it is an obs::Error naming the direction, before anything is built.
TEST(BoxMesh, BoxesTooThinOrTooLargeForFloatingPointAreErrors) {
  using obs::mesh::CellType;
  using obs::mesh::Point;
  for (const CellType t : {CellType::Quadrilateral, CellType::Triangle}) {
    EXPECT_THROW(obs::mesh::boxMesh(t, {32, 8, 1}, Point(0, 0, 0), Point(4, 4.9e-324, 0)), obs::Error);
    EXPECT_THROW(obs::mesh::boxMesh(t, {32, 8, 1}, Point(-1e308, 0, 0), Point(1e308, 1, 0)), obs::Error);
    // both spacings representable, but their product (the cell volume) underflows
    EXPECT_THROW(obs::mesh::boxMesh(t, {2, 2, 1}, Point(0, 0, 0), Point(1e-200, 1e-200, 0)), obs::Error);
  }
  EXPECT_THROW(obs::mesh::boxMesh(CellType::Hexahedron, {2, 2, 2}, Point(0, 0, 0), Point(1e-110, 1e-110, 1e-110)),
               obs::Error);
  // small but representable boxes still work
  EXPECT_EQ(obs::mesh::boxMesh(CellType::Quadrilateral, {4, 4, 1}, Point(0, 0, 0), Point(1e-100, 1e-100, 0)).numCells(), 16);
}
