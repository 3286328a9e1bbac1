#pragma once
/// \file ReferenceElement.hpp
/// Table-driven description of the reference element of each cell type and its first-order
/// Lagrange shape functions (one per vertex):
///   - Segment        [0,1]                       P1
///   - Triangle       (0,0) (1,0) (0,1)            P1
///   - Quadrilateral  [0,1]^2, counter-clockwise  Q1
///   - Tetrahedron    origin and unit vectors      P1
///   - Hexahedron     [0,1]^3, bottom ccw then top Q1
///   - Prism          triangle x [0,1]            P1 x Q1
///   - Pyramid        base [0,1]^2 ccw at z = 0, apex (0,0,1)
///                    rational element: bilinear on the base, linear on the triangular faces,
///                    phi_0 = (1-x-z)(1-y-z)/(1-z), ..., phi_4 = z  (conforming with hexahedra,
///                    prisms and tetrahedra on shared faces).
/// Faces are listed with vertices ordered so that their right-hand normal points out of the cell.
#include <span>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

struct ReferenceFace {
  CellType type;             ///< Segment (2D cells), Triangle or Quadrilateral (3D cells)
  std::vector<int> vertices; ///< local vertex numbers, outward orientation
};

class ReferenceElement {
public:
  CellType type;
  int dim;
  int numVertices;
  double volume;                       ///< measure of the reference element
  std::vector<Point> vertices;         ///< reference coordinates (unused components 0)
  std::vector<std::array<int, 2>> edges;
  std::vector<ReferenceFace> faces;    ///< codimension-1 subentities
  Point centroid;                      ///< barycentre of the reference element

  /// Shape function values at reference point xi: out[i], i < numVertices.
  void values(const Point& xi, std::span<double> out) const { values_(xi, out.data()); }
  /// Gradients w.r.t. reference coordinates: out[i*dim + k] = d phi_i / d xi_k.
  void gradients(const Point& xi, std::span<double> out) const { gradients_(xi, out.data()); }
  /// Second derivatives: out[(i*dim + k)*dim + l] = d^2 phi_i / d xi_k d xi_l.
  void hessians(const Point& xi, std::span<double> out) const { hessians_(xi, out.data()); }

  using Kernel = void (*)(const Point&, double*);
  Kernel values_ = nullptr;
  Kernel gradients_ = nullptr;
  Kernel hessians_ = nullptr;
};

/// The reference element of a cell type (a static table; never null).
const ReferenceElement& referenceElement(CellType type);

}  // namespace obs::mesh
