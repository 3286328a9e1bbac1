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
/// Several bodies in one file (readGmshGroups, extractCellGroup): the physical groups of the cells
/// (physical volumes in 3D, physical surfaces in 2D) select the cells of one body. readGmshGroups
/// returns readGmsh's Mesh unchanged together with the physical tags of every cell and the list of
/// the file's physical groups; extractCellGroup makes the Mesh of one cell group:
///   - its cells are the cells in the group, in file order; its vertices are the vertices of these
///     cells, numbered compactly in file order (so a file holding only this body's nodes and
///     elements, in the same order, gives the same vertices, cells and boundary faces);
///   - its boundary faces are the boundary faces of the whole file (elements of dimension - 1 in a
///     physical group, with that tag as id) that are faces of a cell of the group; faces of other
///     bodies are dropped. A face on the interface between two bodies whose meshes match (one face
///     element shared by cells of both groups) is a boundary face of each body, with its physical
///     tag as id in both;
///   - the interface rule: a face of the body's boundary that the file puts in no physical group
///     (typically the interface to another body, an interior face of the whole file) is, as for
///     every unlisted boundary face, not listed in the Mesh; Grid gives it the boundary id 0
///     (kUnlistedBoundaryId, Grid.hpp). Give the interface a physical group to address it by name;
///   - boundary names: those of the boundary ids the body has faces of.
/// Selecting a group that does not exist, is not of the mesh dimension or holds no cells is an
/// obs::Error that names the file and lists the cell groups.
///
/// Every problem with the file (missing or unreadable file, binary or unsupported format,
/// truncated or malformed content, higher-order or unknown element types, references to unknown
/// nodes, no cells) is reported as an obs::Error whose message names the file and line, e.g.
/// "mesh.msh:17: element 12 references unknown node 99".
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

/// Reads a Gmsh .msh file (format 4.1 or 2.2, ASCII). Throws obs::Error on any problem.
Mesh readGmsh(const std::filesystem::path& file);

/// Reads .msh text held in memory (the same parser as readGmsh); `fileName` names it in messages.
Mesh readGmshString(std::string text, const std::string& fileName);

/// A physical group of a .msh file.
struct GmshPhysicalGroup {
  int dimension = 0;  ///< 0-3: points, curves, surfaces, volumes
  int tag = 0;        ///< physical tag (unique per dimension)
  std::string name;   ///< from $PhysicalNames; empty if the file gives none
  Index elements = 0; ///< elements of this dimension in the group (cells for a cell group)
};

/// A .msh file read with the physical groups of its cells (readGmshGroups).
struct GmshMesh {
  std::string fileName;  ///< the file as named in messages
  Mesh mesh;             ///< exactly readGmsh(file)
  /// Physical tags of cell c: cellGroupTags[cellGroupOffsets[c] .. cellGroupOffsets[c + 1]) (format
  /// 4.1: the tags of the cell's entity; 2.2: its first tag unless 0). Empty: the cell is in no group.
  std::vector<Index> cellGroupOffsets{0};
  std::vector<int> cellGroupTags;
  /// Every physical group of the file (named in $PhysicalNames, listed by an entity (4.1) or used
  /// by an element (2.2)), ordered by dimension and tag.
  std::vector<GmshPhysicalGroup> groups;

  std::span<const int> cellGroups(Index c) const {
    return {cellGroupTags.data() + cellGroupOffsets[static_cast<std::size_t>(c)],
            cellGroupTags.data() + cellGroupOffsets[static_cast<std::size_t>(c) + 1]};
  }
  /// The group of the mesh dimension with this tag, or with this name. Throws obs::Error
  /// ("<file>: ...", listing the cell groups) if there is none, if the tag or name belongs to a
  /// group of another dimension only, if the name is that of two cell groups, or if the group holds
  /// no cells.
  const GmshPhysicalGroup& cellGroup(int tag) const;
  const GmshPhysicalGroup& cellGroup(const std::string& name) const;
  /// "1 \"lower\" (162 cells), 2 \"upper\" (50 cells)": the groups of the mesh dimension, for
  /// messages ("none" if there are none).
  std::string describeCellGroups() const;
};

/// Reads a .msh file like readGmsh and keeps the physical groups of its cells.
GmshMesh readGmshGroups(const std::filesystem::path& file);
/// readGmshGroups on .msh text held in memory; `fileName` names it in messages.
GmshMesh readGmshGroupsString(std::string text, const std::string& fileName);

/// The Mesh of the cells in one physical group of the mesh dimension (the rules are in the file
/// comment above). Throws obs::Error as GmshMesh::cellGroup does.
Mesh extractCellGroup(const GmshMesh& file, int tag);
Mesh extractCellGroup(const GmshMesh& file, const std::string& name);

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
