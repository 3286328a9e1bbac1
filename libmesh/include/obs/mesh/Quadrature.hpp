#pragma once
/// \file Quadrature.hpp
/// Quadrature rules on the reference elements of ReferenceElement.hpp.
///
/// `quadratureRule(type, degree)` returns a rule that integrates exactly
///   - on segments, triangles, tetrahedra: every polynomial of total degree <= degree;
///   - on quadrilaterals and hexahedra: every polynomial of degree <= degree in each coordinate
///     (tensor Gauss-Legendre);
///   - on prisms: every polynomial of total degree <= degree in (x, y) times degree <= degree in z;
///   - on pyramids: every polynomial of total degree <= degree; in the collapsed coordinates
///     u = x/(1-z), v = y/(1-z), w = z it is exact for Q_degree(u, v) x P_degree(w), which holds
///     the stiffness integrands of the rational pyramid element on affine pyramids for degree 2.
/// Simplex and pyramid rules are conical-product (Stroud) rules built from Gauss-Jacobi points, so
/// all weights are positive and all points interior; up to degree 1 a simplex gets the one-point
/// centroid rule. Rules are computed once and cached.
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

struct QuadratureRule {
  CellType type;
  int degree;                ///< exactness degree, see above
  std::vector<Point> points; ///< reference coordinates
  std::vector<double> weights;
  std::size_t size() const { return weights.size(); }
};

/// Rule of exactness at least `degree` (0 <= degree <= 30). Thread-safe; the reference stays valid.
const QuadratureRule& quadratureRule(CellType type, int degree);

}  // namespace obs::mesh
