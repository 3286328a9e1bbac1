#include "obs/drivers/DynamicScene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <utility>
#include <variant>

#include <nlohmann/json.hpp>

#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/SceneSolver.hpp"
#include "obs/drivers/SolutionFields.hpp"
#include "obs/drivers/Summary.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/DistributedMultiBody.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/Newmark.hpp"
#include "DistributedOutput.hpp"
#include "PlotScript.hpp"
#include "RunCheckpoint.hpp"
#include "RunSupport.hpp"

#ifndef OBS_DYNAMICS_PLOT_SCRIPT
#define OBS_DYNAMICS_PLOT_SCRIPT "scripts/plot_dynamics.py"
#endif

namespace obs::drivers {

namespace {

namespace fs = std::filesystem;

std::string fmt(double x, int precision = 6) {
  std::ostringstream os;
  os << std::setprecision(precision) << x;
  return os.str();
}

/// Contact times of one tracked vertex (NaN: did not happen).
struct TrackedTimes {
  double firstContact = std::numeric_limits<double>::quiet_NaN();
  double detachment = std::numeric_limits<double>::quiet_NaN();  ///< gap open again
  double release = std::numeric_limits<double>::quiet_NaN();     ///< nu'v < 0 after contact
  double velocityScale = 1e-300;                                  ///< max |nu'v| so far
};

struct TrackedInfo {
  mesh::Point requested = mesh::Point::Zero();
  mesh::Index vertex = -1;  ///< stacked vertex (distributed: global index)
  /// the vertex the stepper reports (NewmarkOptions::trackedVertices): serially `vertex`;
  /// distributed its local index on the rank that owns it, -1 on the others
  mesh::Index stepperVertex = -1;
  mesh::Point position = mesh::Point::Zero();
  bool contactNode = false;
  double distance = 0;
};

/// Figures of one scheme's run.
struct SchemeRun {
  std::string scheme;
  int steps = 0;
  double setupSeconds = 0, stepSeconds = 0, solverSeconds = 0;
  long long iterations = 0;
  int maxIterations = 0;
  double initialEnergy = 0, finalEnergy = 0;
  bool hasRedistributed = false;
  double initialEnergyRedistributed = 0, finalEnergyRedistributed = 0;
  /// M~ (hasRedistributed): entries at the lower bound theta M_ij, smallest M~_ij / M_ij, definiteness
  long long redistributionBounded = 0;
  double redistributionMinFactor = 1;
  bool redistributionPositiveDefinite = true;
  bool redistributionChecked = true;  ///< false: not computed (distributed runs)
  double maxPenetration = 0;
  double forceVariation = 0;  ///< sum_n |F^{n+1} - F^n| (total variation of the contact force)
  double maxForce = 0;        ///< max_n |F^n|
  long long maxActive = 0;
  /// smallest and largest TNNMG tolerance of a step (they differ only with [dynamics] inexact)
  double minTolerance = std::numeric_limits<double>::infinity(), maxTolerance = 0;
  std::vector<TrackedTimes> times;
  StepRecord last;
  Eigen::VectorXd u, v;
  fs::path timeseries;
  std::vector<fs::path> vtuFiles;   ///< listed by the .pvd (distributed: the .pvtu files)
  std::vector<fs::path> pieceFiles;  ///< distributed: the ranks' pieces of them (rank 0)
  std::vector<double> vtuTimes;
};

/// Two distributed bodies coupled by mortar (runDistributedDynamicScene): the pair's rows and
/// DistributedMultiBody, whose numbering is the run's stacked numbering, in the run's dimension.
struct Coupled {
  std::unique_ptr<DistributedMortar> mortar;
  std::variant<std::unique_ptr<DistributedMultiBody<2>>, std::unique_ptr<DistributedMultiBody<3>>> multi;
  template <int d>
  const DistributedMultiBody<d>* get() const {
    const auto* m = std::get_if<std::unique_ptr<DistributedMultiBody<d>>>(&multi);
    return m ? m->get() : nullptr;
  }
  template <typename F>
  decltype(auto) visit(F&& f) const {
    return std::visit([&](const auto& m) -> decltype(auto) { return f(*m); }, multi);
  }
};

struct Context {
  const Scene& scene;
  const RunOptions& options;
  const ContactSet& contact;
  const SceneCouplings& couplings;  ///< the contact model of the scene without meshes
  const std::vector<TrackedInfo>& tracked;
  Eigen::VectorXd u0, v0;
  int steps = 0;
  fs::path dir;
  /// Checkpoints (first scheme of a run without comparison): written to checkpointFile on the
  /// [output] checkpoint schedule, on SIGINT/SIGTERM and at --stop-after-step.
  bool checkpointing = false;
  fs::path checkpointFile;
  const CheckpointRecord* restart = nullptr;  ///< --restart: the checkpoint to continue from
  fs::path restartFile;
  /// The bodies in stacked order (Scene::bodyScenes: grid, leaf mesh, boundary conditions, first
  /// stacked vertex).
  /// Distributed: the body's grid and the rank's leaf view (whose local mesh is `mesh`).
  struct Body {
    const Scene* spec = nullptr;
    const mesh::Grid* grid = nullptr;
    const mesh::Mesh* mesh = nullptr;
    const BoundaryConditions* bc = nullptr;
    std::vector<Index> index;  ///< the stacked (distributed: local) index of each vertex of mesh
    const DistributedGrid* distributed = nullptr;
    const DistributedView* leaf = nullptr;
  };
  std::vector<Body> bodies;
  OutputLayout layout;
  /// A distributed run (runDistributedDynamicScene, docs/architecture.md#distributed-dynamics): the
  /// communicator (null for one process) and, for two bodies, their DistributedMultiBody, whose
  /// local numbering is the stacked one. Rank 0 writes the time series, the .pvd and summary.json;
  /// every rank writes its piece of each .vtu.
  const Communicator* comm = nullptr;
  const Coupled* coupled = nullptr;
  /// The checkpoint rows (docs/checkpoint.md#rows): the key of every stacked (local) vertex, and the
  /// vertices whose rows this process writes (the first `owned`; one process: all).
  std::vector<std::uint64_t> keys;
  Index owned = 0;
  /// The body and its vertex of every stacked vertex (-1: an extra ghost of a distributed pair).
  std::vector<int> bodyOf;
  std::vector<Index> vertexOf;
  bool writer() const { return !comm || comm->rank() == 0; }
  /// Runs local work so that an error on one rank reaches every rank (Communicator::collective).
  void collective(const std::function<void()>& work) const {
    if (comm)
      comm->collective(work);
    else
      work();
  }
  double maximum(double x) const { return comm ? comm->max(x) : x; }
};

/// The bodies whose grids a checkpoint identifies, in stacked order, named as in the layout's files
/// (a one-body file: ""), known by their vertex keys (the checkpoints hold rows; distributed: the
/// rank's owned vertices and cells, collective).
std::vector<RunBody> runBodies(const std::vector<Context::Body>& bodies, const OutputLayout& layout,
                               const Communicator* comm = nullptr) {
  std::vector<RunBody> out;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    RunBody r{layout.perBody() ? bodies[b].spec->name : std::string(), bodies[b].mesh};
    r.keyed = true;
    r.index = b;
    if (const DistributedView* leaf = bodies[b].leaf) {
      r.comm = comm;
      r.ownedVertices = leaf->halo.numOwned();
      r.ownedCells = static_cast<Index>(leaf->part.owned.size());
    }
    out.push_back(r);
  }
  return out;
}

/// A Newmark state in a checkpoint record with rows: the per-vertex vectors of scheme/ (those of the
/// stacked length n_local * d) as rows of the owned vertices, with their keys (docs/checkpoint.md#rows).
void storeStateRows(CheckpointRecord& cp, const Context& c, int d) {
  const auto local = static_cast<Eigen::Index>(c.keys.size()) * d;
  const auto owned = static_cast<Eigen::Index>(c.owned) * d;
  std::vector<std::pair<std::string, CheckpointRecord::Entry>> rows;
  for (const auto& [name, e] : cp.entries())
    if (name.rfind("scheme/", 0) == 0)
      if (const auto* x = std::get_if<Eigen::VectorXd>(&e.value); x && x->size() == local && local > 0)
        rows.emplace_back(name, CheckpointRecord::Entry{Eigen::VectorXd(x->head(owned)), e.description});
  for (auto& [name, e] : rows) cp.setRows(name, std::move(e.value), d, e.description);
  cp.setRowKeys(std::vector<std::uint64_t>(c.keys.begin(), c.keys.begin() + static_cast<std::ptrdiff_t>(c.owned)));
}

/// The driver's running figures of a scheme run (SchemeRun) in a checkpoint, "run/...", with the
/// length and hash of the time series written so far.
void storeSchemeRun(CheckpointRecord& cp, const SchemeRun& run, long long csvBytes, std::uint64_t csvHash) {
  cp.set("run/steps", static_cast<long long>(run.steps), "time steps done");
  cp.set("run/solver_iterations", run.iterations, "TNNMG iterations, all steps so far");
  cp.set("run/max_solver_iterations", static_cast<long long>(run.maxIterations), "max TNNMG iterations of a step");
  cp.set("run/setup_seconds", run.setupSeconds, "wall time of the stepper setup (first run)");
  cp.set("run/step_seconds", run.stepSeconds, "wall time of the steps so far");
  cp.set("run/solver_seconds", run.solverSeconds, "wall time of TNNMG so far");
  cp.set("run/initial_energy", run.initialEnergy, "energy E of the initial state");
  cp.set("run/initial_energy_redistributed", run.initialEnergyRedistributed, "E~ of the initial state (M~ schemes)");
  cp.set("run/has_redistributed", static_cast<long long>(run.hasRedistributed), "1: the scheme has M~");
  cp.set("run/max_penetration", run.maxPenetration, "max penetration so far");
  cp.set("run/contact_force_variation", run.forceVariation, "sum_n |F^{n+1} - F^n| so far");
  cp.set("run/max_contact_force", run.maxForce, "max_n |F^n| so far");
  cp.set("run/max_active_nodes", run.maxActive, "max nodes in contact so far");
  if (run.steps > 0) {
    cp.set("run/min_solver_tolerance", run.minTolerance, "smallest TNNMG tolerance of a step so far");
    cp.set("run/max_solver_tolerance", run.maxTolerance, "largest TNNMG tolerance of a step so far");
  }
  Eigen::VectorXd first(run.times.size()), detach(run.times.size()), release(run.times.size()),
      scale(run.times.size());
  for (std::size_t k = 0; k < run.times.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    first[i] = run.times[k].firstContact;
    detach[i] = run.times[k].detachment;
    release[i] = run.times[k].release;
    scale[i] = run.times[k].velocityScale;
  }
  cp.set("run/tracked_first_contact_time", first, "per tracked point: first contact time (NaN: none yet)");
  cp.set("run/tracked_detachment_time", detach, "per tracked point: time the gap opened again (NaN: none yet)");
  cp.set("run/tracked_release_time", release, "per tracked point: time nu'v < 0 after contact (NaN: none yet)");
  cp.set("run/tracked_velocity_scale", scale, "per tracked point: max |nu'v| so far");
  std::string files;
  for (const fs::path& f : run.vtuFiles) files += f.filename().string() + "\n";
  Eigen::VectorXd times(static_cast<Eigen::Index>(run.vtuTimes.size()));
  for (std::size_t k = 0; k < run.vtuTimes.size(); ++k) times[static_cast<Eigen::Index>(k)] = run.vtuTimes[k];
  cp.set("run/vtu_files", files, "the .vtu files written so far (output directory), one per line");
  cp.set("run/vtu_times", times, "their times (the .pvd collection)");
  cp.set("run/timeseries_bytes", csvBytes, "bytes of the time series written up to this step");
  cp.set("run/timeseries_hash", hexHash(csvHash), "FNV-1a 64 of those bytes");
}

void restoreSchemeRun(const CheckpointRecord& cp, SchemeRun& run, const fs::path& dir) {
  run.steps = static_cast<int>(cp.integer("run/steps"));
  run.iterations = cp.integer("run/solver_iterations");
  run.maxIterations = static_cast<int>(cp.integer("run/max_solver_iterations"));
  run.setupSeconds = cp.real("run/setup_seconds");
  run.stepSeconds = cp.real("run/step_seconds");
  run.solverSeconds = cp.real("run/solver_seconds");
  run.initialEnergy = cp.real("run/initial_energy");
  run.initialEnergyRedistributed = cp.real("run/initial_energy_redistributed");
  run.hasRedistributed = cp.integer("run/has_redistributed") != 0;
  run.maxPenetration = cp.real("run/max_penetration");
  run.forceVariation = cp.real("run/contact_force_variation");
  run.maxForce = cp.real("run/max_contact_force");
  run.maxActive = cp.integer("run/max_active_nodes");
  if (cp.has("run/min_solver_tolerance")) {
    run.minTolerance = cp.real("run/min_solver_tolerance");
    run.maxTolerance = cp.real("run/max_solver_tolerance");
  }
  const Eigen::VectorXd& first = cp.vector("run/tracked_first_contact_time");
  const Eigen::VectorXd& detach = cp.vector("run/tracked_detachment_time");
  const Eigen::VectorXd& release = cp.vector("run/tracked_release_time");
  const Eigen::VectorXd& scale = cp.vector("run/tracked_velocity_scale");
  const auto n = static_cast<Eigen::Index>(run.times.size());
  if (first.size() != n || detach.size() != n || release.size() != n || scale.size() != n)
    throw Error("the checkpoint tracks " + std::to_string(first.size()) + " points, the scene " + std::to_string(n));
  for (Eigen::Index k = 0; k < n; ++k)
    run.times[static_cast<std::size_t>(k)] = TrackedTimes{first[k], detach[k], release[k], scale[k]};
  std::istringstream files(cp.text("run/vtu_files"));
  for (std::string f; std::getline(files, f);) {
    if (!fs::exists(dir / f))
      throw Error("the interrupted run's " + (dir / f).string() +
                  " is missing (restart into the output directory of the interrupted run)");
    run.vtuFiles.push_back(dir / f);
  }
  const Eigen::VectorXd& times = cp.vector("run/vtu_times");
  if (static_cast<std::size_t>(times.size()) != run.vtuFiles.size())
    throw Error("run/vtu_times and run/vtu_files differ in length");
  run.vtuTimes.assign(times.data(), times.data() + times.size());
}

/// The friction columns of the time series (scenes with friction only).
constexpr const char* kFrictionColumns =
    ",friction_dissipation,friction_force_x,friction_force_y,friction_force_z,stick_nodes,slip_nodes,friction_solves";

std::string csvHeaderLine(std::size_t tracked, bool friction) {
  std::string h =
      "t,step,energy,energy_redistributed,kinetic_energy,elastic_energy,momentum_x,momentum_y,"
      "momentum_z,momentum_redistributed_x,momentum_redistributed_y,momentum_redistributed_z,"
      "contact_force_x,contact_force_y,contact_force_z,active_solution,active_predictor,"
      "predictor_only,solution_only,max_penetration,solver_iterations,solver_seconds,step_seconds,"
      "solver_tolerance,time_error,solver_kkt,solver_error_bound";
  for (std::size_t k = 0; k < tracked; ++k) {
    const std::string p = ",tracked" + std::to_string(k) + "_";
    h += p + "normal_displacement" + p + "normal_velocity" + p + "gap";
  }
  if (friction) h += kFrictionColumns;
  return h;
}

std::string csvLine(const StepRecord& r, bool friction) {
  std::ostringstream os;
  os << std::setprecision(17) << r.time << "," << r.step << "," << r.energy << ",";
  if (r.hasRedistributed) os << r.energyRedistributed;
  os << "," << r.kineticEnergy << "," << r.elasticEnergy;
  for (int i = 0; i < 3; ++i) os << "," << r.momentum[i];
  for (int i = 0; i < 3; ++i) {  // M~ v, empty without a redistributed mass (as energy_redistributed)
    os << ",";
    if (r.hasRedistributed) os << r.momentumRedistributed[i];
  }
  for (int i = 0; i < 3; ++i) os << "," << r.contactForce[i];
  os << "," << r.activeSolution << "," << r.activePredictor << "," << r.predictorOnly << ","
     << r.solutionOnly << "," << r.maxPenetration << "," << r.solverIterations << ","
     << r.solverSeconds << "," << r.stepSeconds << ",";
  // NaN (initial state; time error without [dynamics] inexact or before the third level): empty
  if (!std::isnan(r.solverTolerance)) os << r.solverTolerance;
  os << ",";
  if (!std::isnan(r.timeError)) os << r.timeError;
  os << ",";
  if (!std::isnan(r.solverKkt)) os << r.solverKkt;
  os << ",";
  if (!std::isnan(r.solverErrorBound)) os << r.solverErrorBound;
  for (const TrackedVertex& t : r.tracked)
    os << "," << t.normalDisplacement << "," << t.normalVelocity << "," << t.gap;
  if (friction) {
    os << "," << r.frictionDissipation;
    for (int i = 0; i < 3; ++i) os << "," << r.frictionForce[i];
    os << "," << r.stickNodes << "," << r.slipNodes << "," << r.frictionSolves;
  }
  return os.str();
}

/// The contact data of a state for the .vtu fields, stacked and vertex-major: the relative
/// displacement and velocity x = (I - C) u, w = (I - C) v of the mortar basis transformation (= u, v
/// without mortar pairs; nu_p'x_p at a slave node p is the normal jump [u]_nu,
/// docs/theory.md#dynamic-two-body-contact), and given a NewmarkFamily stepper the nodal contact
/// forces of the step at the constrained nodes F~ (NewmarkFamily::nodalContactForces(): F_p nu_p at an
/// obstacle node, D_pp lambda_p n_p at a slave node) and, for several bodies, the forces on the
/// vertices F = (I - C')F~ (NewmarkFamily::contactForces(); the force on the bodies is -F).
struct StateContact {
  Eigen::VectorXd x, w;
  double scale = 1e-300;  ///< max |u| (distributed: over the ranks), the scale of contact_state
  std::optional<Eigen::VectorXd> nodal, forces;
  /// with friction, after a step: NewmarkFamily::frictionForces() and frictionStates()
  std::optional<Eigen::VectorXd> friction;
  std::vector<char> frictionStates;
};

/// The .vtu fields of a state on body b of Context::bodies (its segment of the stacked vectors): displacement, stress, von_mises, boundary_id,
/// velocity and the contact fields of the body's constrained nodes (gap g - nu'x, normal_displacement
/// nu'x, normal_velocity nu'w, contact_state 0 / 1 potential / 2 active; at a mortar slave node these
/// are of the normal jump) and, given the nodal forces F~, contact_pressure s_p = F~_p / m_p^C as in
/// static scenes (slave nodes: the dual-mortar pressure lambda_p); given the vertex forces F,
/// contact_force -F (the nodal contact force on the body, both sides of a pair, as in static
/// runs with several bodies). Vertices without a constraint (a master side) have 0 in the contact fields.
/// Scenes with friction add friction_force (-F_T, the friction force on the body at a constrained node)
/// and stick_slip (0 not in contact, 1 stick, 2 slip) of the last step (zero in the initial state).
std::vector<Field> stateFields(const Context& c, std::size_t b, const Eigen::VectorXd& u, const Eigen::VectorXd& v,
                               const StateContact& sc, std::vector<Field>* cells) {
  const mesh::Mesh& mesh = *c.bodies[b].mesh;
  const Material& material = c.bodies[b].spec->material;
  const std::vector<Index>& at = c.bodies[b].index;
  const int dim = mesh.dimension();
  const mesh::Index n = mesh.numVertices();
  ElasticitySolution s;
  s.dimension = dim;
  s.displacement.resize(static_cast<Eigen::Index>(n) * dim);
  for (mesh::Index p = 0; p < n; ++p) s.displacement.segment(p * dim, dim) = u.segment(at[p] * dim, dim);
  recoverStresses(mesh, material, s);
  std::vector<Field> pf = pointFields(mesh, s);
  *cells = cellFields(mesh, s);
  Field vel{"velocity", 3, std::vector<double>(3 * n, 0.0), false};
  for (mesh::Index p = 0; p < n; ++p)
    for (int a = 0; a < dim; ++a) vel.values[3 * p + a] = v[at[p] * dim + a];
  Field gap{"gap", 1, std::vector<double>(n, 0.0), false};
  Field nd{"normal_displacement", 1, std::vector<double>(n, 0.0), false};
  Field nv{"normal_velocity", 1, std::vector<double>(n, 0.0), false};
  Field sp{"contact_pressure", 1, std::vector<double>(n, 0.0), false};
  Field state{"contact_state", 1, std::vector<double>(n, 0.0), true};
  Field force{"contact_force", 3, std::vector<double>(3 * n, 0.0), false};
  Field friction{"friction_force", 3, std::vector<double>(3 * n, 0.0), false};
  Field stickSlip{"stick_slip", 1, std::vector<double>(n, 0.0), true};
  const double scale = sc.scale;
  for (Index k = 0; k < c.contact.size(); ++k) {
    const double g = c.contact.gap(k);
    if (!std::isfinite(g)) continue;
    const Index P = c.contact.vertex(k);  // stacked
    if (c.bodyOf[P] != static_cast<int>(b)) continue;  // a node of another body (or an extra ghost)
    const Index p = c.vertexOf[P];
    double nu_u = 0, nu_v = 0, nu_f = 0;
    for (int a = 0; a < dim; ++a) {
      nu_u += c.contact.direction(k)[a] * sc.x[P * dim + a];
      nu_v += c.contact.direction(k)[a] * sc.w[P * dim + a];
      if (sc.nodal) nu_f += c.contact.direction(k)[a] * (*sc.nodal)[P * dim + a];
    }
    nd.values[p] = nu_u;
    nv.values[p] = nu_v;
    sp.values[p] = nu_f / c.contact.boundaryMass(k);
    gap.values[p] = g - nu_u;
    state.values[p] = g - nu_u <= 1e-8 * std::max({scale, std::abs(g), 1e-300}) ? 2 : 1;
    if (sc.friction) {
      for (int a = 0; a < dim; ++a) friction.values[3 * p + a] = -(*sc.friction)[P * dim + a];
      if (static_cast<std::size_t>(k) < sc.frictionStates.size()) stickSlip.values[p] = sc.frictionStates[static_cast<std::size_t>(k)];
    }
  }
  if (sc.forces)
    for (mesh::Index p = 0; p < n; ++p)
      for (int a = 0; a < dim; ++a) force.values[3 * p + a] = -(*sc.forces)[at[p] * dim + a];
  pf.push_back(std::move(vel));
  pf.push_back(std::move(gap));
  pf.push_back(std::move(nd));
  pf.push_back(std::move(nv));
  if (sc.nodal) pf.push_back(std::move(sp));
  pf.push_back(std::move(state));
  if (sc.forces) pf.push_back(std::move(force));
  if (c.scene.frictional()) {  // every file of the run has them (zero before the first step)
    pf.push_back(std::move(friction));
    pf.push_back(std::move(stickSlip));
  }
  return pf;
}

/// The time stepper of one scheme on the scene's bodies (the contact model of the scene's
/// couplings, kept in `model`, which must outlive it), initialised with the initial state.
/// Errors name the [dynamics] line of the scheme or of the initial state.
template <int d>
std::unique_ptr<TimeStepper<d>> makeSchemeStepper(const Context& c, const std::string& schemeName,
                                                  const NewmarkOptions& o, ContactModel<d>& model) {
  const Scene& scene = c.scene;
  const DynamicsSpec& dyn = *scene.dynamics;
  std::unique_ptr<TimeStepper<d>> stepper;
  try {
    std::vector<const mesh::Mesh*> meshes;
    std::vector<const mesh::Grid*> grids;
    for (const Context::Body& b : c.bodies) {
      meshes.push_back(b.mesh);
      grids.push_back(b.grid);
    }
    if (c.comm) {  // the bodies on the rank's local meshes; the stepper's construction is collective
      c.collective([&] { model = makeContactModel<d>(c.couplings.spec, meshes); });
      std::vector<const DistributedGrid*> distributed;
      std::vector<const DistributedView*> leaves;
      for (const Context::Body& b : c.bodies) {
        distributed.push_back(b.distributed);
        leaves.push_back(b.leaf);
      }
      stepper = std::make_unique<NewmarkFamily<d>>(distributed, leaves, model, o, c.coupled ? c.coupled->get<d>() : nullptr);
    } else {
      model = makeContactModel<d>(c.couplings.spec, meshes);
      stepper = makeTimeStepper<d>(grids, model, o);
    }
  } catch (const Error& e) {
    const int line = schemeName == dyn.scheme ? dyn.schemeLine : dyn.compareLine;  // 0: --compare-schemes
    throw Error(scene.where(line ? line : dyn.line) + "[dynamics] scheme = \"" +
                schemeName + "\": " + e.what());
  }
  try {
    stepper->initialize(c.u0, c.v0);
  } catch (const Error& e) {
    const int line = dyn.initialDisplacementLine ? dyn.initialDisplacementLine : dyn.line;
    throw Error(scene.where(line) + "[dynamics] the initial state (initial_displacement, initial_velocity) " +
                "is not admissible, nothing was integrated: " + e.what());
  }
  if (!dynamic_cast<NewmarkFamily<d>*>(stepper.get()))  // the .vtu fields need its transformation
    throw Error(scene.where(dyn.schemeLine) + "[dynamics] scheme = \"" + schemeName +
                "\" is no NewmarkFamily scheme, which the runner needs for its outputs and checkpoints");
  return stepper;
}

/// The time series of a scheme (timeseries.csv): the rows as they are written, with the length and
/// FNV-1a hash of the bytes so far, which go into checkpoints; a restart checks the file against
/// them and cuts it back to them.
class TimeSeriesFile {
public:
  /// writer false: a distributed run's ranks other than 0, which write nothing (every rank holds
  /// the same records)
  TimeSeriesFile(fs::path path, bool friction, bool writer = true)
      : path_(std::move(path)), friction_(friction), writer_(writer) {}

  /// A new file with the header and the initial state's row.
  void start(std::size_t tracked, const StepRecord& first) {
    if (writer_) {
      out_.open(path_, std::ios::binary);
      if (!out_) throw Error(path_.string() + ": cannot write the time series");
    }
    emit(csvHeaderLine(tracked, friction_));
    emit(csvLine(first, friction_));
  }

  /// Continues the file of an interrupted run at the checkpoint's length (`step`: the checkpoint's
  /// step, for the message); throws if the file does not begin with the bytes it recorded.
  void resume(const CheckpointRecord& cp, std::size_t tracked, int step) {
    bytes_ = cp.integer("run/timeseries_bytes");
    const std::string hash = cp.text("run/timeseries_hash");
    if (!writer_) {  // the length and hash only (the same in every rank's checkpoint entries)
      hash_ = std::stoull(hash, nullptr, 16);
      return;
    }
    std::ifstream in(path_, std::ios::binary);
    std::string text(static_cast<std::size_t>(std::max(bytes_, 0LL)), '\0');
    if (!in || !in.read(text.data(), static_cast<std::streamsize>(text.size())) ||
        hexHash(fnv1a(text.data(), text.size())) != hash)
      throw Error(path_.string() + " does not begin with the " + std::to_string(bytes_) +
                  " bytes the interrupted run wrote up to step " + std::to_string(step) +
                  " (restart into the output directory of the interrupted run)");
    // the rows appended below must have the columns of the rows already there
    const std::string header = csvHeaderLine(tracked, friction_) + "\n";
    if (text.compare(0, header.size(), header) != 0)
      throw Error(path_.string() +
                  " has other columns than this version of obs writes (written by another version; "
                  "start the run again without --restart)");
    in.close();
    hash_ = std::stoull(hash, nullptr, 16);
    fs::resize_file(path_, static_cast<std::uintmax_t>(bytes_));
  }

  /// Opens the resumed file for appending (after resume, outside its error context).
  void openForAppend() {
    if (!writer_) return;
    out_.open(path_, std::ios::app | std::ios::binary);
    if (!out_) throw Error(path_.string() + ": cannot write the time series");
  }

  void emit(const std::string& line) {
    const std::string text = line + "\n";
    if (writer_) out_ << text;
    bytes_ += static_cast<long long>(text.size());  // on every rank: the checkpoints' entries
    hash_ = fnv1a(text.data(), text.size(), hash_);
  }

  /// Flushes; throws if anything could not be written.
  void flush() {
    if (!writer_) return;
    out_.flush();
    if (!out_) throw Error(path_.string() + ": cannot write the time series");
  }

  long long bytes() const { return bytes_; }
  std::uint64_t hash() const { return hash_; }

private:
  fs::path path_;
  bool friction_ = false;  ///< the friction columns (kFrictionColumns)
  bool writer_ = true;
  std::ofstream out_;
  long long bytes_ = 0;
  std::uint64_t hash_ = kFnvOffset;
};

/// Writes the .vtu files of the stepper's state at record r: one per body (the .pvd lists them as
/// parts of one time step), or one, and adds them to run.vtuFiles / vtuTimes.
template <int d>
void writeStateVtu(const Context& c, const TimeStepper<d>& stepper, const NewmarkFamily<d>* newmark,
                   const StepRecord& r, SchemeRun& run) {
  const DynamicState& state = stepper.state();
  StateContact sc;
  if (newmark) {
    sc.x = newmark->problem().fromDisplacement(state.u);  // (I - C) u; a copy of u without mortar pairs
    sc.w = newmark->problem().fromDisplacement(state.v);
    sc.nodal = newmark->nodalContactForces();
    if (c.layout.perBody()) sc.forces = newmark->contactForces();  // the contact_force field
    if (newmark->frictionForces().size() > 0) {
      sc.friction = newmark->frictionForces();
      sc.frictionStates = newmark->frictionStates();
    }
  } else {
    sc.x = state.u;
    sc.w = state.v;
  }
  sc.scale = c.maximum(state.u.size() ? state.u.cwiseAbs().maxCoeff() : 0.0);
  sc.scale = std::max(sc.scale, 1e-300);
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    const fs::path path = c.dir / c.layout.dynamicVtu(r.step, b);
    std::vector<Field> cells;
    const auto pf = stateFields(c, b, state.u, state.v, sc, &cells);
    if (c.comm) {  // each rank its owned cells, rank 0 the .pvtu the .pvd lists
      const std::string base = path.stem().string();
      const auto files = writePieces(c.dir, base, *c.bodies[b].mesh, static_cast<Index>(c.bodies[b].leaf->part.owned.size()), pf,
                                     cells, *c.comm);
      run.vtuFiles.push_back(c.dir / (base + ".pvtu"));  // on every rank: the checkpoints' entries
      if (!files.empty()) run.pieceFiles.insert(run.pieceFiles.end(), files.begin(), files.end() - 1);
    } else {
      writeVtu(path, *c.bodies[b].mesh, pf, cells);
      run.vtuFiles.push_back(path);
    }
    run.vtuTimes.push_back(r.time);
  }
}

/// The contact times of the tracked vertices after record r: first contact, detachment (the gap
/// opens again) and release (the normal velocity points away beyond round-off).
void trackContactTimes(const StepRecord& r, std::vector<TrackedTimes>& times) {
  for (std::size_t k = 0; k < r.tracked.size() && k < times.size(); ++k) {
    const TrackedVertex& t = r.tracked[k];
    if (!t.contactNode) continue;
    TrackedTimes& tt = times[k];
    tt.velocityScale = std::max(tt.velocityScale, std::abs(t.normalVelocity));
    const double tol = 1e-8 * std::max({1.0, std::abs(t.normalDisplacement), std::abs(t.gap)});
    const bool touching = t.gap <= tol;
    if (std::isnan(tt.firstContact)) {
      if (touching) tt.firstContact = r.time;
      continue;
    }
    if (std::isnan(tt.detachment) && !touching) tt.detachment = r.time;
    if (std::isnan(tt.release) && t.normalVelocity < -1e-8 * tt.velocityScale) tt.release = r.time;
  }
}

/// The run's totals and extremes after step r (previous: the step before).
void accumulateStep(const StepRecord& r, const StepRecord& previous, SchemeRun& run) {
  ++run.steps;
  run.iterations += r.solverIterations;
  run.maxIterations = std::max(run.maxIterations, r.solverIterations);
  run.solverSeconds += r.solverSeconds;
  run.stepSeconds += r.stepSeconds;
  run.maxPenetration = std::max(run.maxPenetration, r.maxPenetration);
  run.forceVariation += (r.contactForce - previous.contactForce).norm();
  run.maxForce = std::max(run.maxForce, r.contactForce.norm());
  run.maxActive = std::max<long long>(run.maxActive, r.activeSolution);
  run.minTolerance = std::min(run.minTolerance, r.solverTolerance);
  run.maxTolerance = std::max(run.maxTolerance, r.solverTolerance);
}

/// Integrates one scheme over the scene's steps: the stepper (makeSchemeStepper), the time series
/// (TimeSeriesFile), the .vtu files every output_stride steps (writeStateVtu), the contact times of
/// the tracked vertices, progress lines, checkpoints and --stop-after-step / signals; a restart
/// continues from the checkpoint's state and time series.
template <int d>
SchemeRun runScheme(const Context& c, const std::string& schemeName, bool writeVtk,
                    const std::string& timeseriesName) {
  const Scene& scene = c.scene;
  const DynamicsSpec& dyn = *scene.dynamics;
  SchemeRun run;
  run.scheme = schemeName;
  NewmarkOptions o = newmarkOptions(scene, schemeName);
  for (const TrackedInfo& t : c.tracked) o.trackedVertices.push_back(t.stepperVertex);

  const auto t0 = Clock::now();
  ContactModel<d> model;  // the bodies and the couplings
  const std::unique_ptr<TimeStepper<d>> stepper = makeSchemeStepper<d>(c, schemeName, o, model);
  run.setupSeconds = c.maximum(secondsSince(t0));  // distributed: the slowest rank's
  auto* newmark = dynamic_cast<NewmarkFamily<d>*>(stepper.get());

  const StepRecord first = stepper->record();
  run.initialEnergy = first.energy;
  run.hasRedistributed = first.hasRedistributed;
  run.initialEnergyRedistributed = first.energyRedistributed;
  if (run.hasRedistributed && newmark) {
    run.redistributionBounded = static_cast<long long>(newmark->redistributedMass().boundedEntries);
    run.redistributionMinFactor = newmark->redistributedMass().minimumFactor;
    run.redistributionPositiveDefinite = newmark->redistributedMassDefiniteness().positiveDefinite;
    run.redistributionChecked = newmark->redistributedMassDefiniteness().checked;
  }
  run.times.assign(c.tracked.size(), TrackedTimes{});

  run.timeseries = c.dir / timeseriesName;
  TimeSeriesFile csv(run.timeseries, scene.frictional(), c.writer());
  int startStep = 0;
  if (c.restart) {
    const CheckpointRecord& cp = *c.restart;
    try {
      NewmarkSchemeState state;
      // the checks of the entries and of the time series (rank 0's file) reach every rank
      c.collective([&] {
        state = loadNewmarkState(cp);
        if (state.state.step > c.steps)
          throw Error("the checkpoint is at step " + std::to_string(state.state.step) + ", beyond the scene's " +
                      std::to_string(c.steps) + " steps");
        restoreSchemeRun(cp, run, c.dir);
        csv.resume(cp, c.tracked.size(), state.state.step);
      });
      newmark->setSchemeState(state);  // collective (the records' sums)
      startStep = state.state.step;
    } catch (const Error& e) {
      throw Error(c.restartFile.string() + ": " + e.what());
    }
    c.collective([&] { csv.openForAppend(); });
  } else {
    c.collective([&] { csv.start(c.tracked.size(), first); });
    if (writeVtk) writeStateVtu<d>(c, *stepper, newmark, first, run);
    trackContactTimes(first, run.times);
  }

  CheckpointSchedule schedule(scene.output.checkpoint);
  auto writeCheckpointAt = [&](int k) {
    c.collective([&] { csv.flush(); });  // the checkpoint refers to these bytes
    CheckpointRecord cp;
    cp.kind = "dynamic";
    storeRunIdentity(cp, scene, runBodies(c.bodies, c.layout, c.comm));  // collective
    storeNewmarkState(cp, newmark->schemeState());
    storeStateRows(cp, c, d);
    storeSchemeRun(cp, run, csv.bytes(), csv.hash());
    // one file from every rank (one process: all rows)
    writeCheckpoint(c.checkpointFile, cp, c.comm ? *c.comm : Communicator::world());
    schedule.written();
    if (c.options.stepProgress)
      c.options.stepProgress("checkpoint: step " + std::to_string(k) + " -> " + c.checkpointFile.string());
  };

  StepRecord previous = c.restart ? stepper->record() : first;
  auto lastReport = Clock::now();
  const auto loopStart = Clock::now();
  for (int k = startStep + 1; k <= c.steps; ++k) {
    StepRecord r;
    try {
      r = stepper->step();
    } catch (const Error& e) {
      std::ostringstream os;
      os << scene.where(dyn.line) << "[dynamics] scheme = \"" << schemeName << "\": step " << k << " (t = "
         << fmt(k * dyn.timeStep) << ") failed: " << e.what();
      throw Error(os.str());
    }
    csv.emit(csvLine(r, scene.frictional()));
    accumulateStep(r, previous, run);
    trackContactTimes(r, run.times);
    if (writeVtk && (k % dyn.outputStride == 0 || k == c.steps)) writeStateVtu<d>(c, *stepper, newmark, r, run);
    if (c.options.stepProgress && (secondsSince(lastReport) >= 2.0 || k == c.steps)) {
      lastReport = Clock::now();
      std::ostringstream os;
      os << schemeName << ": step " << k << "/" << c.steps << ", t = " << fmt(r.time) << ", E/E0 = "
         << fmt(run.initialEnergy != 0 ? r.energy / run.initialEnergy : r.energy) << ", contact nodes "
         << r.activeSolution << ", " << r.solverIterations << " TNNMG its, " << fmt(secondsSince(loopStart), 3)
         << " s";
      c.options.stepProgress(os.str());
    }
    previous = r;
    // distributed: every rank stops if one was signalled
    const bool signalled = c.maximum(InterruptGuard::requested() ? 1.0 : 0.0) > 0;
    const bool stop = k < c.steps && (signalled || (c.options.stopAfterStep && k >= *c.options.stopAfterStep));
    if (stop && !c.checkpointing)
      throw RunInterrupted("interrupted by " + InterruptGuard::signalName() + " after step " + std::to_string(k) + " of " +
                  schemeName + " (scheme comparisons write no checkpoints)");
    // distributed: due on every rank if on one (the schedule in seconds reads each rank's clock)
    const bool due = c.checkpointing && c.maximum(schedule.due(k) ? 1.0 : 0.0) > 0;
    if (c.checkpointing && (stop || due)) writeCheckpointAt(k);
    if (stop) {
      std::ostringstream os;
      os << (signalled ? "interrupted by " + InterruptGuard::signalName() : std::string("stopped (--stop-after-step)"))
         << " after step " << k << " of " << c.steps << " (t = " << fmt(r.time) << "): checkpoint written to "
         << c.checkpointFile.string() << "; continue with: obs run " << scene.fileName << " --restart "
         << c.checkpointFile.string() << " (and the same --output, --refine and --set options)";
      throw RunInterrupted(os.str());
    }
  }
  run.last = previous;
  run.finalEnergy = previous.energy;
  run.finalEnergyRedistributed = previous.energyRedistributed;
  run.u = stepper->state().u;
  run.v = stepper->state().v;
  c.collective([&] { csv.flush(); });
  return run;
}

nlohmann::json optionalTime(double t) { return std::isnan(t) ? nlohmann::json(nullptr) : nlohmann::json(t); }

nlohmann::json schemeJson(const Context& c, const SchemeRun& run) {
  const DynamicsSpec& dyn = *c.scene.dynamics;
  nlohmann::json tracked = nlohmann::json::array();
  for (std::size_t k = 0; k < c.tracked.size(); ++k) {
    const TrackedInfo& t = c.tracked[k];
    nlohmann::json p = nlohmann::json::array(), x = nlohmann::json::array();
    for (int a = 0; a < c.bodies.front().mesh->dimension(); ++a) {
      p.push_back(t.requested[a]);
      x.push_back(t.position[a]);
    }
    nlohmann::json j = {{"point", p},
                        {"vertex", t.vertex},
                        {"coordinates", x},
                        {"distance", t.distance},
                        {"contact_node", t.contactNode},
                        {"first_contact_time", optionalTime(run.times[k].firstContact)},
                        {"detachment_time", optionalTime(run.times[k].detachment)},
                        {"release_time", optionalTime(run.times[k].release)}};
    if (k < run.last.tracked.size()) {
      j["final_normal_displacement"] = run.last.tracked[k].normalDisplacement;
      j["final_normal_velocity"] = run.last.tracked[k].normalVelocity;
    }
    tracked.push_back(j);
  }
  nlohmann::json j = {
      {"scheme", run.scheme},
      {"tau", dyn.timeStep},
      {"steps", run.steps},
      {"end_time", run.last.time},
      {"mass", dyn.consistentMass ? "consistent" : "lumped"},
      {"initial_energy", run.initialEnergy},
      {"final_energy", run.finalEnergy},
      {"energy_ratio", run.initialEnergy != 0 ? nlohmann::json(run.finalEnergy / run.initialEnergy)
                                              : nlohmann::json(nullptr)},
      {"max_penetration", run.maxPenetration},
      {"max_contact_force", run.maxForce},
      {"contact_force_variation", run.forceVariation},
      {"max_active_nodes", run.maxActive},
      {"final_active_nodes", run.last.activeSolution},
      {"mean_iterations_per_step", run.steps ? static_cast<double>(run.iterations) / run.steps : 0.0},
      {"max_iterations_per_step", run.maxIterations},
      {"inexact", dyn.inexact},
      {"warm_start", dyn.warmStart},
      {"min_solver_tolerance", run.steps ? nlohmann::json(run.minTolerance) : nlohmann::json(nullptr)},
      {"max_solver_tolerance", run.steps ? nlohmann::json(run.maxTolerance) : nlohmann::json(nullptr)},
      {"setup_s", run.setupSeconds},
      {"total_step_s", run.stepSeconds},
      {"solver_s", run.solverSeconds},
      {"seconds_per_step", run.steps ? run.stepSeconds / run.steps : 0.0},
      {"timeseries", run.timeseries.string()},
      {"tracked", tracked},
  };
  if (c.scene.frictional())
    j["friction"] = {{"dissipated_energy", run.last.frictionDissipation},
                     {"final_stick_nodes", run.last.stickNodes},
                     {"final_slip_nodes", run.last.slipNodes}};
  if (run.hasRedistributed) {
    j["initial_energy_redistributed"] = run.initialEnergyRedistributed;
    j["final_energy_redistributed"] = run.finalEnergyRedistributed;
    j["energy_ratio_redistributed"] = run.initialEnergyRedistributed != 0
                                          ? nlohmann::json(run.finalEnergyRedistributed / run.initialEnergyRedistributed)
                                          : nlohmann::json(nullptr);
    j["redistribution"] = {{"moments", dyn.redistributionMoments},
                           {"bounded_entries", run.redistributionBounded},
                           {"min_factor", run.redistributionMinFactor},
                           {"positive_definite", run.redistributionChecked
                                                     ? nlohmann::json(run.redistributionPositiveDefinite)
                                                     : nlohmann::json(nullptr)}};
  }
  return j;
}

/// Runs scripts/plot_dynamics.py on the output directory; a failure is a warning.
void runPlots(const fs::path& dir, const RunOptions& options) {
  auto warn = [&](const std::string& m) {
    if (options.stepProgress) options.stepProgress("warning: " + m);
  };
  fs::path script = OBS_DYNAMICS_PLOT_SCRIPT;
  if (const char* env = std::getenv("OBS_PLOT_DYNAMICS_SCRIPT")) script = env;
  std::error_code ec;
  if (!fs::is_regular_file(script, ec)) {
    warn("plots skipped: " + script.string() + " not found (set OBS_PLOT_DYNAMICS_SCRIPT)");
    return;
  }
  const PlotScriptRun plot = runPlotScript(script, {dir.string()});
  if (!plot.ok)
    warn("plots skipped (" + plot.command + " failed" + (plot.output.empty() ? std::string(")") : "): " + plot.output));
}

}  // namespace

std::vector<std::string> dynamicSchemes(const Scene& scene, bool compareAll) {
  std::vector<std::string> out = {scene.dynamics->scheme};
  std::vector<std::string> more = scene.dynamics->compare;
  if (compareAll)
    for (NewmarkScheme k : allNewmarkSchemes()) more.emplace_back(name(k));
  for (const std::string& s : more)
    if (std::find(out.begin(), out.end(), s) == out.end()) out.push_back(s);
  return out;
}

NewmarkOptions newmarkOptions(const Scene& scene, const std::string& scheme) {
  const DynamicsSpec& dyn = *scene.dynamics;
  NewmarkOptions o;
  o.scheme = newmarkSchemeFromName(scheme);
  o.timeStep = dyn.timeStep;
  o.mass = dyn.consistentMass ? MassKind::Consistent : MassKind::Lumped;
  o.solver = solverConfig(scene);
  o.inexactFraction = dyn.inexact;
  o.redistribution.moments = dyn.redistributionMoments;
  o.start = newmarkStartFromName(dyn.warmStart);
  return o;
}

namespace {

/// The couplings of the scene merged into one ContactSet over the stacked vertices (the steppers
/// build the same model again; this one names the contact nodes for tracking and reports; no
/// stiffness is assembled for it).
template <int d>
ContactSet mergedContactSet(const Scene& scene, const SceneCouplings& couplings, const std::vector<Context::Body>& bodies) {
  std::vector<const mesh::Mesh*> meshes;
  for (const Context::Body& b : bodies) meshes.push_back(b.mesh);
  ContactModel<d> model = makeContactModel<d>(couplings.spec, meshes);
  try {
    return model.constraints().contact;
  } catch (const Error& e) {
    if (scene.pairs.empty()) throw;
    throw Error(scene.where(scene.pairs.front().line) + "[[contact]] " + e.what());
  }
}

/// The tracked vertices of [dynamics] tracked: the stacked vertex nearest to each point (of
/// coinciding vertices, the two sides of a contact interface, the contact node; of several, the
/// lowest index). Distributed (comm): the candidates are the rank's `owned` first vertices, with the
/// global indices offset + local index; every rank gets the same list (collective).
std::vector<TrackedInfo> trackedVertices(const Scene& scene, const std::vector<mesh::Point>& positions,
                                         const ContactSet& contact, int dim, const Communicator* comm = nullptr,
                                         mesh::Index owned = -1, mesh::Index offset = 0) {
  const DynamicsSpec& dyn = *scene.dynamics;
  const auto n = comm ? owned : static_cast<mesh::Index>(positions.size());
  const auto lowest = [&](double x) { return comm ? -comm->max(-x) : x; };
  const auto distance = [&](mesh::Index v, const TrackedInfo& t) {
    return (positions[static_cast<std::size_t>(v)] - t.requested).norm();
  };
  const auto isContactNode = [&](mesh::Index v) {
    const Index node = contact.nodeOf(v);
    return node >= 0 && std::isfinite(contact.gap(node));
  };
  std::vector<TrackedInfo> tracked;
  for (std::size_t k = 0; k < dyn.tracked.size(); ++k) {
    if (dyn.trackedDimensions[k] != dim)
      throw Error(scene.where(dyn.trackedLine) + "[dynamics] tracked[" + std::to_string(k) + "] has " +
                  std::to_string(dyn.trackedDimensions[k]) + " coordinates, expected " + std::to_string(dim) +
                  " (the mesh is " + std::to_string(dim) + "D)");
    TrackedInfo t;
    t.requested = dyn.tracked[k];
    double best = std::numeric_limits<double>::infinity();
    for (mesh::Index v = 0; v < n; ++v) best = std::min(best, distance(v, t));
    best = lowest(best);
    // the vertices within round-off of the nearest distance (coinciding vertices: the two sides of
    // a contact interface): the first contact node among them, else the first of them
    const double tie = best + 1e-12 * (1 + best);
    mesh::Index nearest = -1, node = -1;
    for (mesh::Index v = 0; v < n && node < 0; ++v) {
      if (distance(v, t) > tie) continue;
      if (nearest < 0) nearest = v;
      if (isContactNode(v)) node = v;
    }
    const double big = std::numeric_limits<double>::max();
    const bool anyNode = lowest(node >= 0 ? 0.0 : 1.0) == 0;
    const mesh::Index chosen = anyNode ? node : nearest;  // on this rank (-1: none here)
    const double global = lowest(chosen >= 0 ? static_cast<double>(offset + chosen) : big);
    t.vertex = static_cast<mesh::Index>(global);
    t.stepperVertex = chosen >= 0 && offset + chosen == t.vertex ? chosen : -1;
    // position, distance and contact node from the rank that holds the vertex
    std::vector<double> info(5, 0.0);
    if (t.stepperVertex >= 0) {
      for (int a = 0; a < 3; ++a) info[static_cast<std::size_t>(a)] = positions[static_cast<std::size_t>(chosen)][a];
      info[3] = distance(chosen, t);
      info[4] = isContactNode(chosen) ? 1 : 0;
    }
    if (comm) comm->sum(info);
    t.position = mesh::Point(info[0], info[1], info[2]);
    t.distance = info[3];
    t.contactNode = info[4] > 0;
    tracked.push_back(t);
  }
  return tracked;
}

/// The initial state u^0, v^0 on the stacked vertices: a body's own [[body]] initial_displacement /
/// initial_velocity, else the [dynamics] ones, evaluated at the vertices (owner: the body of each),
/// then the Dirichlet values with velocity 0 at the prescribed components. Returns the stacked
/// Dirichlet data.
DirichletValues initialState(const Scene& scene, const std::vector<Context::Body>& bodies,
                             const std::vector<mesh::Point>& positions, const std::vector<const Scene*>& owner, int dim,
                             Eigen::VectorXd& u0, Eigen::VectorXd& v0) {
  const DynamicsSpec& dyn = *scene.dynamics;
  const auto n = static_cast<mesh::Index>(positions.size());
  u0 = Eigen::VectorXd::Zero(n * dim);
  v0 = Eigen::VectorXd::Zero(n * dim);
  // u^0, v^0: a body's own [[body]] initial_displacement / initial_velocity, else the [dynamics] ones
  auto evaluate = [&](bool velocity, Eigen::VectorXd& x) {
    for (mesh::Index v = 0; v < n; ++v) {
      const Scene& body = *owner[static_cast<std::size_t>(v)];
      const std::vector<Expression>& own = velocity ? body.bodyInitialVelocity : body.bodyInitialDisplacement;
      const bool local = !own.empty();  // ([[body]] only)
      const std::vector<Expression>& e = local ? own : velocity ? dyn.initialVelocity : dyn.initialDisplacement;
      if (e.empty()) continue;
      const int line = local ? (velocity ? body.bodyInitialVelocityLine : body.bodyInitialDisplacementLine)
                             : (velocity ? dyn.initialVelocityLine : dyn.initialDisplacementLine);
      const std::string key = std::string(local ? "[[body]] '" + body.name + "' " : "[dynamics] ") +
                              (velocity ? "initial_velocity" : "initial_displacement");
      if (static_cast<int>(e.size()) != dim)
        throw Error(scene.where(line) + key + " has " + std::to_string(e.size()) + " entries, expected " +
                    std::to_string(dim) + " (one per coordinate of the " + std::to_string(dim) + "D mesh)");
      for (int a = 0; a < dim; ++a) {
        const double value = e[a](positions[static_cast<std::size_t>(v)]);
        if (!std::isfinite(value))
          throw Error(scene.where(line) + key + "[" + std::to_string(a) + "] is not finite at vertex " +
                      std::to_string(v));
        x[v * dim + a] = value;
      }
    }
  };
  evaluate(false, u0);
  evaluate(true, v0);
  DirichletValues dirichlet;
  dirichlet.constrained.assign(static_cast<std::size_t>(n) * dim, 0);
  dirichlet.values = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * dim);
  for (const Context::Body& b : bodies) {
    const DirichletValues own = collectDirichlet(*b.mesh, b.bc->dirichlet);
    // a body prescribed everywhere moves as its Dirichlet data say: an initial velocity of its own
    // would be overwritten below without a word
    if (!b.spec->bodyInitialVelocity.empty() &&
        std::all_of(own.constrained.begin(), own.constrained.end(), [](char f) { return f != 0; }))
      throw Error(scene.where(b.spec->bodyInitialVelocityLine) + "[[body]] '" + b.spec->name +
                  "' initial_velocity: every vertex of the body is prescribed ([[dirichlet]] everywhere = true), "
                  "so it moves as its prescribed displacement says; remove initial_velocity");
    for (std::size_t p = 0; p < b.index.size(); ++p)
      for (int a = 0; a < dim; ++a) {
        const auto i = static_cast<std::size_t>(b.index[p]) * dim + a, j = p * dim + a;
        dirichlet.constrained[i] = own.constrained[j];
        dirichlet.values[static_cast<Eigen::Index>(i)] = own.values[static_cast<Eigen::Index>(j)];
      }
  }
  for (Eigen::Index i = 0; i < u0.size(); ++i)
    if (dirichlet.constrained[static_cast<std::size_t>(i)]) {
      u0[i] = dirichlet.values[i];
      v0[i] = 0;
    }
  return dirichlet;
}

/// The run's figures (RunResult): the first scheme's solver and contact figures, the setup and
/// step times of all schemes, max |u| and max von Mises of the final state (per body where the
/// layout reports bodies).
void reportDynamics(const Context& c, const ContactSet& contact, const std::vector<SchemeRun>& runs, RunResult& r) {
  const Scene& scene = c.scene;
  const OutputLayout& layout = c.layout;
  const std::vector<Context::Body>& bodies = c.bodies;
  const int dim = bodies.front().mesh->dimension();
  // distributed: the counts over the owned vertices and cells, added (maxima) over the ranks
  const Index ownedVertices = c.comm ? c.owned : std::numeric_limits<Index>::max();
  const auto total = [&](double x) { return c.comm ? c.comm->sum(x) : x; };
  const SchemeRun& primary = runs.front();
  for (const SchemeRun& run : runs) {
    r.assemblySeconds += run.setupSeconds;
    r.solveSeconds += run.stepSeconds;
  }
  r.solver.type = "tnnmg";
  r.solver.iterations = static_cast<int>(std::min<long long>(primary.iterations, std::numeric_limits<int>::max()));
  r.solver.converged = true;
  r.solver.seconds = primary.solverSeconds;
  r.solver.tolerance = solverConfig(scene).tolerance;
  ContactReport cr;
  cr.obstacle = layout.perBody() ? contact.obstacleName() : scene.contact->obstacle;
  // (a distributed pair's constraints are the coupling's: the pair's label, as serially)
  cr.boundary = c.coupled ? c.couplings.spec.couplings.front().label
                : layout.perBody() ? contact.boundaryLabel() : scene.contact->boundary.describe();
  for (Index k = 0; k < contact.size(); ++k) {
    if (contact.vertex(k) >= ownedVertices) continue;
    ++cr.boundaryVertices;
    if (std::isfinite(contact.gap(k))) ++cr.potentialVertices;
  }
  cr.boundaryVertices = static_cast<Index>(total(static_cast<double>(cr.boundaryVertices)));
  cr.potentialVertices = static_cast<Index>(total(static_cast<double>(cr.potentialVertices)));
  cr.actualVertices = primary.last.activeSolution;
  for (int a = 0; a < 3; ++a) cr.force[a] = primary.last.contactForce[a];
  cr.load = primary.last.contactForce.norm();
  cr.maxViolation = primary.last.maxPenetration;
  r.contact = cr;
  for (const Context::Body& b : bodies) {
    BodyReport br;
    br.name = b.spec->name;
    br.vertices = b.leaf ? b.leaf->globalVertices() : b.mesh->numVertices();
    br.cells = b.distributed ? b.distributed->globalLeaves() : b.mesh->numCells();
    const Index ownedCells = b.leaf ? static_cast<Index>(b.leaf->part.owned.size()) : std::numeric_limits<Index>::max();
    ElasticitySolution sol;
    sol.dimension = dim;
    sol.displacement.resize(static_cast<Eigen::Index>(b.mesh->numVertices()) * dim);
    for (mesh::Index v = 0; v < b.mesh->numVertices(); ++v)
      sol.displacement.segment(v * dim, dim) = primary.u.segment(b.index[v] * dim, dim);
    recoverStresses(*b.mesh, b.spec->material, sol);
    for (mesh::Index v = 0; v < (b.leaf ? b.leaf->halo.numOwned() : b.mesh->numVertices()); ++v)
      br.maxDisplacement = std::max(br.maxDisplacement, sol.displacement.segment(v * dim, dim).norm());
    for (std::size_t k = 0; k < sol.cellStress.size() && static_cast<Index>(k) < ownedCells; ++k)
      br.maxVonMises = std::max(br.maxVonMises, vonMises(sol.cellStress[k]));
    br.maxDisplacement = c.maximum(br.maxDisplacement);
    br.maxVonMises = c.maximum(br.maxVonMises);
    r.maxDisplacement = std::max(r.maxDisplacement, br.maxDisplacement);
    r.maxVonMises = std::max(r.maxVonMises, br.maxVonMises);
    if (layout.perBody()) r.bodies.push_back(br);
  }
}

void writeRunFiles(const Context& c, const RunOptions& options, const std::vector<SchemeRun>& runs,
                   const nlohmann::json& extra, RunResult& r, Clock::time_point t, Clock::time_point start);

/// The end of a dynamic run: the .pvd of the first scheme's .vtu files (one part per body), the
/// runs.csv row, the plots, summary.json (the run, "dynamics" of the first scheme and, comparing
/// schemes, "dynamics_comparison" with the schemes that failed) and the "written" line.
void writeDynamicOutputs(const Context& c, const RunOptions& options, const std::vector<SchemeRun>& runs,
                         const std::vector<std::pair<std::string, std::string>>& failed, bool comparison,
                         RunResult& r, Clock::time_point start) {
  const SchemeRun& primary = runs.front();
  const auto t = Clock::now();
  nlohmann::json extra;
  extra["dynamics"] = schemeJson(c, primary);
  if (comparison) {
    nlohmann::json all = nlohmann::json::array();
    for (const SchemeRun& run : runs) all.push_back(schemeJson(c, run));
    for (const auto& [scheme, message] : failed) all.push_back({{"scheme", scheme}, {"error", message}});
    extra["dynamics_comparison"] = all;
  }
  if (c.comm) {  // distributed: the memory per rank and the per-rank work (collective)
    const Communicator& comm = *c.comm;
    const Index owned = c.owned;
    double contactOwned = 0, ghosts = 0, cells = 0;
    for (Index k = 0; k < c.contact.size(); ++k) contactOwned += c.contact.vertex(k) < owned ? 1 : 0;
    for (const Context::Body& b : c.bodies) {
      ghosts += static_cast<double>(b.leaf->halo.numLocal() - b.leaf->halo.numOwned());
      cells += static_cast<double>(b.leaf->part.owned.size());
    }
    RankLoad load;
    load.add("owned_vertices", static_cast<double>(owned));
    load.add("ghost_vertices", ghosts);
    load.add("owned_cells", cells);
    load.add("contact_vertices", contactOwned);
    if (c.coupled) {  // the pair's rows and the coupling's extra ghosts (as static runs of two bodies)
      load.add("slave_vertices", static_cast<double>(c.coupled->mortar->rows().size()));
      load.add("extra_ghosts", static_cast<double>(c.coupled->visit([](const auto& m) { return m.extraGhosts(); })));
    }
    addDistributedSummary(extra, comm, c.bodies.front().distributed->partition().level, load);
  }
  c.collective([&] {
    if (c.writer()) writeRunFiles(c, options, runs, extra, r, t, start);
  });
}

/// writeDynamicOutputs' files (rank 0 of a distributed run).
void writeRunFiles(const Context& c, const RunOptions& options, const std::vector<SchemeRun>& runs,
                   const nlohmann::json& extra, RunResult& r, Clock::time_point t, Clock::time_point start) {
  const Scene& scene = c.scene;
  const SchemeRun& primary = runs.front();
  for (const SchemeRun& run : runs) r.outputFiles.push_back(run.timeseries);
  for (const fs::path& f : primary.pieceFiles) r.outputFiles.push_back(f);
  for (const fs::path& f : primary.vtuFiles) r.outputFiles.push_back(f);
  if (!primary.vtuFiles.empty()) {
    const fs::path pvd = c.dir / (scene.name + ".pvd");
    const std::size_t parts = c.bodies.size();  // the files come in groups of parts per time
    std::vector<PvdEntry> entries;
    for (std::size_t i = 0; i < primary.vtuFiles.size(); ++i)
      entries.push_back(PvdEntry{primary.vtuTimes[i], static_cast<int>(i % parts), primary.vtuFiles[i].filename().string()});
    writePvdCollection(pvd, entries);
    r.outputFiles.push_back(pvd);
  }
  if (scene.output.plots || options.plots) {
    runPlots(c.dir, options);
    for (const char* png : {"dyn_energy.png", "dyn_contact_force.png", "dyn_active.png", "dyn_velocity.png"})
      if (fs::exists(c.dir / png)) r.outputFiles.push_back(c.dir / png);
  }
  finishRun(scene, options, c.dir, r, t, start, extra);
}

/// The distributed part of a run (runDistributedDynamicScene), null for one process.
struct Distribution {
  const Communicator* comm = nullptr;
  const Coupled* coupled = nullptr;  ///< two bodies: their coupling
};

/// runDynamicScene on the bodies of the scene (Context::bodies, in stacked order), or
/// runDistributedDynamicScene on the bodies of the rank's local meshes (`dist`).
RunResult runDynamics(const Scene& scene, const std::vector<Context::Body>& bodies, const SceneCouplings& couplings,
                      const RunOptions& options, RunResult r, Clock::time_point start, const Distribution& dist = {}) {
  const DynamicsSpec& dyn = *scene.dynamics;
  const bool distributed = dist.comm != nullptr;
  const auto collective = [&](const std::function<void()>& work) {
    if (distributed)
      dist.comm->collective(work);
    else
      work();
  };
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  const OutputLayout layout(scene);
  const int dim = bodies.front().mesh->dimension();
  // the stacked vertices: the bodies' (Body::index), and of a distributed pair the coupling's extra
  // ghosts, whose positions and bodies come from their owners
  const mesh::Index n = dist.coupled ? dist.coupled->visit([](const auto& m) { return m.numLocal(); })
                                     : static_cast<mesh::Index>(bodies.back().index.back() + 1);
  const InterruptGuard interrupts;  // SIGINT/SIGTERM: finish the step, checkpoint, stop
  std::vector<int> bodyOf(static_cast<std::size_t>(n), -1);
  std::vector<mesh::Index> vertexOf(static_cast<std::size_t>(n), -1);
  Eigen::VectorXd where = Eigen::VectorXd::Zero(4 * n);  // position, body
  for (std::size_t b = 0; b < bodies.size(); ++b)
    for (mesh::Index v = 0; v < bodies[b].mesh->numVertices(); ++v) {
      const Index P = bodies[b].index[v];
      bodyOf[P] = static_cast<int>(b);
      vertexOf[P] = v;
      for (int a = 0; a < 3; ++a) where[4 * P + a] = bodies[b].mesh->vertex(v)[a];
      where[4 * P + 3] = static_cast<double>(b);
    }
  if (dist.coupled) dist.coupled->visit([&](const auto& m) { m.halo().update(where, 4); });
  std::vector<mesh::Point> positions;
  std::vector<const Scene*> owner;  // the body description of each stacked vertex
  // the checkpoint rows: a key per stacked vertex (docs/checkpoint.md#rows)
  std::vector<std::uint64_t> keys;
  for (mesh::Index P = 0; P < n; ++P) {
    const mesh::Point x(where[4 * P], where[4 * P + 1], where[4 * P + 2]);
    const auto b = static_cast<std::size_t>(where[4 * P + 3]);
    positions.push_back(x);
    owner.push_back(bodies[b].spec);
    keys.push_back(vertexKey(b, x));
  }
  const Communicator world = Communicator::world();
  const Communicator& comm = distributed ? *dist.comm : world;  // one process: a communicator of one
  // --restart: the checkpoint must belong to this scene, its bodies and grids (checked before its
  // rows are matched with this run's vertices), whatever number of ranks wrote it
  std::optional<CheckpointRecord> restart;
  if (options.restart) {
    long long missing = 0;
    restart = readCheckpoint(*options.restart, keys, comm, &missing);
    if (missing < 0 && restart->kind == "dynamic")
      throw Error(options.restart->string() + ": the checkpoint has no rows/keys (written by an obs before "
                  "checkpoints with rows, docs/checkpoint.md#rows): this obs cannot continue it; start the run again");
    checkRunIdentity(*restart, *options.restart, "dynamic", scene, runBodies(bodies, layout, dist.comm));
    if (missing > 0)
      throw Error(options.restart->string() + ": " + std::to_string(missing) +
                  " vertices of this run are not in the checkpoint (written for another grid: another --refine?)");
  }

  // contact set, tracked vertices, initial state (all checked before any time step)
  // (a distributed pair: the coupling's constraints of the held slave vertices)
  std::optional<ContactSet> merged;
  collective([&] {
    if (dist.coupled)
      merged.emplace(dist.coupled->visit([](const auto& m) { return m.contactSet(); }));
    else
      merged.emplace(dim == 2 ? mergedContactSet<2>(scene, couplings, bodies) : mergedContactSet<3>(scene, couplings, bodies));
  });
  const ContactSet& contact = *merged;
  // distributed: the owned vertices come first; their global indices from the rank's first one
  const Index owned = !distributed ? n
                      : dist.coupled ? dist.coupled->visit([](const auto& m) { return m.numOwned(); })
                                     : bodies.front().leaf->halo.numOwned();
  const Index firstGlobal =
      !distributed ? 0
      : dist.coupled ? dist.coupled->visit([&](const auto& m) { return owned > 0 ? m.global().front() : Index(0); })
                     : bodies.front().leaf->numbering.offsets[static_cast<std::size_t>(dist.comm->rank())];
  const std::vector<TrackedInfo> tracked =
      distributed ? trackedVertices(scene, positions, contact, dim, dist.comm, owned, firstGlobal)
                  : trackedVertices(scene, positions, contact, dim);

  Context c{scene, options, contact, couplings, tracked, {}, {}, 0, {}, false, {}, nullptr, {}, bodies, layout,
            dist.comm, dist.coupled, keys, owned, bodyOf, vertexOf};
  c.steps = dyn.steps ? *dyn.steps : static_cast<int>(std::ceil(*dyn.endTime / dyn.timeStep - 1e-9));
  DirichletValues dirichlet;
  collective([&] { dirichlet = initialState(scene, bodies, positions, owner, dim, c.u0, c.v0); });
  if (distributed) {  // the global unknowns; the free ones counted over the owned vertices
    r.dofs = 0;
    for (const Context::Body& b : bodies) r.dofs += static_cast<long long>(b.leaf->globalVertices()) * dim;
    long long fixed = 0;
    for (Index i = 0; i < owned * dim; ++i) fixed += dirichlet.constrained[static_cast<std::size_t>(i)] ? 1 : 0;
    r.freeDofs = r.dofs - dist.comm->sum(fixed);
  } else {
    r.dofs = static_cast<long long>(n) * dim;
    r.freeDofs = r.dofs - dirichlet.count();
  }

  c.dir = options.outputDirectory.value_or(scene.output.directory);
  collective([&] {
    std::error_code ec;
    fs::create_directories(c.dir, ec);
    if (ec) throw Error(c.dir.string() + ": cannot create the output directory (" + ec.message() + ")");
  });

  const std::vector<std::string> schemes = dynamicSchemes(scene, options.compareSchemes);
  const bool comparison = schemes.size() > 1;
  if (comparison && scene.output.checkpoint)
    throw Error(scene.where(scene.output.checkpoint->line) +
                "[output] checkpoint: scheme comparisons ([dynamics] compare, --compare-schemes) write no checkpoints");
  if (comparison && (options.restart || options.stopAfterStep))
    throw Error(scene.fileName + ": " + (options.restart ? "--restart" : "--stop-after-step") +
                ": scheme comparisons ([dynamics] compare, --compare-schemes) write no checkpoints");
  if (options.stopAfterStep && (*options.stopAfterStep < 1 || *options.stopAfterStep >= c.steps))
    throw Error(scene.fileName + ": --stop-after-step " + std::to_string(*options.stopAfterStep) +
                " must lie in [1, " + std::to_string(c.steps - 1) + "] (the run has " + std::to_string(c.steps) +
                " steps)");
  c.checkpointing = !comparison;
  c.checkpointFile = c.dir / "checkpoint.h5";
  if (restart) {
    c.restart = &*restart;
    c.restartFile = *options.restart;
    try {
      progress("restart from " + options.restart->string() + " at step " +
               std::to_string(restart->integer("scheme/step")) + " (t = " + fmt(restart->real("scheme/time")) + ")");
    } catch (const Error& e) {
      throw Error(options.restart->string() + ": " + e.what());
    }
  }
  {
    long long contactNodes = 0;  // over the owned vertices (and the ranks)
    for (Index k = 0; k < contact.size(); ++k) contactNodes += contact.vertex(k) < owned ? 1 : 0;
    if (distributed) contactNodes = dist.comm->sum(contactNodes);
    std::ostringstream os;
    os << "dynamics: " << (comparison ? std::to_string(schemes.size()) + " schemes" : schemes[0]) << ", tau = "
       << dyn.timeStep << ", " << c.steps << " steps, " << contactNodes << " potential contact nodes";
    progress(os.str());
  }
  std::vector<SchemeRun> runs;
  std::vector<std::pair<std::string, std::string>> failed;  // compared schemes the library refused
  for (std::size_t i = 0; i < schemes.size(); ++i) {
    const std::string file = comparison ? "timeseries_" + schemes[i] + ".csv" : "timeseries.csv";
    const bool vtk = scene.output.vtk && i == 0;
    ++r.massAssemblies;
    try {
      runs.push_back(dim == 2 ? runScheme<2>(c, schemes[i], vtk, file) : runScheme<3>(c, schemes[i], vtk, file));
    } catch (const RunInterrupted&) {
      throw;  // a signal stops the whole comparison
    } catch (const Error& e) {
      if (i == 0) throw;  // the scene's own scheme must run
      // a compared scheme that cannot run on this scene (e.g. an indefinite redistributed mass on
      // a coarse mesh) is reported, and the comparison goes on
      failed.emplace_back(schemes[i], e.what());
      std::error_code ignore;
      if (c.writer()) fs::remove(c.dir / file, ignore);
      if (options.stepProgress) options.stepProgress("warning: " + schemes[i] + " skipped: " + e.what());
      continue;
    }
    const SchemeRun& run = runs.back();
    std::ostringstream os;
    os << run.scheme << ": " << run.steps << " steps in " << fmt(run.stepSeconds, 3) << " s ("
       << fmt(run.steps ? static_cast<double>(run.iterations) / run.steps : 0.0, 3)
       << " TNNMG its/step), E_end/E_0 = " << fmt(run.initialEnergy != 0 ? run.finalEnergy / run.initialEnergy : 0.0)
       << ", max penetration " << fmt(run.maxPenetration, 3);
    progress(os.str());
  }

  reportDynamics(c, contact, runs, r);
  writeDynamicOutputs(c, options, runs, failed, comparison, r, start);
  return r;
}

}  // namespace

RunResult runDynamicScene(const Scene& scene, const std::vector<const mesh::Grid*>& grids,
                          const std::vector<const mesh::Mesh*>& meshes, const std::vector<BoundaryConditions>& bcs,
                          const RunOptions& options, RunResult r, Clock::time_point start) {
  const std::size_t n = scene.bodyScenes().size();
  if (grids.size() != n || meshes.size() != n || bcs.size() != n)
    throw Error(scene.where(0) + "internal: dynamics with inconsistent body lists");
  const std::vector<const Scene*> specs = scene.bodyScenes();
  std::vector<Context::Body> bodies;
  Index offset = 0;
  for (std::size_t i = 0; i < n; ++i) {
    Context::Body b;
    b.spec = specs[i];
    b.grid = grids[i];
    b.mesh = meshes[i];
    b.bc = &bcs[i];
    for (Index v = 0; v < meshes[i]->numVertices(); ++v) b.index.push_back(offset + v);
    offset += meshes[i]->numVertices();
    bodies.push_back(std::move(b));
  }
  const SceneCouplings couplings = sceneCouplings(scene, meshes, bcs);
  return runDynamics(scene, bodies, couplings, options, std::move(r), start);
}

namespace {

/// The coupling of two distributed bodies (Coupled): the scene's mortar pair on the leaf views and
/// the DistributedMultiBody of the bodies' elastic systems (only its numbering, constraints and C
/// are used). Errors name the [[contact]] line. Collective.
template <int d>
void couple(const Scene& scene, const std::vector<const DistributedView*>& leaves,
            const std::vector<BoundaryConditions>& bcs, const ContactModelSpec& spec, Coupled& out) {
  const MortarPairSpec& pair = scene.pairs.front();
  const auto& cs = spec.couplings.front();
  const std::vector<const Scene*> specs = scene.bodyScenes();
  const int s = pair.slaveIndex, m = pair.masterIndex;
  const Index offsets[2] = {0, leaves[0]->globalVertices()};
  const auto side = [](const std::string& body, const BoundaryRef& ref) {
    return body + ":" + (ref.name.empty() ? std::to_string(ref.id) : ref.name);
  };
  MortarOptions mo;
  mo.minCoverage = pair.minCoverage;
  mo.searchDistance = pair.searchDistance;
  try {
    out.mortar = std::make_unique<DistributedMortar>(
        DistributedMortarSurface{leaves[static_cast<std::size_t>(s)], cs.boundaryId, offsets[s], side(pair.slaveBody, pair.slave)},
        DistributedMortarSurface{leaves[static_cast<std::size_t>(m)], cs.masterId, offsets[m], side(pair.masterBody, pair.master)},
        mo);
    std::vector<BodySystem<d>> systems(2);
    leaves.front()->halo.communicator().collective([&] {
      for (std::size_t i = 0; i < 2; ++i) systems[i] = assembleBody<d>(leaves[i]->local, specs[i]->material, bcs[i]);
    });
    out.multi = std::make_unique<DistributedMultiBody<d>>(
        std::vector<DistributedBody<d>>{{leaves[0], &systems[0]}, {leaves[1], &systems[1]}}, *out.mortar, s, m);
  } catch (const Error& e) {
    throw Error(scene.where(pair.line) + "[[contact]] " + e.what());
  }
}

}  // namespace

RunResult runDistributedDynamicScene(const Scene& scene, const std::vector<const DistributedGrid*>& grids,
                                     const std::vector<const DistributedView*>& leaves,
                                     const std::vector<const mesh::Mesh*>& coarseMeshes,
                                     const std::vector<BoundaryConditions>& bcs, const RunOptions& options, RunResult r,
                                     Clock::time_point start) {
  const std::vector<const Scene*> specs = scene.bodyScenes();
  const std::size_t n = specs.size();
  if (grids.size() != n || leaves.size() != n || coarseMeshes.size() != n || bcs.size() != n || n == 0)
    throw Error(scene.where(0) + "internal: distributed dynamics with inconsistent body lists");
  const Communicator& comm = grids.front()->communicator();
  // the couplings resolve the boundaries on the coarse meshes (the same on every rank; ids survive
  // refinement, a rank's local mesh may have no face of a boundary)
  std::optional<SceneCouplings> couplings;
  comm.collective([&] {
    couplings.emplace(sceneCouplings(scene, coarseMeshes, bcs));
    if (n > 1 && (n != 2 || scene.pairs.size() != 1 || couplings->spec.couplings.size() != 1))
      throw Error(scene.fileName + ": distributed dynamic runs take one body or two bodies with one mortar pair (" +
                  std::to_string(n) + " bodies, " + std::to_string(couplings->spec.couplings.size()) + " couplings)");
  });
  Coupled coupled;
  if (n == 2) {
    if (leaves.front()->local.dimension() == 2)
      couple<2>(scene, leaves, bcs, couplings->spec, coupled);
    else
      couple<3>(scene, leaves, bcs, couplings->spec, coupled);
  }
  std::vector<Context::Body> bodies;
  for (std::size_t i = 0; i < n; ++i) {
    Context::Body b;
    b.spec = specs[i];
    b.grid = &grids[i]->grid();
    b.mesh = &leaves[i]->local;
    b.bc = &bcs[i];
    for (Index v = 0; v < leaves[i]->local.numVertices(); ++v)
      b.index.push_back(n == 2 ? coupled.visit([&](const auto& m) { return m.local(static_cast<int>(i), v); }) : v);
    b.distributed = grids[i];
    b.leaf = leaves[i];
    bodies.push_back(std::move(b));
  }
  return runDynamics(scene, bodies, *couplings, options, std::move(r), start,
                     Distribution{&comm, n == 2 ? &coupled : nullptr});
}

}  // namespace obs::drivers
