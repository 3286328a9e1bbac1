#pragma once
/// \file MassRedistribution.hpp
/// Mass redistribution (Khenous, Laborde, Renard 2006/2008; thesis Sec. 5.2.4,
/// docs/theory.md#mass-redistribution): a mass matrix M~ without mass at the potential contact vertices C,
///   M~_ij = 0 if i in C or j in C,   M~_ij = 0 where M_ij = 0 (pattern of M kept),
/// with the total mass and the centre of gravity of M,
///   sum_ij M~_ij = sum_ij M_ij,   sum_ij M~_ij (x_i + x_j)/2 = sum_ij M_ij (x_i + x_j)/2  (each coordinate),
/// and closest to M in the Frobenius norm among such matrices (constrained least squares).
///
/// Solution: with the kept entries K = {(i, j) in pattern, i, j not in C}, M0 = M restricted to K and
/// the constraint weights W^0_ij = 1, W^c_ij = (x_i,c + x_j,c)/2 - xbar_c on K (centred coordinates,
/// an equivalent set of constraints that is better conditioned), the minimiser is
///   M~ = M0 + sum_k lambda_k W^k     (symmetric, on K),
/// with Lagrange multipliers lambda solving the (d+1) x (d+1) constraints. They are computed by an
/// Uzawa iteration lambda <- lambda + G^{-1} (c - C(M~(lambda))), preconditioned with the Gram matrix
/// G_kl = sum_K W^k W^l (as the thesis, Sec. 5.2.6, we use Uzawa; with this preconditioner it converges
/// in one or two sweeps, the extra sweeps only remove round-off). The moment of inertia is not kept.
///
/// M~ is symmetric; it is positive semidefinite on the remaining vertices when the removed mass is
/// small against the smallest eigenvalue of M (a boundary layer of a mesh with several cells across).
/// On coarse meshes it can be indefinite (4^3 tetrahedral unit cube with the bottom removed: smallest
/// eigenvalue -7.7e-5); checkPositiveDefinite() decides this with one sparse factorisation (any size),
/// smallestEigenvalue() computes the eigenvalue densely (small problems, tests).
#include <Eigen/Core>

#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/MassMatrix.hpp"

namespace obs {

struct MassRedistributionOptions {
  /// Relative constraint residual |c - C(M~)| / (total mass * max(1, diam)) to reach; the iteration
  /// also stops at the round-off floor (a residual <= 1e-11 that a sweep no longer halves).
  double tolerance = 1e-14;
  int maxIterations = 50;
};

struct RedistributedMass {
  ScalarSparseMatrix matrix;        ///< M~ (pattern of M, zero rows/columns at the massless vertices)
  std::vector<char> massless;       ///< per vertex: in C
  Eigen::VectorXd multipliers;      ///< lambda (d + 1)
  int iterations = 0;               ///< Uzawa sweeps
  double residual = 0;              ///< final relative constraint residual
  double movedMass = 0;             ///< sum of the removed entries of M (the mass taken off C)
};

/// Redistributes M away from the vertices with massless[v] != 0 (see the file comment).
/// `vertices` are the mesh vertex positions, `dimension` 2 or 3. Throws obs::Error on inconsistent
/// sizes, if every vertex is massless or no kept entry exists, or if the Uzawa iteration does not
/// reach the tolerance.
RedistributedMass redistributeMass(const ScalarSparseMatrix& M, const std::vector<mesh::Point>& vertices,
                                   int dimension, const std::vector<char>& massless,
                                   const MassRedistributionOptions& options = {});

/// Result of checkPositiveDefinite.
struct DefinitenessCheck {
  bool positiveDefinite = false;
  Eigen::Index size = 0;               ///< rows of the restricted matrix
  Eigen::Index nonPositivePivots = 0;  ///< = number of eigenvalues <= 0 (up to the pivot tolerance)
};

/// Positive definiteness of M restricted to the vertices with mask[v] == 0, by a sparse LDL'
/// factorisation (fill-reducing AMD ordering, no pivoting). By Sylvester's law of inertia the
/// number of negative pivots D_kk equals the number of negative eigenvalues; a pivot
/// D_kk <= 1e-12 max_i |M_ii| counts as non-positive, and so does a breakdown (zero pivot: the
/// remaining pivots are then not known, nonPositivePivots >= 1). Cost: one scalar sparse
/// factorisation (one row per vertex, not per unknown). Throws obs::Error on a size mismatch or if
/// every row is masked.
DefinitenessCheck checkPositiveDefinite(const ScalarSparseMatrix& M, const std::vector<char>& mask);

/// Smallest eigenvalue of M restricted to the vertices with mask[v] == 0 (dense; small problems only:
/// throws obs::Error above 4000 vertices).
double smallestEigenvalue(const ScalarSparseMatrix& M, const std::vector<char>& mask);

}  // namespace obs
