#include "obs/mesh/Mesh.hpp"

#include "obs/mesh/Error.hpp"

namespace obs::mesh {

Mesh::Mesh(int dimension) : dim_(dimension) {
  if (dimension != 2 && dimension != 3) throw Error("Mesh: dimension must be 2 or 3");
}

void Mesh::reserve(Index vertices, Index cells, std::size_t cellConnectivity, Index boundaryFaces) {
  vertices_.reserve(vertices);
  cellTypes_.reserve(cells);
  cellOffsets_.reserve(static_cast<std::size_t>(cells) + 1);
  cellConn_.reserve(cellConnectivity);
  faceIds_.reserve(boundaryFaces);
  faceOffsets_.reserve(static_cast<std::size_t>(boundaryFaces) + 1);
  faceConn_.reserve(static_cast<std::size_t>(boundaryFaces) * (dim_ == 2 ? 2 : 4));
}

Index Mesh::addVertex(const Point& x) {
  vertices_.push_back(x);
  return numVertices() - 1;
}

Index Mesh::addCell(CellType type, std::span<const Index> vertices) {
  if (mesh::dimension(type) != dim_)
    throw Error("Mesh::addCell: a " + std::string(name(type)) + " in a " + std::to_string(dim_) +
                "D mesh");
  if (static_cast<int>(vertices.size()) != mesh::numVertices(type))
    throw Error("Mesh::addCell: a " + std::string(name(type)) + " needs " +
                std::to_string(mesh::numVertices(type)) + " vertices");
  for (Index v : vertices)
    if (v < 0 || v >= numVertices())
      throw Error("Mesh::addCell: vertex index " + std::to_string(v) + " out of range");
  cellTypes_.push_back(type);
  cellConn_.insert(cellConn_.end(), vertices.begin(), vertices.end());
  cellOffsets_.push_back(static_cast<Index>(cellConn_.size()));
  return numCells() - 1;
}

Index Mesh::addBoundaryFace(std::span<const Index> vertices, int id) {
  const int n = static_cast<int>(vertices.size());
  if ((dim_ == 2 && n != 2) || (dim_ == 3 && n != 3 && n != 4))
    throw Error("Mesh::addBoundaryFace: a face of a " + std::to_string(dim_) + "D mesh with " +
                std::to_string(n) + " vertices");
  for (Index v : vertices)
    if (v < 0 || v >= numVertices())
      throw Error("Mesh::addBoundaryFace: vertex index " + std::to_string(v) + " out of range");
  faceIds_.push_back(id);
  faceConn_.insert(faceConn_.end(), vertices.begin(), vertices.end());
  faceOffsets_.push_back(static_cast<Index>(faceConn_.size()));
  return numBoundaryFaces() - 1;
}

void Mesh::setBoundaryName(int id, const std::string& name) { names_[id] = name; }

std::optional<int> Mesh::boundaryId(const std::string& name) const {
  for (const auto& [id, n] : names_)
    if (n == name) return id;
  return std::nullopt;
}

std::array<Index, 7> Mesh::cellCounts() const {
  std::array<Index, 7> counts{};
  for (CellType t : cellTypes_) ++counts[static_cast<int>(t)];
  return counts;
}

VertexCells vertexCells(const Mesh& mesh) {
  VertexCells vc;
  vc.start.assign(static_cast<std::size_t>(mesh.numVertices()) + 1, 0);
  for (Index c = 0; c < mesh.numCells(); ++c)
    for (Index v : mesh.cellVertices(c)) ++vc.start[static_cast<std::size_t>(v) + 1];
  for (std::size_t v = 0; v + 1 < vc.start.size(); ++v) vc.start[v + 1] += vc.start[v];
  vc.cells.resize(static_cast<std::size_t>(vc.start.back()));
  std::vector<Index> fill(vc.start.begin(), vc.start.end() - 1);
  for (Index c = 0; c < mesh.numCells(); ++c)
    for (Index v : mesh.cellVertices(c)) vc.cells[static_cast<std::size_t>(fill[static_cast<std::size_t>(v)]++)] = c;
  return vc;
}

}  // namespace obs::mesh
