#pragma once
/// \file PrimalDualActiveSet.hpp
/// Primal-dual active set method = semismooth Newton for the complementarity conditions
/// (Hintermueller, Ito, Kunisch 2002), on the rotated problem of ContactProblem (docs/theory.md#rotations):
///   min 1/2 w'Aw - b'w  s.t.  w_{p,1} <= g_p,   multipliers mu_p = (b - A w)_{p,1}.
/// Iteration k, from (w^k, mu^k):
///   1. active set  A_k = { p bounded : mu_p^k + c_p (w^k_{p,1} - g_p) > 0 },  c_p = c * A_pp(1,1)
///      (scaling c by the diagonal makes the rule independent of the units);
///   2. if k > 0 and A_k = A_{k-1}: stop, (w^k, mu^k) satisfies the KKT conditions exactly
///      (inactive: mu = 0, w_1 <= g; active: w_1 = g, mu > 0);
///   3. w^{k+1} solves A w = b on all components except w_{p,1} = g_p for p in A_k (symmetric
///      elimination as for Dirichlet values, CHOLMOD);
///   4. mu^{k+1}_p = (b - A w^{k+1})_{p,1} on A_k, 0 elsewhere.
/// The start is the projected u with mu^0 = (b - A w^0)_{p,1}. The method converges locally
/// superlinearly and stops after finitely many steps; the relative energy-norm corrections are
/// recorded but the stopping rule is step 2 (then converged also requires KKT residuals <=
/// kktTolerance). If an active set repeats one that is not the previous one, the iteration cycles:
/// obs::Error. Each iteration factorises anew (the matrix changes with the active set).
///
/// Tresca friction (RotatedProblem::frictionVertices; docs/theory.md#friction-baseline), after
/// Hueeber, Stadler, Wohlmuth (2008): with the tangential multiplier lambda_T = (b - A w)_T, the slip
/// t = (w - o)_T and c_T = c * max_a A_pp(a, a) over the free tangential components a,
///   stick set  S_k = { |lambda_T + c_T t| <= s }:  t = 0 in the Newton step (fixed like a Dirichlet value);
///   slip:      lambda_T = s e, e = (lambda_T + c_T t)/|lambda_T + c_T t|, the force -s e on the right-hand side.
/// In 2D e = +-1 and this is the semismooth Newton method for Tresca friction: the state of a
/// friction vertex is stick, slip forward or slip backward, and the iteration stops when the normal
/// and these states repeat. In 3D e is a direction in the tangent plane, and the step linearises it
/// in the slip t: lambda_T = s e + K (t^{k+1} - t^k) with K = (s c_T / |xi|) (I - e e') (the
/// derivative of s xi/|xi| with respect to t, the dependence of xi on lambda_T left out), so the
/// Newton matrix stays symmetric (A + K, CHOLMOD). At a solution |xi| = s + c_T |t|, so K tends to
/// the curvature s (I - e e')/|t| of the friction term for large c. In 3D the iteration stops when the
/// states repeat and the relative correction of the step is below `tolerance` (the directions have
/// converged).
/// Coulomb friction: solveFriction (Friction.hpp) around it. With friction a larger c makes cycling
/// more likely (on the partial-slip problems of tests/obs/test_friction.cpp c = 1 cycles in one of the
/// Tresca problems of a Coulomb fixed point, c = 0.1 and 0.01 do not), so with friction a repeated
/// earlier set divides every c_p and c_T by 10 and the iteration goes on, at most three times; a
/// fourth cycle is the obs::Error above.
#include "obs/obs/ContactSolver.hpp"

namespace obs {

template <int d>
class PrimalDualActiveSet : public ContactSolver<d> {
public:
  struct Options : ContactSolverOptions {
    Options() { maxIterations = 100; }
    double c = 1.0;              ///< complementarity constant, relative to the diagonal entries
    // kktTolerance (ContactSolverOptions, default 1e-8): bound on KktResiduals::max() for converged
  };
  PrimalDualActiveSet() = default;
  explicit PrimalDualActiveSet(const Options& options) : options_(options) {}
  std::string name() const override { return "primal-dual-active-set"; }
  ContactResult solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) override;

  /// Seconds spent in CHOLMOD factorisations during the last solve.
  double factorSeconds() const { return factorSeconds_; }

private:
  Options options_;
  double factorSeconds_ = 0;
};

extern template class PrimalDualActiveSet<2>;
extern template class PrimalDualActiveSet<3>;

}  // namespace obs
