#pragma once
/// \file ContactProblem.hpp
/// The algebraic Signorini problem (docs/theory.md#signorini, thesis Problem 2.1.1):
///   minimise J(u) = 1/2 u'Au - b'u   subject to   nu_p' u_p <= g_p  at the potential contact nodes p,
/// with A, b the stiffness matrix and load after the symmetric elimination of the Dirichlet values
/// (applyDirichlet: prescribed rows/columns are identity rows with b = u_D, so J is minimised at u_D
/// there; J differs from the physical energy by a constant for u with the prescribed values).
///
/// Dirichlet components at contact nodes. The constraint is restricted to the free components F of
/// the node: with nu_F (nu with the prescribed components zeroed) and the prescribed part
/// s = sum_{c prescribed} nu_c u_D,c,
///   nu'u <= g   <=>   (nu_F/|nu_F|)'u <= (g - s)/|nu_F|           (exact for u with u_D prescribed),
/// the *effective* constraint stored in Constraint; its rotation keeps prescribed axes as columns, so
/// the rotated matrix keeps identity rows there. If nu_F = 0 the constraint is decided by the data
/// alone: s > g throws obs::Error before solving, otherwise the node is unconstrained (gap +inf).
/// Without prescribed components nothing changes: the effective constraint is (nu_p, g_p, Q_p).
///
/// Rotated form (docs/theory.md#rotations): with w_p = Q_p' u_p (Q_p = I at vertices without a constraint)
///   A~_pq = Q_p' A_pq Q_q,  b~_p = Q_p' b_p,  bounds w_{p,1} <= g_p (first local component),
/// a bound-constrained quadratic problem: the form the Gauss-Seidel smoother, the primal-dual active
/// set method and TNNMG work on.
///
/// Basis transformation (two-body contact, see MortarCoupling.hpp). A problem may be given a sparse
/// scalar matrix C with C^2 = 0 (rows: the constrained slave vertices; columns: master vertices) that
/// relates its unknowns x to the stacked displacements u of the bodies by
///   u = (I + C) x,   x = (I - C) u   (C acts on every component alike, see below for one exception).
/// The stiffness and load given to the constructor are those of u; the problem stores
/// A = T'A_u T and b = T'b_u (T = I + C) and eliminates the Dirichlet values afterwards. A transformed
/// (slave) vertex may have Dirichlet components only (nearly) orthogonal to its constraint direction
/// (rollers, as for one body; normal components up to 0.1 for a symmetry line through a curved slave
/// surface, whose constraint then acts along the projected normal; others throw obs::Error,
/// docs/theory.md#mortar-transformation): the transformation leaves those components alone
/// (basisSkip()), so their values are values of x as well. Every
/// member function, and every solver, works with the problem unknowns x; toDisplacement() and
/// fromDisplacement() convert. Without a transformation (one body against obstacles) x = u.
///
/// Tresca friction (docs/theory.md#friction). setFriction() adds to J the convex, nonsmooth term
///   sum_k s_k |(x_p - o_p)_T|      (p the vertex of contact node k)
/// with slip bounds s_k >= 0 (nodal forces) and an origin o (the displacement of the previous load
/// increment or time step; zero by default). (.)_T are the tangential components of the rotated
/// frame (local components 2..d) that are not prescribed. For a mortar pair x_p of a slave vertex is
/// the relative displacement of the two surfaces, so the term acts on the relative slip. Coulomb
/// friction is a fixed point over such problems (Friction.hpp). Without slip bounds (or with all of
/// them zero) nothing changes: every solver runs its frictionless code.
#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Material.hpp"

namespace obs {

/// min 1/2 w'Aw - b'w + sum_p slip_p |(w_p - o_p)_T| subject to w[p*d] <= upper[p] (upper = +inf: no
/// bound): the rotated problem. (.)_T: the components 2..d of a vertex that are not prescribed; the
/// friction term only with Tresca friction (ContactProblem::setFriction).
template <int d>
struct RotatedProblem {
  using Vec = Eigen::Matrix<double, d, 1>;
  /// A~ = Q'AQ (block-wise), shared with the ContactProblem it came from (which keeps only this form)
  std::shared_ptr<const BlockSparseMatrix<d>> matrixPtr;
  Eigen::VectorXd rhs;           ///< b~ = Q'b
  std::vector<double> upper;     ///< bound of the first local component per vertex
  std::vector<char> prescribed;  ///< Dirichlet components in rotated numbering (identity rows of A~)
  /// ContactProblem::diagonalLowerBound() (empty: none); rotation-invariant, so it bounds A~ too
  std::vector<double> diagonalLowerBound;
  /// Tresca friction: the vertices with a positive slip bound and a free tangential component,
  /// slip[f] the bound of frictionVertices[f], and the origin o (rotated, size numDofs(); empty:
  /// zero). frictionVertices empty: frictionless.
  std::vector<Index> frictionVertices;
  std::vector<double> slip;
  Eigen::VectorXd origin;

  const BlockSparseMatrix<d>& matrix() const { return *matrixPtr; }
  Index numVertices() const { return matrix().rows(); }
  bool bounded(Index p) const { return upper[p] < std::numeric_limits<double>::infinity(); }
  bool frictional() const { return !frictionVertices.empty(); }
  /// (w_p - o_p)_T of friction vertex number f (frictionVertices[f]): normal and prescribed
  /// components zero.
  Vec slipOf(std::size_t f, const Eigen::VectorXd& w) const {
    const Index p = frictionVertices[f];
    const auto i = static_cast<Eigen::Index>(p) * d;
    Vec t = w.template segment<d>(i);
    if (origin.size() > 0) t -= origin.template segment<d>(i);
    t[0] = 0;
    for (int a = 1; a < d; ++a)
      if (prescribed[static_cast<std::size_t>(i + a)]) t[a] = 0;
    return t;
  }
  /// sum_p slip_p |(w_p - o_p)_T| (0 without friction).
  double frictionEnergy(const Eigen::VectorXd& w) const {
    double e = 0;
    for (std::size_t f = 0; f < frictionVertices.size(); ++f) e += slip[f] * slipOf(f, w).norm();
    return e;
  }
  double energy(const Eigen::VectorXd& w) const {
    return 0.5 * matrix().energy(w) - rhs.dot(w) + frictionEnergy(w);
  }
  /// True if diagonalLowerBound is given and positive at every vertex with a free component, and
  /// there is no friction (the bound is derived for the bound-constrained quadratic problem).
  bool hasErrorBound() const;
  /// The a posteriori bound sqrt(2 sum_i componentGain(r_i, m_p, room_i)) >= ||w - w*||_A~ of an
  /// admissible w (docs/theory.md#tnnmg-error-bound), from Aw = A~ w: r = rhs - Aw over the free
  /// components, room_i = upper[p] - w_i for the bounded first components, +inf otherwise. NaN
  /// without hasErrorBound(). (TNNMG evaluates the same sum inside its fused vector pass.)
  double errorBound(const Eigen::VectorXd& w, const Eigen::VectorXd& Aw) const;
  /// Clamps w[p*d] to upper[p] (the componentwise projection onto the admissible set).
  void project(Eigen::VectorXd& w) const;
  /// Number of vertices with w[p*d] >= upper[p] (exactly at the bound, as the solvers set it).
  Index countActive(const Eigen::VectorXd& w) const;
};

/// max over t <= room of r t - m t^2 / 2 (m > 0, room >= 0, +inf: unbounded): the largest decrease of
/// J(w + t e_i) - J(w) that the lower bound m of the curvature allows (docs/theory.md#tnnmg-error-bound).
inline double componentGain(double r, double m, double room) {
  return r <= m * room ? 0.5 * r * r / m : room * (r - 0.5 * m * room);
}

template <int d>
class ContactProblem {
public:
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;

  /// The effective constraint direction' u_vertex <= gap at one contact node (see file comment).
  struct Constraint {
    Index vertex = -1;
    Vec direction;   ///< unit, in the free subspace of the vertex
    double gap = 0;  ///< +inf: unconstrained
    double scale = 1;  ///< |nu_F|; the multiplier of nu_p'u <= g_p is (effective multiplier) / scale
    Mat rotation;    ///< orthogonal, rotation e_1 = direction (identity if unconstrained)
    double shift = 0;  ///< s = sum of nu_c u_D,c over prescribed components c (gap = (g_p - s) / scale)
    bool bounded() const { return gap < std::numeric_limits<double>::infinity(); }
  };

  /// Assembles A and b on the mesh (assembleStiffness, assembleLoad), eliminates the Dirichlet values
  /// of bc and builds the constraints of `contact`. Throws obs::Error on invalid material, dimension
  /// mismatches, or Dirichlet values that violate a contact constraint.
  ContactProblem(const mesh::Mesh& mesh, const Material& material, const BoundaryConditions& bc,
                 const ContactSet& contact);
  /// From an assembled stiffness matrix and load (Dirichlet values not yet eliminated).
  ContactProblem(BlockSparseMatrix<d> stiffness, Eigen::VectorXd load, DirichletValues dirichlet,
                 const ContactSet& contact);
  /// With a basis transformation C (see the file comment; C.rows == 0: none). Throws obs::Error if
  /// C has the wrong size, C^2 != 0, or a transformed vertex has a Dirichlet component with a normal
  /// component above 0.1.
  ContactProblem(BlockSparseMatrix<d> stiffness, Eigen::VectorXd load, DirichletValues dirichlet,
                 const ContactSet& contact, mesh::CsrMatrix basis);
  /// Marks the stiffness and load of the constructor below as already transformed.
  struct Transformed {};
  /// The same with T'AT and T'b given instead of A and b (e.g. summed over the ranks of a
  /// distributed run, DistributedMultiBody.hpp): C is checked and basisSkip() computed as above, and
  /// the given operator and load must have been transformed with these skips (the Dirichlet
  /// components of the vertices with a row of C).
  ContactProblem(BlockSparseMatrix<d> stiffness, Eigen::VectorXd load, DirichletValues dirichlet,
                 const ContactSet& contact, mesh::CsrMatrix basis, Transformed);

  /// The pattern of T'AT (T = I + C) for a matrix A of `pattern`: the rows next to transformed
  /// (slave) vertices and the rows of master vertices gain columns. A stiffness matrix assembled on
  /// this pattern (zero blocks where A has none; assembleStackedStiffness' `widen`) is transformed
  /// in place by the constructor, so the operator is never stored twice. Any other pattern works
  /// too, at the cost of one copy of the operator. C.rows == 0: the pattern itself.
  static typename BlockSparseMatrix<d>::Pattern transformedPattern(typename BlockSparseMatrix<d>::Pattern pattern,
                                                                   const mesh::CsrMatrix& C);

  /// The basis transformation C (rows() == 0 if there is none).
  const mesh::CsrMatrix& basisTransformation() const { return basis_; }
  bool transformed() const { return basis_.rows > 0; }
  /// u = (I + C) x: the stacked displacements of problem unknowns x.
  Eigen::VectorXd toDisplacement(const Eigen::VectorXd& x) const;
  /// x = (I - C) u: the problem unknowns of displacements u (e.g. a warm start).
  Eigen::VectorXd fromDisplacement(const Eigen::VectorXd& u) const;
  /// f = (I - C)' y: forces on the displacements u of forces y on the problem unknowns x (the
  /// multipliers of the bounds, for one).
  Eigen::VectorXd applyInverseTransposedBasis(const Eigen::VectorXd& y) const;
  /// Per vertex, the components (bit a: component a) the transformation leaves alone: Dirichlet
  /// components of slave vertices (see the file comment). Empty if there are none.
  const std::vector<std::uint8_t>& basisSkip() const { return skip_; }

  Index numVertices() const { return A_->rows(); }
  Index numDofs() const { return A_->rows() * d; }
  /// The operator in rotated form, A~ = Q'AQ (see the file comment): the only copy of the stiffness
  /// the problem keeps (products with A itself: multiply()).
  const BlockSparseMatrix<d>& rotatedMatrix() const { return *A_; }
  /// Au = A u = Q A~ Q'u (problem unknowns, after the Dirichlet elimination).
  void multiply(const Eigen::VectorXd& u, Eigen::VectorXd& Au) const;
  const Eigen::VectorXd& rhs() const { return b_; }
  const DirichletValues& dirichlet() const { return dirichlet_; }
  const ContactSet& contactSet() const { return contact_; }
  /// Constraint of contact node k (ContactSet numbering).
  const Constraint& constraint(Index k) const { return constraints_[k]; }
  const std::vector<Constraint>& constraints() const { return constraints_; }

  double energy(const Eigen::VectorXd& u) const;
  /// Gradient A u - b of J.
  Eigen::VectorXd gradient(const Eigen::VectorXd& u) const;
  /// Energy norm ||x||_A = sqrt(x'Ax).
  double energyNorm(const Eigen::VectorXd& x) const;
  /// Largest constraint violation max_p (nu_p'u_p - g_p)^+ (effective constraints).
  double maxViolation(const Eigen::VectorXd& u) const;
  /// An admissible start: sets the Dirichlet components to their values and moves every node that
  /// violates its constraint back onto it along the constraint direction, u_p -= (nu'u_p - g)^+ nu.
  /// (Resizes a vector of the wrong size to zero first.)
  void projectToFeasible(Eigen::VectorXd& u) const;
  /// Nodal contact forces (effective multipliers) mu_k = (b - A u)_p . nu_p (0 if unconstrained).
  Eigen::VectorXd multipliers(const Eigen::VectorXd& u) const;

  // --- changing the data of a fixed operator (time stepping: one matrix, many right-hand sides) ---
  /// Identifies the rotated operator A~ = Q'AQ and its prescribed components: a new id for every
  /// constructed problem, kept by copies and by setLoad()/setGaps() (which change neither A nor
  /// the rotations). Solvers may keep operator data (e.g. multigrid hierarchies) for one id.
  std::uint64_t operatorId() const { return operatorId_; }
  /// Replaces the load b by `load` (before Dirichlet elimination and transformation, like the
  /// constructor's load; the Dirichlet values of construction are eliminated again). Throws
  /// obs::Error on a wrong size.
  void setLoad(const Eigen::VectorXd& load);
  /// The same with T'b given instead of b (the transformed constructor's load; e.g. summed over
  /// the ranks, DistributedMultiBody::transposedProduct): only the Dirichlet elimination is applied.
  void setLoad(const Eigen::VectorXd& load, Transformed);
  /// Replaces the gaps g_p of the physical constraints nu_p'u_p <= g_p (ContactSet numbering;
  /// +infinity: no constraint at that node). Directions and rotations stay those of construction,
  /// so operatorId() is unchanged. Throws obs::Error on a wrong size, a NaN or -infinity gap, a
  /// finite gap at a node that had no constraint at construction (no rotation), or Dirichlet
  /// values that violate a new gap (as the constructor).
  void setGaps(const std::vector<double>& gaps);

  // --- a posteriori error bound (docs/theory.md#tnnmg-error-bound) ---
  /// Declares m_p >= 0 per vertex with A - diag(m_p I) positive semidefinite for the stiffness given
  /// to the constructor (e.g. the lumped masses of a time step's matrix M + c tau^2 A; after the
  /// Dirichlet elimination it holds on the free components, the only ones the bound uses). Solvers
  /// may then bound the energy-norm error of an admissible iterate by its residual (TNNMG stops on
  /// it). Part of the operator: kept by copies,
  /// setLoad() and setGaps(). Throws obs::Error on a wrong size, a negative or non-finite entry, or
  /// a transformed problem (T'AT has no such diagonal bound in general).
  void setDiagonalLowerBound(std::vector<double> bound);
  /// The bound of setDiagonalLowerBound (empty: none declared).
  const std::vector<double>& diagonalLowerBound() const { return lowerBound_; }
  /// The rotated problem (built on each call; it shares the matrix, and copies the vectors).
  RotatedProblem<d> rotated() const;
  // --- Tresca friction (see the file comment) ---
  /// Sets the slip bounds s_k (ContactSet numbering, finite, >= 0) and the origin o (problem
  /// unknowns; empty: zero). Bounds at nodes without a finite gap are ignored (no tangential frame).
  /// All bounds zero (or an empty vector) removes the friction term. Part of the data, not of the
  /// operator: operatorId() is unchanged. Throws obs::Error on wrong sizes or invalid bounds.
  void setFriction(std::vector<double> slipBounds, Eigen::VectorXd origin = {});
  /// True if some node has a positive slip bound.
  bool frictional() const { return !slip_.empty(); }
  /// The slip bounds of setFriction (empty: frictionless).
  const std::vector<double>& slipBounds() const { return slip_; }
  /// The origin of setFriction (empty: zero).
  const Eigen::VectorXd& slipOrigin() const { return origin_; }
  /// The tangential slip (x_p - o_p)_T of contact node k in its rotated frame: the normal and the
  /// prescribed components are zero (the zero vector at nodes without a finite gap).
  Vec tangentialSlip(Index k, const Eigen::VectorXd& x) const;
  /// The friction term sum_k s_k |(x_p - o_p)_T| (0 if not frictional()).
  double frictionEnergy(const Eigen::VectorXd& x) const;

  /// Per component in rotated numbering: prescribed (Dirichlet) or not (RotatedProblem::prescribed).
  const std::vector<char>& prescribedRotated() const { return prescribedRotated_; }
  /// Writes the friction fields (frictionVertices, slip, origin) of a rotated problem of this
  /// problem's operator, as rotated() does (solvers that keep the rotated operator across solves).
  void rotateFriction(RotatedProblem<d>& rotated) const;
  /// w = Q'u and u = Q w.
  Eigen::VectorXd toRotated(const Eigen::VectorXd& u) const;
  Eigen::VectorXd fromRotated(const Eigen::VectorXd& w) const;

private:
  /// applied: the operator and load are already transformed (checks and skips only)
  void setup(BlockSparseMatrix<d> A, bool applied = false);
  void transform(BlockSparseMatrix<d>& A, bool applied);
  /// Removes the (zero) off-diagonal blocks of fully prescribed vertices from A~'s pattern when they
  /// are half of its blocks or more (BlockSparseMatrix::isolate).
  void isolatePrescribed(BlockSparseMatrix<d>& A) const;
  void rotateOperator(BlockSparseMatrix<d>& A);

  /// (I +- C) x with the components of basisSkip() left alone
  Eigen::VectorXd applyBasis(const Eigen::VectorXd& x, double sign) const;

  mesh::CsrMatrix basis_;  ///< C (empty: no transformation)
  std::vector<std::uint8_t> skip_;  ///< basisSkip()
  std::shared_ptr<const BlockSparseMatrix<d>> A_;  ///< A~ = Q'AQ (shared with rotated problems)
  std::vector<char> prescribedRotated_;  ///< Dirichlet components in rotated numbering
  Eigen::VectorXd b_;
  DirichletValues dirichlet_;
  ContactSet contact_;
  std::vector<Constraint> constraints_;
  Eigen::VectorXd dirichletLift_;  ///< A g (original A) on free rows, to eliminate the values in setLoad
  std::vector<char> rotated_;      ///< per contact node: a rotation was built at construction
  std::vector<double> lowerBound_;  ///< setDiagonalLowerBound (empty: none)
  std::vector<double> slip_;        ///< setFriction: slip bounds per contact node (empty: none)
  Eigen::VectorXd origin_;          ///< setFriction: origin o (empty: zero)
  std::uint64_t operatorId_ = 0;
};

/// Contact quantities of a solution (docs/theory.md#contact-pressure), per contact node k of the ContactSet:
///   inContact[k]  actual contact: the gap is closed, g_p - nu_p'u_p <= relativeTolerance * U with
///                 U = max(|u|_inf, |g|_inf) over finite gaps, and the node carries a force,
///                 mu_p > relativeTolerance * F with F = max(|b_i|, |(A u)_i|) over the free
///                 components (the KKT force scale): surfaces that touch without load, or nodes
///                 whose multiplier is round-off of the force scale, are not in contact
///                 (docs/theory.md#node-classes);
///   multiplier[k] mu_p = (b - A u)_p . nu_p (physical constraint, see Constraint::scale);
///   pressure[k]   s_p = mu_p / m_p^C  (docs/theory.md#contact-pressure, thesis (4.1)), an approximation of
///   -sigma_nu;
/// totals: force = sum_p mu_p nu_p (the force the obstacle exerts on the body is -force), contact area
/// = measure of the contact faces all of whose nodes are in contact, and a contact radius estimate:
/// sqrt(area / pi) in 3D (a disk), area / 2 in 2D (half the contact length, the b of
/// docs/theory.md#analytic-references).
/// Tangential quantities (docs/theory.md#friction-outputs), per contact node:
///   tangential[k] f_T = (b - A u)_p minus its normal part, without prescribed components (the
///                 friction force, in Cartesian axes; round-off of the force scale without friction);
///   slip[k]       |(u_p - o_p)_T| (ContactProblem::tangentialSlip);
///   state[k]      0 not in contact, 1 stick (slip <= relativeTolerance * U), 2 slip;
/// totals: tangentialForce = sum f_T (the obstacle's friction force on the body is -tangentialForce),
/// the numbers of sticking and slipping contact nodes, and the stick area: the measure of the faces
/// all of whose nodes stick (as contactArea for the contact nodes).
struct ContactOutputs {
  std::vector<char> inContact;
  std::vector<double> multiplier;
  std::vector<double> pressure;
  std::vector<Point> tangential;
  std::vector<double> slip;
  std::vector<char> state;
  Index contactNodes = 0;
  Index stickNodes = 0;
  Index slipNodes = 0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d tangentialForce = Eigen::Vector3d::Zero();
  double contactArea = 0;
  double contactRadius = 0;
  double stickArea = 0;
};

template <int d>
ContactOutputs computeContactOutputs(const ContactProblem<d>& problem, const Eigen::VectorXd& u,
                                     double relativeTolerance = 1e-8);
/// The same with the scales U and F given, e.g. a distributed run's over all ranks (the
/// KktResiduals' displacementScale and forceScale), so that every rank decides contact and stick
/// by the same thresholds.
template <int d>
ContactOutputs computeContactOutputs(const ContactProblem<d>& problem, const Eigen::VectorXd& u, double relativeTolerance,
                                     double displacementScale, double forceScale);

extern template struct RotatedProblem<2>;
extern template struct RotatedProblem<3>;
extern template class ContactProblem<2>;
extern template class ContactProblem<3>;

}  // namespace obs
