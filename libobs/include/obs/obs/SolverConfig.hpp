#pragma once
/// \file SolverConfig.hpp
/// One solver configuration for every kind of run (docs/scenes.md#solver): which contact solver, its
/// stopping rule, TNNMG's nonsmooth smoothing and the linear multigrid of its correction. A static
/// solve, the adaptive loop (estimators::AdaptiveLoopOptions::solver) and time stepping
/// (NewmarkOptions::solver) hold it as a member and create their solvers from it (makeContactSolver,
/// tnnmgOptions), so one scene [solver] section means the same in the three kinds, with one set of
/// defaults.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactSolver.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs {

/// The contact solvers behind ContactSolver: TNNMG (TNNMG.hpp), the primal-dual active-set method
/// with CHOLMOD (PrimalDualActiveSet.hpp) and projected block Gauss-Seidel (ProjectedGaussSeidel.hpp).
enum class ContactSolverKind { TNNMG, PrimalDualActiveSet, ProjectedGaussSeidel };

/// Scene-file name: "tnnmg", "pdas", "pgs".
std::string_view name(ContactSolverKind kind);
/// The kind of a scene-file name; empty for any other name (the caller says what it accepts).
std::optional<ContactSolverKind> contactSolverKindFromName(std::string_view name);
/// The iteration cap of a kind when none is given: 200 (TNNMG), 100 (the active-set method, which
/// stops once its active set repeats), 10,000 (Gauss-Seidel, whose rate degrades with the mesh size).
int defaultMaxIterations(ContactSolverKind kind);

struct SolverConfig {
  ContactSolverKind kind = ContactSolverKind::TNNMG;
  /// Relative energy-norm correction at which the iteration stops (ContactSolverOptions::tolerance;
  /// the active-set method stops on its exact rule, the repeated active set).
  double tolerance = 1e-10;
  /// Iteration cap; unset: defaultMaxIterations(kind).
  std::optional<int> maxIterations;
  int preSmoothing = 3;   ///< TNNMG: nonsmooth Gauss-Seidel sweeps before the correction
  int postSmoothing = 0;  ///< TNNMG: nonsmooth sweeps after the line search
  /// TNNMG's linear correction (smoother, cycle, Krylov steps, local smoothing, sweeps); a linear
  /// multigrid solve without contact takes it too, with `tolerance` and its own iteration cap.
  LinearMultigridOptions multigrid;

  /// maxIterations, or the default of the kind.
  int iterationCap() const { return maxIterations.value_or(defaultMaxIterations(kind)); }
  bool operator==(const SolverConfig&) const = default;
};

/// TNNMG's options of a configuration (tolerance, iteration cap, smoothing, multigrid); the caller
/// adds what depends on the run (recordHistory, onIteration, an inexact tolerance).
template <int d>
typename TNNMG<d>::Options tnnmgOptions(const SolverConfig& config);

/// The solver of a configuration: TNNMG on the block-stacked hierarchy of `grids` (one grid for one
/// body), the active-set method or projected Gauss-Seidel; `onIteration` receives every iteration's
/// record, `recordHistory` keeps them in the result.
template <int d>
std::unique_ptr<ContactSolver<d>> makeContactSolver(const SolverConfig& config,
                                                    const std::vector<const mesh::Grid*>& grids,
                                                    std::function<void(const IterationRecord&)> onIteration = {},
                                                    bool recordHistory = true);

}  // namespace obs
