#pragma once
/// \file MeshTopology.hpp
/// Topological and geometric utilities on a flat Mesh: local edge/face tables of the cell types,
/// the face table (which cells share a face), a conformity check, cell volumes and orientation,
/// and a random interior perturbation used to build distorted (non-affine) test meshes.
///
/// The local edge and face tables here are the single source of the topology of each cell type
/// (outward orientation: the right-hand normal of a face's vertex cycle points out of the cell);
/// ReferenceElement takes its `edges` and `faces` from them.
#include <array>
#include <map>
#include <span>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

// --- local tables ------------------------------------------------------------------------------

/// A face of a reference cell: its type and local vertices in outward orientation.
struct LocalFace {
  CellType type;                ///< Segment, Triangle or Quadrilateral
  int size;                     ///< number of vertices (2, 3 or 4)
  std::array<int, 4> vertices;  ///< local vertex numbers; entries >= size are unused
  std::span<const int> span() const { return {vertices.data(), static_cast<std::size_t>(size)}; }
};

/// Edges of a cell type (also of Segment/Triangle/Quadrilateral as faces), ReferenceElement order.
std::span<const std::array<int, 2>> localEdges(CellType type);
/// Codimension-1 faces of a cell type, ReferenceElement order and orientation (none for Segment).
std::span<const LocalFace> localFaces(CellType type);

// --- edge and face tables ---------------------------------------------------------------------

/// All distinct edges of the cells of a mesh. Edges are numbered in lexicographic order of their
/// sorted vertex pairs (deterministic, independent of the cell order). Built by bucketing the
/// cell edges by their smaller vertex (no hashing), so construction is linear and cache friendly.
class EdgeTable {
public:
  explicit EdgeTable(const Mesh& mesh);

  Index numEdges() const { return static_cast<Index>(edges_.size()); }
  /// Vertices of edge e, smaller first.
  const std::array<Index, 2>& vertices(Index e) const { return edges_[e]; }
  /// Edge number of local edge `localEdge` (localEdges() order) of `cell`.
  Index edge(Index cell, int localEdge) const { return cellEdges_[cellOffsets_[cell] + localEdge]; }
  /// Edge joining a and b (any order), or -1 if no cell has this edge.
  Index find(Index a, Index b) const;

private:
  std::vector<std::array<Index, 2>> edges_;
  std::vector<Index> start_;  ///< edges with smaller vertex v: [start_[v], start_[v+1])
  std::vector<Index> cellOffsets_;
  std::vector<Index> cellEdges_;
};

/// Key of a face: its vertex numbers sorted ascending, unused trailing entries -1.
using FaceKey = std::array<Index, 4>;
FaceKey makeFaceKey(std::span<const Index> vertices);

struct FaceKeyHash {
  std::size_t operator()(const FaceKey& k) const noexcept;
};

/// All distinct faces of the cells of a mesh and the cells sharing each face.
/// A face of a conforming mesh has one cell (boundary) or two (interior); a count above two means a
/// non-manifold face. Faces are numbered in lexicographic order of their keys; the sides of a face
/// are in increasing cell order. Built by bucketing the cells' faces on their smallest vertex (a
/// counting sort in two streaming passes over the cells) and sorting each bucket in place.
class FaceTable {
public:
  /// One side of a face: the cell and the number of the face in that cell's localFaces().
  struct Side {
    Index cell = -1;
    int localFace = -1;
  };

  /// The table of the mesh's cells, built on `threads` threads (OpenMP; the table is the same
  /// for any count: every thread writes what the sequential loops would).
  explicit FaceTable(const Mesh& mesh, int threads = 1);

  Index numFaces() const { return static_cast<Index>(keys_.size()); }
  const FaceKey& key(Index f) const { return keys_[f]; }
  /// Number of vertices of face f (2, 3 or 4).
  int size(Index f) const { return keys_[f][3] >= 0 ? 4 : keys_[f][2] >= 0 ? 3 : 2; }
  /// Number of cells having face f (1 boundary, 2 interior, > 2 non-manifold).
  int numCells(Index f) const { return counts_[f]; }
  /// Side k (0 or 1) of face f; side 1 is {-1, -1} for a face with one cell.
  const Side& side(Index f, int k) const { return sides_[f][k]; }
  /// Face number of local face `localFace` of `cell`.
  Index face(Index cell, int localFace) const { return cellFaces_[cellOffsets_[cell] + localFace]; }
  /// Face with the given vertices (any order), or -1 if no cell has this face.
  Index find(std::span<const Index> vertices) const;

private:
  std::vector<FaceKey> keys_;
  std::vector<int> counts_;
  std::vector<std::array<Side, 2>> sides_;
  std::vector<Index> start_;  ///< faces with smallest vertex v: [start_[v], start_[v+1])
  std::vector<Index> cellOffsets_;
  std::vector<Index> cellFaces_;
};

// --- conformity --------------------------------------------------------------------------------

/// Result of checkConformity(). All counts refer to distinct faces (codimension-1 entities) of the
/// cells and to the boundary faces stored in the Mesh.
struct ConformityReport {
  /// Cell faces shared by exactly two cells.
  Index interiorFaces = 0;
  /// Cell faces belonging to exactly one cell.
  Index boundaryFaces = 0;
  /// Violation: cell faces shared by three or more cells.
  Index nonManifoldFaces = 0;
  /// Violation: interior faces both of whose cells traverse the face in the same direction (an
  /// inverted or mirrored cell).
  Index misorientedFaces = 0;
  /// Violation: one-cell faces not listed as Mesh boundary faces.
  Index hangingFaces = 0;
  /// Violation: Mesh boundary faces that are not a one-cell face (no such cell face, an interior
  /// face, or listed twice).
  Index unmatchedBoundaryFaces = 0;
  /// True if no violation was found.
  bool conforming() const {
    return nonManifoldFaces == 0 && misorientedFaces == 0 && hangingFaces == 0 &&
           unmatchedBoundaryFaces == 0;
  }
};

/// Checks the combinatorial conformity of a mesh whose boundary faces cover its whole boundary:
///  - every cell face is shared by one or two cells (nonManifoldFaces otherwise);
///  - the two cells of an interior face induce opposite orientations on it (misorientedFaces);
///  - the one-cell faces are exactly the Mesh boundary faces, each listed once: a one-cell face not
///    in the list (hangingFaces) is an interior face whose neighbour does not match it, which is
///    how hanging vertices and split faces show up (e.g. a vertex in the interior of a neighbour's
///    edge); a listed boundary face that is not a one-cell face counts as unmatchedBoundaryFaces.
/// The check is purely combinatorial (vertex numbers); geometric overlaps are not detected.
ConformityReport checkConformity(const Mesh& mesh);

// --- geometry ----------------------------------------------------------------------------------

/// Signed measure of a cell with the given corner coordinates under the first-order reference
/// mapping (integral of the Jacobian determinant): positive for positively oriented cells. Exact
/// for all cell types including trilinear hexahedra, bilinear quadrilaterals, prisms with
/// non-planar sides and pyramids with a non-planar (bilinear) base. 2D cells use the x-y
/// components.
double signedMeasure(CellType type, std::span<const Point> corners);
/// Jacobian determinant of the reference mapping at every corner is positive (for a pyramid: at the
/// four base corners, where det J = (B_u x B_v) . (apex - B) is taken along the edges to the apex).
bool isPositivelyOriented(CellType type, std::span<const Point> corners);

/// Corner coordinates of a cell.
std::vector<Point> cellCorners(const Mesh& mesh, Index cell);
/// Signed volume (area in 2D) of a cell, see signedMeasure().
double cellVolume(const Mesh& mesh, Index cell);
/// Sum of the signed cell volumes.
double totalVolume(const Mesh& mesh);
bool isPositivelyOriented(const Mesh& mesh, Index cell);

/// Measure of a boundary face of the mesh (length of a segment, area of a triangle or of a
/// bilinear quadrilateral; the latter by a 4x4 Gauss rule, exact for planar faces).
double boundaryFaceMeasure(const Mesh& mesh, Index face);
/// Total measure of the boundary faces of each boundary id.
std::map<int, double> boundaryMeasureById(const Mesh& mesh);

/// Vertices lying on a Mesh boundary face or on a cell face with only one cell (flag per vertex).
std::vector<char> boundaryVertexFlags(const Mesh& mesh);

/// Moves every vertex that is not a boundary vertex (boundaryVertexFlags) by a random offset of
/// length up to relativeAmount * h_v (h_v = shortest edge at the vertex), drawn from a
/// std::mt19937 seeded with `seed`, so the result is deterministic. Vertices are moved one after
/// another; an offset that would make an adjacent cell not positively oriented is halved (up to
/// ten times) and otherwise dropped, so a valid mesh stays valid. Boundary vertices stay fixed,
/// hence the total volume is unchanged. Throws obs::Error if relativeAmount is negative.
void perturbInteriorVertices(Mesh& mesh, double relativeAmount, unsigned seed);

}  // namespace obs::mesh
