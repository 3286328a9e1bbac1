#pragma once
/// \file AdaptiveLoop.hpp
/// The adaptive loop solve -> estimate -> mark -> refine (thesis Sec. 4.1, 4.2; docs/theory.md#adaptive-loop;
/// docs/architecture.md#libestimators) on the grids of one or several bodies: a Signorini problem
/// (an obstacle on one boundary id), two-body contact (dual-mortar pairs between bodies,
/// docs/theory.md#two-body-estimator) or plain linear elasticity (no coupling), with a per-step
/// record and an optional callback. No printing: drivers report through the callback.
///
/// Step k (k = 0, 1, ...):
///  1. assemble on the leaf views: the ContactModel of the bodies and couplings (ContactModel.hpp;
///     one body with one obstacle is its one-element case) -> ContactProblem (A, b with Dirichlet
///     values, the mortar basis transformation);
///  2. solve: TNNMG on the bodies' grid hierarchies (default) or the primal-dual active set method;
///     without a coupling a direct CHOLMOD solve. Warm start (default): the start is the previous
///     solution interpolated to the new leaf views (mesh::transferMatrix per body, exact where the
///     grids are nested), which the solvers project onto the admissible set; a cold start begins at 0;
///  3. contact outputs (computeContactOutputs: actual contact, s_p, load), node classes
///     (classifyContactNodes: actual / semi / full), optional reference errors;
///  4. estimate with the registry estimator `estimator`, body by body (EstimatorInput with the
///     body's contact data: its obstacle or slave nodes as a ContactSet on its mesh, the pressures,
///     the exact gap, and on a master side the mortar traction; docs/theory.md#two-body-estimator);
///     eta^2 is the sum over the bodies; in Uniform mode only if `estimateUniform`;
///  5. record + callback; stop if k + 1 = maxSteps, the leaf views have >= targetVertices vertices
///     together, eta <= etaTolerance, or (adaptive) nothing was marked;
///  6. refine: Adaptive: mark the cells chosen by the marking strategy (MarkingStrategy, default
///     "mean" with theta = 1.1) among the cells of all bodies together and Grid::adapt() every
///     grid (boundary projections of the grid apply); Uniform: Grid::refineUniformly().
/// eoc (docs/theory.md#eoc, on the vertex count N): eoc_k = (ln eta_{k-1} - ln eta_k) /
/// (ln N_k - ln N_{k-1}), NaN at k = 0 or without estimates.
///
/// Reference errors (docs/theory.md#pressure-error) with a ContactReference (AnalyticContact.hpp) and the
/// computed load P = sum_p mu_p = int_{Gamma_C} s_m (s_m = sum_p s_p phi_p, m_p^C = int phi_p):
///  - pressureError = ||s_m - p(., P)||_{Gamma_C} / ||p(., P)||_{Gamma_C} by face quadrature of
///    degree reference.quadratureDegree (for the punch, p is not square integrable at the strip
///    edges; Gauss points never hit them, so the value is a quadrature approximation as in the thesis);
///  - radius = max over actual contact vertices of |x_p - centre|, radiusError = |radius - b(P)| / b(P);
///  - centreError = |s_c - p(x_c, P)| / p(x_c, P) at the potential contact vertex c nearest to the centre.
///
/// Sample use (a complete program is examples/adaptive_custom_estimator.cpp):
///   mesh::Grid grid(mesh::boxMesh(mesh::CellType::Quadrilateral, 4));
///   const StripObstacle punch(Point(0.5, 0, 0), 0.0625, Point(0, -1, 0));
///   AdaptiveLoopOptions o;  o.maxSteps = 6;
///   AdaptiveLoop loop(grid, material, bc, o);
///   loop.setContact(punch, mesh::kBottom);
///   loop.setReference(punchReference());
///   loop.setCallback([](const AdaptiveStepView& s) {
///     std::printf("%d %ld %g\n", s.record.step, long(s.record.vertices), s.record.eta);
///   });
///   const std::vector<AdaptiveStep> steps = loop.run();
#include <Eigen/Core>

#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "obs/estimators/AnalyticContact.hpp"
#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/estimators/Estimator.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/SolverConfig.hpp"

namespace obs::estimators {

class EstimatorRegistry;

/// Adaptive: refine the cells the marking strategy chooses; Uniform: refine every cell.
enum class RefinementMode { Adaptive, Uniform };

/// What the loop does: estimator, marking, stopping rules, solver.
struct AdaptiveLoopOptions {
  RefinementMode mode = RefinementMode::Adaptive;  ///< adaptive or uniform refinement
  std::string estimator = "contact-residual";  ///< registry name
  std::string marking = "mean";                ///< MarkingStrategy name
  std::optional<double> markingParameter;      ///< theta (the strategy's default if unset)
  bool estimateUniform = false;  ///< Uniform mode: run the estimator anyway (for eta and eoc)
  int maxSteps = 5;              ///< number of solves (>= 1); refinements = solves - 1 at most
  Index targetVertices = 0;      ///< stop once the leaf view has at least this many vertices (0: off)
  double etaTolerance = 0;       ///< stop once eta <= etaTolerance (0: off)
  /// The contact solver of every step (SolverConfig.hpp; TNNMG on the bodies' hierarchies by default).
  SolverConfig solver;
  bool warmStart = true;           ///< start from the prolonged previous solution
  /// Inexact solves (docs/estimators.md#inexact-solves): > 0 stops TNNMG once the estimated
  /// algebraic error is below this fraction of the estimator predicted for the step (from the
  /// previous step's eta and eoc); steps that are known to be the last (maxSteps, targetVertices)
  /// and the first step use solver.tolerance. 0: every step to solver.tolerance.
  double inexactFraction = 0;
  /// Rule 2 of the marking closure of every grid's adapt() (mesh::ClosureRule; the loop sets it on
  /// the grids before refining them). docs/estimators.md#closure-overhead compares the two.
  mesh::ClosureRule closure = mesh::ClosureRule::MoreThanHalfEdges;
  double contactTolerance = 1e-8;  ///< relative tolerance of actual contact
  /// Registry to create the estimator from (null: EstimatorRegistry::global()).
  const EstimatorRegistry* registry = nullptr;
};

/// Errors of one step against an analytic reference (docs/theory.md#pressure-error).
struct ReferenceErrors {
  double load = 0;               ///< computed P = sum_p mu_p
  double pressureError = 0;      ///< relative L2 error of s_m (docs/theory.md#pressure-error)
  double radius = 0;             ///< measured contact radius
  double exactRadius = 0;        ///< b(P)
  double radiusError = 0;        ///< |radius - b| / b
  Index centreVertex = -1;       ///< leaf-view vertex nearest to the centre
  double centrePressure = 0;     ///< s_c
  double exactCentrePressure = 0;  ///< p(x_c, P)
  double centreError = 0;        ///< |s_c - p(x_c)| / p(x_c)
};

/// The share of one body in a step.
struct BodyRecord {
  Index cells = 0, vertices = 0;
  double eta = std::numeric_limits<double>::quiet_NaN();  ///< the body's estimate (NaN if none)
  Index marked = 0;                                       ///< its cells marked after the step
};

/// The record of one step (cells, vertices, unknowns, contact counts and eta summed over the bodies).
struct AdaptiveStep {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();  ///< "not computed"
  int step = 0;                            ///< k = 0, 1, ...
  Index cells = 0;                         ///< cells of the leaf view
  Index vertices = 0;                      ///< vertices of the leaf view (N of the eoc)
  Index unknowns = 0;                      ///< d * vertices
  /// Contact vertices (docs/theory.md#node-classes): potential (N^C), actual, semi, full contact.
  Index potentialContact = 0;
  Index actualContact = 0;                 ///< N^sC + N^fC
  Index semiContact = 0;                   ///< N^sC
  Index fullContact = 0;                   ///< N^fC
  double eta = kNaN;                       ///< NaN if not estimated
  std::vector<Contribution> contributions; ///< eta_k (empty if not estimated)
  double eoc = kNaN;                       ///< against the previous step (docs/theory.md#eoc)
  std::string solver;                      ///< name of the solver used
  int solverIterations = 0;                ///< its iterations (1 for a direct solve)
  double solverTolerance = 0;              ///< the relative tolerance the step was solved to
  bool converged = false;                  ///< whether the solver reached its tolerance
  double kkt = 0;                          ///< max KKT residual of the solution (contact only)
  double load = 0;                         ///< sum_p mu_p (0 without contact)
  double assemblySeconds = 0;              ///< assembling the problem on the leaf view
  double solverSeconds = 0;                ///< the contact (or linear) solve
  double estimatorSeconds = 0;             ///< the estimate
  double refinementSeconds = 0;            ///< marking + adapt after this step (0 for the last;
                                           ///< filled after the callback of the step)
  double transferSeconds = 0;              ///< building the start vector of this step
  Index marked = 0;                        ///< cells marked after this step
  /// The refinement after this step, summed over the bodies (mesh::AdaptResult; 0 for the last
  /// step and for uniform refinement): elements refined red (marked leaves, fathers of marked
  /// green leaves and the closure's additions), of these the ones only the closure rules
  /// refined, and elements given a green closure. cells of the next step minus cells of this one
  /// is the growth; docs/estimators.md#closure-overhead explains the split.
  Index refinedRed = 0;
  Index closureRed = 0;
  Index greenClosed = 0;
  std::optional<ReferenceErrors> reference;  ///< with a ContactReference (setReference) only
  std::vector<BodyRecord> bodies;          ///< per body, in the order of the bodies
  std::vector<CouplingRecord> couplings;   ///< per coupling, in the order they were added
};

/// What the callback sees of one body (valid during the call only).
struct AdaptiveBodyView {
  const mesh::Grid& grid;                   ///< the body's grid, not yet refined
  const mesh::GridView& view;               ///< its leaf view of the step
  const Eigen::VectorXd& displacement;      ///< on view.mesh, vertex-major
  const ContactSet* contactSet;             ///< the body's constrained nodes on view.mesh (obstacle or
                                            ///< mortar slave side; null if none)
  const ContactOutputs* outputs;            ///< for contactSet (pressure s_p = mortar lambda_p)
  const ContactNodeClasses& classes;        ///< node classes of view.mesh
  const EstimatorResult* estimate;          ///< null if not estimated
  const std::vector<Index>& marked;         ///< cells (of view.mesh) to be refined after the step
};

/// What the callback sees after step k, before the grids are refined (valid during the call only).
/// The members after `record` describe the first body (the only one of a one-body loop); `bodies`
/// describes every body.
struct AdaptiveStepView {
  const AdaptiveStep& record;               ///< the step's record (refinementSeconds not yet set)
  const mesh::Grid& grid;                   ///< the grid, not yet refined
  const mesh::GridView& view;               ///< the leaf view the step was computed on
  const Eigen::VectorXd& displacement;      ///< on view.mesh, vertex-major
  const ContactSet* contactSet;             ///< null without contact
  const ContactOutputs* outputs;            ///< null without contact
  const ContactNodeClasses& classes;        ///< node classes of view.mesh (all None without contact)
  const EstimatorResult* estimate;          ///< null if not estimated
  const std::vector<AdaptiveBodyView>& bodies;  ///< every body, in order
};

/// What the loop needs to continue after step k (docs/checkpoint.md#adaptive-runs): taken by the
/// state hook (AdaptiveLoop::setStateHook) once the grids are refined after step k, given to
/// AdaptiveLoop::restore in another process to continue with step k + 1 exactly as the first run
/// would have. The grids are not part of it: they are rebuilt by replaying `refinements` on the
/// bodies' initial grids (Grid::adapt is deterministic: same grid and marks, same grid, vertex
/// numbering and level views).
struct AdaptiveLoopState {
  int nextStep = 0;                ///< k + 1: the step the loop continues with
  std::vector<AdaptiveStep> steps;  ///< the records of steps 0..k (refinementSeconds set)
  /// [step j][body b]: the cells of body b's leaf view of step j marked for refinement after step j
  /// (Adaptive mode; Uniform mode refines every cell and leaves the lists empty).
  std::vector<std::vector<std::vector<Index>>> refinements;
  Eigen::VectorXd start;       ///< start vector of step k + 1 on the refined leaf views (empty: cold start)
  double transferSeconds = 0;  ///< the time taken to build `start` (reported by step k + 1)
  double lastRate = 0;         ///< convergence rate of step k's contact solve (inexact solves)
  double lastEnergyNorm = 0;   ///< energy norm of step k's solution (inexact solves)
};

/// Stores an AdaptiveLoopState under "adaptivity/" of a checkpoint record (obs/obs/Checkpoint.hpp;
/// the entries are listed in docs/checkpoint.md#adaptive-runs): the step records as one column per
/// field, the refinement history, the start vector and the inexact-solve inputs.
void storeAdaptiveState(CheckpointRecord& record, const AdaptiveLoopState& state);
/// The state stored by storeAdaptiveState; obs::Error naming a missing or inconsistent entry.
AdaptiveLoopState loadAdaptiveState(const CheckpointRecord& record);

/// One body of the loop: its grid (refined in place), material and boundary conditions (not
/// copied: they must outlive the loop).
struct AdaptiveBody {
  std::string name;
  mesh::Grid* grid = nullptr;
  const Material* material = nullptr;
  const BoundaryConditions* bc = nullptr;
};

/// The adaptive loop (see the file comment); examples/adaptive_custom_estimator.cpp shows it in use.
class AdaptiveLoop {
public:
  /// Called after every step with its view (see AdaptiveStepView).
  using Callback = std::function<void(const AdaptiveStepView&)>;

  /// The grid is refined in place; material and bc must outlive the loop. Throws obs::Error for
  /// maxSteps < 1, an unknown estimator or marking name (listing the known ones) or a bad marking
  /// parameter.
  AdaptiveLoop(mesh::Grid& grid, const Material& material, const BoundaryConditions& bc,
               AdaptiveLoopOptions options = {});
  /// Several bodies (at least one; grids of one dimension). Throws what the one-body constructor
  /// throws, and obs::Error for an empty list, a null pointer or grids of different dimensions.
  AdaptiveLoop(std::vector<AdaptiveBody> bodies, AdaptiveLoopOptions options = {});

  /// Contact of the first body with a rigid obstacle on the boundary faces with this id (the
  /// obstacle must outlive the loop); replaces the couplings given before. Without any coupling
  /// the loop solves linear elasticity.
  void setContact(const Obstacle& obstacle, int boundaryId);
  /// Adds contact of body `body` with a rigid obstacle on its boundary faces with this id.
  void addObstacleContact(int body, const Obstacle& obstacle, int boundaryId, std::string label = {});
  /// Adds a dual-mortar pair: boundary `slaveId` of body `slave` against `masterId` of body
  /// `master` (MortarCoupling.hpp), rebuilt on the leaf views of every step.
  void addMortarContact(int slave, int slaveId, int master, int masterId, std::string label = {},
                        const MortarOptions& options = {});
  /// Adds a coupling of a ContactModelSpec (the loop's bodies are the specification's bodies): the
  /// two functions above, or an obstacle coupling whose contact set a driver makes itself.
  void addCoupling(ContactModelSpec::Coupling coupling);
  /// An analytic reference (AnalyticContact.hpp): every step then records ReferenceErrors.
  void setReference(ContactReference reference);
  /// The function called after every step (replaces an earlier one).
  void setCallback(Callback callback);
  /// Called with the loop's state after the grids were refined after a step and the next start
  /// vector was built (not after the last step): a checkpoint there lets a restart continue with
  /// the next step (restore). An exception thrown by the hook ends run() (e.g. to stop on a signal).
  using StateHook = std::function<void(const AdaptiveLoopState&)>;
  void setStateHook(StateHook hook);
  /// Continues a loop from a state its state hook gave: replays state.refinements on the bodies'
  /// grids (which must be the initial grids of that loop, not yet refined) at once, so that the
  /// grids can be checked before run(); run() then begins with step state.nextStep and returns the
  /// records of all steps, state.steps first. obs::Error if the state does not fit the loop (another
  /// number of bodies, a marked cell outside its leaf view, nextStep outside [1, maxSteps - 1]).
  void restore(AdaptiveLoopState state);

  /// Runs the loop (see the file comment) and returns the records. A step whose contact solve did
  /// not converge is the last: it is recorded (converged = false) and passed to the callback, but
  /// not estimated (eta NaN) and not refined, so the caller can report it.
  std::vector<AdaptiveStep> run();
  /// The solution on the final leaf view (after run()): the bodies' displacements stacked in the
  /// order of the bodies (for one body, its displacement).
  const Eigen::VectorXd& displacement() const { return u_; }
  /// The options given to the constructor.
  const AdaptiveLoopOptions& options() const { return options_; }

private:
  template <int d>
  std::vector<AdaptiveStep> runDim();
  /// Assembles and solves step rec on the leaf views (the contact model of model_ and its problem,
  /// or linear elasticity without couplings) from `start` (warm starts); u the stacked
  /// displacements, x the problem's unknowns.
  template <int d>
  void solveStep(const std::vector<mesh::GridView>& views, const std::vector<const mesh::Grid*>& grids,
                 const Eigen::VectorXd& start, const std::vector<AdaptiveStep>& steps, AdaptiveStep& rec,
                 std::optional<ContactModel<d>>& model, std::optional<ContactProblem<d>>& problem, Eigen::VectorXd& u,
                 Eigen::VectorXd& x);
  /// The relative solver tolerance of step rec (AdaptiveLoopOptions::inexactFraction).
  double inexactTolerance(const std::vector<AdaptiveStep>& steps, const AdaptiveStep& rec, int d) const;

  void checkBody(int body, const std::string& what) const;

  std::vector<AdaptiveBody> bodies_;
  AdaptiveLoopOptions options_;
  ContactModelSpec model_;  ///< the bodies and couplings, built on every step's leaf views
  std::optional<ContactReference> reference_;
  Callback callback_;
  StateHook stateHook_;
  std::optional<AdaptiveLoopState> resume_;  ///< set by restore(), used by the next run()
  Eigen::VectorXd u_;
  double lastRate_ = 0;        ///< convergence rate of the previous step's contact solve
  double lastEnergyNorm_ = 0;  ///< free-component energy norm of the previous step's solution
};

/// eoc = (ln eta0 - ln eta1) / (ln n1 - ln n0) (docs/theory.md#eoc); NaN if undefined.
double experimentalOrder(double eta0, double n0, double eta1, double n1);

/// The reference errors of a solution (see the file comment; the centre vertex: the nearest,
/// equal distances by lexicographic position).
ReferenceErrors referenceErrors(const mesh::Mesh& mesh, const ContactSet& set, const ContactOutputs& outputs,
                                const ContactReference& reference);
/// The same on the ranks of a distributed run, from each rank's local mesh (its first
/// `ownedVertices` vertices owned, their rows and hence outputs complete): the load over the owned
/// nodes, the L2 sums over the boundary faces with countedFaces[f] != 0 (every face counted on one
/// rank), the radius and the centre vertex over all ranks (centreVertex: local, on the rank that
/// holds it; -1 on the others). Collective.
ReferenceErrors referenceErrors(const mesh::Mesh& mesh, const ContactSet& set, const ContactOutputs& outputs,
                                const ContactReference& reference, Index ownedVertices,
                                std::span<const char> countedFaces, const Communicator& comm);

}  // namespace obs::estimators
