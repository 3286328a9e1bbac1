#pragma once
/// \file Mesh.hpp
/// A flat unstructured mesh: vertices, cells of any of the six types (all of one dimension), and
/// boundary faces carrying integer ids with optional names. This is the exchange format between
/// generators, file readers, the hierarchical grid (whose leaf and level views are Meshes) and
/// the finite element code.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/CellType.hpp"

namespace obs::mesh {

using Index = std::int32_t;
/// Vertex coordinates; always three components, z = 0 in 2D.
using Point = Eigen::Vector3d;

class Mesh {
public:
  explicit Mesh(int dimension = 2);

  int dimension() const { return dim_; }

  /// Reserves storage (a hint; avoids reallocation when the final sizes are known).
  void reserve(Index vertices, Index cells, std::size_t cellConnectivity, Index boundaryFaces = 0);

  // --- vertices --------------------------------------------------------------------------------
  Index addVertex(const Point& x);
  Index numVertices() const { return static_cast<Index>(vertices_.size()); }
  const Point& vertex(Index v) const { return vertices_[v]; }
  Point& vertex(Index v) { return vertices_[v]; }
  const std::vector<Point>& vertices() const { return vertices_; }

  // --- cells -----------------------------------------------------------------------------------
  /// Adds a cell; its type must have the mesh dimension and `vertices` its vertex count.
  Index addCell(CellType type, std::span<const Index> vertices);
  Index addCell(CellType type, std::initializer_list<Index> vertices) {
    return addCell(type, std::span<const Index>(vertices.begin(), vertices.size()));
  }
  Index numCells() const { return static_cast<Index>(cellTypes_.size()); }
  CellType cellType(Index c) const { return cellTypes_[c]; }
  std::span<const Index> cellVertices(Index c) const {
    return {cellConn_.data() + cellOffsets_[c], cellConn_.data() + cellOffsets_[c + 1]};
  }
  std::span<Index> cellVertices(Index c) {
    return {cellConn_.data() + cellOffsets_[c], cellConn_.data() + cellOffsets_[c + 1]};
  }

  // --- boundary faces --------------------------------------------------------------------------
  /// Adds a boundary face (segment in 2D, triangle or quadrilateral in 3D) with boundary id `id`.
  Index addBoundaryFace(std::span<const Index> vertices, int id);
  Index addBoundaryFace(std::initializer_list<Index> vertices, int id) {
    return addBoundaryFace(std::span<const Index>(vertices.begin(), vertices.size()), id);
  }
  Index numBoundaryFaces() const { return static_cast<Index>(faceIds_.size()); }
  std::span<const Index> boundaryFaceVertices(Index f) const {
    return {faceConn_.data() + faceOffsets_[f], faceConn_.data() + faceOffsets_[f + 1]};
  }
  CellType boundaryFaceType(Index f) const {
    return faceTypeFromVertexCount(faceOffsets_[f + 1] - faceOffsets_[f]);
  }
  int boundaryFaceId(Index f) const { return faceIds_[f]; }
  /// A vertex on boundary `id` none of whose faces with that id is in the mesh: the local mesh of a
  /// distributed run (localMesh, HaloExchange.hpp) holds a ghost vertex at the edge of its ghost
  /// layer whose boundary faces have vertices it does not hold. Dirichlet conditions on `id`
  /// prescribe it (collectDirichlet) as they prescribe the vertices of the faces.
  void addBoundaryVertex(Index v, int id) { vertexIds_.emplace_back(v, id); }
  const std::vector<std::pair<Index, int>>& boundaryVertices() const { return vertexIds_; }

  // --- boundary names --------------------------------------------------------------------------
  void setBoundaryName(int id, const std::string& name);
  /// Id of a named boundary, if the name exists.
  std::optional<int> boundaryId(const std::string& name) const;
  const std::map<int, std::string>& boundaryNames() const { return names_; }

  /// Number of cells of each type, indexed by static_cast<int>(CellType).
  std::array<Index, 7> cellCounts() const;

private:
  int dim_;
  std::vector<Point> vertices_;
  std::vector<CellType> cellTypes_;
  std::vector<Index> cellOffsets_{0};
  std::vector<Index> cellConn_;
  std::vector<int> faceIds_;
  std::vector<std::pair<Index, int>> vertexIds_;  ///< addBoundaryVertex
  std::vector<Index> faceOffsets_{0};
  std::vector<Index> faceConn_;
  std::map<int, std::string> names_;
};

/// The cells around each vertex in compressed form: cellsOf(v) lists the cells having v as a
/// vertex, in ascending order.
struct VertexCells {
  std::vector<Index> start;  ///< numVertices() + 1 offsets into cells
  std::vector<Index> cells;
  std::span<const Index> cellsOf(Index v) const {
    return {cells.data() + start[static_cast<std::size_t>(v)], cells.data() + start[static_cast<std::size_t>(v) + 1]};
  }
};
VertexCells vertexCells(const Mesh& mesh);

}  // namespace obs::mesh
