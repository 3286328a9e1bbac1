#pragma once
/// \file BoxMesh.hpp
/// Structured meshes of boxes with every cell type, and a conforming mixed-type 3D box mesh.
///
/// Boundary faces carry ids and names:
///   2D: left (x = lower.x) 1, right (x = upper.x) 2, bottom (y = lower.y) 3, top (y = upper.y) 4;
///   3D: left 1, right 2, bottom (z = lower.z) 3, top (z = upper.z) 4, front (y = lower.y) 5,
///       back (y = upper.y) 6.
/// Boundary faces are oriented like the faces of their cells (outward normal). All cells are
/// positively oriented and the meshes are conforming.
#include <array>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

/// Boundary ids of box meshes.
enum BoxBoundary : int { kLeft = 1, kRight = 2, kBottom = 3, kTop = 4, kFront = 5, kBack = 6 };

/// Structured mesh of the box [lower, upper] with cells[0] x cells[1] (x cells[2]) blocks:
///   Triangle      2D, each square split into 2 along its diagonal from (x0,y0) to (x1,y1);
///   Quadrilateral 2D, one per square;
///   Tetrahedron   3D, each cube split into 6 (Kuhn/Freudenthal, all around the diagonal from the
///                 lower-left-front to the upper-right-back corner; conforming);
///   Hexahedron    3D, one per cube;
///   Prism         3D, each cube split into 2 along the (x0,y0)-(x1,y1) diagonal, axis along z;
///   Pyramid       3D, each cube split into 6 from an added centre vertex (one per cube face).
/// 2D types use cells[0..1] and lower/upper x and y (z of the vertices is 0). Vertices of the
/// block grid are numbered i + (nx+1) (j + (ny+1) k); pyramid centres follow.
/// Throws obs::Error for a Segment type, cells < 1 or upper <= lower in a used direction.
Mesh boxMesh(CellType type, std::array<int, 3> cells, const Point& lower, const Point& upper);

/// boxMesh with n blocks in every direction (default: the unit square / cube).
Mesh boxMesh(CellType type, int n, const Point& lower = Point::Zero(),
             const Point& upper = Point::Ones());

/// A conforming 3D mesh of [lower, upper] mixing all four 3D types, stacked in slabs along z. The
/// cells[2] block layers are divided into four slabs as evenly as possible (lower slabs get the
/// extra layers), from bottom to top:
///   1. hexahedra;
///   2. prisms with axis along x (each block split along its (y0,z0)-(y1,z1) diagonal, so the
///      z-faces are whole quadrilaterals);
///   3. pyramids: each block of the slab's top layer split into 3 pyramids with common apex at the
///      block corner (x1 or x0 for even or odd i, y1 or y0 for even or odd j, z1), whose bases are
///      the three block faces away from the apex; the three faces at the apex are then triangulated
///      through it and match neighbours and the slab above. Lower layers of the slab (if any) use
///      the 6-pyramid split with a centre vertex;
///   4. tetrahedra: Kuhn split of each block, mirrored in x, y and z for odd i, j, k, which matches
///      the triangulated faces of the pyramid layer below.
/// Boundary ids as for boxMesh. Throws obs::Error if cells[2] < 4 or for the conditions of boxMesh.
Mesh mixedBoxMesh3D(std::array<int, 3> cells, const Point& lower, const Point& upper);

}  // namespace obs::mesh
