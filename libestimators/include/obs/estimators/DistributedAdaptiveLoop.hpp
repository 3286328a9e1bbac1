#pragma once
/// \file DistributedAdaptiveLoop.hpp
/// The adaptive loop of AdaptiveLoop.hpp on the ranks of a distributed run
/// (docs/architecture.md#distributed-adaptivity), for one body against a rigid obstacle. Step k:
///  1. the leaf view of the DistributedGrid; the contact problem assembled on the rank's local mesh
///     (its owned rows complete);
///  2. distributed TNNMG, warm started (default) from the previous solution transferred to the new
///     leaf view as serially (mesh::transferMatrix on the local grid; exact at the owned vertices,
///     which lie in old owned or ghost cells only; the ghosts' values from their owners);
///  3. contact outputs and node classes on the local mesh at the scales over all ranks (as one
///     process's), counted over the owned vertices; the load P = sum_p mu_p over the owned contact
///     vertices of all ranks;
///  4. the estimate of the owned cells (estimateOwned; its node classes at the same scale) and eta
///     over all ranks; eoc as serially;
///  5. record + callback; the stopping rules of AdaptiveLoop;
///  6. marking with global thresholds (markOwned; ties by DistributedGrid::cellKey), then
///     DistributedGrid::adapt; Uniform mode: every owned leaf;
///  7. load balancing: DistributedGrid::rebalance when the owned leaves of the largest rank exceed
///     the mean by more than the imbalance tolerance (and the grid's balanced boundary, if set);
///     the warm start moves with the vertices;
///  8. the state hook (checkpoints): the records, the marks by cell key and the warm start, from
///     which restore() continues on any number of ranks.
/// The records are AdaptiveStep's, with the figures over all ranks (every rank holds the same
/// record). Every call is collective; an error on one rank reaches every rank.
///
/// Not on ranks (obs::Error at construction): the primal-dual active set solver, inexact solves,
/// friction, several bodies or couplings.
#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/estimators/Estimator.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs::estimators {

/// What the callback sees after step k, before the grid is refined (valid during the call only).
struct DistributedAdaptiveStepView {
  const AdaptiveStep& record;           ///< the step's record, the same on every rank
  const DistributedGrid& grid;          ///< not yet refined
  const DistributedView& leaf;          ///< the rank's part of the leaf view of the step
  const Eigen::VectorXd& displacement;  ///< on leaf.local (owned vertices first, ghosts current)
  const ContactSet& contactSet;         ///< the obstacle's nodes on leaf.local
  const ContactOutputs& outputs;        ///< for contactSet (exact at the owned vertices)
  const EstimatorResult* estimate;      ///< of the owned cells (null if not estimated)
  const std::vector<Index>& marked;     ///< owned cells (of leaf.local) to be refined after the step
  /// The load balancing after the refinement that made this step's grid (before: the imbalance of
  /// the refined grid on the old parts; nothing moved at step 0) and its seconds (largest rank).
  const RebalanceReport& balance;
  double balanceSeconds;
};

/// What the loop needs to continue after step k on any number of ranks (checkpoints,
/// docs/checkpoint.md#distributed-adaptive-runs): taken by the state hook once the grid is refined
/// (and rebalanced) after step k, given to restore() in another run. The grid is rebuilt by
/// replaying the marks, which are known by cell key (DistributedGrid::cellKey), the same on every
/// partition; the start vector is a function on the vertices, which the caller keeps by vertex.
struct DistributedAdaptiveLoopState {
  int nextStep = 0;                ///< k + 1: the step the loop continues with
  std::vector<AdaptiveStep> steps;  ///< the records of steps 0..k (the same on every rank)
  /// [step j]: the cell keys of the leaves marked after step j on all ranks, sorted
  std::vector<std::vector<std::uint64_t>> marked;
  double transferSeconds = 0;  ///< the time taken to build the start (reported by step k + 1)
};

class DistributedAdaptiveLoop {
public:
  using Callback = std::function<void(const DistributedAdaptiveStepView&)>;
  /// After the grid is refined and rebalanced after step k (not after the last step): the state,
  /// the rank's part `next` of the new leaf view, and the start of step k + 1 on next.local (d
  /// values per vertex, owned vertices first; empty: cold start). Collective.
  using StateHook = std::function<void(const DistributedAdaptiveLoopState&, const DistributedView& next,
                                       const Eigen::VectorXd& start)>;

  /// The grid is refined in place; material, bc and obstacle must outlive the loop; contact on the
  /// boundary faces with id `boundaryId`. Throws obs::Error (on every rank) for what is not on ranks
  /// (see the file comment) and what AdaptiveLoop refuses.
  DistributedAdaptiveLoop(DistributedGrid& grid, const Material& material, const BoundaryConditions& bc,
                          const Obstacle& obstacle, int boundaryId, AdaptiveLoopOptions options = {});

  /// An analytic reference (AnalyticContact.hpp): every step then records ReferenceErrors, over
  /// all ranks (referenceErrors on ranks: each contact face counted by the owner of its vertex of
  /// smallest global index).
  void setReference(ContactReference reference) { reference_ = std::move(reference); }
  /// Load balancing after each refinement: the grid is repartitioned when the owned leaves of the
  /// largest rank exceed the mean by more than the factor `tolerance` (>= 1; infinity: never;
  /// default kDefaultImbalanceTolerance). Throws obs::Error for a tolerance below 1.
  void setImbalanceTolerance(double tolerance);
  static constexpr double kDefaultImbalanceTolerance = 1.1;
  /// The function called after every step (replaces an earlier one).
  void setCallback(Callback callback) { callback_ = std::move(callback); }
  void setStateHook(StateHook hook) { hook_ = std::move(hook); }
  /// Continues a loop from a state its hook gave (collective): replays state.marked on the grid,
  /// which must be the initial grid of that loop, not yet refined, with the loop's closure rule
  /// and load balancing (on the same number of ranks: the same parts), then asks `start` for the
  /// start of step state.nextStep on the rank's part of the rebuilt leaf view (d values per local
  /// vertex; empty: cold start). run() then begins with step state.nextStep and returns every
  /// record. Throws obs::Error on every rank for an inconsistent state or a start of another size.
  void restore(DistributedAdaptiveLoopState state, const std::function<Eigen::VectorXd(const DistributedView&)>& start);
  /// Runs the loop; the records of the steps. Collective.
  std::vector<AdaptiveStep> run();

private:
  template <int d>
  std::vector<AdaptiveStep> runDim();

  DistributedGrid& grid_;
  const Material& material_;
  const BoundaryConditions& bc_;
  const Obstacle& obstacle_;
  int boundaryId_;
  AdaptiveLoopOptions options_;
  double imbalanceTolerance_ = kDefaultImbalanceTolerance;
  std::optional<ContactReference> reference_;
  Callback callback_;
  StateHook hook_;
  /// restore(): the state, the start on the grid's leaf view vertices and the last balancing
  std::optional<DistributedAdaptiveLoopState> resume_;
  std::vector<double> resumeStart_;
  RebalanceReport resumeBalance_;
  double resumeBalanceSeconds_ = 0;
};

}  // namespace obs::estimators
