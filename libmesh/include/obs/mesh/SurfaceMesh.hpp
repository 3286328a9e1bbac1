#pragma once
/// \file SurfaceMesh.hpp
/// Surface meshes: the boundary of a rigid obstacle given as faces only, with no volume cells (a
/// scanned or CAD surface such as the thesis' tibial head). A surface mesh of a 3D obstacle holds
/// triangles and quadrilaterals in space; one of a 2D obstacle holds segments in the xy-plane.
///
/// Orientation: faces are ordered counterclockwise seen from outside the obstacle, i.e. their
/// normals (b - a) x (c - a) (3D) or the tangent b - a turned clockwise, (t_y, -t_x) (2D), point out
/// of the obstacle towards the body. This is the usual orientation of the boundary of a solid (STL
/// files, Gmsh surfaces of a volume, a counterclockwise outline in 2D).
///
/// Readers:
///   - Gmsh .msh 4.1 / 2.2 ASCII (Gmsh.hpp's parser): the elements of the highest dimension in the
///     file (2: triangles, quadrilaterals; 1: segments) are the faces, in file order, with their
///     coordinates kept (z must be 0 for segments); physical groups are ignored;
///   - STL, ASCII ("solid ... endsolid") or binary (80-byte header, triangle count, 50 bytes per
///     triangle): triangles whose corners are merged into shared vertices by exact coordinate
///     equality (as STL writers repeat them bit for bit), so that neighbouring faces share edges.
/// Every problem (missing file, malformed or truncated content, non-finite coordinates, no faces)
/// is an obs::Error naming the file and, where there is one, the line.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

struct SurfaceMesh {
  /// Dimension of the space the surface lives in: 2 (segments) or 3 (triangles, quadrilaterals).
  int dimension = 3;
  std::vector<Point> vertices;
  /// Face types: CellType::Segment (2D), Triangle or Quadrilateral (3D).
  std::vector<CellType> types;
  /// Vertex indices of each face (the first numVertices(type) entries are used).
  std::vector<std::array<Index, 4>> faces;
  /// Where the surface came from, for messages ("tibia.stl").
  std::string source;

  Index numFaces() const { return static_cast<Index>(faces.size()); }
};

/// The faces of the highest dimension in a Gmsh .msh file (see the file comment).
SurfaceMesh readGmshSurface(const std::filesystem::path& file);
/// The same from .msh text in memory; `fileName` names it in messages.
SurfaceMesh readGmshSurfaceString(std::string text, const std::string& fileName);

/// An STL file, ASCII or binary (told apart by content, not by name).
SurfaceMesh readStl(const std::filesystem::path& file);
/// The same from STL bytes in memory.
SurfaceMesh readStlString(const std::string& bytes, const std::string& fileName);

/// readGmshSurface for ".msh", readStl for ".stl" (case-insensitive); other extensions are an
/// obs::Error naming the formats.
SurfaceMesh readSurfaceMesh(const std::filesystem::path& file);

}  // namespace obs::mesh
