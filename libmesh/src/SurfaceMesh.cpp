/// \file SurfaceMesh.cpp
/// The STL reader and the dispatch by file extension (the Gmsh surface reader is in GmshReader.cpp).
///
/// STL has two encodings. ASCII: "solid [name]", then per triangle "facet normal nx ny nz",
/// "outer loop", three "vertex x y z", "endloop", "endfacet", and "endsolid [name]" (several
/// solids may follow each other). Binary: an 80-byte header, a little-endian uint32 triangle count
/// and 50 bytes per triangle (12 floats: normal, three corners; a 2-byte attribute). Binary headers
/// may themselves begin with "solid", so a file is taken as binary when its size is exactly
/// 84 + 50 * count, and as ASCII otherwise. The facet normals are ignored: the corner order decides
/// the orientation (SurfaceMesh.hpp), as in every STL writer.
#include "obs/mesh/SurfaceMesh.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string_view>
#include <tuple>

#include "obs/mesh/Error.hpp"

namespace obs::mesh {

namespace {

std::string readBytes(const std::filesystem::path& file, const char* what) {
  const std::string name = file.string();
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) throw Error(name + ": file not found");
  if (std::filesystem::is_directory(file, ec)) throw Error(name + ": is a directory, not " + what);
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw Error(name + ": cannot open file");
  std::string bytes((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
  if (stream.bad()) throw Error(name + ": read error");
  return bytes;
}

/// Collects triangle corners into shared vertices (exact coordinate equality).
class TriangleCollector {
public:
  explicit TriangleCollector(SurfaceMesh& surface) : surface_(surface) { surface_.dimension = 3; }

  void add(const std::array<Point, 3>& corners) {
    std::array<Index, 4> face{-1, -1, -1, -1};
    for (int k = 0; k < 3; ++k) face[static_cast<std::size_t>(k)] = vertex(corners[static_cast<std::size_t>(k)]);
    surface_.types.push_back(CellType::Triangle);
    surface_.faces.push_back(face);
  }

private:
  Index vertex(const Point& x) {
    const auto key = std::make_tuple(x.x(), x.y(), x.z());
    const auto [it, inserted] = index_.emplace(key, static_cast<Index>(surface_.vertices.size()));
    if (inserted) surface_.vertices.push_back(x);
    return it->second;
  }

  SurfaceMesh& surface_;
  std::map<std::tuple<double, double, double>, Index> index_;
};

std::uint32_t littleEndian32(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}

float littleEndianFloat(const unsigned char* p) {
  const std::uint32_t bits = littleEndian32(p);
  float value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

SurfaceMesh readBinaryStl(const std::string& bytes, const std::string& fileName, std::uint32_t count) {
  SurfaceMesh surface;
  TriangleCollector collect(surface);
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  for (std::uint32_t t = 0; t < count; ++t) {
    const unsigned char* record = data + 84 + 50 * std::size_t(t);
    std::array<Point, 3> corners;
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i) {
        const float value = littleEndianFloat(record + 12 + 12 * k + 4 * i);
        if (!std::isfinite(value))
          throw Error(fileName + ": triangle " + std::to_string(t + 1) + " has a non-finite coordinate");
        corners[static_cast<std::size_t>(k)][i] = value;
      }
    collect.add(corners);
  }
  return surface;
}

/// ASCII STL, token by token with line numbers for messages.
class AsciiStl {
public:
  AsciiStl(const std::string& text, const std::string& fileName) : text_(text), fileName_(fileName) {}

  SurfaceMesh read() {
    SurfaceMesh surface;
    TriangleCollector collect(surface);
    if (!next() || token_ != "solid") fail("expected \"solid\" at the start of an ASCII STL file");
    skipRestOfLine();  // the solid's name
    while (true) {
      if (!next()) fail("unexpected end of file: missing \"endsolid\"");
      if (token_ == "endsolid") {
        skipRestOfLine();
        if (!next()) break;  // end of file
        if (token_ != "solid") fail("expected \"solid\" or the end of the file, found \"" + shown() + "\"");
        skipRestOfLine();
        continue;
      }
      if (token_ != "facet") fail("expected \"facet\" or \"endsolid\", found \"" + shown() + "\"");
      expect("normal");
      for (int i = 0; i < 3; ++i) number("normal component");
      expect("outer");
      expect("loop");
      std::array<Point, 3> corners;
      for (auto& x : corners) {
        expect("vertex");
        for (int i = 0; i < 3; ++i) x[i] = number("vertex coordinate");
      }
      expect("endloop");
      expect("endfacet");
      collect.add(corners);
    }
    return surface;
  }

private:
  bool next() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= text_.size()) return false;
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    token_ = text_.substr(start, pos_ - start);
    return true;
  }
  void skipRestOfLine() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  }
  void expect(const char* word) {
    if (!next()) fail(std::string("unexpected end of file: expected \"") + word + "\"");
    if (token_ != word) fail(std::string("expected \"") + word + "\", found \"" + shown() + "\"");
  }
  double number(const char* what) {
    if (!next()) fail(std::string("unexpected end of file: expected a ") + what);
    std::istringstream in(token_);
    double value = 0;
    char rest = 0;
    if (!(in >> value) || (in >> rest)) fail(std::string("expected a ") + what + ", found \"" + shown() + "\"");
    if (!std::isfinite(value)) fail(std::string("a ") + what + " must be finite, found \"" + shown() + "\"");
    return value;
  }
  /// The current token for messages, at most 40 characters.
  std::string shown() const { return token_.size() <= 40 ? token_ : token_.substr(0, 37) + "..."; }
  [[noreturn]] void fail(const std::string& message) const {
    throw Error(fileName_ + ":" + std::to_string(line_) + ": " + message);
  }

  const std::string& text_;
  const std::string& fileName_;
  std::size_t pos_ = 0, line_ = 1;
  std::string token_;
};

}  // namespace

SurfaceMesh readStlString(const std::string& bytes, const std::string& fileName) {
  SurfaceMesh surface;
  bool binary = false;
  std::uint32_t count = 0;
  if (bytes.size() >= 84) {
    count = littleEndian32(reinterpret_cast<const unsigned char*>(bytes.data()) + 80);
    binary = bytes.size() == 84 + 50 * std::uint64_t(count);
  }
  if (binary)
    surface = readBinaryStl(bytes, fileName, count);
  else if (bytes.compare(0, 5, "solid") == 0)
    surface = AsciiStl(bytes, fileName).read();
  else
    throw Error(fileName + ": not an STL file (neither ASCII, starting with \"solid\", nor binary of size "
                           "84 + 50 x the triangle count in bytes 80-83)");
  if (surface.faces.empty()) throw Error(fileName + ": no triangles");
  surface.source = fileName;
  return surface;
}

SurfaceMesh readStl(const std::filesystem::path& file) {
  return readStlString(readBytes(file, "an STL file"), file.string());
}

SurfaceMesh readSurfaceMesh(const std::filesystem::path& file) {
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".msh") return readGmshSurface(file);
  if (extension == ".stl") return readStl(file);
  throw Error(file.string() + ": unknown surface mesh format \"" + extension +
              "\" (readable: Gmsh .msh, STL .stl)");
}

}  // namespace obs::mesh
