#pragma once
/// \file MassRedistribution.hpp
/// Mass redistribution (Khenous, Laborde, Renard 2006/2008; thesis Sec. 5.2.4,
/// docs/theory.md#mass-redistribution): a mass matrix M~ without mass at the potential contact vertices C,
///   M~_ij = 0 if i in C or j in C,   M~_ij = 0 where M_ij = 0 (pattern of M kept),
/// with the total mass, the centre of gravity and the moment of inertia of M,
///   sum_ij M~_ij = sum_ij M_ij                                   (total mass),
///   sum_ij M~_ij x_j,a = sum_ij M_ij x_j,a              for each a  (first moments),
///   sum_ij M~_ij x_i,a x_j,b = sum_ij M_ij x_i,a x_j,b  for a <= b  (second moments),
/// 1 + d + d(d+1)/2 constraints (6 in 2D, 10 in 3D; MassRedistributionOptions::moments = 1 drops the
/// second moments: 1 + d), and closest to M among such matrices in the
/// weighted Frobenius norm sum_K (M~_ij - M_ij)^2 / |M_ij| (constrained least squares). For the consistent M the right-hand sides are the
/// integrals of rho, rho x_a and rho x_a x_b over the body (the coordinates are finite element
/// functions), so M~ has the body's mass, centre of gravity and second-moment tensor, and with it
/// its inertia tensor J = tr(I) Id - I, I_ab = int rho x_a x_b (about any point).
///
/// Solution: with the kept entries K = {(i, j) in pattern, i, j not in C}, M0 = M restricted to K and
/// the constraint weights on K, in the coordinates y = (x - xbar)/L of the kept vertices (centre xbar,
/// radius L; an equivalent, better conditioned set of constraints),
///   W^0_ij = 1,  W^a_ij = (y_i,a + y_j,a)/2,  W^ab_ij = (y_i,a y_j,b + y_j,a y_i,b)/2,
/// the minimiser is
///   M~_ij = M_ij + |M_ij| sum_k lambda_k W^k_ij  on K   (symmetric, pattern of M),
/// i.e. every kept (non-negative) entry is rescaled by a quadratic polynomial of the pair's coordinates, like a
/// density modulation. The weight 1/|M_ij| makes the correction relative: with the plain Frobenius
/// norm the correction sum_k lambda_k W^k is the same for small and large entries, and with the second
/// moments kept it made M~ indefinite up to 4 cells across (4^2 quadrilaterals, 4^3 hexahedra, prisms,
/// tetrahedra; docs/dynamics.md). The Lagrange multipliers lambda are computed by an Uzawa iteration
/// lambda <- lambda + G^{-1} (c - C(M~(lambda))), preconditioned with the Gram matrix
/// G_kl = sum_K |M_ij| W^k W^l (as the thesis, Sec. 5.2.6, we use Uzawa; with this preconditioner it converges
/// in one or two sweeps, the extra sweeps only remove round-off). G is singular if the kept entries
/// cannot carry the constraints (e.g. every vertex that keeps mass on one line): obs::Error.
///
/// Lower bound. The problem is solved with the bounds M~_ij >= theta M_ij (MassRedistributionOptions::
/// minimumScale, default 0.1): mass may be moved but no entry may lose more than 1 - theta of itself, so
/// every diagonal entry stays positive. The minimiser is M~_ij = M_ij max(theta, 1 + sum_k lambda_k W^k_ij)
/// and lambda maximises the concave, piecewise quadratic dual
///   g(lambda) = sum_K [ (M~_ij - M_ij)^2 / (2 M_ij) - M~_ij sum_k lambda_k W^k_ij ] + lambda'c,
/// grad g = c - C(M~(lambda)). The iteration above is Newton's method on g (G = its negative Hessian);
/// with entries at the bound it uses the Gram matrix G_A of the entries above the bound (a semismooth
/// Newton step) and halves the step until g increases (Armijo). Without entries at the bound g is
/// quadratic, the first step is exact and nothing changes against the unbounded minimiser. Example:
/// the ball of dynamics_ball.toml with its whole sphere massless, refine 2: without the bound some
/// diagonal entries are negative; with it 5,519 of the 70,177 entries of M sit at the bound and M~ is positive
/// definite (tests/obs/test_mass.cpp). The bound can make the constraints infeasible: with three cell
/// layers behind a flat contact face the second moment in the normal direction needs a massless middle
/// layer (docs/dynamics.md); the iteration then does not converge and the error says so.
///
/// M~ is symmetric; it is positive semidefinite on the remaining vertices when the removed mass is
/// small against the smallest eigenvalue of M (a boundary layer of a mesh with several cells across).
/// On coarse meshes it can be indefinite (3^3 tetrahedral unit cube with the bottom removed);
/// checkPositiveDefinite() decides this with one sparse factorisation (any size), smallestEigenvalue()
/// computes the eigenvalue densely (small problems, tests).
#include <Eigen/Core>

#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/MassMatrix.hpp"

namespace obs {

struct MassRedistributionOptions {
  /// Relative constraint residual |c - C(M~)| / (total mass) to reach (constraints in the coordinates
  /// y = (x - xbar)/L of the file comment); the iteration also stops at the round-off floor (a residual <= 1e-11 that a sweep no longer halves).
  double tolerance = 1e-14;
  int maxIterations = 50;
  /// Lower bound theta on the rescaling: every kept entry satisfies M~_ij >= theta M_ij (theta < 1;
  /// -infinity: no bound, the minimiser of the file comment without the bound, which can be negative).
  /// The unconstrained minimiser rescales by 1 + q with a quadratic polynomial q; when much mass must move
  /// outwards (a ball whose whole surface is massless) 1 + q drops below 0 near the centre and M~ gets a
  /// negative diagonal entry. With the bound the minimiser is M~_ij = M_ij max(theta, 1 + q_ij) (see the
  /// file comment); where 1 + q >= theta everywhere it is the unconstrained one, bit for bit.
  double minimumScale = 0.1;
  /// Which moments of M the redistributed matrix keeps: 2 (default) the total mass, the first and the
  /// second moments (mass, centre of gravity, inertia tensor: 1 + d + d(d+1)/2 constraints); 1 only the
  /// total mass and the first moments (1 + d constraints), the variant of the thesis' experiments
  /// (Sec. 5.2.6: "the whole mass of the system and the center of gravity are conserved"); 0 none:
  /// M~ is M with the rows and columns of the massless vertices zeroed and the removed mass is lost
  /// (the thesis' control run of Fig. 5.3(b), which separates the effect of the zeroed rows from that
  /// of the redistribution). Other values: obs::Error.
  int moments = 2;
};

struct RedistributedMass {
  ScalarSparseMatrix matrix;        ///< M~ (pattern of M, zero rows/columns at the massless vertices)
  std::vector<char> massless;       ///< per vertex: in C
  Eigen::VectorXd multipliers;      ///< lambda (1 + d [+ d(d+1)/2], order of the file comment)
  int iterations = 0;               ///< Uzawa (semismooth Newton) sweeps
  double minimumFactor = 1;         ///< smallest M~_ij / M_ij over the kept entries (>= minimumScale)
  Eigen::Index boundedEntries = 0;  ///< kept entries at the bound M~_ij = minimumScale M_ij
  double residual = 0;              ///< final relative constraint residual
  double movedMass = 0;             ///< sum of the removed entries of M (the mass taken off C)
};

/// Redistributes M away from the vertices with massless[v] != 0 (see the file comment).
/// `vertices` are the mesh vertex positions, `dimension` 2 or 3. Throws obs::Error on inconsistent
/// sizes, if every vertex is massless, no kept entry exists or the kept entries cannot carry the
/// constraints (singular Gram matrix), or if the Uzawa iteration does not reach the tolerance.
///
/// Distributed (docs/architecture.md#distributed-dynamics): with `comm`, M is a rank's matrix on its
/// local vertices whose first `owned` rows are complete (owned vertices first, as a DistributedView's
/// local mesh; the other rows may be partial). The multipliers are global: the centre and radius of
/// the kept vertices, the targets, the Gram matrices and the dual are sums (maxima) over the owned
/// rows and the ranks, so every rank takes the same iterations and rescales its entries with the
/// same lambda; the counts and moved mass of the result are global too. A collective call: every
/// rank throws the same obs::Error. Without `comm` (owned < 0) every row is owned.
RedistributedMass redistributeMass(const ScalarSparseMatrix& M, const std::vector<mesh::Point>& vertices,
                                   int dimension, const std::vector<char>& massless,
                                   const MassRedistributionOptions& options = {}, Index owned = -1,
                                   const Communicator* comm = nullptr);

/// Result of checkPositiveDefinite.
struct DefinitenessCheck {
  bool positiveDefinite = false;
  /// false: not computed (distributed time stepping, which has no rank with the whole matrix);
  /// positiveDefinite is then assumed, not known.
  bool checked = true;
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
