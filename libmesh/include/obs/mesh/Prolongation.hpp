#pragma once
/// \file Prolongation.hpp
/// Transfer (interpolation) operators between views of a Grid, as sparse matrices.
///
/// transferMatrix(grid, coarse, fine) maps vertex values of the first-order Lagrange space on the
/// coarse view to the fine view: row i (fine vertex) holds the values of the coarse basis
/// functions at that vertex, so P u_H = I_h u_H, the fine interpolant of the coarse function. A
/// fine vertex that is also a coarse vertex gets the identity row. Every other fine vertex was
/// created by refining some element E at a known local point (Grid::vertexOrigin):
///  - if E is in the coarse view (always so between consecutive level views), the row holds E's
///    shape functions at that point's reference coordinates (LocalPoints::weights): exact;
///  - otherwise the vertex position (the local point of E, before any boundary projection) is
///    located in a coarse ancestor of E or, going down, among the descendants of E in the coarse
///    view, e.g. green elements that the fine view replaced (leaf views before and after an
///    adapt()); its reference coordinates there come from Newton's method on that cell's geometry
///    map (referenceCoordinates()) and the row holds that cell's shape functions there.
/// So P reproduces every function of the coarse space exactly where the spaces are nested and
/// interpolates it otherwise; linear functions are always reproduced exactly.
///
/// Typical uses:
///   CsrMatrix P = prolongation(grid, l);                   // level l -> level l + 1 (multigrid)
///   GridView before = grid.leafView(); ... grid.adapt();
///   CsrMatrix T = transferMatrix(grid, before, grid.leafView());  // solution transfer
#include <optional>
#include <span>
#include <vector>

#include "obs/mesh/Grid.hpp"

namespace obs::mesh {

/// A sparse matrix in compressed row storage (columns ascending within a row).
struct CsrMatrix {
  Index rows = 0, cols = 0;
  std::vector<Index> rowStart{0};  ///< row r: entries [rowStart[r], rowStart[r+1])
  std::vector<Index> columns;
  std::vector<double> values;

  Index nonZeros() const { return static_cast<Index>(columns.size()); }
  /// y = A x (sizes cols and rows).
  void multiply(std::span<const double> x, std::span<double> y) const;
  std::vector<double> operator*(std::span<const double> x) const;
  /// x = A^T y, the restriction for a prolongation A (sizes rows and cols).
  void multiplyTransposed(std::span<const double> y, std::span<double> x) const;
};

/// Interpolation from the coarse view to the fine view (see the file comment). Throws obs::Error if
/// a fine vertex cannot be located in the coarse view (views of different grids or not nested).
CsrMatrix transferMatrix(const Grid& grid, const GridView& coarse, const GridView& fine);

/// The prolongation P_l from levelView(l) to levelView(l + 1), 0 <= l < maxLevel().
CsrMatrix prolongation(const Grid& grid, int coarseLevel);

/// Reference coordinates xi of the point x in the cell with the given corners (the inverse of the
/// first-order geometry map sum_i phi_i(xi) corners[i]), by Newton's method from the reference
/// centroid; nullopt if it does not converge to |step| < tol (or to round-off: a step below 1e-8
/// that no longer halves, as on very small cells) within maxIterations. For 2D cells
/// only the x and y components are used. One step suffices for affine cells.
std::optional<Point> referenceCoordinates(CellType type, std::span<const Point> corners,
                                          const Point& x, double tol = 1e-13,
                                          int maxIterations = 30);

/// Whether reference coordinates xi lie in the reference element of the type, up to tol.
bool insideReferenceElement(CellType type, const Point& xi, double tol = 1e-10);

}  // namespace obs::mesh
