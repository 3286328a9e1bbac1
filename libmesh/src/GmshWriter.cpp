/// \file GmshWriter.cpp
/// writeGmsh: writes a Mesh as a Gmsh .msh 4.1 ASCII file.
///
/// Layout of the file:
///   - one entity of the mesh dimension (tag 1) holding all nodes and cells, in physical group 1
///     named "domain";
///   - one entity of dimension - 1 per boundary id that has faces (tags 1, 2, ... in ascending
///     id order), in the physical group whose tag is the boundary id;
///   - $PhysicalNames with "domain" and every entry of Mesh::boundaryNames();
///   - element blocks for maximal runs of consecutive faces (same id and type) or cells (same
///     type), so that reading the file back gives cells and faces in their original order.
/// Numbers are written with std::to_chars, whose shortest form reads back to the same double.
#include <algorithm>
#include <array>
#include <charconv>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Gmsh.hpp"

namespace obs::mesh {
namespace {

/// Appends numbers and text to a string; spaces and newlines are added explicitly.
class Output {
public:
  Output& operator<<(std::string_view text) {
    text_ += text;
    return *this;
  }
  Output& operator<<(char c) {
    text_ += c;
    return *this;
  }
  Output& operator<<(long long value) { return appendNumber(value); }
  Output& operator<<(int value) { return appendNumber(static_cast<long long>(value)); }
  Output& operator<<(std::size_t value) { return appendNumber(value); }
  /// Shortest representation that reads back to exactly `value`.
  Output& operator<<(double value) { return appendNumber(value); }

  const std::string& text() const { return text_; }

private:
  template <class T>
  Output& appendNumber(T value) {
    std::array<char, 32> buffer;
    const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    text_.append(buffer.data(), end);  // 32 characters always suffice for these types
    return *this;
  }

  std::string text_;
};

/// Axis-aligned bounding box, written as "minX minY minZ maxX maxY maxZ" in $Entities.
struct Box {
  Point min = Point::Constant(std::numeric_limits<double>::infinity());
  Point max = Point::Constant(-std::numeric_limits<double>::infinity());

  void add(const Point& x) {
    min = min.cwiseMin(x);
    max = max.cwiseMax(x);
  }
  void write(Output& out) const {
    const bool empty = min.x() > max.x();
    for (int k = 0; k < 3; ++k) out << (empty ? 0.0 : min[k]) << ' ';
    for (int k = 0; k < 3; ++k) out << (empty ? 0.0 : max[k]) << ' ';
  }
};

/// A run of consecutive elements that goes into one element block.
struct Block {
  int entityDim;
  int entityTag;
  CellType type;
  Index first;  ///< first cell or face of the run
  Index count;
};

void checkName(const std::filesystem::path& file, int id, const std::string& name) {
  if (name.find_first_of("\"\n\r") != std::string::npos)
    throw Error(file.string() + ": boundary name of id " + std::to_string(id) +
                " contains a double quote or line break, which .msh cannot store");
}

}  // namespace

void writeGmsh(const Mesh& mesh, const std::filesystem::path& file) {
  const int dim = mesh.dimension();
  constexpr int domainTag = 1;  // entity tag and physical tag of the cells

  // Entities of the boundary ids that have faces, in ascending id order, with bounding boxes.
  std::map<int, int> entityOfId;
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) entityOfId.emplace(mesh.boundaryFaceId(f), 0);
  int numFaceEntities = 0;
  for (auto& [id, entity] : entityOfId) entity = ++numFaceEntities;
  std::vector<Box> faceBoxes(entityOfId.size());
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f)
    for (Index v : mesh.boundaryFaceVertices(f))
      faceBoxes[static_cast<std::size_t>(entityOfId[mesh.boundaryFaceId(f)] - 1)].add(
          mesh.vertex(v));
  Box cellBox;
  for (const Point& x : mesh.vertices()) cellBox.add(x);

  // Element blocks: runs of faces with equal id and type, then runs of cells of equal type.
  std::vector<Block> blocks;
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    const int entity = entityOfId[mesh.boundaryFaceId(f)];
    const CellType type = mesh.boundaryFaceType(f);
    if (!blocks.empty() && blocks.back().entityTag == entity && blocks.back().type == type)
      ++blocks.back().count;
    else
      blocks.push_back({dim - 1, entity, type, f, 1});
  }
  const std::size_t numFaceBlocks = blocks.size();
  for (Index c = 0; c < mesh.numCells(); ++c) {
    const CellType type = mesh.cellType(c);
    if (blocks.size() > numFaceBlocks && blocks.back().type == type)
      ++blocks.back().count;
    else
      blocks.push_back({dim, domainTag, type, c, 1});
  }

  Output out;
  out << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";

  out << "$PhysicalNames\n" << mesh.boundaryNames().size() + 1 << '\n';
  out << dim << ' ' << domainTag << " \"domain\"\n";
  for (const auto& [id, name] : mesh.boundaryNames()) {
    checkName(file, id, name);
    out << dim - 1 << ' ' << id << " \"" << std::string_view(name) << "\"\n";
  }
  out << "$EndPhysicalNames\n";

  // $Entities: no points; boundary entities of dimension dim - 1, one cell entity of dimension
  // dim; every entity with exactly one physical tag and no bounding entities.
  std::array<int, 4> numEntities{};
  numEntities[static_cast<std::size_t>(dim - 1)] = numFaceEntities;
  numEntities[static_cast<std::size_t>(dim)] = 1;
  out << "$Entities\n";
  for (int d = 0; d < 4; ++d)
    out << numEntities[static_cast<std::size_t>(d)] << (d < 3 ? ' ' : '\n');
  for (const auto& [id, entity] : entityOfId) {
    out << entity << ' ';
    faceBoxes[static_cast<std::size_t>(entity - 1)].write(out);
    out << "1 " << id << " 0\n";
  }
  out << domainTag << ' ';
  cellBox.write(out);
  out << "1 " << domainTag << " 0\n";
  out << "$EndEntities\n";

  // $Nodes: one block on the cell entity, tags 1..n.
  const Index numNodes = mesh.numVertices();
  out << "$Nodes\n";
  if (numNodes == 0) {
    out << "0 0 0 0\n";
  } else {
    out << "1 " << numNodes << " 1 " << numNodes << '\n';
    out << dim << ' ' << domainTag << " 0 " << numNodes << '\n';
    for (Index v = 0; v < numNodes; ++v) out << v + 1 << '\n';
    for (const Point& x : mesh.vertices()) out << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
  }
  out << "$EndNodes\n";

  // $Elements: faces get tags 1..F, cells F+1..F+C.
  const long long numElements = static_cast<long long>(mesh.numBoundaryFaces()) + mesh.numCells();
  out << "$Elements\n"
      << blocks.size() << ' ' << numElements << ' ' << (numElements > 0 ? 1 : 0) << ' '
      << numElements << '\n';
  long long tag = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const Block& block = blocks[b];
    const bool faces = b < numFaceBlocks;
    out << block.entityDim << ' ' << block.entityTag << ' ' << gmshElementType(block.type) << ' '
        << block.count << '\n';
    for (Index i = block.first; i < block.first + block.count; ++i) {
      out << ++tag;
      for (Index v : faces ? mesh.boundaryFaceVertices(i) : mesh.cellVertices(i))
        out << ' ' << v + 1;
      out << '\n';
    }
  }
  out << "$EndElements\n";

  std::ofstream stream(file, std::ios::binary | std::ios::trunc);
  if (!stream) throw Error(file.string() + ": cannot open file for writing");
  stream.write(out.text().data(), static_cast<std::streamsize>(out.text().size()));
  stream.close();
  if (!stream) throw Error(file.string() + ": write error");
}

}  // namespace obs::mesh
