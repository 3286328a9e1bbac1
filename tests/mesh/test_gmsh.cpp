// Gmsh .msh reading and writing (Gmsh.hpp): exact write/read round trips for every cell type and
// a mixed mesh, handwritten 2.2 and 4.1 files (physical groups, names, non-contiguous node tags,
// unused nodes, skipped sections), every class of malformed input (obs::Error naming file and
// line), the example meshes in data/meshes, and several bodies in one file (readGmshGroups,
// extractCellGroup: renumbering, boundary faces and the interface between bodies, both formats,
// the bad selections, and data/meshes/two_blocks.msh against the box generator).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Gmsh.hpp"
#include "obs/mesh/Grid.hpp"

using namespace obs::mesh;
namespace fs = std::filesystem;

namespace {

/// A fresh path in the test directory for this test binary.
fs::path tmpPath(const std::string& name) {
  const fs::path dir = fs::path(OBS_TEST_TMP_DIR) / "gmsh";
  fs::create_directories(dir);
  return dir / name;
}

/// Writes `content` to a file in the test directory and returns its path.
fs::path writeText(const std::string& name, const std::string& content) {
  const fs::path path = tmpPath(name);
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

/// The message of the obs::Error that reading `path` throws ("" and a failure if none).
std::string readError(const fs::path& path) {
  try {
    readGmsh(path);
  } catch (const obs::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "reading " << path << " did not throw obs::Error";
  return {};
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::vector<Index> toVector(std::span<const Index> s) { return {s.begin(), s.end()}; }

/// Expects identical meshes: dimension, vertices (bitwise), cells, faces, names.
void expectSameMesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.dimension(), b.dimension());
  ASSERT_EQ(a.numVertices(), b.numVertices());
  for (Index v = 0; v < a.numVertices(); ++v)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a.vertex(v)[k], b.vertex(v)[k]) << "vertex " << v;
  ASSERT_EQ(a.numCells(), b.numCells());
  for (Index c = 0; c < a.numCells(); ++c) {
    EXPECT_EQ(a.cellType(c), b.cellType(c)) << "cell " << c;
    EXPECT_EQ(toVector(a.cellVertices(c)), toVector(b.cellVertices(c))) << "cell " << c;
  }
  ASSERT_EQ(a.numBoundaryFaces(), b.numBoundaryFaces());
  for (Index f = 0; f < a.numBoundaryFaces(); ++f) {
    EXPECT_EQ(a.boundaryFaceId(f), b.boundaryFaceId(f)) << "face " << f;
    EXPECT_EQ(toVector(a.boundaryFaceVertices(f)), toVector(b.boundaryFaceVertices(f)))
        << "face " << f;
  }
  EXPECT_EQ(a.boundaryNames(), b.boundaryNames());
}

// --- hand-built meshes for round trips ----------------------------------------------------------

struct CellTable {
  std::vector<Point> vertices;            // reference-like vertices
  std::vector<std::vector<Index>> faces;  // local faces, outward
};

CellTable cellTable(CellType type) {
  switch (type) {
    case CellType::Triangle: return {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1}, {1, 2}, {2, 0}}};
    case CellType::Quadrilateral:
      return {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1}, {1, 2}, {2, 3}, {3, 0}}};
    case CellType::Tetrahedron:
      return {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
              {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}};
    case CellType::Hexahedron:
      return {
          {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},
          {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}}};
    case CellType::Prism:
      return {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}},
              {{0, 2, 1}, {3, 4, 5}, {0, 1, 4, 3}, {1, 2, 5, 4}, {2, 0, 3, 5}}};
    case CellType::Pyramid:
      return {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}},
              {{0, 3, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}}};
    default: return {};
  }
}

/// Coordinates that are not short decimals, so that exact round trips are a real test.
Point perturbed(const Point& x, int k) {
  return x * (1.0 + 1e-3 * std::sin(k + 1.0)) + Point(1.0 / 3.0, -2.0 / 7.0, 0.1) * (k % 3);
}

/// Two copies of a single cell of `type` (the second shifted), all faces of the first copy as
/// boundary faces with ids 1, 2, ... (the last one with id 0), some names (one for an id without
/// faces). 2D meshes keep z = 0.
Mesh singleTypeMesh(CellType type) {
  const CellTable table = cellTable(type);
  const int dim = dimension(type);
  Mesh mesh(dim);
  const auto n = static_cast<Index>(table.vertices.size());
  for (int copy = 0; copy < 2; ++copy)
    for (Index v = 0; v < n; ++v) {
      Point x = perturbed(table.vertices[static_cast<std::size_t>(v)] + Point(2.0 * copy, 0, 0),
                          copy * n + v);
      if (dim == 2) x.z() = 0;
      mesh.addVertex(x);
    }
  for (int copy = 0; copy < 2; ++copy) {
    std::vector<Index> cell;
    for (Index v = 0; v < n; ++v) cell.push_back(copy * n + v);
    mesh.addCell(type, cell);
  }
  const auto numFaces = static_cast<int>(table.faces.size());
  for (int f = 0; f < numFaces; ++f)
    mesh.addBoundaryFace(table.faces[static_cast<std::size_t>(f)], f + 1 < numFaces ? f + 1 : 0);
  mesh.setBoundaryName(1, "first face");
  mesh.setBoundaryName(0, "zero");
  mesh.setBoundaryName(42, "no faces");
  return mesh;
}

class GmshRoundTrip : public ::testing::TestWithParam<CellType> {};

TEST_P(GmshRoundTrip, SingleType) {
  const Mesh mesh = singleTypeMesh(GetParam());
  const fs::path path = tmpPath("roundtrip_" + std::string(name(GetParam())) + ".msh");
  writeGmsh(mesh, path);
  expectSameMesh(mesh, readGmsh(path));
}

INSTANTIATE_TEST_SUITE_P(AllCellTypes, GmshRoundTrip, ::testing::ValuesIn(kVolumeCellTypes),
                         [](const auto& info) { return std::string(name(info.param)); });

TEST(Gmsh, RoundTripMixed3D) {
  // Cells of all four 3D types interleaved, faces of both types with interleaved ids (including
  // a negative id): the writer must keep the order of cells and faces.
  Mesh mesh(3);
  for (int v = 0; v < 14; ++v) mesh.addVertex(perturbed(Point(v % 3, (v / 3) % 3, v / 9), v));
  mesh.addCell(CellType::Hexahedron, {0, 1, 2, 3, 4, 5, 6, 7});
  mesh.addCell(CellType::Prism, {1, 2, 8, 5, 6, 9});
  mesh.addCell(CellType::Pyramid, {4, 5, 6, 7, 10});
  mesh.addCell(CellType::Hexahedron, {3, 2, 11, 12, 7, 6, 13, 0});
  mesh.addCell(CellType::Tetrahedron, {10, 11, 12, 13});
  mesh.addCell(CellType::Tetrahedron, {9, 10, 11, 12});
  mesh.addCell(CellType::Pyramid, {0, 1, 2, 3, 13});
  mesh.addBoundaryFace({0, 3, 2, 1}, 1);
  mesh.addBoundaryFace({1, 2, 8}, 1);
  mesh.addBoundaryFace({4, 5, 10}, 2);
  mesh.addBoundaryFace({3, 0, 4, 7}, 1);
  mesh.addBoundaryFace({10, 11, 12}, -3);
  mesh.addBoundaryFace({0, 3, 2, 1}, 2);
  mesh.setBoundaryName(1, "bottom and sides");
  mesh.setBoundaryName(-3, "negative id");
  const fs::path path = tmpPath("roundtrip_mixed.msh");
  writeGmsh(mesh, path);
  expectSameMesh(mesh, readGmsh(path));
}

TEST(Gmsh, WriterOutputIsFormat41) {
  const fs::path path = tmpPath("format41.msh");
  writeGmsh(singleTypeMesh(CellType::Triangle), path);
  std::ifstream in(path);
  std::string first, second;
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_EQ(first, "$MeshFormat");
  EXPECT_EQ(second, "4.1 0 8");
}

TEST(Gmsh, RoundTripDropsUnusedVertices) {
  Mesh mesh(2);
  mesh.addVertex({5, 5, 0});  // used by no cell
  mesh.addVertex({0, 0, 0});
  mesh.addVertex({1, 0, 0});
  mesh.addVertex({0, 1, 0});
  mesh.addCell(CellType::Triangle, {1, 2, 3});
  mesh.addBoundaryFace({1, 2}, 4);
  const fs::path path = tmpPath("unused_vertex.msh");
  writeGmsh(mesh, path);
  const Mesh back = readGmsh(path);
  ASSERT_EQ(back.numVertices(), 3);
  EXPECT_EQ(back.vertex(0), Point(0, 0, 0));
  EXPECT_EQ(toVector(back.cellVertices(0)), (std::vector<Index>{0, 1, 2}));
  EXPECT_EQ(toVector(back.boundaryFaceVertices(0)), (std::vector<Index>{0, 1}));
  EXPECT_EQ(back.boundaryFaceId(0), 4);
}

TEST(Gmsh, WriterRejectsUnrepresentableNamesAndBadPaths) {
  Mesh mesh = singleTypeMesh(CellType::Triangle);
  mesh.setBoundaryName(7, "say \"hi\"");
  EXPECT_THROW(writeGmsh(mesh, tmpPath("quote.msh")), obs::Error);
  const Mesh ok = singleTypeMesh(CellType::Triangle);
  EXPECT_THROW(writeGmsh(ok, tmpPath("no/such/dir/x.msh")), obs::Error);
}

// --- handwritten files ---------------------------------------------------------------------------

// A unit square of two triangles in format 2.2: node tags 10..50 (50 unused, 30 with z != 0),
// a point element, two boundary lines in named physical groups, one line without a group, and a
// name for the (2D) surface group that must not become a boundary name.
const std::string kSquare22 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
1 1 "bottom"
1 2 "top edge"
2 7 "domain"
$EndPhysicalNames
$Nodes
5
10 0 0 0
20 1 0 0
30 1 1 0.5
40 0 1 0
50 9 9 9
$EndNodes
$Elements
6
1 15 2 0 1 10
2 1 2 1 1 10 20
3 1 2 2 2 30 40
4 1 2 0 3 20 30
5 2 2 7 1 10 20 30
6 2 2 7 1 10 30 40
$EndElements
)";

TEST(Gmsh, ReadHandwritten22) {
  const Mesh mesh = readGmsh(writeText("square22.msh", kSquare22));
  EXPECT_EQ(mesh.dimension(), 2);
  ASSERT_EQ(mesh.numVertices(), 4);  // node 50 dropped
  EXPECT_EQ(mesh.vertex(0), Point(0, 0, 0));
  EXPECT_EQ(mesh.vertex(1), Point(1, 0, 0));
  EXPECT_EQ(mesh.vertex(2), Point(1, 1, 0));  // z dropped in 2D
  EXPECT_EQ(mesh.vertex(3), Point(0, 1, 0));
  ASSERT_EQ(mesh.numCells(), 2);
  EXPECT_EQ(mesh.cellType(1), CellType::Triangle);
  EXPECT_EQ(toVector(mesh.cellVertices(1)), (std::vector<Index>{0, 2, 3}));
  ASSERT_EQ(mesh.numBoundaryFaces(), 2);  // the line without physical group is ignored
  EXPECT_EQ(mesh.boundaryFaceId(0), 1);
  EXPECT_EQ(toVector(mesh.boundaryFaceVertices(0)), (std::vector<Index>{0, 1}));
  EXPECT_EQ(mesh.boundaryFaceId(1), 2);
  EXPECT_EQ(toVector(mesh.boundaryFaceVertices(1)), (std::vector<Index>{2, 3}));
  EXPECT_EQ(mesh.boundaryNames(), (std::map<int, std::string>{{1, "bottom"}, {2, "top edge"}}));
  EXPECT_EQ(mesh.boundaryId("top edge"), 2);
}

// A hexahedron with a pyramid on top in format 4.1: entities of every dimension (a curve with
// signed bounding points, a surface in two physical groups, a surface in none), a parametric
// node block, non-contiguous node tags with an unused node, unknown sections to skip, blank
// lines and CRLF line ends on a few lines.
const std::string kHexPyramid41 =
    "$MeshFormat\r\n"
    "4.1 0 8\r\n"
    "$EndMeshFormat\n"
    "$Comments\n"
    "written by hand; $Nodes here is no section header\n"
    "$EndComments\n"
    "$PhysicalNames\n"
    "3\n"
    "2 5 \"bottom\"\n"
    "2 6 \"all walls\"\n"
    "3 10 \"solid\"\n"
    "$EndPhysicalNames\n"
    "$Entities\n"
    "1 1 2 1\n"
    "1 0 0 0 0\n"
    "1 0 0 0 1 0 0 0 2 1 -1\n"
    "1 0 0 0 1 1 0 2 5 6 0\n"
    "2 0 0 1 1 1 1.5 0 0\n"
    "1 0 0 0 1 1 1.5 1 10 2 1 2\n"
    "$EndEntities\n"
    "\n"
    "$Nodes\n"
    "3 10 3 109\n"
    "0 1 0 1\n"
    "3\n"
    "0 0 0\n"
    "2 1 1 3\n"
    "105\n"
    "7\n"
    "109\n"
    "1 0 0 0.5 0\n"
    "1 1 0 0.5 0.5\n"
    "0 1 0 0 0.5\n"
    "3 1 0 6\n"
    "101\n"
    "11\n"
    "12\n"
    "13\n"
    "50\n"
    "77\n"
    "0 0 1\n"
    "1 0 1\n"
    "1 1 1\n"
    "0 1 1\n"
    "0.5 0.5 1.5\n"
    "5 5 5\n"
    "$EndNodes\n"
    "$Elements\n"
    "5 8 1 8\n"
    "2 1 3 1\n"
    "1 3 109 7 105\n"
    "2 2 2 4\n"
    "2 101 11 50\n"
    "3 11 12 50\n"
    "4 12 13 50\n"
    "5 13 101 50\n"
    "3 1 5 1\n"
    "6 3 105 7 109 101 11 12 13\n"
    "3 1 7 1\n"
    "7 101 11 12 13 50\n"
    "0 1 15 1\n"
    "8 3\n"
    "$EndElements\n"
    "$NodeData\n"
    "1\n"
    "\"temperature\"\n"
    "1\n"
    "0.0\n"
    "3\n"
    "0\n"
    "1\n"
    "1\n"
    "3 1.0\n"
    "$EndNodeData\n"
    "$Periodic\n"
    "0\n"
    "$EndPeriodic\n";

TEST(Gmsh, ReadHandwritten41) {
  const Mesh mesh = readGmsh(writeText("hexpyramid41.msh", kHexPyramid41));
  EXPECT_EQ(mesh.dimension(), 3);
  ASSERT_EQ(mesh.numVertices(), 9);  // node 77 dropped; file order 3 105 7 109 101 11 12 13 50
  EXPECT_EQ(mesh.vertex(0), Point(0, 0, 0));
  EXPECT_EQ(mesh.vertex(1), Point(1, 0, 0));
  EXPECT_EQ(mesh.vertex(3), Point(0, 1, 0));
  EXPECT_EQ(mesh.vertex(8), Point(0.5, 0.5, 1.5));
  ASSERT_EQ(mesh.numCells(), 2);
  EXPECT_EQ(mesh.cellType(0), CellType::Hexahedron);
  EXPECT_EQ(toVector(mesh.cellVertices(0)), (std::vector<Index>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(mesh.cellType(1), CellType::Pyramid);
  EXPECT_EQ(toVector(mesh.cellVertices(1)), (std::vector<Index>{4, 5, 6, 7, 8}));
  const auto counts = mesh.cellCounts();
  EXPECT_EQ(counts[static_cast<int>(CellType::Hexahedron)], 1);
  EXPECT_EQ(counts[static_cast<int>(CellType::Pyramid)], 1);
  // The bottom quad is in physical groups 5 and 6: one face for each; the pyramid's side
  // triangles are in no group.
  ASSERT_EQ(mesh.numBoundaryFaces(), 2);
  for (Index f = 0; f < 2; ++f) {
    EXPECT_EQ(mesh.boundaryFaceType(f), CellType::Quadrilateral);
    EXPECT_EQ(toVector(mesh.boundaryFaceVertices(f)), (std::vector<Index>{0, 3, 2, 1}));
  }
  EXPECT_EQ(mesh.boundaryFaceId(0), 5);
  EXPECT_EQ(mesh.boundaryFaceId(1), 6);
  EXPECT_EQ(mesh.boundaryNames(), (std::map<int, std::string>{{5, "bottom"}, {6, "all walls"}}));
}

TEST(Gmsh, NonContiguousNodeTags) {
  // Huge, descending and scattered tags; elements refer to them in any order.
  const std::string text = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
4
9000000000 0 0 0
7 2 0 0
123456 2 3 0
1 0 3 0
$EndNodes
$Elements
3
100 3 2 4 1 9000000000 7 123456 1
7 1 1 3 1 9000000000
8 1 1 4 7 123456
$EndElements
)";
  const Mesh mesh = readGmsh(writeText("noncontiguous.msh", text));
  ASSERT_EQ(mesh.numVertices(), 4);
  EXPECT_EQ(mesh.vertex(2), Point(2, 3, 0));
  ASSERT_EQ(mesh.numCells(), 1);
  EXPECT_EQ(mesh.cellType(0), CellType::Quadrilateral);
  EXPECT_EQ(toVector(mesh.cellVertices(0)), (std::vector<Index>{0, 1, 2, 3}));
  ASSERT_EQ(mesh.numBoundaryFaces(), 2);
  EXPECT_EQ(toVector(mesh.boundaryFaceVertices(0)), (std::vector<Index>{3, 0}));
  EXPECT_EQ(mesh.boundaryFaceId(0), 3);
  EXPECT_EQ(toVector(mesh.boundaryFaceVertices(1)), (std::vector<Index>{1, 2}));
  EXPECT_EQ(mesh.boundaryFaceId(1), 4);
  EXPECT_TRUE(mesh.boundaryNames().empty());
}

// --- malformed input -----------------------------------------------------------------------------

// Minimal valid files (one triangle) that the cases below break line by line. In kBase22 the
// line numbers are: 1 $MeshFormat, 2 version, 4 $Nodes, 6-8 nodes, 9 $EndNodes, 10 $Elements,
// 12 the triangle, 13 $EndElements.
const std::string kBase22 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
3
1 0 0 0
2 1 0 0
3 0 1 0
$EndNodes
$Elements
1
1 2 0 1 2 3
$EndElements
)";

// Line numbers: 4 $Entities, 6 curve, 9 $Nodes, 10 header, 11 block, 12-14 tags, 15-17
// coordinates, 19 $Elements, 20 header, 21 line block, 22 line, 23 triangle block, 24 triangle.
const std::string kBase41 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Entities
0 1 1 0
1 0 0 0 1 0 0 1 3 0
1 0 0 0 1 1 0 0 0
$EndEntities
$Nodes
1 3 1 3
2 1 0 3
1
2
3
0 0 0
1 0 0
0 1 0
$EndNodes
$Elements
2 2 1 2
1 1 1 1
1 1 2
2 1 2 1
2 1 2 3
$EndElements
)";

/// Replacement text for replaceLine() that removes the line.
const std::string kRemove = "\x7f";

/// `text` with line `line` (1-based) replaced by `replacement` (kRemove: line removed).
std::string replaceLine(const std::string& text, int line, const std::string& replacement) {
  std::string out;
  int current = 1;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t end = text.find('\n', pos);
    const std::string content = text.substr(pos, end - pos);
    if (current != line)
      out += content + "\n";
    else if (replacement != kRemove)
      out += replacement + "\n";
    pos = end == std::string::npos ? text.size() : end + 1;
    ++current;
  }
  return out;
}

/// The first `n` lines of `text`.
std::string firstLines(const std::string& text, int n) {
  std::size_t pos = 0;
  for (int i = 0; i < n; ++i) pos = text.find('\n', pos) + 1;
  return text.substr(0, pos);
}

TEST(Gmsh, BaseFilesAreValid) {
  const Mesh a = readGmsh(writeText("base22.msh", kBase22));
  EXPECT_EQ(a.numCells(), 1);
  const Mesh b = readGmsh(writeText("base41.msh", kBase41));
  EXPECT_EQ(b.numCells(), 1);
  ASSERT_EQ(b.numBoundaryFaces(), 1);
  EXPECT_EQ(b.boundaryFaceId(0), 3);
}

struct BadCase {
  std::string name;     // file name stem
  std::string content;  // file content
  int line;             // expected line number in the message
  std::string problem;  // expected part of the message
};
/// Prints the case by name (otherwise GoogleTest dumps its bytes into every test's listing).
void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

// A line element in physical group 5 on node 4, which no cell uses (line 14).
const std::string kBoundaryNodeWithoutCell = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
4
1 0 0 0
2 1 0 0
3 0 1 0
4 5 5 0
$EndNodes
$Elements
2
1 2 0 1 2 3
2 1 2 5 1 3 4
$EndElements
)";

std::vector<BadCase> badCases() {
  using namespace std::string_literals;
  const std::string b22 = kBase22, b41 = kBase41;
  return {
      // format
      {"missing_format", b22.substr(b22.find("$Nodes")), 1, "expected $MeshFormat"},
      {"empty", "", 1, "empty file"},
      {"version3", replaceLine(b22, 2, "3.0 0 8"), 2, "unsupported .msh format version 3.0"},
      {"version40", replaceLine(b41, 2, "4 0 8"), 2, "unsupported .msh format version 4"},
      {"binary22", replaceLine(b22, 2, "2.2 1 8"), 2, "binary .msh is not supported"},
      {"binary41",
       "$MeshFormat\n4.1 1 8\n\x01\x00\x00\x00\n$EndMeshFormat\n"s + std::string(40, '\0'), 2,
       "binary .msh is not supported"},
      {"format_tokens", replaceLine(b22, 2, "2.2 0"), 2, "expected 3 values"},
      // truncation and end markers
      {"truncated_nodes", firstLines(b22, 7), 7, "unexpected end of file in $Nodes"},
      {"truncated_elements", firstLines(b22, 11), 11, "unexpected end of file in $Elements"},
      {"truncated41_coordinates", firstLines(b41, 16), 16, "unexpected end of file in $Nodes"},
      {"missing_end_nodes", replaceLine(b22, 9, kRemove), 9,
       "expected $EndNodes, found '$Elements'"},
      {"missing_end_elements", replaceLine(b22, 13, kRemove), 12, "missing $EndElements"},
      {"missing_end_format", replaceLine(b22, 3, kRemove), 3, "expected $EndMeshFormat"},
      {"unterminated_unknown", b22 + "$Comments\nno end\n", 15, "missing $EndComments"},
      {"stray_end", replaceLine(b22, 4, "$EndFoo"), 4, "without a matching $Foo"},
      {"text_outside_section", b22 + "garbage here\n", 14, "expected a section header"},
      // numbers
      {"non_numeric_coordinate", replaceLine(b22, 7, "2 1 abc 0"), 7,
       "expected a number (y coordinate), found 'abc'"},
      {"non_numeric_node_tag41", replaceLine(b41, 13, "x2"), 13, "found 'x2'"},
      {"non_numeric_element", replaceLine(b22, 12, "1 2 0 1 2 three"), 12, "found 'three'"},
      {"infinite_coordinate", replaceLine(b22, 6, "1 inf 0 0"), 6, "must be finite"},
      {"negative_count", replaceLine(b22, 5, "-3"), 5, "must not be negative"},
      {"zero_node_tag", replaceLine(b22, 6, "0 0 0 0"), 6, "node tag must be positive"},
      {"node_tokens", replaceLine(b22, 7, "2 1 0"), 7, "expected 4 values"},
      // elements
      {"too_few_nodes", replaceLine(b22, 12, "1 2 0 1 2"), 12,
       "element 1 of type 2 (3-node triangle) has 2 node tags, expected 3"},
      {"too_many_nodes41", replaceLine(b41, 24, "2 1 2 3 1"), 24, "has 4 node tags, expected 3"},
      {"tags_overflow22", replaceLine(b22, 12, "1 2 9 1 2 3"), 12, "announces 9 tags"},
      {"unknown_node", replaceLine(b22, 12, "1 2 0 1 2 99"), 12,
       "element 1 references unknown node 99"},
      {"unsupported_type", replaceLine(b22, 12, "1 9 0 1 2 3 4 5 6"), 12,
       "unsupported element type 9 (6-node second-order triangle)"},
      {"unsupported_type41", replaceLine(b41, 23, "2 1 11 1"), 23, "unsupported element type 11"},
      {"unknown_type", replaceLine(b22, 12, "1 99 0 1 2 3"), 12, "unsupported element type 99"},
      {"no_cells", replaceLine(b22, 12, "1 1 0 1 2"), 10, "no cells"},
      {"no_elements", firstLines(b22, 9), 9, "no $Elements section"},
      {"duplicate_node", replaceLine(b22, 8, "1 0 1 0"), 8,
       "duplicate node tag 1 (first defined at line 6)"},
      {"duplicate_nodes_section", b22 + "$Nodes\n0\n$EndNodes\n", 14, "second $Nodes section"},
      {"element_count41", replaceLine(b41, 20, "2 3 1 2"), 20,
       "announces 3 elements, but the blocks hold 2"},
      {"node_count41", replaceLine(b41, 10, "1 4 1 3"), 10, "announces 4 nodes"},
      {"boundary_node_without_cell", kBoundaryNodeWithoutCell, 14,
       "boundary element 2 (physical group 5) uses node 4, which belongs to no cell"},
      // entities and names
      {"unknown_entity41", replaceLine(b41, 21, "1 7 1 1"), 21, "entity (dimension 1, tag 7)"},
      {"entity_tokens41", replaceLine(b41, 6, "1 0 0 0 1 0 0 1 3"), 6,
       "missing number of bounding entities"},
      {"entity_phys_overflow41", replaceLine(b41, 6, "1 0 0 0 1 0 0 9 3 0"), 6,
       "too few physical tags"},
      {"partitioned41", replaceLine(b41, 4, "$PartitionedEntities"), 4,
       "partitioned meshes are not supported"},
      {"unquoted_name",
       replaceLine(b22, 4, "$PhysicalNames\n1\n1 3 bottom\n$EndPhysicalNames\n$Nodes"), 6,
       "must be in double quotes"},
  };
}

class GmshMalformed : public ::testing::TestWithParam<BadCase> {};

TEST_P(GmshMalformed, ThrowsWithFileAndLine) {
  const BadCase& c = GetParam();
  const std::string file = "bad_" + c.name + ".msh";
  const std::string message = readError(writeText(file, c.content));
  EXPECT_TRUE(contains(message, file + ":" + std::to_string(c.line) + ": ")) << message;
  EXPECT_TRUE(contains(message, c.problem)) << message;
}

INSTANTIATE_TEST_SUITE_P(AllCases, GmshMalformed, ::testing::ValuesIn(badCases()),
                         [](const auto& info) { return info.param.name; });

TEST(Gmsh, MissingFileOrDirectory) {
  const std::string message = readError(tmpPath("does_not_exist.msh"));
  EXPECT_TRUE(contains(message, "does_not_exist.msh")) << message;
  EXPECT_TRUE(contains(message, "not found")) << message;
  const std::string dirMessage = readError(fs::path(OBS_TEST_TMP_DIR));
  EXPECT_TRUE(contains(dirMessage, "directory")) << dirMessage;
}

// --- data/meshes ---------------------------------------------------------------------------------

TEST(Gmsh, ReadsEveryExampleMesh) {
  const fs::path dir = fs::path(OBS_DATA_DIR) / "meshes";
  int count = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".msh") continue;
    SCOPED_TRACE(entry.path().string());
    const Mesh mesh = readGmsh(entry.path());
    EXPECT_GT(mesh.numCells(), 0);
    EXPECT_GT(mesh.numBoundaryFaces(), 0);
    EXPECT_FALSE(mesh.boundaryNames().empty());
    ++count;
  }
  EXPECT_GE(count, 7);
}

struct ExampleMesh {
  std::string file;
  int dim;
  Index vertices;
  std::array<Index, 7> cells;  // per CellType
  Index faces;
  std::map<int, std::string> names;
};

TEST(Gmsh, ExampleMeshContents) {
  // The counts listed in data/meshes/README.md.
  const std::map<int, std::string> sides3d{{1, "left"}, {2, "right"},  {3, "front"},
                                           {4, "back"}, {5, "bottom"}, {6, "top"}};
  const std::map<int, std::string> sides3d2{{1, "left"}, {2, "right"}, {3, "bottom"},
                                            {4, "top"},  {5, "front"}, {6, "back"}};  // box ids
  const std::map<int, std::string> plate{{1, "bottom"}, {2, "left"}, {3, "free"}, {4, "hole"}};
  const std::vector<ExampleMesh> examples = {
      {"square_triangles.msh",
       2,
       25,
       {0, 32, 0, 0, 0, 0, 0},
       16,
       {{1, "left"}, {2, "right"}, {3, "bottom"}, {4, "top"}}},
      {"square_quads_v22.msh",
       2,
       9,
       {0, 0, 4, 0, 0, 0, 0},
       8,
       {{1, "clamped"}, {2, "contact"}, {3, "free"}}},
      {"plate_with_hole.msh", 2, 145, {0, 236, 0, 0, 0, 0, 0}, 54, plate},
      {"plate_with_hole_v22.msh", 2, 145, {0, 236, 0, 0, 0, 0, 0}, 54, plate},
      {"cube_tetrahedra.msh", 3, 27, {0, 0, 0, 48, 0, 0, 0}, 48, sides3d},
      {"mixed_hex_prism_pyramid.msh", 3, 17, {0, 0, 0, 0, 1, 2, 6}, 16, sides3d},
      {"block_hex_pyramid_tet.msh", 3, 165, {0, 0, 0, 408, 8, 0, 4}, 70, {{1, "base"}, {2, "lid"}}},
      // two bodies (physical volumes 1 "lower", 2 "upper"); read whole, they overlap at z = 1
      {"two_blocks.msh", 3, 172, {0, 0, 0, 162, 50, 0, 0}, 198, sides3d2},
      {"two_blocks_v22.msh", 3, 172, {0, 0, 0, 162, 50, 0, 0}, 198, sides3d2},
      // upper bodies of the Geometry B readings (scripts/make_geometry_b.py): one rotated unit cube
      {"cube_on_corner.msh", 3, 8, {0, 0, 0, 0, 1, 0, 0}, 6, {{1, "corner"}, {2, "free"}}},
      {"cube_on_edge.msh", 3, 8, {0, 0, 0, 0, 1, 0, 0}, 6, {{1, "edge"}, {2, "free"}}},
      // the graded half-cylinders of data/scenes/twobody_gmsh_cylinders.toml (Gmsh 4.8.4)
      {"half_cylinder_upper.msh", 2, 1533, {0, 2922, 0, 0, 0, 0, 0}, 142, {{1, "arc"}, {2, "flat"}}},
      {"half_cylinder_lower.msh", 2, 1533, {0, 2922, 0, 0, 0, 0, 0}, 142, {{1, "arc"}, {2, "flat"}}},
      // the graded half ball and block of data/scenes/cattaneo_mindlin_3d.toml (Gmsh 4.8.4); read
      // whole, both bodies: they touch at the origin
      {"cattaneo_mindlin_3d.msh", 3, 2324, {0, 0, 0, 10535, 0, 0, 0}, 1948,
       {{3, "surface"}, {4, "top"}, {5, "block_top"}, {6, "bottom"}}},
  };
  for (const ExampleMesh& e : examples) {
    SCOPED_TRACE(e.file);
    const Mesh mesh = readGmsh(fs::path(OBS_DATA_DIR) / "meshes" / e.file);
    EXPECT_EQ(mesh.dimension(), e.dim);
    EXPECT_EQ(mesh.numVertices(), e.vertices);
    EXPECT_EQ(mesh.cellCounts(), e.cells);
    EXPECT_EQ(mesh.numBoundaryFaces(), e.faces);
    EXPECT_EQ(mesh.boundaryNames(), e.names);
  }
}

TEST(Gmsh, SameMeshFromFormats22And41) {
  // Gmsh wrote the plate in both formats from the same geometry.
  const fs::path dir = fs::path(OBS_DATA_DIR) / "meshes";
  expectSameMesh(readGmsh(dir / "plate_with_hole.msh"), readGmsh(dir / "plate_with_hole_v22.msh"));
}

TEST(Gmsh, ExampleMeshesRoundTrip) {
  const fs::path dir = fs::path(OBS_DATA_DIR) / "meshes";
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".msh") continue;
    SCOPED_TRACE(entry.path().string());
    const Mesh mesh = readGmsh(entry.path());
    const fs::path copy = tmpPath("copy_" + entry.path().filename().string());
    writeGmsh(mesh, copy);
    expectSameMesh(mesh, readGmsh(copy));
  }
}

}  // namespace

// Found by fuzz_parsers (seed 1000, gmsh input 76694): an unterminated unknown section quoted its
// name in full, so a 285,000-character header line gave a message of that length.
TEST(Gmsh, UnterminatedLongSectionNameIsShortenedInTheMessage) {
  const std::string text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$" + std::string(100000, 'X') + "\n1 2 3\n";
  try {
    obs::mesh::readGmshString(text, "long.msh");
    FAIL() << "accepted";
  } catch (const obs::Error& e) {
    const std::string msg = e.what();
    EXPECT_LT(msg.size(), 200u) << msg.substr(0, 300);
    EXPECT_EQ(msg.rfind("long.msh:5: unexpected end of file: missing $EndXXXX", 0), 0u) << msg.substr(0, 300);
  }
}

// Found by fuzz_parsers on a corpus with two-body files (seeds 2 and 4): an end marker without its
// section and an unsupported version number were quoted in full (messages of 27,000 and 9,000
// characters).
TEST(Gmsh, LongEndMarkerAndVersionAreShortenedInTheMessage) {
  const std::string end = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$End" + std::string(5000, 'X') + "\n";
  const std::string version = "$MeshFormat\n4." + std::string(5000, '1') + " 0 8\n$EndMeshFormat\n";
  for (const std::string* text : {&end, &version}) {
    try {
      readGmshString(*text, "long.msh");
      ADD_FAILURE() << "accepted";
    } catch (const obs::Error& e) {
      const std::string msg = e.what();
      EXPECT_LT(msg.size(), 200u) << msg.substr(0, 300);
      EXPECT_TRUE(contains(msg, text == &end ? "without a matching $XXXX" : "unsupported .msh format version 4.111"))
          << msg.substr(0, 300);
    }
  }
  // short tokens are shown unchanged
  EXPECT_TRUE(contains(readError(writeText("v3.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n")),
                       "unsupported .msh format version 3.0 (readable"));
}

// --- several bodies in one file: cell groups ------------------------------------------------------

namespace {

// Two bodies in 2D sharing the edge x = 1 (conforming): "left" (physical surface 1, two triangles)
// and "right" (physical surface 2, a quadrilateral), plus a triangle in no group and a group
// "empty" without elements. Physical curves: "bottom" (tag 1 like the surface "left": tags are per
// dimension) on both bodies, "top" (2) on the right body only, "interface" (5) the shared edge;
// the left edge is in no group; a point group "corner" (dimension 0, tag 3); an unnamed curve group
// 6 holding a segment 40-20 whose nodes are vertices of the left body but which is a face of no
// cell (dropped by every body). Node 80 is unused.
const std::string kTwoBodies22 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
7
0 3 "corner"
1 1 "bottom"
1 2 "top"
1 5 "interface"
2 1 "left"
2 2 "right"
2 9 "empty"
$EndPhysicalNames
$Nodes
8
10 0 0 0
20 1 0 0
30 2 0 0
40 0 1 0
50 1 1 0
60 2 1 0
70 3 0 0
80 9 9 9
$EndNodes
$Elements
11
1 15 2 3 1 10
2 1 2 1 1 10 20
3 1 2 1 2 20 30
4 1 2 5 3 20 50
5 1 2 2 4 50 60
6 1 2 0 5 40 10
7 2 2 1 1 10 20 50
8 2 2 1 1 10 50 40
9 3 2 2 2 20 30 60 50
10 2 2 0 3 30 70 60
11 1 2 6 6 40 20
$EndElements
)";

// The same mesh in format 4.1: the groups come from the entities.
const std::string kTwoBodies41 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
7
0 3 "corner"
1 1 "bottom"
1 2 "top"
1 5 "interface"
2 1 "left"
2 2 "right"
2 9 "empty"
$EndPhysicalNames
$Entities
1 6 3 0
1 0 0 0 1 3
1 0 0 0 1 0 0 1 1 0
2 1 0 0 2 0 0 1 1 0
3 1 0 0 1 1 0 1 5 0
4 1 1 0 2 1 0 1 2 0
5 0 0 0 0 1 0 0 0
6 0 0 0 1 1 0 1 6 0
1 0 0 0 1 1 0 1 1 0
2 1 0 0 2 1 0 1 2 0
3 2 0 0 3 1 0 0 0
$EndEntities
$Nodes
1 8 10 80
2 1 0 8
10
20
30
40
50
60
70
80
0 0 0
1 0 0
2 0 0
0 1 0
1 1 0
2 1 0
3 0 0
9 9 9
$EndNodes
$Elements
10 11 1 11
0 1 15 1
1 10
1 1 1 1
2 10 20
1 2 1 1
3 20 30
1 3 1 1
4 20 50
1 4 1 1
5 50 60
1 5 1 1
6 40 10
2 1 2 2
7 10 20 50
8 10 50 40
2 2 3 1
9 20 30 60 50
2 3 2 1
10 30 70 60
1 6 1 1
11 40 20
$EndElements
)";

/// kTwoBodies22 with the interface edge in no physical group.
std::string withoutInterfaceGroup() {
  std::string text = kTwoBodies22;
  const std::string from = "4 1 2 5 3 20 50", to = "4 1 2 0 3 20 50";
  text.replace(text.find(from), from.size(), to);
  return text;
}

/// The message of the obs::Error that `f` throws ("" and a failure if none).
template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const obs::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no obs::Error";
  return {};
}

/// The boundary faces of a mesh as (id, vertex list) in sorted order (an order-free comparison).
std::vector<std::pair<int, std::vector<Index>>> sortedFaces(const Mesh& m) {
  std::vector<std::pair<int, std::vector<Index>>> faces;
  for (Index f = 0; f < m.numBoundaryFaces(); ++f)
    faces.emplace_back(m.boundaryFaceId(f), toVector(m.boundaryFaceVertices(f)));
  std::sort(faces.begin(), faces.end());
  return faces;
}

/// The id that a Grid built from `m` gives the coarse boundary face at the segment a-b (2D).
int gridFaceId(const Mesh& m, const Point& a, const Point& b) {
  const Mesh leaf = Grid(m).leafMesh();
  for (Index f = 0; f < leaf.numBoundaryFaces(); ++f) {
    const auto v = leaf.boundaryFaceVertices(f);
    const Point &p = leaf.vertex(v[0]), &q = leaf.vertex(v[1]);
    if ((p == a && q == b) || (p == b && q == a)) return leaf.boundaryFaceId(f);
  }
  ADD_FAILURE() << "no boundary face at the segment";
  return -1;
}

TEST(GmshCellGroups, ReadingWithGroupsKeepsTheMeshAndListsTheGroups) {
  for (const std::string* text : {&kTwoBodies22, &kTwoBodies41}) {
    SCOPED_TRACE(text == &kTwoBodies22 ? "2.2" : "4.1");
    const GmshMesh file = readGmshGroupsString(*text, "two.msh");
    expectSameMesh(file.mesh, readGmshString(*text, "two.msh"));  // the Mesh is unchanged
    EXPECT_EQ(file.fileName, "two.msh");
    ASSERT_EQ(file.mesh.numCells(), 4);
    EXPECT_EQ(file.mesh.numVertices(), 7);
    EXPECT_EQ(file.mesh.numBoundaryFaces(), 5);  // the 4 boundary segments and the stray one
    const std::vector<std::vector<int>> tags = {{1}, {1}, {2}, {}};
    for (Index c = 0; c < 4; ++c) {
      const auto g = file.cellGroups(c);
      EXPECT_EQ(std::vector<int>(g.begin(), g.end()), tags[static_cast<std::size_t>(c)]) << "cell " << c;
    }
    struct Expected {
      int dim, tag;
      std::string name;
      Index elements;
    };
    const std::vector<Expected> expected = {{0, 3, "corner", 1},    {1, 1, "bottom", 2},
                                            {1, 2, "top", 1},       {1, 5, "interface", 1},
                                            {1, 6, "", 1},
                                            {2, 1, "left", 2},      {2, 2, "right", 1},
                                            {2, 9, "empty", 0}};
    ASSERT_EQ(file.groups.size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(file.groups[i].dimension, expected[i].dim) << i;
      EXPECT_EQ(file.groups[i].tag, expected[i].tag) << i;
      EXPECT_EQ(file.groups[i].name, expected[i].name) << i;
      EXPECT_EQ(file.groups[i].elements, expected[i].elements) << i;
    }
    EXPECT_EQ(file.describeCellGroups(), "1 \"left\" (2 cells), 2 \"right\" (1 cell), 9 \"empty\" (0 cells)");
  }
}

TEST(GmshCellGroups, ExtractsEachBodyWithItsBoundaryAndTheSharedInterface) {
  for (const std::string* text : {&kTwoBodies22, &kTwoBodies41}) {
    SCOPED_TRACE(text == &kTwoBodies22 ? "2.2" : "4.1");
    const GmshMesh file = readGmshGroupsString(*text, "two.msh");
    // left: nodes 10 20 40 50 -> 0 1 2 3 (file order); the faces of the right body are dropped
    const Mesh left = extractCellGroup(file, "left");
    EXPECT_EQ(left.dimension(), 2);
    ASSERT_EQ(left.numVertices(), 4);
    EXPECT_EQ(left.vertex(2), Point(0, 1, 0));
    EXPECT_EQ(left.vertex(3), Point(1, 1, 0));
    ASSERT_EQ(left.numCells(), 2);
    EXPECT_EQ(toVector(left.cellVertices(0)), (std::vector<Index>{0, 1, 3}));
    EXPECT_EQ(toVector(left.cellVertices(1)), (std::vector<Index>{0, 3, 2}));
    ASSERT_EQ(left.numBoundaryFaces(), 2);  // not the stray segment 40-20: no face of a cell
    EXPECT_EQ(left.boundaryFaceId(0), 1);
    EXPECT_EQ(toVector(left.boundaryFaceVertices(0)), (std::vector<Index>{0, 1}));
    EXPECT_EQ(left.boundaryFaceId(1), 5);  // the interface: a boundary face of this body too
    EXPECT_EQ(toVector(left.boundaryFaceVertices(1)), (std::vector<Index>{1, 3}));
    // names of the ids the body has faces of ("top" lies on the right body only)
    EXPECT_EQ(left.boundaryNames(), (std::map<int, std::string>{{1, "bottom"}, {5, "interface"}}));
    expectSameMesh(left, extractCellGroup(file, 1));  // by tag: the surface group 1, not the curve

    // right: nodes 20 30 50 60 -> 0 1 2 3
    const Mesh right = extractCellGroup(file, 2);
    ASSERT_EQ(right.numVertices(), 4);
    EXPECT_EQ(right.vertex(0), Point(1, 0, 0));
    EXPECT_EQ(right.vertex(3), Point(2, 1, 0));
    ASSERT_EQ(right.numCells(), 1);
    EXPECT_EQ(right.cellType(0), CellType::Quadrilateral);
    EXPECT_EQ(toVector(right.cellVertices(0)), (std::vector<Index>{0, 1, 3, 2}));
    ASSERT_EQ(right.numBoundaryFaces(), 3);
    EXPECT_EQ(right.boundaryFaceId(0), 1);
    EXPECT_EQ(toVector(right.boundaryFaceVertices(0)), (std::vector<Index>{0, 1}));
    EXPECT_EQ(right.boundaryFaceId(1), 5);
    EXPECT_EQ(toVector(right.boundaryFaceVertices(1)), (std::vector<Index>{0, 2}));
    EXPECT_EQ(right.boundaryFaceId(2), 2);
    EXPECT_EQ(toVector(right.boundaryFaceVertices(2)), (std::vector<Index>{2, 3}));
    EXPECT_EQ(right.boundaryNames(),
              (std::map<int, std::string>{{1, "bottom"}, {2, "top"}, {5, "interface"}}));
    expectSameMesh(right, extractCellGroup(file, "right"));

    // each body is a valid coarse grid; the interface keeps its physical tag on both sides
    EXPECT_EQ(gridFaceId(left, Point(1, 0, 0), Point(1, 1, 0)), 5);
    EXPECT_EQ(gridFaceId(right, Point(1, 0, 0), Point(1, 1, 0)), 5);
    EXPECT_EQ(Grid(left).inputReport().unlistedBoundaryFaces, 2);  // left and top edges
  }
  // the two formats give the same bodies
  const GmshMesh a = readGmshGroupsString(kTwoBodies22, "a.msh"), b = readGmshGroupsString(kTwoBodies41, "b.msh");
  expectSameMesh(extractCellGroup(a, "left"), extractCellGroup(b, "left"));
  expectSameMesh(extractCellGroup(a, "right"), extractCellGroup(b, "right"));
}

TEST(GmshCellGroups, InterfaceWithoutPhysicalGroupGetsIdZero) {
  const GmshMesh file = readGmshGroupsString(withoutInterfaceGroup(), "two.msh");
  for (const char* body : {"left", "right"}) {
    SCOPED_TRACE(body);
    const Mesh m = extractCellGroup(file, body);
    for (Index f = 0; f < m.numBoundaryFaces(); ++f) EXPECT_NE(m.boundaryFaceId(f), 5);
    EXPECT_EQ(m.boundaryNames().count(5), 0u);  // no face of id 5 left: no name either
    // the edge x = 1 is on each body's boundary: as every unlisted boundary face, id 0 in the Grid
    EXPECT_EQ(gridFaceId(m, Point(1, 0, 0), Point(1, 1, 0)), kUnlistedBoundaryId);
  }
  EXPECT_EQ(extractCellGroup(file, "left").numBoundaryFaces(), 1);
  EXPECT_EQ(Grid(extractCellGroup(file, "left")).inputReport().unlistedBoundaryFaces, 3);
  EXPECT_EQ(extractCellGroup(file, "right").numBoundaryFaces(), 2);
}

TEST(GmshCellGroups, BadSelectionsNameTheFileAndListTheCellGroups) {
  const GmshMesh file = readGmshGroupsString(kTwoBodies41, "two.msh");
  const std::string list = "1 \"left\" (2 cells), 2 \"right\" (1 cell), 9 \"empty\" (0 cells)";
  auto expect = [&](const std::string& message, const std::string& part) {
    EXPECT_EQ(message.rfind("two.msh: ", 0), 0u) << message;
    EXPECT_TRUE(contains(message, part)) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  };
  const std::string unknown = errorOf([&] { extractCellGroup(file, "middle"); });
  expect(unknown, "no physical group named \"middle\"");
  expect(unknown, "cell groups of dimension 2 (surfaces): " + list);
  expect(errorOf([&] { extractCellGroup(file, 7); }), "no physical group of dimension 2 (surfaces) with tag 7");
  expect(errorOf([&] { extractCellGroup(file, 7); }), list);
  // lower-dimensional groups, by name and by tag
  const std::string boundary = errorOf([&] { extractCellGroup(file, "interface"); });
  expect(boundary, "physical group \"interface\" (tag 5) has dimension 1, not the mesh dimension 2");
  expect(boundary, list);
  expect(errorOf([&] { extractCellGroup(file, "corner"); }), "(tag 3) has dimension 0");
  expect(errorOf([&] { extractCellGroup(file, 5); }), "physical tag 5 is a group of dimension 1 only");
  expect(errorOf([&] { extractCellGroup(file, 3); }), "physical tag 3 is a group of dimension 0 only");
  // a group without cells
  expect(errorOf([&] { extractCellGroup(file, "empty"); }), "physical group 9 \"empty\" (dimension 2) holds no cells");
  expect(errorOf([&] { extractCellGroup(file, 9); }), "holds no cells");
  // one name for two cell groups
  std::string twice = kTwoBodies22;
  twice.replace(twice.find("2 9 \"empty\""), 11, "2 9 \"left\"");
  expect(errorOf([&] { extractCellGroup(readGmshGroupsString(twice, "two.msh"), "left"); }),
         "the name \"left\" belongs to two physical groups of dimension 2 (tags 1 and 9)");
  // a file whose cells are in no group
  std::string ungrouped = kSquare22;
  for (const std::string from : {"2 7 \"domain\"", "5 2 2 7", "6 2 2 7"}) {
    std::string to = from;
    to[from[0] == '2' ? 0 : 6] = '0';
    ungrouped.replace(ungrouped.find(from), from.size(), to);
  }
  const GmshMesh square = readGmshGroupsString(ungrouped, "two.msh");
  EXPECT_EQ(square.describeCellGroups(), "none");
  expect(errorOf([&] { extractCellGroup(square, 4); }), "with tag 4 (cell groups: none)");
}

// --- data/meshes/two_blocks.msh -----------------------------------------------------------------

TEST(GmshCellGroups, TwoBlocksFileHoldsTheBoxMeshesOfThePatchScene) {
  const fs::path dir = fs::path(OBS_DATA_DIR) / "meshes";
  const GmshMesh file = readGmshGroups(dir / "two_blocks.msh");
  expectSameMesh(file.mesh, readGmsh(dir / "two_blocks.msh"));
  EXPECT_EQ(file.describeCellGroups(), "1 \"lower\" (162 cells), 2 \"upper\" (50 cells)");
  const Mesh lower = extractCellGroup(file, "lower");
  const Mesh upper = extractCellGroup(file, 2);
  // the bodies of data/scenes/twobody_patch.toml: the generator's vertices and cells, bit for bit,
  // and the same boundary faces (in the order of the file's surfaces)
  const Mesh boxLower = boxMesh(CellType::Tetrahedron, {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1));
  const Mesh boxUpper = boxMesh(CellType::Hexahedron, {5, 5, 2}, Point(0, 0, 1), Point(1, 1, 2));
  for (const auto& [body, box] : {std::pair{&lower, &boxLower}, std::pair{&upper, &boxUpper}}) {
    ASSERT_EQ(body->numVertices(), box->numVertices());
    for (Index v = 0; v < box->numVertices(); ++v)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(body->vertex(v)[k], box->vertex(v)[k]) << "vertex " << v;
    ASSERT_EQ(body->numCells(), box->numCells());
    for (Index c = 0; c < box->numCells(); ++c) {
      EXPECT_EQ(body->cellType(c), box->cellType(c));
      EXPECT_EQ(toVector(body->cellVertices(c)), toVector(box->cellVertices(c))) << "cell " << c;
    }
    EXPECT_EQ(sortedFaces(*body), sortedFaces(*box));
    EXPECT_EQ(body->boundaryNames(), box->boundaryNames());
  }
  EXPECT_EQ(lower.numVertices(), 64);
  EXPECT_EQ(upper.numVertices(), 108);
  EXPECT_EQ(lower.numBoundaryFaces(), 108);
  EXPECT_EQ(upper.numBoundaryFaces(), 90);
  // the interface z = 1 does not match: 18 triangles of "top" below, 25 quadrilaterals of "bottom" above
  auto facesAtZ1 = [](const Mesh& m, int id) {
    int n = 0;
    for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
      if (m.boundaryFaceId(f) != id) continue;
      ++n;
      for (Index v : m.boundaryFaceVertices(f)) EXPECT_EQ(m.vertex(v).z(), 1.0);
    }
    return n;
  };
  EXPECT_EQ(facesAtZ1(lower, 4), 18);
  EXPECT_EQ(facesAtZ1(upper, 3), 25);
  // format 2.2 holds the same bodies
  const GmshMesh v22 = readGmshGroups(dir / "two_blocks_v22.msh");
  expectSameMesh(extractCellGroup(v22, "lower"), lower);
  expectSameMesh(extractCellGroup(v22, "upper"), upper);
}

}  // namespace
