#include "obs/drivers/AdaptiveScene.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <numbers>
#include <sstream>

#include <nlohmann/json.hpp>

#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/SceneSolver.hpp"
#include "obs/drivers/SolutionFields.hpp"
#include "obs/drivers/Summary.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/estimators/DistributedAdaptiveLoop.hpp"
#include "obs/estimators/Marking.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "DistributedOutput.hpp"
#include "PlotScript.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "RunCheckpoint.hpp"
#include "RunSupport.hpp"

namespace obs::drivers {

namespace {

namespace fs = std::filesystem;
namespace est = obs::estimators;

/// A number for CSV/JSON text: empty for NaN.
std::string num(double x) {
  if (!std::isfinite(x)) return "";
  std::ostringstream os;
  os << std::setprecision(10) << x;
  return os.str();
}

nlohmann::json jnum(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

std::vector<double> sceneVector(const ContactSpec& c, const std::string& key, std::vector<double> fallback) {
  const auto it = c.vectors.find(key);
  return it == c.vectors.end() ? fallback : it->second.values;
}

Point toPoint(const std::vector<double>& v) {
  Point p = Point::Zero();
  for (std::size_t i = 0; i < v.size() && i < 3; ++i) p[static_cast<Eigen::Index>(i)] = v[i];
  return p;
}

/// The analytic reference of [adaptivity] reference, with the parameters of [contact] and
/// [material]; the obstacle type must match.
std::optional<est::ContactReference> makeReference(const Scene& scene, int dim) {
  const AdaptivitySpec& a = *scene.adaptivity;
  if (a.reference.empty() || !scene.contact) return std::nullopt;
  const ContactSpec& c = *scene.contact;
  auto need = [&](const char* obstacle, int d) {
    if (c.obstacle != obstacle || dim != d)
      throw Error(scene.where(a.referenceLine) + "[adaptivity] reference = \"" + a.reference + "\" needs obstacle = \"" +
                  obstacle + "\" in " + std::to_string(d) + "D (the scene has obstacle = \"" + c.obstacle +
                  "\" in " + std::to_string(dim) + "D)");
  };
  const double E = scene.material.youngsModulus, nu = scene.material.poissonRatio;
  if (a.reference == "punch") {
    need("strip", 2);
    return est::punchReference(c.numbers.at("half_width").value, toPoint(sceneVector(c, "point", {0, 0})));
  }
  if (a.reference == "wedge") {
    need("wedge", 2);
    return est::wedgeReference(E, nu, c.numbers.at("slope").value, toPoint(sceneVector(c, "apex", {0, 0})));
  }
  need("ball", 3);
  if (c.normalDirection)
    throw Error(scene.where(a.referenceLine) +
                "[adaptivity] reference = \"hertz\" needs a fixed [contact] direction, not \"normal\"");
  const double R = c.numbers.at("radius").value;
  Point dir = toPoint(sceneVector(c, "direction", {0, 0, -1}));
  dir.normalize();
  // the point of the ball nearest to the body (dir points from the body into the obstacle)
  return est::hertzReference(E, nu, R, toPoint(sceneVector(c, "centre", {0, 0, 0})) - R * dir);
}

/// Everything written for one step's .vtu (kept for vtk = "last" until the loop ends).
struct StepSnapshot {
  int step = 0;
  mesh::Mesh mesh;
  std::vector<Field> points, cells;
};

struct PressureRow {
  Point x;
  double s = 0, sp = 0, exact = std::numeric_limits<double>::quiet_NaN();
  double weight = 0;  ///< m_p = m_p^C, the lumped boundary mass
};

/// The constrained vertices of a step (finite gap; of a distributed run's local mesh, the owned
/// ones) as estimators::nodalPressureError samples: x_p, m_p = m_p^C (the lumped boundary mass) and s_p.
std::vector<est::NodalPressure> nodalPressures(const ContactSet& set, const ContactOutputs& out,
                                               Index ownedVertices = std::numeric_limits<Index>::max()) {
  std::vector<est::NodalPressure> nodes;
  for (Index k = 0; k < set.size(); ++k)
    if (std::isfinite(set.gap(k)) && set.vertex(k) < ownedVertices) nodes.push_back(est::NodalPressure{set.position(k), set.boundaryMass(k), out.pressure[k]});
  return nodes;
}

/// The nodal pressure errors of one step (docs/examples.md, docs/scenes.md): against the reference
/// for the load computed on the step's grid, and for the scene's fixed reference_load (NaN without).
struct NodalErrors {
  std::vector<double> load, fixedLoad;  ///< per step (one body with a reference; else empty)
  double at(const std::vector<double>& e, int step) const {
    return static_cast<std::size_t>(step) < e.size() ? e[static_cast<std::size_t>(step)] : std::nan("");
  }
};

struct FinalState {
  double maxDisplacement = 0, maxVonMises = 0;
  std::array<long long, 7> cellsPerType{};
  std::optional<ContactReport> contact;
  std::vector<PressureRow> pressure;
};

std::vector<std::string> contributionNames(const std::vector<est::AdaptiveStep>& steps) {
  std::vector<std::string> names;
  for (const auto& s : steps)
    for (const auto& c : s.contributions)
      if (std::find(names.begin(), names.end(), c.name) == names.end()) names.push_back(c.name);
  return names;
}

double contributionOf(const est::AdaptiveStep& s, const std::string& name) {
  for (const auto& c : s.contributions)
    if (c.name == name) return c.value;
  return std::numeric_limits<double>::quiet_NaN();
}

void writeStepsCsv(const fs::path& path, const std::vector<est::AdaptiveStep>& steps,
                   const NodalErrors& nodalErrors) {
  const auto names = contributionNames(steps);
  std::ofstream out(path);
  if (!out) throw Error(path.string() + ": cannot write the steps table");
  out << stepsCsvHeader(names) << "\n";
  for (const auto& s : steps) {
    out << s.step << "," << s.cells << "," << s.vertices << "," << s.unknowns << "," << s.potentialContact << ","
        << s.actualContact << "," << s.semiContact << "," << s.fullContact << "," << num(s.eta);
    for (const auto& n : names) out << "," << num(contributionOf(s, n));
    out << "," << num(s.eoc) << "," << s.solver << "," << s.solverIterations << "," << (s.converged ? 1 : 0) << ","
        << num(s.solverSeconds) << "," << num(s.estimatorSeconds) << "," << num(s.refinementSeconds) << ","
        << num(s.transferSeconds) << "," << s.marked << "," << s.refinedRed << "," << s.closureRed << ","
        << s.greenClosed;
    if (s.reference) {
      const auto& r = *s.reference;
      out << "," << num(r.load) << "," << num(r.pressureError) << "," << num(r.radius) << "," << num(r.exactRadius)
          << "," << num(r.radiusError) << "," << num(r.centrePressure) << "," << num(r.exactCentrePressure) << ","
          << num(r.centreError) << ","
          << num(nodalErrors.at(nodalErrors.load, s.step)) << ","
          << num(nodalErrors.at(nodalErrors.fixedLoad, s.step));
    } else {
      out << "," << (s.potentialContact > 0 ? num(s.load) : "") << ",,,,,,,,,";
    }
    out << "\n";
  }
  if (!out) throw Error(path.string() + ": cannot write the steps table");
}

nlohmann::json stepJson(const est::AdaptiveStep& s, double nodalError, double nodalErrorFixedLoad, bool friction) {
  nlohmann::json j;
  j["step"] = s.step;
  j["cells"] = s.cells;
  j["vertices"] = s.vertices;
  j["unknowns"] = s.unknowns;
  j["potential_contact"] = s.potentialContact;
  j["actual_contact"] = s.actualContact;
  j["semi_contact"] = s.semiContact;
  j["full_contact"] = s.fullContact;
  j["eta"] = jnum(s.eta);
  nlohmann::json c = nlohmann::json::object();
  for (const auto& k : s.contributions) c[k.name] = jnum(k.value);
  j["contributions"] = c;
  j["eoc"] = jnum(s.eoc);
  j["solver"] = s.solver;
  j["iterations"] = s.solverIterations;
  j["solver_tolerance"] = jnum(s.solverTolerance);
  j["converged"] = s.converged;
  j["kkt"] = jnum(s.kkt);
  j["load"] = s.load;
  if (friction) {  // summed over the couplings (per pair in "pairs" of static runs)
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    Index stick = 0, slip = 0;
    for (const auto& c : s.couplings) {
      force += c.tangentialSlave;
      stick += c.stickVertices;
      slip += c.slipVertices;
    }
    j["friction"] = {{"tangential_force", {force[0], force[1], force[2]}}, {"stick_vertices", stick}, {"slip_vertices", slip}};
  }
  j["times"] = {{"assembly_s", s.assemblySeconds}, {"solver_s", s.solverSeconds},
                {"estimator_s", s.estimatorSeconds}, {"refinement_s", s.refinementSeconds},
                {"transfer_s", s.transferSeconds}};
  j["marked"] = s.marked;
  j["refinement"] = {{"refined_red", s.refinedRed}, {"closure_red", s.closureRed}, {"green_closed", s.greenClosed}};
  if (s.bodies.size() > 1 || s.couplings.size() > 1 || (!s.couplings.empty() && s.couplings.front().mortar)) {
    nlohmann::json b = nlohmann::json::array();
    for (const auto& x : s.bodies)
      b.push_back({{"cells", x.cells}, {"vertices", x.vertices}, {"eta", jnum(x.eta)}, {"marked", x.marked}});
    j["bodies"] = b;
    nlohmann::json c = nlohmann::json::array();
    for (const auto& x : s.couplings)
      c.push_back({{"label", x.label}, {"actual_vertices", x.actualVertices}, {"load_P", x.load}});
    j["pairs"] = c;
  }
  if (s.reference) {
    const auto& r = *s.reference;
    j["reference"] = {{"load", jnum(r.load)},
                      {"pressure_error", jnum(r.pressureError)},
                      {"radius", jnum(r.radius)},
                      {"exact_radius", jnum(r.exactRadius)},
                      {"radius_error", jnum(r.radiusError)},
                      {"centre_pressure", jnum(r.centrePressure)},
                      {"exact_centre_pressure", jnum(r.exactCentrePressure)},
                      {"centre_error", jnum(r.centreError)},
                      {"nodal_pressure_error", jnum(nodalError)},
                      {"nodal_pressure_error_fixed_load", jnum(nodalErrorFixedLoad)}};
  }
  return j;
}

void writePressureCsv(const fs::path& path, const std::vector<PressureRow>& rows) {
  std::ofstream out(path);
  if (!out) throw Error(path.string() + ": cannot write the pressure table");
  out << "x,y,z,s,s_p,exact_p,m_p\n";
  for (const auto& r : rows)
    out << num(r.x[0]) << "," << num(r.x[1]) << "," << num(r.x[2]) << "," << num(r.s) << "," << num(r.sp) << ","
        << num(r.exact) << "," << num(r.weight) << "\n";
}

/// The path of scripts/plot_adaptivity.py: $OBS_PLOT_ADAPTIVITY_SCRIPT, else the source tree's.
fs::path plotScript() {
  if (const char* env = std::getenv("OBS_PLOT_ADAPTIVITY_SCRIPT"); env && *env) return env;
#ifdef OBS_PLOT_ADAPTIVITY_SCRIPT
  return OBS_PLOT_ADAPTIVITY_SCRIPT;
#else
  return "scripts/plot_adaptivity.py";
#endif
}

template <int d>
void snapshotStep(const Scene& scene, const est::AdaptiveStepView& v, const std::vector<Index>& marked,
                  bool allMarked, StepSnapshot& snap, FinalState& fin, const std::optional<est::ContactReference>& ref) {
  const mesh::Mesh& m = v.view.mesh;
  const auto nv = static_cast<std::size_t>(m.numVertices());
  const auto nc = static_cast<std::size_t>(m.numCells());
  ElasticitySolution e;
  e.dimension = d;
  e.displacement = v.displacement;
  recoverStresses(m, scene.material, e);
  snap.step = v.record.step;
  snap.mesh = m;
  snap.points = pointFields(m, e);
  snap.cells = cellFields(m, e);
  Field sp{"contact_pressure", 1, std::vector<double>(nv, 0.0), false};
  Field cls{"node_class", 1, std::vector<double>(nv, 0.0), true};
  for (std::size_t i = 0; i < nv && i < v.classes.ofVertex.size(); ++i)
    cls.values[i] = static_cast<double>(static_cast<int>(v.classes.ofVertex[i]));
  if (v.contactSet && v.outputs)
    for (Index k = 0; k < v.contactSet->size(); ++k)
      if (std::isfinite(v.contactSet->gap(k)))
        sp.values[static_cast<std::size_t>(v.contactSet->vertex(k))] = v.outputs->pressure[k];
  snap.points.push_back(std::move(sp));
  snap.points.push_back(std::move(cls));
  if (scene.frictional()) {  // as in static runs: the friction force on the body and the stick/slip state
    Field force{"friction_force", 3, std::vector<double>(3 * nv, 0.0), false};
    Field state{"stick_slip", 1, std::vector<double>(nv, 0.0), true};
    if (v.contactSet && v.outputs && v.outputs->tangential.size() == static_cast<std::size_t>(v.contactSet->size()))
      for (Index k = 0; k < v.contactSet->size(); ++k) {
        const auto p = static_cast<std::size_t>(v.contactSet->vertex(k));
        for (int a = 0; a < 3; ++a) force.values[3 * p + a] = -v.outputs->tangential[static_cast<std::size_t>(k)][a];
        state.values[p] = v.outputs->state[static_cast<std::size_t>(k)];
      }
    snap.points.push_back(std::move(force));
    snap.points.push_back(std::move(state));
  }
  auto taken = [&](const std::vector<Field>& fs, const std::string& n) {
    return std::any_of(fs.begin(), fs.end(), [&](const Field& f) { return f.name == n; });
  };
  Field marks{"marked", 1, std::vector<double>(nc, allMarked ? 1.0 : 0.0), true};
  for (Index c : marked) marks.values[static_cast<std::size_t>(c)] = 1;
  if (v.estimate) {
    for (const auto& [name, values] : v.estimate->vertexFields) {
      if (taken(snap.points, name) || values.size() != static_cast<Eigen::Index>(nv)) continue;
      snap.points.push_back(Field{name, 1, std::vector<double>(values.data(), values.data() + values.size()), false});
    }
    snap.cells.push_back(Field{"indicator", 1, v.estimate->indicators, false});
    for (const auto& [name, values] : v.estimate->cellFields)
      if (values.size() == nc) snap.cells.push_back(Field{"cell_" + name, 1, values, false});
  }
  snap.cells.push_back(std::move(marks));

  // final-step figures (overwritten each step)
  fin = FinalState{};
  for (mesh::Index p = 0; p < m.numVertices(); ++p)
    fin.maxDisplacement = std::max(fin.maxDisplacement, v.displacement.template segment<d>(p * d).norm());
  for (const Stress& s : e.cellStress) fin.maxVonMises = std::max(fin.maxVonMises, vonMises(s));
  const auto counts = m.cellCounts();
  for (std::size_t i = 0; i < counts.size() && i < fin.cellsPerType.size(); ++i) fin.cellsPerType[i] = counts[i];
  if (!v.contactSet || !v.outputs || !scene.contact) return;  // (mortar slaves: reported per pair)
  const ContactSet& set = *v.contactSet;
  const ContactOutputs& out = *v.outputs;
  ContactReport c;
  c.obstacle = scene.contact->obstacle;
  c.boundary = scene.contact->boundary.name.empty() ? std::to_string(scene.contact->boundary.id)
                                                    : scene.contact->boundary.name;
  c.boundaryVertices = set.size();
  c.actualVertices = out.contactNodes;
  for (int i = 0; i < 3; ++i) c.force[i] = out.force[i];
  c.area = out.contactArea;
  c.radius = out.contactRadius;
  Point centre = Point::Zero(), normal = Point::Zero();
  Index bounded = 0;
  for (Index k = 0; k < set.size(); ++k) {
    if (!std::isfinite(set.gap(k))) continue;
    ++bounded;
    c.load += out.multiplier[k];
    centre += set.position(k);
    normal += set.direction(k);
    const Point& nu = set.direction(k);
    const double un = nu.template head<d>().dot(v.displacement.template segment<d>(set.vertex(k) * d));
    c.maxViolation = std::max(c.maxViolation, un - set.gap(k));
  }
  c.potentialVertices = bounded;
  if (bounded > 0) centre /= static_cast<double>(bounded);
  if (normal.norm() > 0) normal.normalize();
  if (ref) centre = ref->centre;
  for (Index k = 0; k < set.size(); ++k) {
    if (!std::isfinite(set.gap(k))) continue;
    const Point r = set.position(k) - centre;
    const Point tangential = r - r.dot(normal) * normal;
    if (out.inContact[k]) c.radiusNodes = std::max(c.radiusNodes, tangential.norm());
    PressureRow row;
    row.x = set.position(k);
    if (d == 2) {
      const Point t(-normal[1], normal[0], 0);
      row.s = tangential.dot(t);
    } else {
      row.s = tangential.norm();
    }
    row.sp = out.pressure[k];
    row.weight = set.boundaryMass(k);
    if (ref) row.exact = ref->pressure(set.position(k), c.load);
    fin.pressure.push_back(row);
  }
  std::sort(fin.pressure.begin(), fin.pressure.end(), [](const PressureRow& a, const PressureRow& b) { return a.s < b.s; });
  fin.contact = c;
}

}  // namespace

est::AdaptiveLoopOptions adaptiveLoopOptions(const Scene& scene, bool contact) {
  const AdaptivitySpec& spec = *scene.adaptivity;
  est::AdaptiveLoopOptions o;
  o.mode = spec.uniform ? est::RefinementMode::Uniform : est::RefinementMode::Adaptive;
  o.estimator = spec.estimator;
  o.marking = spec.marking;
  o.markingParameter = spec.theta;
  o.estimateUniform = true;
  o.maxSteps = spec.steps;
  o.targetVertices = static_cast<Index>(spec.maxVertices);
  o.etaTolerance = spec.etaTolerance;
  o.warmStart = spec.warmStart;
  o.inexactFraction = spec.inexact;
  if (spec.closureAllEdges) o.closure = mesh::ClosureRule::AllEdges;
  o.solver = solverConfig(scene);
  const std::string type = scene.solverType();
  if (contact && type == "pdas" && spec.inexact > 0)
    throw Error(scene.where(scene.solver.line) + "[solver] type = \"pdas\" solves every step exactly; "
                "[adaptivity] inexact applies to tnnmg only");
  if (contact && type != "tnnmg" && type != "pdas")
    throw Error(scene.where(scene.solver.line) + "[solver] type = \"" + type +
                "\" is not available with [adaptivity] (use tnnmg or pdas)");
  return o;
}

namespace {

std::string stepLine(const est::AdaptiveStep& s, int steps) {
  std::ostringstream os;
  os << "step " << s.step << "/" << steps - 1 << ": " << s.vertices << " vertices, " << s.cells << " cells";
  if (s.potentialContact > 0) os << ", contact " << s.actualContact << " of " << s.potentialContact;
  os << std::setprecision(4);
  if (std::isfinite(s.eta)) os << ", eta " << s.eta;
  if (std::isfinite(s.eoc)) os << ", eoc " << std::setprecision(3) << s.eoc;
  os << ", " << s.solver << " " << s.solverIterations << (s.converged ? " it" : " it NOT converged");
  if (s.reference) os << std::setprecision(4) << ", pressure error " << s.reference->pressureError;
  if (s.marked > 0) os << ", marked " << s.marked;
  os << std::setprecision(3) << " (" << s.solverSeconds + s.estimatorSeconds + s.assemblySeconds << " s)";
  return os.str();
}

/// The marks of a distributed adaptive checkpoint by cell key (docs/checkpoint.md#distributed-adaptive-runs):
/// its mark, and the count per step.
const std::string kMarkedKeys = "adaptivity/refinement/marked_keys";
const std::string kMarkedKeyCounts = "adaptivity/refinement/marked_key_counts";

/// --stop-after-step k of an adaptive run: 0 <= k <= steps - 2 (a checkpoint after the last step
/// would have nothing to continue); obs::Error otherwise.
void checkStopAfterStep(const Scene& scene, const RunOptions& options) {
  const int steps = scene.adaptivity->steps;
  if (options.stopAfterStep && (*options.stopAfterStep < 0 || *options.stopAfterStep > steps - 2))
    throw Error(scene.fileName + ": --stop-after-step " + std::to_string(*options.stopAfterStep) +
                (steps < 2 ? " needs at least two adaptive steps (the run has " + std::to_string(steps) + ")"
                           : " must lie in [0, " + std::to_string(steps - 2) + "] (the run has steps 0 to " +
                                 std::to_string(steps - 1) + ")"));
}

/// The outputs of an adaptive run so far in its checkpoint (docs/checkpoint.md#adaptive-runs): the
/// VTK files (`kind`: ".vtu" or ".pvtu") with their steps and bodies, and the nodal pressure errors.
void storeRunOutputs(CheckpointRecord& cp, const std::vector<PvdEntry>& vtu, const NodalErrors& nodalErrors,
                     const std::string& kind) {
  std::string files;
  std::vector<long long> steps, parts;
  for (const PvdEntry& e : vtu) {
    files += e.file + "\n";
    steps.push_back(static_cast<long long>(e.time));
    parts.push_back(e.part);
  }
  cp.set("run/vtu_files", files, "the " + kind + " files written so far (one name per line)");
  cp.set("run/vtu_steps", steps, "the step of each " + kind + " file");
  cp.set("run/vtu_parts", parts, "the body of each " + kind + " file (its part in the .pvd)");
  auto vec = [](const std::vector<double>& v) {
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  cp.set("run/nodal_pressure_errors", vec(nodalErrors.load),
         "the nodal pressure error of each step so far (with a reference; NaN: none)");
  cp.set("run/nodal_pressure_errors_fixed_load", vec(nodalErrors.fixedLoad),
         "the nodal pressure error for the fixed reference_load of each step so far (NaN: none)");
}

/// The outputs storeRunOutputs stored, each VTK file checked to exist in `dir`; obs::Error naming
/// what is missing or inconsistent.
void loadRunOutputs(const CheckpointRecord& cp, const fs::path& dir, std::vector<PvdEntry>& vtu, NodalErrors& nodalErrors) {
  std::istringstream files(cp.text("run/vtu_files"));
  for (std::string f; std::getline(files, f);) {
    if (!fs::exists(dir / f))
      throw Error("the interrupted run's " + (dir / f).string() +
                  " is missing (restart into the output directory of the interrupted run)");
    vtu.push_back(PvdEntry{0, 0, f});
  }
  const std::vector<long long>& steps = cp.integers("run/vtu_steps");
  // (run/vtu_parts is absent in distributed checkpoints of older versions: one body)
  const std::vector<long long> parts =
      cp.has("run/vtu_parts") ? cp.integers("run/vtu_parts") : std::vector<long long>(vtu.size(), 0);
  if (steps.size() != vtu.size() || parts.size() != vtu.size())
    throw Error("run/vtu_files, run/vtu_steps and run/vtu_parts differ in length");
  for (std::size_t i = 0; i < steps.size(); ++i) {
    vtu[i].time = static_cast<double>(steps[i]);
    vtu[i].part = static_cast<int>(parts[i]);
  }
  const Eigen::VectorXd& e = cp.vector("run/nodal_pressure_errors");
  nodalErrors.load.assign(e.data(), e.data() + e.size());
  if (cp.has("run/nodal_pressure_errors_fixed_load")) {  // (absent in checkpoints of older versions)
    const Eigen::VectorXd& f = cp.vector("run/nodal_pressure_errors_fixed_load");
    nodalErrors.fixedLoad.assign(f.data(), f.data() + f.size());
  }
}

/// Checkpoints of an adaptive run, one body or several (docs/checkpoint.md#adaptive-runs): a
/// checkpoint after step k (on the [output] checkpoint schedule, at --stop-after-step and on
/// SIGINT/SIGTERM) holds the loop's state (estimators AdaptiveLoopState: the step records, the
/// refinement history, the start vector), the identity of the scene and of the initial and refined
/// grids, and the outputs written so far (the .vtu files, the nodal pressure errors); --restart
/// checks the scene and the initial grids, replays the refinements, checks the refined grids and
/// continues with step k + 1.
class AdaptiveCheckpoints {
public:
  /// What the runner has written or collected so far besides the loop's records.
  struct Outputs {
    std::vector<PvdEntry> vtu;        ///< .vtu files (time = step, part = body)
    NodalErrors nodalErrors;          ///< per step (one body with a reference; else empty)
  };

  AdaptiveCheckpoints(const Scene& scene, const RunOptions& options, fs::path dir, std::vector<mesh::Grid*> grids,
                      std::vector<std::string> names)
      : scene_(scene), options_(options), dir_(std::move(dir)), grids_(std::move(grids)),
        names_(std::move(names)), schedule_(scene.output.checkpoint), file_(dir_ / "checkpoint.h5") {
    checkStopAfterStep(scene, options);
    for (const mesh::Grid* g : grids_) initial_.push_back(g->leafView().mesh);
  }

  /// --restart: checks the checkpoint against the scene and the initial grids, restores the loop
  /// (replaying the refinements) and the outputs, and checks the refined grids; nothing otherwise.
  void restore(est::AdaptiveLoop& loop, Outputs& outputs, const std::function<void(const std::string&)>& progress) {
    if (!options_.restart) return;
    const fs::path& file = *options_.restart;
    const CheckpointRecord cp = readCheckpoint(file);
    checkRunScene(cp, file, "adaptive", scene_, names_);
    if (cp.has(kMarkedKeys))
      throw Error(file.string() + ": the checkpoint was written by a distributed run (mpirun): continue it with "
                  "mpirun -np N obs run (N >= 2, any number of ranks)");
    checkInitialGrid(cp, file, runBodies(initial_));
    try {
      est::AdaptiveLoopState state = est::loadAdaptiveState(cp);
      const int next = state.nextStep;
      loop.restore(std::move(state));
      loadRunOutputs(cp, dir_, outputs.vtu, outputs.nodalErrors);  // the outputs of the interrupted run
      progress("restart from " + file.string() + " at step " + std::to_string(next));
    } catch (const Error& e) {
      throw Error(file.string() + ": " + e.what());
    }
    std::vector<mesh::Mesh> refined;
    for (const mesh::Grid* g : grids_) refined.push_back(g->leafView().mesh);
    checkRunIdentity(cp, file, "adaptive", scene_, runBodies(refined));
  }

  /// The loop's state hook after step k = state.nextStep - 1: writes a checkpoint if it is due or
  /// the run stops here, and stops it (RunInterrupted) on a signal or at --stop-after-step.
  void after(const est::AdaptiveLoopState& state, const Outputs& outputs) {
    const int k = state.nextStep - 1;
    const bool signalled = InterruptGuard::requested();
    const bool stop = signalled || (options_.stopAfterStep && k >= *options_.stopAfterStep);
    if (stop || schedule_.due(k + 1)) {
      CheckpointRecord cp;
      cp.kind = "adaptive";
      std::vector<mesh::Mesh> refined;
      for (const mesh::Grid* g : grids_) refined.push_back(g->leafView().mesh);
      storeRunIdentity(cp, scene_, runBodies(refined));
      storeInitialGrid(cp, runBodies(initial_));
      est::storeAdaptiveState(cp, state);
      storeRunOutputs(cp, outputs.vtu, outputs.nodalErrors, ".vtu");
      writeCheckpoint(file_, cp);
      schedule_.written();
      if (options_.stepProgress)
        options_.stepProgress("checkpoint: step " + std::to_string(k) + " -> " + file_.string());
    }
    if (!stop) return;
    Index vertices = 0;
    for (const mesh::Grid* g : grids_) vertices += g->leafView().mesh.numVertices();
    std::ostringstream os;
    os << (signalled ? "interrupted by " + InterruptGuard::signalName() : std::string("stopped (--stop-after-step)"))
       << " after adaptive step " << k << " of " << scene_.adaptivity->steps - 1 << " (refined to " << vertices
       << " vertices): checkpoint written to " << file_.string() << "; continue with: obs run " << scene_.fileName
       << " --restart " << file_.string() << " (and the same --output, --refine and --set options)";
    throw RunInterrupted(os.str());
  }

private:
  std::vector<RunBody> runBodies(const std::vector<mesh::Mesh>& meshes) const {
    std::vector<RunBody> bodies;
    for (std::size_t i = 0; i < meshes.size(); ++i) bodies.push_back(RunBody{names_[i], &meshes[i]});
    return bodies;
  }

  const Scene& scene_;
  const RunOptions& options_;
  fs::path dir_;
  std::vector<mesh::Grid*> grids_;
  std::vector<std::string> names_;
  CheckpointSchedule schedule_;
  fs::path file_;
  std::vector<mesh::Mesh> initial_;
};

/// The run's sizes from the last step and the assembly and solve times summed over the steps.
void recordFinalStep(const std::vector<est::AdaptiveStep>& steps, RunResult& r) {
  const est::AdaptiveStep& final = steps.back();
  r.vertices = final.vertices;
  r.cells = final.cells;
  r.dofs = final.unknowns;
  r.freeDofs = final.unknowns;
  for (const auto& s : steps) {
    r.assemblySeconds += s.assemblySeconds;
    r.solveSeconds += s.solverSeconds;
  }
}

/// The end of an adaptive run: the plots, finishRun with summary.json "adaptivity", and the error
/// of an unconverged last step.
void finishAdaptiveRun(const Scene& scene, const RunOptions& options, const fs::path& dir, const fs::path& stepsCsv,
                       const std::vector<est::AdaptiveStep>& steps, const NodalErrors& nodalErrors,
                       double theta, RunResult& r, Clock::time_point t, Clock::time_point start,
                       nlohmann::json extra = nlohmann::json::object()) {
  const AdaptivitySpec& spec = *scene.adaptivity;
  const est::AdaptiveStep& final = steps.back();
  if (scene.output.plots || options.plots) {
    std::vector<std::string> args = {"--output", dir.string(), "--label", scene.name};
    if (scene.contact) args.insert(args.end(), {"--pressure", (dir / "pressure.csv").string()});
    args.push_back(stepsCsv.string());
    const fs::path script = plotScript();
    const PlotScriptRun plot = runPlotScript(script, args);
    std::ofstream(dir / "plots.log") << plot.command << "\n" << plot.output << "\n";
    if (!plot.ok) {
      if (options.stepProgress)
        options.stepProgress("warning: no plots (python3 with matplotlib needed to run " + script.string() +
                             "; see " + (dir / "plots.log").string() + ")");
    } else {
      for (const char* png : {"estimator.png", "pressure.png", "pressure_error.png"})
        if (fs::exists(dir / png)) r.outputFiles.push_back(dir / png);
    }
  }

  nlohmann::json a;
  a["refinement"] = spec.uniform ? "uniform" : "adaptive";
  a["estimator"] = spec.estimator;
  a["marking"] = spec.marking;
  a["theta"] = theta;
  a["max_steps"] = spec.steps;
  a["max_vertices"] = spec.maxVertices;
  a["eta_tolerance"] = spec.etaTolerance;
  a["reference"] = spec.reference.empty() ? nlohmann::json(nullptr) : nlohmann::json(spec.reference);
  a["reference_load"] = spec.referenceLoad ? nlohmann::json(*spec.referenceLoad) : nlohmann::json(nullptr);
  a["steps"] = nlohmann::json::array();
  for (const auto& s : steps)
    a["steps"].push_back(
        stepJson(s, nodalErrors.at(nodalErrors.load, s.step), nodalErrors.at(nodalErrors.fixedLoad, s.step),
                 scene.frictional()));
  extra["adaptivity"] = std::move(a);
  finishRun(scene, options, dir, r, t, start, extra);
  if (!final.converged) {
    std::ostringstream os;
    os << scene.where(scene.solver.line) << "[solver] " << final.solver << " did not converge in step "
       << final.step << " (" << final.solverIterations
       << " iterations), so the adaptive loop stopped there without estimating on it; raise [solver] "
          "max_iterations or tolerance"
       << (scene.frictional() ? "; with Coulomb friction the fixed point over Tresca solves may be what failed "
                                "(docs/theory.md#friction-coulomb)"
                              : "")
       << " (outputs written to "
       << dir.string() << ")";
    throw Error(os.str());
  }
}

}  // namespace

std::string stepsCsvHeader(const std::vector<std::string>& contributions) {
  std::string h =
      "step,cells,vertices,unknowns,potential_contact,actual_contact,semi_contact,full_contact,eta";
  for (const auto& n : contributions) h += "," + n;
  h += ",eoc,solver,iterations,converged,solver_s,estimator_s,refinement_s,transfer_s,marked,"
       "refined_red,closure_red,green_closed,"
       "load,pressure_error,radius,exact_radius,radius_error,centre_pressure,exact_centre_pressure,centre_error,"
       "nodal_pressure_error,nodal_pressure_error_fixed_load";
  return h;
}

RunResult runAdaptiveScene(const Scene& scene, const RunOptions& options) {
  const auto start = Clock::now();
  const AdaptivitySpec& spec = *scene.adaptivity;
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  RunResult r;
  r.scene = scene.fileName;
  const std::vector<const Scene*> specs = scene.bodyScenes();
  const OutputLayout layout(scene);

  // the bodies' grids, checks, boundary conditions
  auto t = Clock::now();
  BodyGrids built = buildBodyGrids(scene, options.refine);
  const int dim = built.meshes.front().dimension();
  r.meshSeconds = secondsSince(t);
  r.dimension = dim;
  r.refine = options.refine.value_or(specs.front()->mesh.refine);

  // the loop on the bodies and couplings of the scene
  const bool contact = scene.hasContact();
  const est::AdaptiveLoopOptions o = adaptiveLoopOptions(scene, contact);
  std::vector<est::AdaptiveBody> bodies;
  for (std::size_t i = 0; i < specs.size(); ++i)
    bodies.push_back({specs[i]->name, &built.grids[i], &specs[i]->material, &built.bcs[i]});
  est::AdaptiveLoop loop(std::move(bodies), o);
  // the couplings of the scene (the loop builds the model on every step's leaf views)
  const SceneCouplings couplings = sceneCouplings(scene, built.meshPointers(), built.bcs);
  for (const ContactModelSpec::Coupling& c : couplings.spec.couplings) loop.addCoupling(c);
  const std::vector<std::pair<std::string, std::string>>& sides = couplings.sides;
  // the analytic reference (punch, wedge, Hertz) of one body against an obstacle
  const std::optional<est::ContactReference> reference =
      specs.size() == 1 && specs.front()->contact ? makeReference(*specs.front(), dim) : std::nullopt;
  if (reference) loop.setReference(*reference);
  Index vertices = 0;
  for (const mesh::Mesh& m : built.meshes) vertices += m.numVertices();
  progress("adaptive loop: " + std::string(spec.uniform ? "uniform" : "adaptive") + " refinement" +
           (specs.size() > 1 ? " of " + std::to_string(specs.size()) + " bodies" : std::string()) + ", estimator " +
           spec.estimator + (spec.uniform ? "" : ", marking " + spec.marking) + ", up to " +
           std::to_string(spec.steps) + " steps from " + std::to_string(vertices) + " vertices");

  const fs::path dir = options.outputDirectory.value_or(scene.output.directory);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(dir.string() + ": cannot create the output directory (" + ec.message() + ")");

  // checkpoints: the grids of the bodies (named as in the layout's files)
  const InterruptGuard interrupts;  // SIGINT/SIGTERM: finish the step, checkpoint, stop
  std::vector<mesh::Grid*> gridList;
  std::vector<std::string> names;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    gridList.push_back(&built.grids[i]);
    names.push_back(layout.perBody() ? specs[i]->name : std::string());
  }
  AdaptiveCheckpoints checkpoints(scene, options, dir, gridList, names);
  AdaptiveCheckpoints::Outputs written;
  std::vector<PvdEntry>& vtkFiles = written.vtu;
  NodalErrors& nodalErrors = written.nodalErrors;
  checkpoints.restore(loop, written, progress);
  loop.setStateHook([&](const est::AdaptiveLoopState& state) { checkpoints.after(state, written); });

  // every step: the .vtu of each body, the figures of the last step so far
  std::vector<FinalState> finals(specs.size());
  loop.setCallback([&](const est::AdaptiveStepView& v) {
    const bool isLast = v.record.marked == 0;
    const bool write = spec.vtk == AdaptivitySpec::Vtk::Every || (spec.vtk == AdaptivitySpec::Vtk::Last && isLast);
    for (std::size_t i = 0; i < v.bodies.size(); ++i) {
      const est::AdaptiveBodyView& b = v.bodies[i];
      const est::AdaptiveStepView bodyView{v.record, b.grid, b.view, b.displacement, b.contactSet,
                                           b.outputs, b.classes, b.estimate, v.bodies};
      StepSnapshot snap;
      if (dim == 2)
        snapshotStep<2>(*specs[i], bodyView, b.marked, !isLast && spec.uniform, snap, finals[i], reference);
      else
        snapshotStep<3>(*specs[i], bodyView, b.marked, !isLast && spec.uniform, snap, finals[i], reference);
      if (write) {
        const std::string file = layout.adaptiveVtu(v.record.step, i);
        writeVtu(dir / file, snap.mesh, snap.points, snap.cells);
        vtkFiles.push_back(PvdEntry{static_cast<double>(v.record.step), static_cast<int>(i), file});
      }
    }
    if (reference && v.contactSet && v.outputs && v.record.reference) {
      const auto k = static_cast<std::size_t>(v.record.step);
      const std::vector<est::NodalPressure> nodes = nodalPressures(*v.contactSet, *v.outputs);
      nodalErrors.load.resize(k + 1, std::nan(""));
      nodalErrors.load[k] = est::nodalPressureError(nodes, *reference, v.record.reference->load);
      nodalErrors.fixedLoad.resize(k + 1, std::nan(""));
      if (spec.referenceLoad) nodalErrors.fixedLoad[k] = est::nodalPressureError(nodes, *reference, *spec.referenceLoad);
    }
    if (spec.pressureEvery && !layout.perBody() && finals.front().contact) {
      char name[32];
      std::snprintf(name, sizeof name, "pressure_%03d.csv", v.record.step);
      writePressureCsv(dir / name, finals.front().pressure);
    }
    if (options.stepProgress) options.stepProgress(stepLine(v.record, spec.steps));
  });
  const std::vector<est::AdaptiveStep> steps = loop.run();
  const est::AdaptiveStep& final = steps.back();

  // outputs
  t = Clock::now();
  if (!vtkFiles.empty()) {
    const fs::path pvd = dir / (scene.name + ".pvd");
    writePvdCollection(pvd, vtkFiles);
    for (const PvdEntry& e : vtkFiles) r.outputFiles.push_back(dir / e.file);
    r.outputFiles.push_back(pvd);
  }
  const fs::path stepsCsv = dir / "steps.csv";
  writeStepsCsv(stepsCsv, steps, nodalErrors);
  r.outputFiles.push_back(stepsCsv);
  if (!layout.perBody() && scene.contact) {
    const fs::path p = dir / "pressure.csv";
    writePressureCsv(p, finals.front().pressure);
    r.outputFiles.push_back(p);
  }

  recordFinalStep(steps, r);
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const FinalState& fin = finals[i];
    for (std::size_t k = 0; k < r.cellsPerType.size(); ++k) r.cellsPerType[k] += fin.cellsPerType[k];
    r.maxDisplacement = std::max(r.maxDisplacement, fin.maxDisplacement);
    r.maxVonMises = std::max(r.maxVonMises, fin.maxVonMises);
    if (!layout.perBody()) continue;
    BodyReport br;
    br.name = specs[i]->name;
    br.vertices = final.bodies[i].vertices;
    br.cells = final.bodies[i].cells;
    br.maxDisplacement = fin.maxDisplacement;
    br.maxVonMises = fin.maxVonMises;
    r.bodies.push_back(br);
  }
  const std::string type = scene.solverType();
  r.solver.type = contact ? type : "direct";
  r.solver.iterations = final.solverIterations;
  r.solver.converged = final.converged;
  r.solver.seconds = final.solverSeconds;
  r.solver.tolerance = contact && type == "tnnmg" ? o.solver.tolerance : 0.0;
  if (layout.perBody())
    for (std::size_t k = 0; k < final.couplings.size(); ++k)
      r.pairs.push_back(pairReport(final.couplings[k], sides[k].first, sides[k].second, dim));
  else
    r.contact = finals.front().contact;

  finishAdaptiveRun(scene, options, dir, stepsCsv, steps, nodalErrors,
                    est::MarkingStrategy(spec.marking, spec.theta).parameter(), r, t, start);
  return r;
}

RunResult runDistributedAdaptiveScene(const Scene& scene, const std::vector<DistributedGrid*>& grids,
                                      const std::vector<BoundaryConditions>& bcs,
                                      const std::vector<const mesh::Mesh*>& coarseMeshes, const RunOptions& options,
                                      RunResult r, Clock::time_point start) {
  const AdaptivitySpec& spec = *scene.adaptivity;
  const Communicator& comm = grids.front()->communicator();
  const std::size_t nb = grids.size();
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  const int dim = grids.front()->grid().dimension();
  const std::vector<const Scene*> specs = scene.bodyScenes();
  const est::AdaptiveLoopOptions o = adaptiveLoopOptions(scene, true);
  std::unique_ptr<Obstacle> obstacle;
  std::optional<SceneCouplings> couplings;  // several bodies: the scene's pair (ids, label, options)
  int contactId = -1;
  std::vector<int> balancedIds(nb, -1);  // --balance-contact: each body's contact boundary
  std::optional<est::DistributedAdaptiveLoop> loop;
  const fs::path dir = options.outputDirectory.value_or(scene.output.directory);
  comm.collective([&] {
    if (grids.size() != specs.size() || bcs.size() != nb || coarseMeshes.size() != nb)
      throw Error(scene.where(0) + "internal: a distributed adaptive run with inconsistent body lists");
    checkStopAfterStep(scene, options);
    if (scene.multiBody()) {
      couplings.emplace(sceneCouplings(scene, coarseMeshes, bcs));
      if (couplings->spec.couplings.size() != 1 || !couplings->spec.couplings.front().mortar)
        throw Error(scene.where(0) + "internal: a distributed adaptive run of several bodies needs one mortar pair");
      const ContactModelSpec::Coupling& c = couplings->spec.couplings.front();
      balancedIds[static_cast<std::size_t>(c.body)] = c.boundaryId;
      balancedIds[static_cast<std::size_t>(c.master)] = c.masterId;
    } else {
      obstacle = makeObstacle(scene, dim);
      contactId = balancedIds[0] = contactBoundaryId(scene, *coarseMeshes.front());
    }
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw Error(dir.string() + ": cannot create the output directory (" + ec.message() + ")");
  });
  if (couplings) {
    std::vector<est::DistributedAdaptiveBody> bodies;
    for (std::size_t b = 0; b < nb; ++b) bodies.push_back({specs[b]->name, grids[b], &specs[b]->material, &bcs[b]});
    loop.emplace(std::move(bodies), o);
    const ContactModelSpec::Coupling& c = couplings->spec.couplings.front();
    loop->addMortarContact(c.body, c.boundaryId, c.master, c.masterId, c.label, c.options);
  } else {
    loop.emplace(*grids.front(), scene.material, bcs.front(), *obstacle, contactId, o);
  }
  const std::optional<est::ContactReference> reference = couplings ? std::nullopt : makeReference(scene, dim);
  if (reference) loop->setReference(*reference);
  loop->setImbalanceTolerance(options.imbalanceTolerance.value_or(est::DistributedAdaptiveLoop::kDefaultImbalanceTolerance));
  if (options.balanceContact)  // the contact faces a second weight
    for (std::size_t b = 0; b < nb; ++b) grids[b]->setBalancedBoundary(balancedIds[b]);
  progress("adaptive loop on " + std::to_string(comm.size()) + " ranks: " +
           std::string(spec.uniform ? "uniform" : "adaptive") + " refinement" +
           (nb > 1 ? " of " + std::to_string(nb) + " bodies" : std::string()) + ", estimator " + spec.estimator +
           (spec.uniform ? "" : ", marking " + spec.marking) + ", up to " + std::to_string(spec.steps) + " steps from " +
           std::to_string(r.vertices) + " vertices");

  // every step: the solution's pieces (each rank its owned cells) and the figures of the last step
  const OutputLayout layout(scene);
  std::vector<PvdEntry> vtkFiles;
  std::vector<fs::path> pieces;
  RankLoad load;
  std::ostringstream balance;  // balance.csv: the imbalance of every step, before and after balancing
  balance << std::setprecision(10) << "step,owned_cells_max,owned_cells_mean,cells_imbalance,contact_nodes_max,"
          << "contact_nodes_mean,contact_imbalance,held_leaves_max,held_leaves_mean,refined_imbalance,rebalanced,"
          << "moved_leaves,rebalance_s,memory_mb_max,memory_mb_sum\n";
  int rebalances = 0;
  NodalErrors nodalErrors;
  std::vector<double> maxU(nb, 0.0), maxMises(nb, 0.0);

  // checkpoints (docs/checkpoint.md#distributed-adaptive-runs): after step k the loop's records, the
  // marks by cell key, the starts as rows keyed by vertex, the outputs so far; one file from all ranks
  const InterruptGuard interrupts;  // SIGINT/SIGTERM: finish the step, checkpoint, stop
  const fs::path checkpointFile = dir / "checkpoint.h5";
  CheckpointSchedule schedule(scene.output.checkpoint);
  std::vector<std::string> names;
  for (std::size_t b = 0; b < nb; ++b) names.push_back(layout.perBody() ? specs[b]->name : std::string());
  std::vector<DistributedView> initial;  // the grids before any adaptive step
  for (DistributedGrid* g : grids) initial.push_back(g->view());
  const auto keyedBodies = [&](const std::vector<DistributedView>& views) {
    std::vector<RunBody> bodies;
    for (std::size_t b = 0; b < nb; ++b) {
      RunBody& body = bodies.emplace_back(RunBody{names[b], &views[b].local});
      body.keyed = true;
      body.index = b;
      body.comm = &comm;
      body.ownedVertices = views[b].halo.numOwned();
      body.ownedCells = static_cast<Index>(views[b].part.owned.size());
    }
    return bodies;
  };
  // the keys of the bodies' vertices, body after body: the owned ones, or all the rank holds
  const auto vertexKeys = [&](const std::vector<DistributedView>& views, bool ownedOnly) {
    std::vector<std::uint64_t> keys;
    for (std::size_t b = 0; b < nb; ++b) {
      const Index count = ownedOnly ? views[b].halo.numOwned() : views[b].local.numVertices();
      for (Index v = 0; v < count; ++v) keys.push_back(vertexKey(b, views[b].local.vertex(v)));
    }
    return keys;
  };
  if (options.restart) {
    const fs::path& file = *options.restart;
    long long missing = 0;
    const CheckpointRecord cp = readCheckpoint(file, {}, comm, &missing);  // the entries; the rows below
    checkRunScene(cp, file, "adaptive", scene, names);
    comm.collective([&] {
      if (!cp.has(kMarkedKeys))
        throw Error(file.string() + ": the checkpoint was written by one process: continue it without mpirun");
    });
    checkInitialGrid(cp, file, keyedBodies(initial));  // (collective)
    est::DistributedAdaptiveLoopState state;
    comm.collective([&] {
      try {
        const est::AdaptiveLoopState serial = est::loadAdaptiveState(cp);
        state.nextStep = serial.nextStep;
        state.steps = serial.steps;
        state.transferSeconds = serial.transferSeconds;
        // per step, per body: the count of the marked keys
        const std::vector<long long>& counts = cp.integers(kMarkedKeyCounts);
        const std::vector<long long>& keys = cp.integers(kMarkedKeys);
        if (counts.size() % nb != 0)
          throw Error(kMarkedKeyCounts + " has " + std::to_string(counts.size()) + " entries, not a multiple of " +
                      std::to_string(nb) + " bodies");
        std::size_t at = 0;
        for (std::size_t i = 0; i < counts.size(); ++i) {
          const long long c = counts[i];
          if (c < 0 || at + static_cast<std::size_t>(c) > keys.size()) throw Error(kMarkedKeys + " is shorter than its counts");
          if (i % nb == 0) state.marked.emplace_back(nb);
          std::vector<std::uint64_t>& step = state.marked.back()[i % nb];
          for (long long j = 0; j < c; ++j) step.push_back(static_cast<std::uint64_t>(keys[at++]));
        }
        loadRunOutputs(cp, dir, vtkFiles, nodalErrors);
        std::istringstream written(cp.text("run/pieces"));
        for (std::string f; std::getline(written, f);) pieces.push_back(dir / f);
        balance.str(cp.text("run/balance_csv"));
        balance.seekp(0, std::ios::end);
        rebalances = static_cast<int>(cp.integer("run/rebalances"));
      } catch (const Error& e) {
        throw Error(file.string() + ": " + e.what());
      }
    });
    const int next = state.nextStep;
    // the refinements replayed, then the starts by vertex on the rebuilt leaf views
    loop->restore(std::move(state), [&](const std::vector<DistributedView>& views) {
      checkRunIdentity(cp, file, "adaptive", scene, keyedBodies(views));  // the rebuilt grids (collective)
      long long absent = 0;
      const CheckpointRecord rows = readCheckpoint(file, vertexKeys(views, false), comm, &absent);
      std::vector<Eigen::VectorXd> starts(nb);
      comm.collective([&] {
        if (absent != 0)
          throw Error(file.string() + ": " + std::to_string(absent) + " vertices of the rebuilt grid are not in the checkpoint");
        if (!rows.has("run/start")) return;
        const Eigen::VectorXd& all = rows.vector("run/start");
        Eigen::Index at = 0;
        for (std::size_t b = 0; b < nb; ++b) {
          const Eigen::Index n = static_cast<Eigen::Index>(views[b].local.numVertices()) * dim;
          starts[b] = all.segment(at, n);
          at += n;
        }
      });
      return starts;
    });
    progress("restart from " + file.string() + " at step " + std::to_string(next));
  }
  loop->setStateHook([&](const est::DistributedAdaptiveLoopState& state, const std::vector<DistributedView>& next,
                         const std::vector<Eigen::VectorXd>& starts) {
    const int k = state.nextStep - 1;
    const bool signalled = comm.max(InterruptGuard::requested() ? 1.0 : 0.0) > 0;
    const bool stop = signalled || (options.stopAfterStep && k >= *options.stopAfterStep);
    const bool due = comm.max(schedule.due(k + 1) ? 1.0 : 0.0) > 0;  // (a schedule in seconds: each rank's clock)
    if (!stop && !due) return;
    CheckpointRecord cp;
    cp.kind = "adaptive";
    storeRunIdentity(cp, scene, keyedBodies(next));  // collective
    storeInitialGrid(cp, keyedBodies(initial));      // collective
    comm.collective([&] {
      est::AdaptiveLoopState serial;
      serial.nextStep = state.nextStep;
      serial.steps = state.steps;
      serial.refinements.assign(state.steps.size(), std::vector<std::vector<Index>>(nb));  // (by key below)
      serial.transferSeconds = state.transferSeconds;
      est::storeAdaptiveState(cp, serial);
      std::vector<long long> counts, keys;
      for (const auto& step : state.marked)
        for (const auto& body : step) {
          counts.push_back(static_cast<long long>(body.size()));
          for (std::uint64_t key : body) keys.push_back(static_cast<long long>(key));
        }
      cp.set(kMarkedKeyCounts, counts, "the number of leaves marked after each step (all ranks), per body");
      cp.set(kMarkedKeys, keys,
             "the cell keys (DistributedGrid::cellKey) of the leaves marked after each step, per body, sorted");
      storeRunOutputs(cp, vtkFiles, nodalErrors, ".pvtu");
      std::string written;
      for (const fs::path& f : pieces) written += f.filename().string() + "\n";
      cp.set("run/pieces", written, "the pieces of the .pvtu files written so far (one name per line)");
      cp.set("run/balance_csv", balance.str(), "balance.csv so far");
      cp.set("run/rebalances", static_cast<long long>(rebalances), "the rebalances so far");
      if (std::all_of(starts.begin(), starts.end(), [](const Eigen::VectorXd& s) { return s.size() > 0; })) {
        std::vector<double> owned;  // the bodies' owned rows, body after body
        for (std::size_t b = 0; b < nb; ++b)
          owned.insert(owned.end(), starts[b].data(), starts[b].data() + next[b].halo.numOwned() * dim);
        cp.setRows("run/start", Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(owned.data(), static_cast<Eigen::Index>(owned.size()))), dim,
                   "the start of step next_step (the last solution on the refined grids) at the owned vertices");
      }
      cp.setRowKeys(vertexKeys(next, true));
    });
    writeCheckpoint(checkpointFile, cp, comm);
    schedule.written();
    if (options.stepProgress) options.stepProgress("checkpoint: step " + std::to_string(k) + " -> " + checkpointFile.string());
    if (!stop) return;
    Index vertices = 0;
    for (const DistributedView& v : next) vertices += v.globalVertices();
    std::ostringstream os;
    os << (signalled ? "interrupted by " + InterruptGuard::signalName() : std::string("stopped (--stop-after-step)"))
       << " after adaptive step " << k << " of " << spec.steps - 1 << " (refined to " << vertices
       << " vertices): checkpoint written to " << checkpointFile.string() << "; continue with: mpirun -np N obs run "
       << scene.fileName << " --restart " << checkpointFile.string()
       << " (any N >= 2; the same --output, --refine and --set options)";
    throw RunInterrupted(os.str());
  });
  loop->setCallback([&](const est::DistributedAdaptiveStepView& v) {
    const bool isLast = v.record.marked == 0;
    const bool write = spec.vtk == AdaptivitySpec::Vtk::Every || (spec.vtk == AdaptivitySpec::Vtk::Last && isLast);
    // the work per rank of this step, summed over the bodies: owned cells, owned contact nodes, held
    // leaves; the peak memory so far
    std::vector<double> work(4, 0.0);
    RebalanceReport moved;  // the bodies' balancing together: the worst before, any move, the moved leaves
    moved.before = 0;
    for (std::size_t b = 0; b < nb; ++b) {
      const est::DistributedAdaptiveBodyView& body = v.bodies[b];
      const Scene& bodyScene = *specs[b];
      const auto ownedCells = static_cast<Index>(body.leaf.part.owned.size());
      const Index owned = body.leaf.halo.numOwned();
      // the local work in collective() (an error reaches every rank), the reductions after it
      ElasticitySolution e;
      std::vector<double> largest(2, 0.0);  // max |u|, max von Mises
      std::vector<double> mine;             // the owned nodes' nodal pressure samples
      comm.collective([&] {
        e.dimension = dim;
        e.displacement = body.displacement;
        recoverStresses(body.leaf.local, bodyScene.material, e);
        for (Index p = 0; p < owned; ++p)
          largest[0] = std::max(largest[0], body.displacement.segment(static_cast<Eigen::Index>(p) * dim, dim).norm());
        for (Index c = 0; c < ownedCells; ++c) largest[1] = std::max(largest[1], vonMises(e.cellStress[c]));
        work[0] += static_cast<double>(ownedCells);
        if (body.contactSet)
          for (Index q = 0; q < body.contactSet->size(); ++q) work[1] += body.contactSet->vertex(q) < owned ? 1 : 0;
        work[2] += static_cast<double>(body.grid.grid().numLeafElements());
        if (reference && v.record.reference && body.contactSet && body.outputs)
          for (const est::NodalPressure& n : nodalPressures(*body.contactSet, *body.outputs, owned))
            mine.insert(mine.end(), {n.x[0], n.x[1], n.x[2], n.weight, n.pressure});
      });
      comm.max(largest);
      maxU[b] = largest[0];
      maxMises[b] = largest[1];
      moved.before = std::max(moved.before, body.balance.before);
      moved.moved = moved.moved || body.balance.moved;
      moved.movedLeaves += body.balance.movedLeaves;
      if (write) {
        std::vector<Field> points, cells;
        comm.collective([&] {
          points = pointFields(body.leaf.local, e);
          cells = cellFields(body.leaf.local, e);
          if (body.estimate) {
            Field eta{"eta", 1, std::vector<double>(static_cast<std::size_t>(body.leaf.local.numCells()), 0.0)};
            for (Index c = 0; c < ownedCells; ++c) eta.values[c] = body.estimate->indicators[c];
            cells.push_back(std::move(eta));
          }
        });
        const std::string base = fs::path(layout.adaptiveVtu(v.record.step, b)).stem().string();
        for (auto& f : writePieces(dir, base, body.leaf.local, ownedCells, points, cells, comm)) pieces.push_back(f);
        vtkFiles.push_back(PvdEntry{static_cast<double>(v.record.step), static_cast<int>(b), base + ".pvtu"});
      }
      if (reference && v.record.reference) {  // the owned nodes of every rank, on every rank
        std::vector<est::NodalPressure> nodes;
        for (const std::vector<double>& part : comm.allGather(mine))
          for (std::size_t i = 0; i + 4 < part.size(); i += 5)
            nodes.push_back(est::NodalPressure{Point(part[i], part[i + 1], part[i + 2]), part[i + 3], part[i + 4]});
        const auto k = static_cast<std::size_t>(v.record.step);
        nodalErrors.load.resize(k + 1, std::nan(""));
        nodalErrors.load[k] = est::nodalPressureError(nodes, *reference, v.record.reference->load);
        nodalErrors.fixedLoad.resize(k + 1, std::nan(""));
        if (spec.referenceLoad) nodalErrors.fixedLoad[k] = est::nodalPressureError(nodes, *reference, *spec.referenceLoad);
      }
    }
    {  // balance.csv: the largest rank's and the mean work
      work[3] = peakMemoryMB();
      std::vector<double> largest = work, total = work;
      comm.max(largest);
      comm.sum(total);
      balance << v.record.step << "," << largest[0] << "," << total[0] / comm.size() << ","
              << largest[0] * comm.size() / std::max(total[0], 1.0) << "," << largest[1] << ","
              << total[1] / comm.size() << "," << (total[1] > 0 ? largest[1] * comm.size() / total[1] : 1.0) << ","
              << largest[2] << "," << total[2] / comm.size() << "," << moved.before << "," << (moved.moved ? 1 : 0)
              << "," << moved.movedLeaves << "," << v.balanceSeconds << "," << largest[3] << "," << total[3] << "\n";
      rebalances += moved.moved ? 1 : 0;
    }
    if (isLast) {
      load = RankLoad{};
      double owned = 0, ghosts = 0, cells = 0;
      for (const est::DistributedAdaptiveBodyView& body : v.bodies) {
        owned += static_cast<double>(body.leaf.halo.numOwned());
        ghosts += static_cast<double>(body.leaf.halo.numLocal() - body.leaf.halo.numOwned());
        cells += static_cast<double>(body.leaf.part.owned.size());
      }
      load.add("owned_vertices", owned);
      load.add("ghost_vertices", ghosts);
      load.add("owned_cells", cells);
    }
    if (options.stepProgress) options.stepProgress(stepLine(v.record, spec.steps));
  });
  const std::vector<est::AdaptiveStep> steps = loop->run();
  const est::AdaptiveStep& final = steps.back();

  // rank 0: the .pvd, steps.csv and summary.json (the figures are the same on every rank)
  recordFinalStep(steps, r);
  r.maxDisplacement = *std::max_element(maxU.begin(), maxU.end());
  r.maxVonMises = *std::max_element(maxMises.begin(), maxMises.end());
  if (layout.perBody())
    for (std::size_t b = 0; b < nb; ++b) {
      BodyReport br;
      br.name = specs[b]->name;
      br.vertices = final.bodies[b].vertices;
      br.cells = final.bodies[b].cells;
      br.maxDisplacement = maxU[b];
      br.maxVonMises = maxMises[b];
      r.bodies.push_back(br);
    }
  if (couplings)
    for (std::size_t k = 0; k < final.couplings.size(); ++k)
      r.pairs.push_back(pairReport(final.couplings[k], couplings->sides[k].first, couplings->sides[k].second, dim));
  r.solver.type = "tnnmg";
  r.solver.iterations = final.solverIterations;
  r.solver.converged = final.converged;
  r.solver.seconds = final.solverSeconds;
  r.solver.tolerance = o.solver.tolerance;
  nlohmann::json extra;
  addDistributedSummary(extra, comm, grids.front()->partition().level, load);
  extra["rebalances"] = rebalances;
  comm.collective([&] {
    if (comm.rank() != 0) return;
    const auto t = Clock::now();
    r.outputFiles = pieces;
    if (!vtkFiles.empty()) {
      const fs::path pvd = dir / (scene.name + ".pvd");
      writePvdCollection(pvd, vtkFiles);
      r.outputFiles.push_back(pvd);
    }
    const fs::path stepsCsv = dir / "steps.csv";
    writeStepsCsv(stepsCsv, steps, nodalErrors);
    r.outputFiles.push_back(stepsCsv);
    const fs::path balanceCsv = dir / "balance.csv";
    std::ofstream(balanceCsv) << balance.str();
    r.outputFiles.push_back(balanceCsv);
    finishAdaptiveRun(scene, options, dir, stepsCsv, steps, nodalErrors,
                      est::MarkingStrategy(spec.marking, spec.theta).parameter(), r, t, start, extra);
  });
  return r;
}

}  // namespace obs::drivers
