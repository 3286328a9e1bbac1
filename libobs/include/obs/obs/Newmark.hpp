#pragma once
/// \file Newmark.hpp
/// Time stepping for dynamic contact of linear-elastic bodies with rigid obstacles and with each
/// other (dual mortar, ContactModel.hpp), frictionless or with the couplings' friction (Coulomb or
/// Tresca on the slip of each step, docs/theory.md#friction-dynamics): the Newmark family of the reference thesis (Sec. 5.2, 5.3; docs/theory.md#newmark), behind the TimeStepper
/// interface. Equation of motion M u'' + A u = f + contact forces, f the constant load of the
/// BoundaryConditions (body force, Neumann), Dirichlet values constant in time, time step tau.
/// Every step solves one variational inequality
///   S u^{n+1} = rhs + lambda,  u^{n+1} in K^{n+1},  S = M_s + c tau^2 A  (constant for fixed tau),
/// with TNNMG on the grid hierarchy (operators reused across steps, see TNNMG.hpp "Operator reuse");
/// lambda, the multiplier of the bounds, is c' tau^2 M F_con (c' below). K^{n+1} is the
/// non-penetration set nu_p'u_p <= g_p, or the discrete persistency set (Laursen-Chawla, HHW):
/// nu_p'(u^{n+1} - u^n)_p <= 0 at the nodes in contact or penetrated at t^n, no bound elsewhere.
///
/// Predictor (5.43), lumped M: u_pred = node-wise projection of u^n + tau v^n onto K; local impact
/// time tau*(p) from nu'u_pred = nu'u^n + tau* nu'v^n (tau* = tau where the predictor is inactive);
/// delta_p = (tau*(p) - tau) nu_p'v^n_p <= 0 is the normal predictor correction.
///
/// Schemes (name in scene files; all nodal parameters act on the normal component only):
///  - "contact-implicit" (Alg. 5.2.1; alpha = beta = 0), "contact-stabilized" (Alg. 5.2.2; alpha = 0,
///    beta = 1), "improved-contact-stabilized" (Alg. 5.3.2; alpha(p) = tau/(2(tau - tau*)) if
///    tau* <= tau/2, else 1, at nodes active in predictor and solution, 0 elsewhere; beta = 1 - alpha),
///    "alpha-half" (alpha = beta = 1/2 at every potential contact node), "alpha-one-zero" (alpha = 1 at
///    nodes active in predictor and solution, else 0; beta = 1 - alpha), the family of Alg. 5.3.1:
///      (M + tau^2/4 A) u^{n+1} = M(u^n + tau v^n + (alpha+beta) delta nu) - tau^2/4 A u^n + tau^2/2 f
///                                + tau^2/2 M F_con,   u^{n+1} in K,
///      v^{n+1} = (2/tau)(u^{n+1} - u^n - beta delta nu) - v^n.
///    With alpha + beta = 1 the displacement system is the contact-stabilized one (alpha chosen after
///    the solve).
///  - "classical" (5.21-5.22): (M + tau^2/4 A) u^{n+1} = M(u^n + tau v^n) - tau^2/4 A u^n + tau^2/2 f
///    + tau^2/4 (M F_con^n + M F_con^{n+1}), u^{n+1} in K; v^{n+1} = (2/tau)(u^{n+1} - u^n) - v^n.
///    Both contact forces enter with the same sign (the reaction of step n is stored); then
///    E^{n+1} - E^n = -1/2 (F^n + F^{n+1}).(u^{n+1} - u^n) with F = contactForces() (thesis (5.24)).
///  - "laursen-chawla" (Alg. 5.2.3): contact-implicit with the persistency set.
///  - "khenous-laborde-renard" (Alg. 5.2.4), redistributed mass M~ (MassRedistribution.hpp):
///    (M~ + tau^2/2 A) u^{n+1} = M~(u^n + tau v^n) + tau^2/2 (f + M F_con), u^{n+1} in K;
///    a^{n+1} = (2/tau^2)(u^{n+1} - u^n - tau v^n), v^{n+1} = v^n + tau/2 (a^n + a^{n+1});
///    a^0 solves M~ a^0 = f - A u^0 on the vertices with mass (0 at massless vertices, which never
///    influence the displacements).
///  - "hager-huebner-wohlmuth" (Alg. 5.2.5): (M~ + tau^2/4 A) u^{n+1} = M~(u^n + tau v^n)
///    - tau^2/4 A u^n + tau^2/2 (f + M F_con) with the persistency set, v^{n+1} = (2/tau)(u^{n+1} - u^n)
///    - v^n; "hager-huebner-wohlmuth-nonpenetration": the same with the non-penetration set.
/// The mass M is lumped by default; MassKind::Consistent is accepted by the schemes without a
/// predictor (classical, contact-implicit, laursen-chawla); the redistributed schemes start from the
/// consistent matrix (their M in the energy E is the lumped or consistent one as chosen).
///
/// Diagnostics per step (StepRecord): E = 1/2 v'Mv + 1/2 u'Au - f'u, E~ with M~, linear momentum M v
/// (and M~ v), the total contact force sum_p F_p nu_p with F_p the nodal multiplier divided by c'
/// tau^2 (c' = 1/2, 1/4 for classical), node counts active for solution / predictor / only one of
/// them, max penetration max_p (nu_p'u_p - g_p)^+, tracked vertices, solver iterations and time.
///
/// Several bodies (docs/theory.md#dynamic-two-body-contact). A ContactModel with several bodies and
/// dual-mortar pairs is the same computation on the stacked unknowns: M, A and f are stacked
/// block-diagonally, every contact quantity above is taken of the relative displacement x = (I - C) u
/// of the mortar basis transformation (ContactProblem.hpp), so nu_p'x_p is the normal jump
/// [u]_nu at slave node p and g_p its weighted gap. The predictor is the projection of u^n + tau v^n
/// onto {[u]_nu <= g} in the lumped-mass norm (thesis (5.43)); its correction is the pair of equal
/// and opposite forces -M^{-1} B'mu on both sides (B the mortar constraint rows, mu >= 0), computed by
/// a projected Gauss-Seidel iteration on the multipliers (Hildreth) over the contact zone only. For a
/// rigid obstacle B is diagonal and the projection is the node-wise formula above. The contact
/// forces are physical forces on both bodies (action = reaction), the linear momentum M v of free
/// bodies is conserved by every scheme (thesis (5.46)), and mass redistribution removes the mass of
/// the slave and the coupled master vertices, body by body (each body keeps its own mass, centre of
/// gravity and second moments).
///
/// A constraint is active in the predictor if the projected predictor lies on it (within the active
/// tolerance), not by the sign of its multiplier, which is round-off where the projection barely
/// moves the row.
///
/// Distributed (docs/architecture.md#distributed-dynamics): each body on a DistributedGrid, the
/// vectors in the local numbering of the rank's leaf view (owned vertices first, then ghosts; the
/// rows of the owned vertices complete), or for two bodies coupled by mortar in the numbering of
/// their DistributedMultiBody (owned vertices of both bodies, their ghosts, the extra ghosts).
/// Every step is the serial one: the matrices are assembled on the local meshes, the obstacle
/// predictor and the velocity update are node-wise, the mortar predictor iterates over the rows of
/// every rank (gathered), T'ST and the loads T'b are summed over the ranks, the step problem is
/// solved by distributed TNNMG, and the new state's ghosts are taken from their owners. Every
/// figure of a StepRecord is a sum or maximum over the owned vertices and the ranks, so every rank
/// holds the same record; the redistributed mass is computed with global multipliers
/// (redistributeMass with each body's owned rows) and the initial acceleration of
/// khenous-laborde-renard by a conjugate gradient iteration whose sums run over the ranks.
#include <Eigen/Core>

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMultiBody.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/MassMatrix.hpp"
#include "obs/obs/MassRedistribution.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/SolverConfig.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs {

enum class NewmarkScheme {
  Classical,
  ContactImplicit,
  ContactStabilized,
  ImprovedContactStabilized,
  AlphaHalf,
  AlphaOneZero,
  LaursenChawla,
  KhenousLabordeRenard,
  HagerHuebnerWohlmuth,
  HagerHuebnerWohlmuthNonPenetration,
};

/// Every scheme, in the order of the enum.
const std::vector<NewmarkScheme>& allNewmarkSchemes();
/// Scene-file name ("contact-stabilized", ...).
std::string_view name(NewmarkScheme scheme);
/// The scheme of a name; throws obs::Error listing the valid names for an unknown one.
NewmarkScheme newmarkSchemeFromName(std::string_view name);
/// Uses the redistributed mass matrix M~.
bool usesRedistributedMass(NewmarkScheme scheme);
/// Enforces the persistency set instead of the non-penetration set (penetration can occur).
bool usesPersistency(NewmarkScheme scheme);

enum class MassKind { Lumped, Consistent };

/// Initial iterate of TNNMG in a step (docs/theory.md#dynamic-warm-start). The step problem is posed for
/// the increment w = u^{n+1} - base, base = u^n + tau v^n (corrected by the contact predictor for the
/// schemes with one):
///  - Predictor: w = 0, i.e. u^{n+1} starts at base (the default);
///  - PreviousIncrement: w = the increment the previous step solved for, w^{n-1} = u^n - base^{n-1}
///    (about tau^2/2 times the acceleration, so it extrapolates the motion with constant acceleration;
///    0 in the first step). The solver projects it onto the step's admissible set.
/// Both solve the same problem to the same tolerance; they differ in the iterations needed.
enum class NewmarkStart { Predictor, PreviousIncrement };
/// Scene-file name ("predictor", "previous-increment").
std::string_view name(NewmarkStart start);
/// The start of a name; throws obs::Error listing the valid names for an unknown one.
NewmarkStart newmarkStartFromName(std::string_view name);

struct NewmarkOptions {
  NewmarkScheme scheme = NewmarkScheme::ImprovedContactStabilized;
  double timeStep = 0;  ///< tau > 0
  MassKind mass = MassKind::Lumped;
  /// The solver of every step (SolverConfig.hpp): TNNMG, the only kind time stepping takes; its
  /// tolerance is the relative energy-norm correction of the step's increment, and reaching its
  /// iteration cap is an obs::Error.
  SolverConfig solver;
  /// Inexact solves (docs/theory.md#dynamic-inexact-solves): f > 0 solves step n+1 only to the
  /// relative tolerance clamp(f * eta_n / ||w_n||_S * (1 - rho_n) / rho_n, solver.tolerance, 1e-2),
  /// eta_n the local time-error estimate of step n (StepRecord::timeError), w_n its increment,
  /// rho_n its TNNMG convergence rate (clamped to [0.05, 0.9]); the first two steps (no estimate
  /// yet) use solver.tolerance. 0 (default): every step to solver.tolerance. Must lie in [0, 1).
  double inexactFraction = 0;
  /// Initial iterate of each step's solve (NewmarkStart).
  NewmarkStart start = NewmarkStart::Predictor;
  /// A node counts as active (in contact) if g_p - nu_p'u_p <= activeTolerance * U, U = max(|u|_inf,
  /// finite |g_p|, 1e-300).
  double activeTolerance = 1e-8;
  /// Vertices whose displacement and velocity are reported in every record (stacked numbering of
  /// the bodies for a ContactModel). Distributed: the local index on the rank that owns the vertex
  /// and -1 on the others (every rank lists the same number of entries).
  std::vector<Index> trackedVertices;
  /// Predictor of a mortar model (Hildreth iteration on the multipliers): relative tolerance of the
  /// constraint residual and the sweep cap (obs::Error if reached).
  double predictorTolerance = 1e-13;
  int maxPredictorSweeps = 10000;
  MassRedistributionOptions redistribution;
};

struct DynamicState {
  int step = 0;
  double time = 0;
  Eigen::VectorXd u, v;  ///< displacement, velocity (vertex-major)
  Eigen::VectorXd a;     ///< acceleration (khenous-laborde-renard only; empty otherwise)
};

struct TrackedVertex {
  Index vertex = -1;
  bool contactNode = false;  ///< normal values are defined (ContactSet direction) only then (else 0)
  /// displacement, velocity: of the vertex; normalDisplacement, normalVelocity, gap: of the relative
  /// displacement x = (I - C) u (mortar slave nodes: the normal jump), = the vertex's for obstacles
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero(), velocity = Eigen::Vector3d::Zero();
  double normalDisplacement = 0, normalVelocity = 0;
  double gap = 0;  ///< g_p - nu'u_p (contact nodes)
};

struct StepRecord {
  int step = 0;
  double time = 0;
  double kineticEnergy = 0;  ///< 1/2 v'Mv
  double elasticEnergy = 0;  ///< 1/2 u'Au
  double loadPotential = 0;  ///< -f'u
  double energy = 0;         ///< sum of the three
  bool hasRedistributed = false;
  double kineticEnergyRedistributed = 0;  ///< 1/2 v'M~v (hasRedistributed)
  double energyRedistributed = 0;         ///< E~ (hasRedistributed)
  /// khenous-laborde-renard (Newmark beta = gamma = 1/2): accelerationEnergy = tau^2/8 a'M~a and
  /// energyModified = E~ + tau^2/8 a'M~a, the quantity the scheme conserves exactly without contact
  /// (E and E~ alone drift by O(tau^2); docs/theory.md#newmark, docs/dynamics.md "Energies").
  bool hasAcceleration = false;
  double accelerationEnergy = 0;
  double energyModified = 0;
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();              ///< M v (summed per component)
  Eigen::Vector3d momentumRedistributed = Eigen::Vector3d::Zero();  ///< M~ v (hasRedistributed)
  /// sum_p F_p nu_p over the contact nodes: the force on the obstacles, and for mortar pairs the
  /// force the slave side exerts on the master side (the total over both bodies is zero).
  Eigen::Vector3d contactForce = Eigen::Vector3d::Zero();
  Index activeSolution = 0, activePredictor = 0, predictorOnly = 0, solutionOnly = 0;
  double maxPenetration = 0;
  std::vector<TrackedVertex> tracked;
  int solverIterations = 0;
  /// TNNMG's convergence rate in this step: the geometric mean of the ratios of successive relative
  /// corrections, (c_last / c_1)^(1 / (iterations - 1)) (NaN below two iterations, in the record of
  /// the initial state and after a restart). From the predictor the first correction is 1.
  double solverRate = std::numeric_limits<double>::quiet_NaN();
  double solverSeconds = 0;
  double stepSeconds = 0;
  /// The relative TNNMG tolerance this step was solved to (NaN in the record of the initial state).
  double solverTolerance = std::numeric_limits<double>::quiet_NaN();
  /// KKT residual KktResiduals::max() of the step's contact solve (NaN in the record of the initial
  /// state and after a restart).
  double solverKkt = std::numeric_limits<double>::quiet_NaN();
  /// TNNMG's bound of the relative error of the step's solution, ContactResult::errorBound (NaN where
  /// the step problem has no diagonal lower bound, docs/theory.md#tnnmg-error-bound, in the record of
  /// the initial state and after a restart).
  double solverErrorBound = std::numeric_limits<double>::quiet_NaN();
  /// Local time-error estimate eta = |beta - 1/6| tau ||v^{n+1} - 2 v^n + v^{n-1}||_S of the step
  /// (docs/theory.md#dynamic-inexact-solves); computed only with NewmarkOptions::inexactFraction > 0
  /// and from the second step on, NaN otherwise.
  double timeError = std::numeric_limits<double>::quiet_NaN();
  /// Friction (couplings with a FrictionLaw; docs/theory.md#friction-dynamics): the energy dissipated
  /// by friction from t = 0 to this step, sum over steps and contact nodes of |F_T| |(u^{n+1} - u^n)_T|
  /// (F_T the physical friction force); the total friction force on the obstacles / the master sides
  /// (as contactForce); the contact nodes in stick and in slip; the Tresca solves of the step's
  /// Coulomb fixed point. All 0 without friction.
  double frictionDissipation = 0;
  Eigen::Vector3d frictionForce = Eigen::Vector3d::Zero();
  Index stickNodes = 0, slipNodes = 0;
  int frictionSolves = 0;
};

/// Everything a NewmarkFamily carries from one step to the next, for checkpoint/restart
/// (Checkpoint.hpp): with the same grid, material, loads, contact set and options, a stepper set to
/// this state continues bitwise as the one it was taken from. The predictor, active sets and bounds
/// of a step are functions of (u^n, v^n) and are recomputed; the operators are rebuilt.
struct NewmarkSchemeState {
  std::string scheme;                  ///< name(NewmarkScheme) of the stepper
  DynamicState state;                  ///< step, time, u^n, v^n (a^n: khenous-laborde-renard)
  Eigen::VectorXd multiplier;          ///< nodal multiplier lambda of the last step (contact force)
  Eigen::VectorXd previousMultiplier;  ///< classical: lambda^n, part of the next right-hand side
  /// Counters of the last step's StepRecord that the state alone does not determine.
  Index activePredictor = 0, predictorOnly = 0, solutionOnly = 0;
  int solverIterations = 0;
  /// Inexact solves (NewmarkOptions::inexactFraction > 0; empty / 0 otherwise): v^{n-1} and the
  /// tolerance of the next step, so that a restarted run continues bitwise.
  Eigen::VectorXd previousVelocity;
  double nextSolverTolerance = 0;
  /// NewmarkStart::PreviousIncrement: the increment of the last step in the problem unknowns (relative
  /// for mortar pairs; empty before the first step and for the other start).
  Eigen::VectorXd previousIncrement;
  /// Friction: the dissipated energy up to this state (StepRecord::frictionDissipation; 0 without).
  double frictionDissipation = 0;
};

/// Stores a Newmark stepper's state (NewmarkFamily::schemeState) under "scheme/" of a checkpoint
/// record (Checkpoint.hpp): name, step, time, displacement, velocity, acceleration, multiplier,
/// previous_multiplier and the counters of the last step; with inexact solves also
/// previous_velocity and next_solver_tolerance, with the previous-increment warm start
/// previous_increment, with friction friction_dissipation (loaded when present).
void storeNewmarkState(CheckpointRecord& record, const NewmarkSchemeState& state);
/// The state stored by storeNewmarkState (obs::Error naming a missing entry).
NewmarkSchemeState loadNewmarkState(const CheckpointRecord& record);

/// A time integrator for dynamic contact: initialise with u^0, v^0, then step().
template <int d>
class TimeStepper {
public:
  virtual ~TimeStepper() = default;
  virtual std::string name() const = 0;
  /// Sets the initial state. Throws obs::Error on wrong sizes, non-finite values, Dirichlet
  /// components that differ from the prescribed values (u) or zero (v), or u^0 violating a contact
  /// constraint (beyond the active tolerance).
  virtual void initialize(const Eigen::VectorXd& u0, const Eigen::VectorXd& v0) = 0;
  /// Advances by one time step and returns its record. Throws obs::Error if not initialised, if the
  /// solver fails or a value becomes non-finite.
  virtual StepRecord step() = 0;
  virtual const DynamicState& state() const = 0;
  /// Diagnostics of the current state (solver fields of the last step).
  virtual StepRecord record() const = 0;
};

template <int d>
class NewmarkFamily : public TimeStepper<d> {
public:
  /// The body is the leaf mesh of `grid` (the multigrid hierarchy of TNNMG is the grid's); the
  /// contact set must be built on grid.leafView().mesh. Assembles A, M (and M~), f, the system
  /// matrix and the solver. Throws obs::Error for tau <= 0 (or non-finite), an invalid material
  /// (density rho > 0), dimension/size mismatches, a mass kind the scheme does not support, and (schemes
  /// with M~) a step matrix S = M~ + c tau^2 A that is not positive definite: M~ is checked on the
  /// vertices that keep mass by one scalar sparse LDL' (checkPositiveDefinite); only if M~ is indefinite
  /// (coarse meshes whose contact layer carries much of the mass) S is factorised by CHOLMOD. The message
  /// says to refine near the contact boundary or to use a scheme without redistribution. An indefinite M~
  /// with a positive definite S is accepted (redistributedMassDefiniteness() reports it): its modes with
  /// x'M~x < 0 grow, slowly when c tau^2 A dominates, so callers should warn.
  NewmarkFamily(const mesh::Grid& grid, const Material& material, const BoundaryConditions& bc,
                const ContactSet& contact, const NewmarkOptions& options);
  /// Several bodies: grids[i] is the grid of model body i (its leaf mesh is the body's mesh); the
  /// model's couplings (obstacles, mortar pairs) are built by ContactModel::assembleParts() and the
  /// TNNMG hierarchy is the bodies' grids block-stacked. The one-body constructor above is this one
  /// with a model of one body and one obstacle coupling. Throws as above, and obs::Error if the grids
  /// do not match the bodies or the model cannot be assembled.
  NewmarkFamily(const std::vector<const mesh::Grid*>& grids, ContactModel<d>& model, const NewmarkOptions& options);
  /// Distributed (collective; see the file comment): one body on `grid` with its obstacle couplings
  /// (friction allowed), the model's body on the rank's local mesh leaf.local of its leaf view `leaf`
  /// (grid.view(); both must outlive the stepper). Vectors (initial state, state(), forces) are in
  /// the local numbering of the leaf view, with the ghosts' values those of their owners. Throws, on
  /// every rank, what the serial constructor throws, and obs::Error for a model of several bodies or
  /// a body on another mesh.
  NewmarkFamily(const DistributedGrid& grid, const DistributedView& leaf, ContactModel<d>& model,
                const NewmarkOptions& options);
  /// Distributed, any number of bodies (collective; the constructor above is this one with one
  /// body): body i of `model` on grids[i], its mesh the rank's local mesh leaves[i]->local of its leaf
  /// view. One body: obstacle couplings as above. Two bodies: `coupled` is the DistributedMultiBody
  /// of these views and of the model's one mortar pair (the only coupling; frictionless), built
  /// from any systems of the bodies (only its numbering, constraints and C are used); its local
  /// numbering is the stepper's (vectors have coupled->numLocal() vertices, tracked vertices are
  /// its owned local indices). Grids, views and `coupled` must outlive the stepper. Throws, on
  /// every rank, what the serial constructors throw, and obs::Error for bodies on other meshes, a
  /// coupling the distributed stepper does not take, or friction on a mortar pair.
  NewmarkFamily(const std::vector<const DistributedGrid*>& grids, const std::vector<const DistributedView*>& leaves,
                ContactModel<d>& model, const NewmarkOptions& options,
                const DistributedMultiBody<d>* coupled = nullptr);
  ~NewmarkFamily() override;

  std::string name() const override { return std::string(obs::name(options_.scheme)); }
  void initialize(const Eigen::VectorXd& u0, const Eigen::VectorXd& v0) override;
  StepRecord step() override;
  const DynamicState& state() const override { return state_; }
  StepRecord record() const override;

  const NewmarkOptions& options() const { return options_; }
  const BlockSparseMatrix<d>& stiffness() const { return A_; }
  /// The standard mass matrix M (lumped or consistent) as a block matrix.
  const BlockSparseMatrix<d>& mass() const { return M_; }
  /// M~ (redistributed schemes; throws obs::Error otherwise).
  const RedistributedMass& redistributedMass() const;
  /// Inertia check of M~ on the vertices that keep mass (redistributed schemes; throws obs::Error
  /// otherwise): positiveDefinite false means M~ is indefinite but S was positive definite.
  /// Distributed: not checked (checked false; the check is one sparse factorisation of the whole
  /// M~), see docs/architecture.md#distributed-dynamics.
  const DefinitenessCheck& redistributedMassDefiniteness() const;
  const Eigen::VectorXd& load() const { return f_; }
  const ContactProblem<d>& problem() const { return *problem_; }
  /// Energy E(u, v) = 1/2 v'Mv + 1/2 u'Au - f'u (distributed: summed over the ranks, collective).
  double energy(const Eigen::VectorXd& u, const Eigen::VectorXd& v) const;
  /// Nodal contact forces of the last step on the obstacle, F_p nu_p per vertex (vertex-major, zero
  /// away from the contact nodes; all zero after initialize()): the multiplier divided by c' tau^2.
  /// The force on the body is -F; StepRecord::contactForce is its sum over the vertices. Mortar
  /// pairs: F = (I - C') F~ with F~ the nodal multipliers at the slave nodes, i.e. the slave and the
  /// master vertices carry equal and opposite totals (the force on the bodies is -F). Distributed
  /// bodies coupled by mortar: collective (the slave rows' parts summed at the masters' owners).
  Eigen::VectorXd contactForces() const;
  /// The same forces of the last step at the constrained nodes, before the mortar transformation:
  /// F~ = the multipliers of the bounds divided by c' tau^2, F~_p nu_p at the vertex of contact
  /// node p (vertex-major, zero elsewhere), so contactForces() = (I - C') F~ and
  /// StepRecord::contactForce is the sum of F~. At an obstacle node F~_p = F_p; at a mortar slave
  /// node F~_p = D_pp lambda_p, so F~_p / m_p^C (ContactSet::boundaryMass = D_pp) is the dual-mortar
  /// pressure lambda_p, the contact_pressure of the static scenes (computeContactOutputs). Without
  /// mortar pairs the vector equals contactForces() bitwise.
  Eigen::VectorXd nodalContactForces() const;
  /// Friction (docs/theory.md#friction-dynamics): the friction forces F_T of the last step at the
  /// constrained nodes (physical forces of the body on the obstacle / the slave side on the master,
  /// stacked vertex-major; zero elsewhere, empty without friction or before the first step), and
  /// per contact node (ContactSet numbering) 0 not in contact, 1 stick, 2 slip.
  const Eigen::VectorXd& frictionForces() const { return frictionForces_; }
  const std::vector<char>& frictionStates() const { return frictionStates_; }
  /// The state between steps (checkpoints; throws obs::Error before initialize()).
  NewmarkSchemeState schemeState() const;
  /// Continues from a state taken by schemeState() of a stepper built on the same problem (restart).
  /// Throws obs::Error for another scheme, wrong vector sizes or non-finite values.
  void setSchemeState(const NewmarkSchemeState& s);

private:
  struct Predictor;
  struct PredictorRows;
  void init(const std::vector<const mesh::Grid*>& grids, ContactModel<d>& model,
            const std::vector<const DistributedGrid*>& distributed = {});
  /// The mortar predictor's constraint rows of every rank (setupStepProblem; collective).
  void setupPredictorRows();
  /// Values per owned predictor row (`width` each, in the rank's row order) of every rank, in the
  /// order of PredictorRows::rows (serial: the values themselves; collective).
  std::vector<double> gatherRows(const std::vector<double>& own, int width) const;
  /// Runs local work so that an error on one rank reaches every rank (Communicator::collective)
  /// instead of leaving the others in the next reduction; serially the work alone.
  void collective(const std::function<void()>& work) const;
  /// Sums of x over the ranks (in place; serial: nothing), the maximum, and whether a flag is set on
  /// any rank. Distributed figures are sums over the owned vertices (the first owned_).
  void sum(std::vector<double>& x) const;
  double maximum(double x) const;
  bool anyRank(bool flag) const;
  /// x'y over the owned entries, summed over the ranks.
  double dot(const Eigen::VectorXd& x, const Eigen::VectorXd& y) const;
  /// Overwrites the ghost entries of a state vector with the owners' values (serial: nothing).
  void updateGhosts(Eigen::VectorXd& x) const;
  /// The checks of initialize(): sizes, finite values, Dirichlet components; u^0 against the
  /// contact constraints (owned nodes) with the active tolerance `tol`.
  void checkInitialState(const Eigen::VectorXd& u0, const Eigen::VectorXd& v0) const;
  void checkInitialContact(const Eigen::VectorXd& u0, double tol) const;
  /// khenous-laborde-renard: a^0 from M~ a^0 = f - A u^0 (initialize()).
  Eigen::VectorXd initialAcceleration(const Eigen::VectorXd& u0) const;
  /// The steps of init: the options and the grids against the model; the lumped and (where needed)
  /// consistent masses, stacked like the stiffness, and M; the redistributed mass M~ with its checks;
  /// the step matrix S = M_s + c tau^2 A (checked when M~ is indefinite); the step problem for the
  /// increments with the effective constraints and the predictor rows of mortar pairs.
  void checkInputs(const std::vector<const mesh::Grid*>& grids, const ContactModel<d>& model) const;
  void assembleMasses(const ContactModel<d>& model, const ContactSet& contact);
  void redistributeMasses(const ContactModel<d>& model, const std::vector<ScalarSparseMatrix>& consistentPerBody,
                          const ContactSet& contact);
  BlockSparseMatrix<d> stepMatrix(const ContactSet& contact) const;
  void setupStepProblem(BlockSparseMatrix<d> S);
  /// The effective constraints for u and the gaps (setupStepProblem, local work).
  void setupConstraints();
  void checkInitialized() const;
  /// x = (I - C) u (a copy of u without mortar pairs).
  Eigen::VectorXd relative(const Eigen::VectorXd& u) const;
  /// (I - C') y: nodal multipliers at the slave nodes as forces on both sides.
  Eigen::VectorXd physicalForce(const Eigen::VectorXd& y) const;
  /// The predictor correction weighted per contact node, -M^{-1} B'(w mu) (mortar) or w delta nu.
  Eigen::VectorXd predictorCorrection(const Predictor& p, const std::vector<double>& weight) const;
  void computePredictor(Predictor& p) const;
  /// M x with the standard (redistributed: false) or the system's mass (redistributed: true).
  Eigen::VectorXd applyMass(const Eigen::VectorXd& x, bool redistributed) const;
  double activeTolerance(const Eigen::VectorXd& u) const;
  /// The tolerance of the next step from this step's time-error estimate, increment norm and
  /// convergence rate (NewmarkOptions::inexactFraction; docs/theory.md#dynamic-inexact-solves).
  double inexactTolerance(double timeError, double incrementNorm, double rate) const;
  StepRecord makeRecord() const;

  NewmarkOptions options_;
  Index numVertices_ = 0;
  BlockSparseMatrix<d> A_, M_, Mr_, S_;  ///< stiffness, standard mass, M~, system matrix
  Eigen::VectorXd lumped_;  ///< lumped masses (scalar per vertex)
  std::unique_ptr<RedistributedMass> redistributed_;
  DefinitenessCheck redistributedCheck_;
  Eigen::VectorXd f_;
  DirichletValues dirichlet_;
  std::unique_ptr<ContactSet> contact_;
  std::unique_ptr<ContactProblem<d>> problem_;  ///< system matrix S, rhs and bounds of a step
  std::vector<typename ContactProblem<d>::Constraint> constraints_;  ///< effective, non-penetration
  std::vector<double> gaps_;                     ///< physical gaps of the ContactSet
  std::unique_ptr<TNNMG<d>> solver_;
  NodalFriction friction_;          ///< of the model's couplings (empty: frictionless)
  bool frictional_ = false;         ///< friction on a coupling with contact nodes (on some rank)
  double frictionDissipation_ = 0;  ///< StepRecord::frictionDissipation of the current state
  Eigen::VectorXd frictionForces_;  ///< frictionForces()
  std::vector<char> frictionStates_;  ///< frictionStates()
  mesh::CsrMatrix basis_;          ///< C of the mortar pairs (rows() == 0: none)
  std::unique_ptr<PredictorRows> rows_;  ///< mortar: the constraint rows B of the predictor
  DynamicState state_;
  bool initialized_ = false;
  Eigen::VectorXd previousMultiplier_;  ///< classical: tau^2/4 M F_con^n as a nodal vector
  Eigen::VectorXd multiplier_;          ///< nodal multiplier vector of the last step
  double multiplierFactor_ = 0.5;       ///< c' (lambda = c' tau^2 M F_con)
  Eigen::VectorXd previousVelocity_;    ///< inexact solves: v^{n-1} (empty before the first step)
  double nextTolerance_ = 0;            ///< inexact solves: tolerance of the next step (0: options.solver.tolerance)
  Eigen::VectorXd previousIncrement_;   ///< NewmarkStart::PreviousIncrement: w of the last step (else empty)
  Eigen::VectorXd Au_;                  ///< A u^n of the current state (energy and the next right-hand side)
  StepRecord last_;
  /// Distributed (the constructor on a DistributedGrid): the communicator and the leaf view's halo;
  /// owned_ the rank's owned vertices (serial: every vertex).
  const Communicator* comm_ = nullptr;
  const HaloExchange* halo_ = nullptr;
  Index owned_ = 0;
  /// Distributed bodies coupled by mortar: their numbering, constraints and C (null otherwise).
  const DistributedMultiBody<d>* multi_ = nullptr;
  /// The stepper's (stacked) index of each body vertex, and each body's owned vertices (its first
  /// ones in its own numbering; serial: -1).
  std::vector<std::vector<Index>> bodyVertices_;
  std::vector<Index> bodyOwned_;
};

/// A stepper by scheme (the factory of scene files).
template <int d>
std::unique_ptr<TimeStepper<d>> makeTimeStepper(const mesh::Grid& grid, const Material& material,
                                                const BoundaryConditions& bc, const ContactSet& contact,
                                                const NewmarkOptions& options);
/// A stepper for a contact model of several bodies (grids[i]: body i).
template <int d>
std::unique_ptr<TimeStepper<d>> makeTimeStepper(const std::vector<const mesh::Grid*>& grids, ContactModel<d>& model,
                                                const NewmarkOptions& options);

extern template class NewmarkFamily<2>;
extern template class NewmarkFamily<3>;

}  // namespace obs
