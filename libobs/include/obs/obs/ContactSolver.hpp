#pragma once
/// \file ContactSolver.hpp
/// The common interface of the contact solvers (docs/architecture.md#libobs): solve the bound-constrained
/// problem of a ContactProblem from a start u, return a result value (iterations, convergence, time, KKT
/// residuals, per-iteration history) in the spirit of DUNE's InverseOperatorResult, never print.
/// Iterative solvers stop when the relative energy-norm correction (docs/theory.md#tnnmg-stopping)
///   ||u^{k+1} - u^k||_A / ||u^{k+1}||_A < tolerance
/// (solvers with an exact stopping rule, like the active-set method, say so); TNNMG in addition
/// requires the KKT residual KktResiduals::max() of the iterate <= max(kktTolerance, tolerance),
/// checked only in the iterations whose correction passes (docs/theory.md#tnnmg-stopping); where the
/// problem declares a diagonal lower bound, TNNMG's error bound may pass instead of the correction
/// (docs/theory.md#tnnmg-error-bound). Reaching
/// maxIterations returns converged = false; NaN/Inf, divergence and stagnation throw obs::Error
/// saying what happened.
///
/// IterationMonitor is the shared bookkeeping (cf. dune-solvers' LoopSolver with its criteria):
/// history, tolerance, NaN, divergence, stagnation and energy-monotonicity checks.
#include <Eigen/Core>

#include <chrono>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/KktResiduals.hpp"

namespace obs {

struct IterationRecord {
  int iteration = 0;
  double energy = 0;      ///< J(u^k)
  double correction = 0;  ///< ||u^k - u^{k-1}||_A / ||u^k||_A
  Index activeSetSize = 0;
  Index truncationChanges = 0;  ///< components whose truncation changed in this iteration (TNNMG; else 0)
  /// Upper bound of the relative energy-norm error ||u^k - u*||_A / ||u^k||_A (TNNMG on problems with
  /// a diagonal lower bound, docs/theory.md#tnnmg-error-bound); NaN where none is computed.
  double errorBound = std::numeric_limits<double>::quiet_NaN();
};

struct ContactSolverOptions {
  /// Relative energy-norm correction at which an iterative solver stops.
  double tolerance = 1e-10;
  /// Bound on the KKT residual KktResiduals::max() of the solution for converged = true (the
  /// active-set method: its criterion next to the repeated active set; TNNMG: next to the correction
  /// test, with max(kktTolerance, tolerance), so that a looser correction tolerance loosens it too).
  double kktTolerance = 1e-8;
  /// Iteration cap; reaching it without convergence returns converged = false.
  int maxIterations = 1000;
  /// Stagnation: obs::Error if in this many consecutive iterations neither the energy decreased by
  /// more than round-off (1e-14 relative) nor the correction reached a new minimum (by a relative
  /// 1e-6, so that slow but steady methods like Gauss-Seidel on fine meshes count as progressing).
  int stagnationIterations = 100;
  /// Divergence: obs::Error if the energy exceeds J_0 + divergenceFactor * max(|J_0|, |J_min|, 1e-300).
  double divergenceFactor = 1e6;
  /// Keep the per-iteration history in the result.
  bool recordHistory = true;
  /// Compute the KKT residuals of the result (one product with the matrix; ContactResult::kkt). Off:
  /// they are NaN. Ignored by the solvers whose stopping rule needs them (TNNMG, which evaluates them
  /// once its correction passes the tolerance, and the active-set method).
  bool computeKkt = true;
  /// Called with the record of every iteration as soon as it is recorded (e.g. progress output of a
  /// driver); unset: nothing is called. The solvers themselves never print.
  std::function<void(const IterationRecord&)> onIteration;
};

struct ContactResult {
  std::string solver;
  int iterations = 0;
  bool converged = false;
  double seconds = 0;
  double correction = 0;       ///< last relative energy-norm correction
  double errorBound = std::numeric_limits<double>::quiet_NaN();  ///< last IterationRecord::errorBound
  double convergenceRate = 0;  ///< geometric mean of the correction ratios (0 if < 2 iterations)
  double energy = 0;           ///< final J(u)
  Index activeSetSize = 0;     ///< final number of nodes at their bound
  KktResiduals kkt;            ///< of the returned u (NaN if not computed, see computeKkt)
  /// TNNMG: iterations whose correction passed the tolerance but whose KKT residual did not (the
  /// solve went on); 0 for the other solvers.
  int kktRejections = 0;
  std::vector<IterationRecord> history;
};

template <int d>
class ContactSolver {
public:
  virtual ~ContactSolver() = default;
  virtual std::string name() const = 0;
  /// Solves the problem starting from u (any vector of the right size; projected onto the admissible
  /// set first; a vector of the wrong size starts from zero) and returns the solution in u.
  virtual ContactResult solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) = 0;
};

class IterationMonitor {
public:
  /// Starts the clock; `initialEnergy` is J of the (projected) start.
  IterationMonitor(std::string solver, const ContactSolverOptions& options, double initialEnergy);

  /// Records iteration k (1, 2, ...). Returns true if correction < tolerance or errorBound <
  /// tolerance (an upper bound of the relative error, NaN if the solver has none). Throws obs::Error
  /// on NaN/Inf, divergence or stagnation.
  bool record(double energy, double correction, Index activeSetSize, Index truncationChanges = 0,
              double errorBound = std::numeric_limits<double>::quiet_NaN());
  /// For energy-monotone methods: throws obs::Error if the last recorded energy exceeds the one
  /// before by more than round-off, 1e-10 * scale (scale: magnitude of the energy's terms).
  void requireMonotone(double scale) const;
  /// Marks the progress counter as reset (e.g. a solver-specific notion of progress).
  void progressed() { sinceProgress_ = 0; }

  int iterations() const { return iteration_; }
  /// Fills the result (time, iterations, correction, rate, energy, history); kkt is left to the solver.
  ContactResult finish(bool converged, Index activeSetSize);

private:
  std::string solver_;
  ContactSolverOptions options_;
  std::chrono::steady_clock::time_point start_;
  double initialEnergy_, minEnergy_, previousEnergy_, lastEnergy_;
  double bestCorrection_, firstCorrection_ = 0, lastCorrection_ = 0;
  double lastErrorBound_ = std::numeric_limits<double>::quiet_NaN();
  int iteration_ = 0, sinceProgress_ = 0;
  std::vector<IterationRecord> history_;
};

}  // namespace obs
