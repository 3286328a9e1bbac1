#pragma once
/// \file Gmsh.hpp
/// Reading and writing Gmsh .msh files (https://gmsh.info, "MSH file format").
///
/// Reading accepts the ASCII variants of format 4.1 and 2.2 (2.0 and 2.1 share the 2.2 syntax)
/// with first-order elements:
///   Gmsh type 1 (2-node line), 2 (3-node triangle), 3 (4-node quadrangle), 4 (4-node
///   tetrahedron), 5 (8-node hexahedron), 6 (6-node prism), 7 (5-node pyramid); type 15 (point)
///   is accepted and ignored. Gmsh's first-order vertex orderings equal the obs orderings (see
///   ReferenceElement.hpp), so vertex lists are taken over unchanged and cells are not reoriented.
///
/// How a file becomes a Mesh:
///   - The mesh dimension is the highest dimension of the elements in the file (2 or 3); every
///     element of that dimension becomes a cell, in file order, whether or not it belongs to a
///     physical group.
///   - Elements one dimension lower that belong to a physical group become boundary faces whose
///     boundary id is the physical tag (format 4.1: the physical tags of the element's entity in
///     $Entities; format 2.2: the element's first tag, where 0 means "no group"). An element in
///     several physical groups gives one boundary face per group. Lower-dimensional elements
///     outside any physical group, and elements of even lower dimension, are ignored.
///   - $PhysicalNames entries of dimension (mesh dimension - 1) become boundary names.
///   - Node tags may be arbitrary positive integers; nodes are numbered compactly in file order,
///     and nodes used by no cell are dropped. In 2D meshes the z coordinate is set to 0.
///   - Unknown sections ($Comments, $Periodic, $NodeData, ...) are skipped.
///
/// Every problem with the file (missing or unreadable file, binary or unsupported format,
/// truncated or malformed content, higher-order or unknown element types, references to unknown
/// nodes, no cells) is reported as an obs::Error whose message names the file and line, e.g.
/// "mesh.msh:17: element 12 references unknown node 99".
#include <filesystem>
#include <optional>
#include <string>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

/// Reads a Gmsh .msh file (format 4.1 or 2.2, ASCII). Throws obs::Error on any problem.
Mesh readGmsh(const std::filesystem::path& file);

/// Reads .msh text held in memory (the same parser as readGmsh); `fileName` names it in messages.
Mesh readGmshString(std::string text, const std::string& fileName);

/// Writes `mesh` as a Gmsh 4.1 ASCII file. The cells form one entity of the mesh dimension in
/// physical group 1 named "domain"; the boundary faces of each boundary id form one entity of
/// dimension - 1 in the physical group with tag = boundary id, named by Mesh::boundaryNames()
/// where a name exists (names of ids without faces are written too). Cells and faces keep their
/// order and coordinates are written in shortest round-trip form, so readGmsh(writeGmsh(m))
/// reproduces m exactly, except that vertices used by no cell are dropped on reading.
/// Gmsh itself expects positive physical tags; other boundary ids round-trip through obs only.
/// Throws obs::Error if the file cannot be written or a boundary name cannot be represented
/// (names must not contain '"' or line breaks).
void writeGmsh(const Mesh& mesh, const std::filesystem::path& file);

/// Gmsh element type number of a first-order cell or face type (1, 2, 3, 4, 5, 6, 7).
constexpr int gmshElementType(CellType type) {
  switch (type) {
    case CellType::Segment: return 1;
    case CellType::Triangle: return 2;
    case CellType::Quadrilateral: return 3;
    case CellType::Tetrahedron: return 4;
    case CellType::Hexahedron: return 5;
    case CellType::Prism: return 6;
    case CellType::Pyramid: return 7;
  }
  return 0;
}

/// The cell type of a first-order Gmsh element type, or nullopt for any other type number.
constexpr std::optional<CellType> cellTypeFromGmsh(int gmshType) {
  switch (gmshType) {
    case 1: return CellType::Segment;
    case 2: return CellType::Triangle;
    case 3: return CellType::Quadrilateral;
    case 4: return CellType::Tetrahedron;
    case 5: return CellType::Hexahedron;
    case 6: return CellType::Prism;
    case 7: return CellType::Pyramid;
    default: return std::nullopt;
  }
}

}  // namespace obs::mesh
