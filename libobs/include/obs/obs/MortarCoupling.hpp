#pragma once
/// \file MortarCoupling.hpp
/// Dual-mortar coupling of two elastic bodies whose meshes do not match at the contact interface
/// (Wohlmuth 2000; Wohlmuth and Krause 2003; thesis Sec. 1.2.1 and 2.1; docs/theory.md#dual-mortar).
///
/// The bodies' unknowns are stacked: vertex v of the slave mesh is unknown `slaveOffset + v`, vertex
/// v of the master mesh `masterOffset + v`. The slave surface S is the set of boundary faces of the
/// slave mesh with id `slaveId`, the master surface M those of the master mesh with `masterId`.
///
/// Discretisation, per slave face e (segment in 2D, triangle or quadrilateral in 3D):
///  - dual basis psi_i = sum_j (A_e)_ij phi_j with A_e = D_e M_e^{-1}, M_e the face mass matrix and
///    D_e = diag(row sums of M_e), so int_e psi_i phi_j = delta_ij int_e phi_j (biorthogonality);
///  - every master face facing e whose bounding box overlaps e's (enlarged by the search distance) is
///    projected along the slave face normal n_e onto e's plane, clipped against e (interval
///    intersection in 2D, Sutherland-Hodgman for convex polygons in 3D), the clipped polygon is
///    split into triangles from its centroid and integrated with a Gauss rule: degree 6 (exact) where
///    both faces are affine, a higher degree chosen by how far a quadrilateral is from a
///    parallelogram otherwise (docs/theory.md#mortar-matrices);
///  - at each quadrature point the slave and master local coordinates are those of the projected
///    faces (exact for flat faces; Newton's method on bilinear quadrilaterals) and
///      M_pq += w psi_p phi^M_q,   gap_p += w psi_p n_p.(x^M - x^S),
///    with n_p the slave nodal normal (face normals averaged with their measures).
/// A weighted gap within the rounding of the coordinates it is computed from (16 eps X D_pp, X the
/// largest coordinate of the surfaces) is set to zero: surfaces that touch touch exactly.
/// D_pp is the row sum of M (= int psi_p over the covered part of the slave surface, which is
/// int_S phi_p wherever the support of phi_p is covered by master faces), so rigid translations of
/// both bodies leave every constraint unchanged. Slave nodes whose support is covered less than
/// `minCoverage` (D_pp / int_S phi_p) get no constraint (they are reported in Statistics).
///
/// Constraint at slave node p (non-penetration in the weak, dual-mortar sense):
///   n_p.(D_pp u_p - sum_q M_pq u_q) <= gap_p.
/// Basis transformation: with C = D^{-1} M (rows of the constrained slave nodes, columns of master
/// vertices; C^2 = 0) and u = (I + C) w, the constraint becomes the nodal bound
///   n_p.w_p <= gap_p / D_pp,
/// so the stacked problem is again a bound-constrained minimisation in w (ContactProblem with a
/// BasisTransformation) and TNNMG, projected Gauss-Seidel and the primal-dual active set method
/// apply unchanged. The multiplier of the bound is D_pp lambda_p, lambda_p the dual-mortar contact
/// pressure at p; the slave node p receives the force -D_pp lambda_p n_p and the master vertex q
/// sum_p lambda_p M_pq n_p, so action equals reaction.
#include <Eigen/Core>

#include <algorithm>
#include <string>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/ContactSet.hpp"

namespace obs {

struct MortarOptions {
  /// Master faces farther than this from a slave face (bounding boxes) are not paired with it, so
  /// slave nodes farther than this from the master surface stay unconstrained: it must exceed the
  /// largest expected approach of the surfaces. <= 0: a tenth of the diagonal of the slave
  /// surface's bounding box, at least the largest slave face diameter (independent of refinement).
  double searchDistance = -1;
  /// Minimum coverage D_pp / int_S phi_p of a constrained slave node (see the file comment).
  double minCoverage = 0.5;
  /// X of the gap rounding (the largest coordinate of either surface, see the file comment). <= 0:
  /// from the surfaces given. A coupling of parts of the surfaces (one rank's, DistributedMortar)
  /// passes the value of the whole surfaces, so that every part rounds as one process would.
  double coordinateScale = -1;
  /// false: a coupling that constrains no slave node is not an error (a part of the surfaces, whose
  /// whole the caller checks).
  bool requireCoverage = true;
};

/// The default search distance (MortarOptions::searchDistance <= 0): a tenth of the diagonal of the
/// slave surface's bounding box, at least its largest face diameter (the diagonal of a face's
/// bounding box).
inline double defaultMortarSearchDistance(double slaveExtentDiagonal, double largestSlaveFace) {
  return std::max(largestSlaveFace, 0.1 * slaveExtentDiagonal);
}

/// One side of a mortar pair: a boundary of one body's mesh and the offset of that body's vertices
/// in the stacked numbering.
struct MortarSurface {
  const mesh::Mesh* mesh = nullptr;
  int boundaryId = 0;
  Index vertexOffset = 0;
  std::string label;  ///< for messages, e.g. "body 'upper', boundary 'bottom'"
};

class MortarCoupling {
public:
  /// Entry M_pq of one slave row (q a stacked master vertex).
  struct Entry {
    Index vertex;
    double value;
  };
  struct Statistics {
    Index slaveFaces = 0, masterFaces = 0;
    Index candidatePairs = 0;     ///< slave/master face pairs whose boxes overlap
    Index segments = 0;           ///< pairs with a non-empty intersection (mortar segments/polygons)
    Index quadraturePoints = 0;
    Index uncoveredNodes = 0;     ///< slave nodes below minCoverage (no constraint)
    double seconds = 0;
  };

  /// Builds D, M and the weighted gaps. `numStackedVertices` is the size of the stacked numbering.
  /// Throws obs::Error if a surface is empty, the dimensions differ, slave and master are the same
  /// boundary of the same mesh, a face is degenerate, a coordinate is not finite, or no slave node
  /// is covered by the master surface (the surfaces do not overlap: the message gives their
  /// distance).
  MortarCoupling(const MortarSurface& slave, const MortarSurface& master, Index numStackedVertices,
                 const MortarOptions& options = {});

  int dimension() const { return dim_; }
  /// Constrained slave nodes (stacked vertex numbers, increasing).
  Index size() const { return static_cast<Index>(nodes_.size()); }
  Index vertex(Index k) const { return nodes_[k]; }
  const Point& normal(Index k) const { return normals_[k]; }
  double D(Index k) const { return D_[k]; }
  /// int_S phi_p over the whole slave surface (D(k) divided by it is the coverage).
  double slaveMass(Index k) const { return mass_[k]; }
  double weightedGap(Index k) const { return gap_[k]; }
  const std::vector<Entry>& row(Index k) const { return M_[k]; }
  const Statistics& statistics() const { return stats_; }

  /// The constraints as a ContactSet over the stacked vertices: direction n_p, gap gap_p / D_pp,
  /// boundary mass D_pp (so pressure = multiplier / D_pp = lambda_p), the slave faces.
  ContactSet contactSet() const;
  /// C = D^{-1} M as a stacked n x n scalar matrix (rows of constrained slave nodes).
  mesh::CsrMatrix transformation() const;

  /// Nodal forces on the master body from the multipliers mu_k (= D_pp lambda_p) of the bound
  /// constraints: f_q = sum_p (mu_p / D_pp) M_pq n_p (along the slave normals, away from the slave),
  /// stacked (numStackedVertices * d entries). The slave body receives -mu_p n_p at its node p, so
  /// the totals are equal and opposite (sum_q M_pq = D_pp).
  Eigen::VectorXd masterForces(const Eigen::VectorXd& multipliers) const;
  /// The same for a force vector per slave node (F_p = mu_p n_p plus, with friction, the tangential
  /// force ContactOutputs::tangential): f_q = sum_p (M_pq / D_pp) F_p.
  Eigen::VectorXd masterForces(const std::vector<Point>& forces) const;

private:
  int dim_ = 0;
  Index numStacked_ = 0;
  std::string label_;
  std::vector<Index> nodes_;
  std::vector<Point> normals_, positions_;
  std::vector<double> D_, mass_, gap_;
  std::vector<std::vector<Entry>> M_;
  std::vector<ContactSet::Face> faces_;
  Statistics stats_;
};

}  // namespace obs
