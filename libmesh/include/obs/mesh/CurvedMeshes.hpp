#pragma once
/// \file CurvedMeshes.hpp
/// Coarse meshes of the curved geometries of the reference thesis' examples (Walloth 2012): the
/// ball of the dynamic one-body contact problems ("Geometry A"), the block with a rounded bottom
/// ("Geometry 1"), and the 2D analogues disk and half disk. Each generator returns the mesh
/// together with the projections of its curved boundary parts onto the exact surface, so that a
/// refinement procedure can move new boundary vertices onto the geometry (e.g. after
/// refineUniformly(), or through the boundary-projection callback of the hierarchical grid).
///
/// Ball and disk use the standard "cubed sphere" block structure: an inner cube (square)
/// [-a, a]^d with n cells per direction, a = r / (2 sqrt(d)) (its corners lie at radius r/2), and
/// on each of its 2d faces one block of n^(d-1) x m cells, m = ceil(n/2), reaching out to the
/// sphere. A block vertex over the inner-cube surface point a q (|q|_inf = 1) at layer l = 0..m is
///   c + (1 - l/m) a q + (l/m) r w/|w|,   w_i = tan(pi/4 q_i)   (equiangular on the sphere),
/// so the outermost vertices lie on the sphere and the blocks match along their common edges.
///
/// All cells are positively oriented, the meshes are conforming, and the boundary faces are
/// oriented like the faces of their cells (outward normal). 2D meshes have z = 0.
#include <array>
#include <functional>
#include <map>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

/// Maps a point onto a curved boundary surface (the closest point of the exact surface for every
/// point off the surface's axis/centre). Projections are idempotent.
using BoundaryProjection = std::function<Point(const Point&)>;

/// A coarse mesh of a curved domain and the projections of its curved boundary parts.
struct CurvedMesh {
  Mesh mesh;
  /// Boundary id -> projection onto the exact curved surface of the faces with that id. Flat
  /// boundary parts have no entry.
  std::map<int, BoundaryProjection> projections;
};

/// Boundary ids of ball, disk and half disk (the rounded block uses BoxBoundary of BoxMesh.hpp).
enum CurvedBoundary : int {
  kCurvedSurface = 1,  ///< "surface" (ball), "circle" (disk), "arc" (half disk)
  kHalfDiskTop = 2,    ///< "top": the straight diameter of the half disk / the flat disc of the half ball
};

/// The ball of radius `radius` around `centre`, cubed-sphere blocks with n = level0Cells cells per
/// direction of the inner cube (see the file comment); boundary id 1 "surface" with the projection
/// onto the sphere. The hexahedra of the block structure are split conformingly:
///   Hexahedron  one cell per hexahedron: n^3 + 6 n^2 m cells;
///   Pyramid     6 pyramids from an added hexahedron centre (average of its corners), one per face;
///   Tetrahedron the 6 pyramids, each split into 2 tetrahedra along the base diagonal through the
///               smallest vertex number of the base (depends on the face only, so neighbours
///               match);
///   Prism       2 prisms per hexahedron; the prism axis is z in the inner cube, radial in the +-z
///               blocks, y in the +-x blocks and x in the +-y blocks, and the triangulated faces
///               are split along the diagonal from the lower-lower to the upper-upper block
///               indices, which makes the split conforming across all blocks.
/// Vertices: the (n+1)^3 inner lattice points, then layer by layer the shell vertices, then the
/// hexahedron centres (pyramids, tetrahedra). Throws obs::Error for a non-3D type, level0Cells < 1,
/// a radius that is not positive and finite, or a non-finite centre.
CurvedMesh ballMesh(const Point& centre, double radius, CellType type, int level0Cells);

/// The disk of radius `radius` around (centre.x, centre.y) (z = 0): an inner square with n cells
/// per direction and 4 blocks of n x m cells (see the file comment). Boundary id 1 "circle" with
/// the projection onto the circle. Triangle: each quadrilateral split into 2 along the diagonal
/// through its smallest vertex number. Throws obs::Error for a type other than
/// Triangle/Quadrilateral, n < 1 or a bad centre/radius.
CurvedMesh diskMesh(const Point& centre, double radius, CellType type, int n);

/// The lower half disk {|x - centre| <= radius, y <= centre.y}: the part of diskMesh(centre,
/// radius, type, 2n) below the diameter y = centre.y (which is a mesh line of that disk), i.e. the
/// 2D analogue of a ball touching a plane from above. Boundary ids 1 "arc" (projection onto the
/// circle) and 2 "top" (the diameter, flat). Throws as diskMesh.
CurvedMesh halfDiskMesh(const Point& centre, double radius, CellType type, int n);

/// The lower half ball {|x - centre| <= radius, z <= centre.z}: the part of ballMesh(centre, radius,
/// type, 2n) below the equator plane (a mesh plane of that ball), i.e. a ball touching a plane from
/// above with a flat top to hold it. Boundary ids 1 "surface" (projection onto the sphere) and 2
/// "top" (the flat disc). Throws as ballMesh.
CurvedMesh halfBallMesh(const Point& centre, double radius, CellType type, int n);

/// The block of the thesis' dynamic examples: [0, width] x [0, depth] x [z_b(x), height] with the
/// cylindrical bottom z_b(x) = R - sqrt(R^2 - (x - width/2)^2), R = arcRadius (cylinder axis along
/// y through x = width/2, z = R; lowest point at z = 0), flat top at z = height. Built from
/// boxMesh(type, cells, ...) of [0, width] x [0, depth] x [0, 1] (same cell splits and numbering)
/// by mapping each vertical line linearly onto [z_b(x), height]. Boundary ids and names as for box
/// meshes (BoxBoundary): left 1, right 2, bottom 3 (curved, projection onto the cylinder), top 4,
/// front 5 (y = 0), back 6 (y = depth).
/// 2D types (Triangle, Quadrilateral) give the cross-section [0, width] x [y_b(x), height] with the
/// circular bottom arc in y, ids left, right, bottom (arc), top; depth and cells[2] are ignored.
/// Throws obs::Error for a Segment type, cells < 1, a size (width, height, arcRadius, 3D: depth)
/// that is not positive and finite, arcRadius < width/2 (the arc would not span the width), or
/// height <= z_b(0) (the block would have no thickness at its sides).
CurvedMesh roundedBlockMesh(double width, double height, double depth, double arcRadius,
                            CellType type, std::array<int, 3> cells);

}  // namespace obs::mesh
