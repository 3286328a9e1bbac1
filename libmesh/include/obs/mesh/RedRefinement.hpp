#pragma once
/// \file RedRefinement.hpp
/// Red (regular) refinement rules as tables, and one uniform red refinement of a flat Mesh.
///
/// A rule lists the "refinement points" of a parent cell, each the average of some parent corners,
/// in a fixed order:
///   1. the parent corners (point i = corner i),
///   2. the edge midpoints, in the edge order of ReferenceElement / localEdges(),
///   3. the centres of the quadrilateral faces in face order (for a quadrilateral: its centre),
///   4. the cell centre of a hexahedron.
/// and the children as (type, refinement-point indices) in the usual vertex order; every child is
/// positively oriented when the parent is (checked on the reference cell and by the tests).
///
///   Segment       -> 2 segments                 (3 points)
///   Triangle      -> 4 triangles                (6 points)
///   Quadrilateral -> 4 quadrilaterals           (9 points)
///   Tetrahedron   -> 8 tetrahedra               (10 points): 4 corner tetrahedra plus the inner
///                    octahedron cut into 4 along one of its three diagonals (Bey 1995); the rule
///                    has three variants, one per diagonal, and refinement picks the shortest.
///   Hexahedron    -> 8 hexahedra                (27 points)
///   Prism         -> 8 prisms                   (18 points)
///   Pyramid       -> 6 pyramids + 4 tetrahedra  (14 points): 4 corner pyramids, the apex pyramid,
///                    the inverted pyramid between the lateral edge midpoints and the base centre,
///                    and one tetrahedron on each base edge.
/// Faces refine the same way in every cell: a segment into 2, a triangle into 4 through its edge
/// midpoints, a quadrilateral into 4 through its edge midpoints and centre. So red children of
/// face neighbours match, and the Segment/Triangle/Quadrilateral rules double as the refinement
/// rules of boundary faces (children keep the parent's orientation).
#include <cstdint>
#include <span>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

/// The parent entity whose centre a refinement point is: a corner, an edge (localEdges() number),
/// a quadrilateral face of a 3D cell (localFaces() number) or the cell itself (index 0; the centre
/// of a hexahedron or quadrilateral, the midpoint of a segment is its Edge 0).
enum class PointLocation : std::uint8_t { Corner, Edge, Face, Cell };

struct PointSite {
  PointLocation location;
  int index;
};

struct RefinementChild {
  CellType type;
  std::vector<int> points;  ///< refinement-point indices, in the child's vertex order
};

struct RefinementRule {
  CellType type;
  int variant = 0;  ///< tetrahedra: the inner diagonal, 0: m01-m23, 1: m12-m03, 2: m20-m13
  /// Refinement point i is the average of the parent corners points[i] (sorted ascending).
  std::vector<std::vector<int>> points;
  /// Parent entity of each refinement point (same order as points).
  std::vector<PointSite> sites;
  std::vector<RefinementChild> children;
};

/// Number of rule variants of a type (3 for tetrahedra, 1 otherwise).
int numRedRuleVariants(CellType type);

/// The red rule of a type (a static table; `variant` as in RefinementRule::variant).
const RefinementRule& redRefinementRule(CellType type, int variant = 0);

/// Index of the shortest inner diagonal of a tetrahedron with corners x (ties: lowest index), i.e.
/// the argmin over |x0+x1-x2-x3|, |x1+x2-x0-x3|, |x2+x0-x1-x3|.
int shortestTetDiagonal(std::span<const Point> x);

/// The rule to use for a parent with corners x: for tetrahedra the shortest-diagonal variant.
const RefinementRule& redRefinementRule(CellType type, std::span<const Point> x);

/// One uniform red refinement of every cell (mixed types allowed). New vertices are averages of
/// parent corners, shared between neighbours. Numbering (deterministic): the old vertices keep
/// their numbers, then come the edge midpoints (EdgeTable order, i.e. by sorted vertex pair), the
/// centres of quadrilateral faces of 3D cells (FaceTable order), and the centres of hexahedra and
/// of 2D quadrilaterals in cell order. Children are numbered cell by cell in rule order. Boundary
/// faces are refined by the face rules (children inherit the parent face's id, names are copied);
/// a boundary face that is not a cell face gets its own new vertices.
Mesh refineUniformly(const Mesh& mesh);

}  // namespace obs::mesh
