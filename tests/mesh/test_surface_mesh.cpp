// Surface mesh readers (SurfaceMesh.hpp): STL ASCII and binary give the same mesh (corners merged
// into shared vertices), Gmsh surfaces keep 3D coordinates and 2D segments, the format follows
// the content for STL and the extension for readSurfaceMesh, and malformed files are one-line
// obs::Errors naming the file (and the line for text formats).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/SurfaceMesh.hpp"

using namespace obs::mesh;
namespace fs = std::filesystem;

namespace {

fs::path writeFile(const std::string& name, const std::string& content) {
  const fs::path dir = fs::path(OBS_TEST_TMP_DIR) / "surface";
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary) << content;
  return dir / name;
}

template <class F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const obs::Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    return message;
  }
  ADD_FAILURE() << "no obs::Error thrown";
  return "";
}

/// Two triangles of the unit square in z = 0.5, counterclockwise from above.
const float kSquare[2][3][3] = {{{0, 0, 0.5f}, {1, 0, 0.5f}, {1, 1, 0.5f}},
                                {{0, 0, 0.5f}, {1, 1, 0.5f}, {0, 1, 0.5f}}};

std::string asciiStl() {
  std::string s = "solid square\n";
  for (const auto& t : kSquare) {
    s += "  facet normal 0 0 1\n    outer loop\n";
    for (const auto& v : t)
      s += "      vertex " + std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]) + "\n";
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid square\n";
}

std::string binaryStl() {
  std::string s(80, ' ');
  s.replace(0, 5, "solid");  // a binary header may begin with "solid" too
  const std::uint32_t count = 2;
  for (int i = 0; i < 4; ++i) s += static_cast<char>((count >> (8 * i)) & 0xff);
  for (const auto& t : kSquare) {
    float record[12] = {0, 0, 1};
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i) record[3 + 3 * k + i] = t[k][i];
    s.append(reinterpret_cast<const char*>(record), sizeof record);  // little-endian machine
    s += std::string(2, '\0');
  }
  return s;
}

}  // namespace

TEST(SurfaceMesh, StlAsciiAndBinaryAgree) {
  for (const std::string& bytes : {asciiStl(), binaryStl()}) {
    const SurfaceMesh s = readStlString(bytes, "square.stl");
    EXPECT_EQ(s.dimension, 3);
    EXPECT_EQ(s.source, "square.stl");
    ASSERT_EQ(s.numFaces(), 2);
    ASSERT_EQ(s.vertices.size(), 4u);  // six corners merged into four vertices
    EXPECT_EQ(s.types[0], CellType::Triangle);
    EXPECT_EQ(s.faces[0][0], s.faces[1][0]);  // shared corner (0, 0, 0.5)
    EXPECT_EQ(s.faces[0][2], s.faces[1][1]);  // shared corner (1, 1, 0.5)
    EXPECT_EQ(s.vertices[static_cast<std::size_t>(s.faces[0][1])], Point(1, 0, 0.5));
  }
  const fs::path file = writeFile("square.STL", binaryStl());
  EXPECT_EQ(readSurfaceMesh(file).numFaces(), 2);  // extension case-insensitive
}

TEST(SurfaceMesh, GmshSurfaces) {
  const std::string tri = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Nodes
1 4 1 4
2 1 0 4
1
2
3
4
0 0 0.5
1 0 0.5
1 1 0.7
0 1 0.5
$EndNodes
$Elements
2 3 1 3
1 1 1 1
1 1 2
2 1 2 2
2 1 2 3
3 3 4 1
$EndElements
)";
  const SurfaceMesh s = readGmshSurfaceString(tri, "tri.msh");
  EXPECT_EQ(s.dimension, 3);
  ASSERT_EQ(s.numFaces(), 2);  // the triangles, not the boundary lines
  EXPECT_EQ(s.vertices[2], Point(1, 1, 0.7));
  EXPECT_EQ(s.source, "tri.msh");

  const std::string segments = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
3
1 0 0 0
2 1 0.5 0
3 2 0 0
$EndNodes
$Elements
2
1 1 2 0 1 1 2
2 1 2 0 1 2 3
$EndElements
)";
  const SurfaceMesh p = readGmshSurfaceString(segments, "line.msh");
  EXPECT_EQ(p.dimension, 2);
  ASSERT_EQ(p.numFaces(), 2);
  EXPECT_EQ(p.types[1], CellType::Segment);
  EXPECT_EQ(p.faces[1][0], p.faces[0][1]);

  std::string lifted = segments;
  lifted.replace(lifted.find("2 1 0.5 0"), 9, "2 1 0.5 1");
  EXPECT_NE(errorOf([&] { readGmshSurfaceString(lifted, "lifted.msh"); }).find("plane z = 0"), std::string::npos);
}

TEST(SurfaceMesh, MalformedFilesAreErrors) {
  std::string bad = asciiStl();
  bad.replace(bad.find("vertex 1.000000 0.000000"), 6, "vertx ");
  const std::string m = errorOf([&] { readStlString(bad, "bad.stl"); });
  EXPECT_EQ(m.rfind("bad.stl:5: expected \"vertex\"", 0), 0u) << m;

  std::string truncated = asciiStl();
  truncated.resize(truncated.find("endsolid"));
  EXPECT_NE(errorOf([&] { readStlString(truncated, "t.stl"); }).find("missing \"endsolid\""), std::string::npos);

  std::string huge = asciiStl();
  huge.replace(huge.find("0.500000"), 8, "1e999   ");  // overflows a double
  EXPECT_NE(errorOf([&] { readStlString(huge, "n.stl"); }).find("vertex coordinate"), std::string::npos);

  EXPECT_NE(errorOf([&] { readStlString("solid empty\nendsolid empty\n", "e.stl"); }).find("no triangles"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { readStlString(std::string(100, 'x'), "x.stl"); }).find("not an STL file"),
            std::string::npos);
  std::string shortBinary = binaryStl();
  shortBinary.resize(shortBinary.size() - 10);  // size no longer 84 + 50 n, not ASCII either
  shortBinary.replace(0, 5, "xxxxx");
  EXPECT_NE(errorOf([&] { readStlString(shortBinary, "s.stl"); }).find("not an STL file"), std::string::npos);

  EXPECT_NE(errorOf([&] { readSurfaceMesh(writeFile("a.obj", "v 0 0 0\n")); }).find("unknown surface mesh format"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { readSurfaceMesh(fs::path(OBS_TEST_TMP_DIR) / "missing.stl"); }).find("file not found"),
            std::string::npos);

  const std::string volume = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
4
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
$EndNodes
$Elements
1
1 4 2 0 1 1 2 3 4
$EndElements
)";
  EXPECT_NE(errorOf([&] { readGmshSurfaceString(volume, "v.msh"); }).find("volume elements"), std::string::npos);
}
