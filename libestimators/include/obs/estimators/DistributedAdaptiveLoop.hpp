#pragma once
/// \file DistributedAdaptiveLoop.hpp
/// The adaptive loop of AdaptiveLoop.hpp on the ranks of a distributed run
/// (docs/architecture.md#distributed-adaptivity): one body against a rigid obstacle, or two bodies
/// (each a DistributedGrid over all ranks) coupled by one dual-mortar pair. Step k:
///  1. the leaf views of the bodies' DistributedGrids; the contact problem assembled on the rank's
///     local meshes (its owned rows complete): the obstacle problem, or the pair's
///     DistributedMortar and the transformed problem of DistributedMultiBody;
///  2. distributed TNNMG (two bodies: with the stacked multigrid), warm started (default) from the
///     previous solution transferred to the new leaf views as serially (mesh::transferMatrix on
///     each local grid; exact at the owned vertices, which lie in old owned or ghost cells only;
///     the ghosts' values from their owners);
///  3. contact outputs at the scales over all ranks (as one process's), the ghosts' from their
///     owners; node classes per body at the body's scale over all ranks, counted over the owned
///     vertices; the load P = sum_p mu_p over the owned constrained vertices of all ranks; with a
///     pair its CouplingRecord over all ranks;
///  4. the estimate of the owned cells of every body (estimateOwned; docs/theory.md#two-body-estimator
///     for a pair: the slave side with its mortar pressures and the exact gap to the displaced
///     master surface, which every rank gathers whole; the master side against the mortar traction,
///     C'(mu n) summed at the master owners over the lumped boundary mass) and eta over all ranks
///     and bodies; eoc as serially;
///  5. record + callback; the stopping rules of AdaptiveLoop;
///  6. marking with global thresholds among the owned cells of all bodies (markOwned; ties by
///     DistributedGrid::cellKey mixed with the body index), then DistributedGrid::adapt of every
///     grid; Uniform mode: every owned leaf;
///  7. load balancing of every grid: DistributedGrid::rebalance when the owned leaves of the
///     largest rank exceed the mean by more than the imbalance tolerance (and the grid's balanced
///     boundary, if set); the warm start moves with the vertices;
///  8. the state hook (checkpoints): the records, the marks by cell key and the warm start, from
///     which restore() continues on any number of ranks.
/// The records are AdaptiveStep's, with the figures over all ranks (every rank holds the same
/// record). Every call is collective; an error on one rank reaches every rank.
///
/// Not on ranks (obs::Error at construction or run()): the primal-dual active set solver, inexact
/// solves, friction, more than two bodies or one coupling, obstacles on a body of a pair.
#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/estimators/Estimator.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs::estimators {

/// What the callback sees of one body after step k (valid during the call only).
struct DistributedAdaptiveBodyView {
  const DistributedGrid& grid;          ///< not yet refined
  const DistributedView& leaf;          ///< the rank's part of the body's leaf view of the step
  const Eigen::VectorXd& displacement;  ///< on leaf.local (owned vertices first, ghosts current)
  /// The body's constrained nodes on leaf.local (obstacle or mortar slave side; null if none) and
  /// their outputs (exact at the owned vertices; mortar: the pressures s_p = lambda_p)
  const ContactSet* contactSet;
  const ContactOutputs* outputs;
  const EstimatorResult* estimate;      ///< of the owned cells (null if not estimated)
  const std::vector<Index>& marked;     ///< owned cells (of leaf.local) to be refined after the step
  /// The load balancing of this body's grid after the refinement that made this step's grid
  /// (before: the imbalance of the refined grid on the old parts; nothing moved at step 0)
  const RebalanceReport& balance;
};

/// What the callback sees after step k, before the grids are refined (valid during the call only).
struct DistributedAdaptiveStepView {
  const AdaptiveStep& record;  ///< the step's record, the same on every rank
  const std::vector<DistributedAdaptiveBodyView>& bodies;  ///< every body, in order
  double balanceSeconds;       ///< the load balancing of all grids (largest rank)
};

/// What the loop needs to continue after step k on any number of ranks (checkpoints,
/// docs/checkpoint.md#distributed-adaptive-runs): taken by the state hook once the grids are
/// refined (and rebalanced) after step k, given to restore() in another run. The grids are rebuilt
/// by replaying the marks, which are known by cell key (DistributedGrid::cellKey), the same on every
/// partition; the start vectors are functions on the vertices, which the caller keeps by vertex.
struct DistributedAdaptiveLoopState {
  int nextStep = 0;                ///< k + 1: the step the loop continues with
  std::vector<AdaptiveStep> steps;  ///< the records of steps 0..k (the same on every rank)
  /// [step j][body b]: the cell keys of body b's leaves marked after step j on all ranks, sorted
  std::vector<std::vector<std::vector<std::uint64_t>>> marked;
  double transferSeconds = 0;  ///< the time taken to build the start (reported by step k + 1)
};

/// One body of the loop: its distributed grid (refined and rebalanced in place), material and
/// boundary conditions (not copied: they must outlive the loop).
struct DistributedAdaptiveBody {
  std::string name;
  DistributedGrid* grid = nullptr;
  const Material* material = nullptr;
  const BoundaryConditions* bc = nullptr;
};

class DistributedAdaptiveLoop {
public:
  using Callback = std::function<void(const DistributedAdaptiveStepView&)>;
  /// After the grids are refined and rebalanced after step k (not after the last step): the state,
  /// the rank's parts `next` of the bodies' new leaf views, and the starts of step k + 1 on each
  /// next[b].local (d values per vertex, owned vertices first; empty: cold start). Collective.
  using StateHook = std::function<void(const DistributedAdaptiveLoopState&, const std::vector<DistributedView>& next,
                                       const std::vector<Eigen::VectorXd>& start)>;
  /// The start of a restored loop on the rank's parts of the rebuilt leaf views (per body, d
  /// values per local vertex; empty: cold start).
  using StartFunction = std::function<std::vector<Eigen::VectorXd>(const std::vector<DistributedView>&)>;

  /// One body against an obstacle: the grid is refined in place; material, bc and obstacle must
  /// outlive the loop; contact on the boundary faces with id `boundaryId`. Throws obs::Error (on
  /// every rank) for what is not on ranks (see the file comment) and what AdaptiveLoop refuses.
  DistributedAdaptiveLoop(DistributedGrid& grid, const Material& material, const BoundaryConditions& bc,
                          const Obstacle& obstacle, int boundaryId, AdaptiveLoopOptions options = {});
  /// Several bodies (on the same ranks, of one dimension), coupled by addMortarContact(). Throws
  /// what the one-body constructor throws, and obs::Error for an empty list, a null pointer or
  /// grids of different dimensions.
  DistributedAdaptiveLoop(std::vector<DistributedAdaptiveBody> bodies, AdaptiveLoopOptions options = {});
  /// A dual-mortar pair: boundary `slaveId` of body `slave` against `masterId` of body `master`,
  /// rebuilt (DistributedMortar) on the leaf views of every step. On ranks: two bodies and this one
  /// pair. Throws obs::Error (on every rank) otherwise.
  void addMortarContact(int slave, int slaveId, int master, int masterId, std::string label = {},
                        const MortarOptions& options = {});

  /// An analytic reference (AnalyticContact.hpp) of one body against its obstacle (ignored for a
  /// pair, as serially): every step then records ReferenceErrors, over all ranks (referenceErrors
  /// on ranks: each contact face counted by the owner of its vertex of smallest global index).
  void setReference(ContactReference reference) { reference_ = std::move(reference); }
  /// Load balancing after each refinement: each grid is repartitioned when the owned leaves of its
  /// largest rank exceed the mean by more than the factor `tolerance` (>= 1; infinity: never;
  /// default kDefaultImbalanceTolerance). Throws obs::Error for a tolerance below 1.
  void setImbalanceTolerance(double tolerance);
  static constexpr double kDefaultImbalanceTolerance = 1.1;
  /// The function called after every step (replaces an earlier one).
  void setCallback(Callback callback) { callback_ = std::move(callback); }
  void setStateHook(StateHook hook) { hook_ = std::move(hook); }
  /// Continues a loop from a state its hook gave (collective): replays state.marked on the grids,
  /// which must be the initial grids of that loop, not yet refined, with the loop's closure rule
  /// and load balancing (on the same number of ranks: the same parts), then asks `start` for the
  /// starts of step state.nextStep on the rank's parts of the rebuilt leaf views. run() then
  /// begins with step state.nextStep and returns every record. Throws obs::Error on every rank for
  /// an inconsistent state or a start of another size.
  void restore(DistributedAdaptiveLoopState state, const StartFunction& start);
  /// Runs the loop; the records of the steps. Collective. Throws obs::Error on every rank without a
  /// coupling (an obstacle, or a pair of two bodies).
  std::vector<AdaptiveStep> run();

private:
  template <int d>
  std::vector<AdaptiveStep> runDim();
  const Communicator& communicator() const { return bodies_.front().grid->communicator(); }

  std::vector<DistributedAdaptiveBody> bodies_;
  AdaptiveLoopOptions options_;
  /// the coupling: an obstacle of body 0 on boundaryId_, or the mortar pair
  const Obstacle* obstacle_ = nullptr;
  int boundaryId_ = -1;
  struct Pair {
    int slave = 0, slaveId = 0, master = 1, masterId = 0;
    std::string label;
    MortarOptions options;
  };
  std::optional<Pair> pair_;
  double imbalanceTolerance_ = kDefaultImbalanceTolerance;
  std::optional<ContactReference> reference_;
  Callback callback_;
  StateHook hook_;
  /// restore(): the state, the starts on the grids' leaf view vertices and the last balancing
  std::optional<DistributedAdaptiveLoopState> resume_;
  std::vector<std::vector<double>> resumeStart_;
  std::vector<RebalanceReport> resumeBalance_;
  double resumeBalanceSeconds_ = 0;
};

}  // namespace obs::estimators
