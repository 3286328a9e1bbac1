#pragma once
/// \file CellType.hpp
/// Geometry types of cells and faces. Vertex numbering follows Gmsh and VTK for first-order cells
/// (they agree for all types used here), see ReferenceElement.hpp for the reference coordinates.
#include <cstdint>
#include <string_view>

namespace obs::mesh {

enum class CellType : std::uint8_t {
  Segment,        ///< 1D, faces of 2D cells
  Triangle,       ///< 2D cell, face of tetrahedra/prisms/pyramids
  Quadrilateral,  ///< 2D cell, face of hexahedra/prisms/pyramids
  Tetrahedron,
  Hexahedron,
  Prism,
  Pyramid,
};

/// All cell types that can form a mesh (2D and 3D), in a fixed order for typed tests and loops.
inline constexpr CellType kVolumeCellTypes[] = {CellType::Triangle,    CellType::Quadrilateral,
                                               CellType::Tetrahedron, CellType::Hexahedron,
                                               CellType::Prism,       CellType::Pyramid};

/// Every type including the segment (the face type of 2D cells).
inline constexpr CellType kAllCellTypes[] = {CellType::Segment,     CellType::Triangle,
                                            CellType::Quadrilateral, CellType::Tetrahedron,
                                            CellType::Hexahedron,  CellType::Prism,
                                            CellType::Pyramid};

constexpr int dimension(CellType t) {
  switch (t) {
    case CellType::Segment: return 1;
    case CellType::Triangle:
    case CellType::Quadrilateral: return 2;
    default: return 3;
  }
}

constexpr int numVertices(CellType t) {
  switch (t) {
    case CellType::Segment: return 2;
    case CellType::Triangle: return 3;
    case CellType::Quadrilateral: return 4;
    case CellType::Tetrahedron: return 4;
    case CellType::Hexahedron: return 8;
    case CellType::Prism: return 6;
    case CellType::Pyramid: return 5;
  }
  return 0;
}

/// Lower-case name as used in scene files ("triangle", "hexahedron", ...).
constexpr std::string_view name(CellType t) {
  switch (t) {
    case CellType::Segment: return "segment";
    case CellType::Triangle: return "triangle";
    case CellType::Quadrilateral: return "quadrilateral";
    case CellType::Tetrahedron: return "tetrahedron";
    case CellType::Hexahedron: return "hexahedron";
    case CellType::Prism: return "prism";
    case CellType::Pyramid: return "pyramid";
  }
  return "?";
}

/// Type of a face with n vertices in a cell of dimension dim (2 -> segment, 3 -> triangle, 4 -> quad).
constexpr CellType faceTypeFromVertexCount(int n) {
  return n == 2 ? CellType::Segment : n == 3 ? CellType::Triangle : CellType::Quadrilateral;
}

}  // namespace obs::mesh
