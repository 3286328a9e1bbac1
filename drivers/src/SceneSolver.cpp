#include "obs/drivers/SceneSolver.hpp"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <algorithm>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <tuple>

#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "ContactReports.hpp"
#include "RunSupport.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/SolverConfig.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::drivers {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kContactTolerance = 1e-8;  ///< relative tolerance of "actual contact"

/// "file:line: [solver] <type> failed: <what>" for errors of a solver.
[[noreturn]] void solverFailed(const Scene& scene, const std::string& type, const Error& e) {
  throw Error(scene.where(scene.solver.line) + "[solver] " + type + " failed: " + e.what());
}

std::function<void(const IterationRecord&)> iterationLines(const std::string& type,
                                                           const IterationProgress& progress) {
  if (!progress) return {};
  return [type, progress](const IterationRecord& r) {
    if (!reportsIteration(r.iteration)) return;
    std::ostringstream os;
    os << type << " iteration " << r.iteration << ": energy " << std::setprecision(10) << r.energy
       << ", correction " << std::setprecision(3) << r.correction << ", active " << r.activeSetSize;
    progress(os.str());
  };
}

/// A scene without contact (one body): CHOLMOD ("direct") or the linear multigrid iteration.
template <int d>
SceneSolution solveLinear(const Scene& scene, const mesh::Grid& grid, const mesh::Mesh& mesh,
                          const BoundaryConditions& bc, const AssembledCallback& assembled) {
  SceneSolution s;
  const std::string type = scene.solverType();
  s.solver.type = type;
  s.bodies.resize(1);
  s.contactFields.resize(1);
  if (type == "direct") {
    s.bodies[0] = solveLinearElasticity(mesh, scene.material, bc);
    s.solver.iterations = 1;
    s.solver.seconds = s.bodies[0].solveSeconds;
    if (assembled) assembled(s.bodies[0]);
    return s;
  }
  // multigrid
  auto t0 = Clock::now();
  auto A = assembleStiffness<d>(mesh, scene.material);
  Eigen::VectorXd b = assembleLoad<d>(mesh, bc);
  const DirichletValues g = collectDirichlet(mesh, bc.dirichlet);
  applyDirichlet(A, b, g);
  A.shareRepeatedBlocks();  // the same values; fewer bytes per sweep on grids of repeated cells
  ElasticitySolution& e = s.bodies[0];
  e.dimension = d;
  e.assemblySeconds = since(t0);
  e.dofs = static_cast<long long>(mesh.numVertices()) * d;
  e.freeDofs = e.dofs - g.count();
  if (assembled) assembled(e);

  t0 = Clock::now();
  const SolverConfig config = solverConfig(scene);
  LinearMultigridOptions options = config.multigrid;
  options.tolerance = config.tolerance;
  options.maxIterations = config.maxIterations.value_or(options.maxIterations);
  LinearSolverResult r;
  try {
    LinearMultigrid<d> mg(grid, options);
    mg.setOperator(A);
    mg.truncate(g.constrained);
    r = mg.solve(b, e.displacement);
    s.solver.vcycles = mg.vcycles();
  } catch (const Error& err) {
    solverFailed(scene, type, err);
  }
  e.solveSeconds = since(t0);
  if (!e.displacement.allFinite())
    throw Error(scene.where(scene.solver.line) + "[solver] multigrid failed: NaN or Inf in the solution");
  recoverStresses(mesh, scene.material, e);
  s.solver.iterations = r.iterations;
  s.solver.converged = r.converged;
  s.solver.seconds = e.solveSeconds;
  s.solver.tolerance = options.tolerance;
  s.solver.correction = r.correction;
  s.solver.convergenceRate = r.convergenceRate;
  return s;
}

/// The contact solver of the scene's solverConfig on the bodies' grids, with the iteration lines
/// of `progress`; `tolerance` receives the stopping tolerance it reports (0 for the active-set
/// method's exact rule).
template <int d>
std::unique_ptr<ContactSolver<d>> sceneContactSolver(const Scene& scene, const std::vector<const mesh::Grid*>& grids,
                                                     const IterationProgress& progress, double& tolerance) {
  const std::string type = scene.solverType();
  if (!contactSolverKindFromName(type))
    throw Error(scene.where(scene.solver.line) + "[solver] type = \"" + type +
                "\" cannot solve contact problems (known: tnnmg, pdas, pgs)");
  const SolverConfig config = solverConfig(scene);
  tolerance = config.kind == ContactSolverKind::PrimalDualActiveSet ? 0 : config.tolerance;
  return makeContactSolver<d>(config, grids, iterationLines(type, progress));
}

/// "body:boundary" (the boundary's name, or its id).
std::string sideLabel(const std::string& body, const BoundaryRef& ref) {
  return body + ":" + (ref.name.empty() ? std::to_string(ref.id) : ref.name);
}

/// The contact point fields of every body (SolutionFields.hpp documents them): at the nodes of each
/// coupling on its constrained body the constraint_direction and normal_displacement (mortar pairs:
/// at the constrained nodes; obstacles: at every node of the contact set), and at the constrained
/// nodes the gap g_p, contact_pressure, contact_state (1 potential, 2 actual) and contact_force -mu_p
/// nu_p (mu_p = D_pp lambda_p for mortar, the nodal force for obstacles); a mortar pair's master
/// forces on the master body. With friction also friction_force (-f_T, the tangential force on the
/// constrained body), slip (|u_T - o_T|) and stick_slip (0 not in contact, 1 stick, 2 slip).
template <int d>
void contactPointFields(const ContactModel<d>& model, const ContactProblem<d>& problem, const Eigen::VectorXd& x,
                        const ContactOutputs& out, const std::vector<const mesh::Mesh*>& meshes,
                        std::vector<std::vector<Field>>& fields) {
  const ContactSet& cs = problem.contactSet();
  fields.resize(meshes.size());
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    const std::size_t n = static_cast<std::size_t>(meshes[i]->numVertices());
    fields[i] = {Field{"gap", 1, std::vector<double>(n, 0.0), false},
                          Field{"normal_displacement", 1, std::vector<double>(n, 0.0), false},
                          Field{"contact_pressure", 1, std::vector<double>(n, 0.0), false},
                          Field{"contact_state", 1, std::vector<double>(n, 0.0), true},
                          Field{"constraint_direction", 3, std::vector<double>(3 * n, 0.0), false},
                          Field{"contact_force", 3, std::vector<double>(3 * n, 0.0), false}};
    if (problem.frictional()) {  // indices 6, 7, 8
      fields[i].push_back(Field{"friction_force", 3, std::vector<double>(3 * n, 0.0), false});
      fields[i].push_back(Field{"slip", 1, std::vector<double>(n, 0.0), false});
      fields[i].push_back(Field{"stick_slip", 1, std::vector<double>(n, 0.0), true});
    }
  }
  for (const auto& c : model.couplings()) {
    const int slaveBody = c.mortar ? c.slave : c.body;
    const Index count = static_cast<Index>(c.nodes.size());
    Eigen::VectorXd mu = Eigen::VectorXd::Zero(count);
    const Index offS = model.bodies()[slaveBody].offset;
    auto& fs = fields[slaveBody];
    for (Index k = 0; k < count; ++k) {
      const Index node = c.nodes[k];
      const bool bounded = problem.constraint(node).bounded();
      if (!bounded && c.mortar) continue;
      const auto v = static_cast<std::size_t>(cs.vertex(node) - offS);
      const Point& nu = cs.direction(node);
      for (int a = 0; a < 3; ++a) fs[4].values[3 * v + a] = nu[a];
      fs[1].values[v] = nu.template head<d>().dot(x.template segment<d>(static_cast<Eigen::Index>(cs.vertex(node)) * d));
      if (!bounded) continue;
      mu[k] = out.multiplier[node];
      fs[0].values[v] = cs.gap(node);
      fs[2].values[v] = out.pressure[node];
      fs[3].values[v] = out.inContact[node] ? 2 : 1;
      for (int a = 0; a < d; ++a) fs[5].values[3 * v + a] = -mu[k] * nu[a];
      if (problem.frictional()) {
        for (int a = 0; a < d; ++a) fs[6].values[3 * v + a] = -out.tangential[node][a];
        fs[7].values[v] = out.slip[node];
        fs[8].values[v] = out.state[node];
      }
    }
    if (c.mortar) {
      const Eigen::VectorXd fm = c.coupling->masterForces(mu);
      const Index offM = model.bodies()[c.master].offset;
      auto& fmField = fields[c.master];
      for (Index v = 0; v < meshes[c.master]->numVertices(); ++v)
        for (int a = 0; a < d; ++a)
          fmField[5].values[3 * static_cast<std::size_t>(v) + a] += fm[static_cast<Eigen::Index>(offM + v) * d + a];
    }
  }
}

/// A contact scene, one body or several: the contact model of its bodies and couplings
/// (sceneCouplings, makeContactModel), one solve by the [solver], the displacement and stresses of every body,
/// then the report in the layout of the scene file: a one-body scene's [contact]
/// (obstacleContactReport), or one report per coupling and the contact fields of every body.
template <int d>
SceneSolution solveContactModel(const Scene& scene, const std::vector<const mesh::Grid*>& grids,
                                const std::vector<const mesh::Mesh*>& meshes, const std::vector<BoundaryConditions>& bcs,
                                const IterationProgress& progress, const AssembledCallback& assembled) {
  SceneSolution s;
  const std::string type = scene.solverType();
  // [loading] steps = N: the boundary conditions at t = i/N, one problem per increment (the Dirichlet
  // values enter the load through the stiffness, so each increment assembles its own)
  const int steps = scene.loading ? scene.loading->steps : 1;
  const std::vector<const Scene*> bodies = scene.bodyScenes();
  std::vector<BoundaryConditions> stepBcs;  // of the current increment (the couplings point to them)
  std::optional<SceneCouplings> couplingsOf;
  std::optional<ContactModel<d>> modelOf;
  std::optional<ContactProblem<d>> problem;
  const auto build = [&](int step) {
    const auto t0 = Clock::now();
    problem.reset();  // (the old couplings point into stepBcs: gone before it changes)
    modelOf.reset();
    couplingsOf.reset();
    const std::vector<BoundaryConditions>* b = &bcs;
    if (scene.loading) {
      stepBcs.clear();
      for (std::size_t i = 0; i < bodies.size(); ++i)
        stepBcs.push_back(makeBoundaryConditions(*bodies[i], *meshes[i], static_cast<double>(step) / steps));
      b = &stepBcs;
    }
    couplingsOf.emplace(sceneCouplings(scene, meshes, *b));
    modelOf.emplace(makeContactModel<d>(couplingsOf->spec, meshes));
    try {
      problem.emplace(modelOf->assemble());
    } catch (const Error& e) {
      if (scene.pairs.empty()) throw;
      throw Error(scene.where(scene.pairs.front().line) + "[[contact]] " + e.what());
    }
    s.assemblySeconds += since(t0);
  };
  build(1);
  s.dofs = static_cast<long long>(modelOf->numVertices()) * d;
  s.freeDofs = s.dofs - problem->dirichlet().count();
  if (assembled) {
    ElasticitySolution e;
    e.dimension = d;
    e.dofs = s.dofs;
    e.freeDofs = s.freeDofs;
    e.assemblySeconds = s.assemblySeconds;
    assembled(e);
  }

  // the solve time: the solver's construction and its solves, without the assembly of later increments
  const auto t0 = Clock::now();
  const double firstAssembly = s.assemblySeconds;
  double tolerance = 0;
  ContactResult result;
  Eigen::VectorXd x;
  try {
    const auto solver = sceneContactSolver<d>(scene, grids, progress, tolerance);
    for (int step = 1; step <= steps; ++step) {
      if (step > 1) build(step);
      const ContactModel<d>& model = *modelOf;
      const NodalFriction friction = nodalFriction(model, problem->contactSet());  // (empty: frictionless)
      long long stepIterations = 0;
      std::tie(result, stepIterations) =
          solveIncrement<d>(*problem, *solver, x, model.frictional() ? &friction : nullptr, tolerance, step, nullptr,
                            s.solver.friction, progress);
      if (scene.loading) {
        s.increments.push_back(incrementReport(problem->contactSet(), computeContactOutputs(*problem, x, kContactTolerance),
                                               OwnedPart::oneProcess(problem->numVertices()), step, steps,
                                               stepIterations, result.converged));
        if (progress) progress(incrementLine(s.increments.back(), steps));
      }
    }
    if (const auto* tnnmg = dynamic_cast<const TNNMG<d>*>(solver.get())) reportTnnmgPhases(tnnmg->statistics(), s.solver);
  } catch (const Error& err) {
    solverFailed(scene, type, err);
  }
  s.solveSeconds = since(t0) - (s.assemblySeconds - firstAssembly);
  const SceneCouplings& couplings = *couplingsOf;
  const ContactModel<d>& model = *modelOf;
  if (!x.allFinite())
    throw Error(scene.where(scene.solver.line) + "[solver] " + type + " failed: NaN or Inf in the solution");
  s.solver.type = type;
  reportContactResult(result, s.solveSeconds, tolerance, s.solver);

  // displacements per body
  const Eigen::VectorXd u = problem->toDisplacement(x);
  const ContactOutputs out = computeContactOutputs(*problem, x, kContactTolerance);
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const auto& b = model.bodies()[i];
    ElasticitySolution e;
    e.dimension = d;
    e.dofs = static_cast<long long>(meshes[i]->numVertices()) * d;
    e.displacement = u.segment(static_cast<Eigen::Index>(b.offset) * d, e.dofs);
    recoverStresses(*meshes[i], bodies[i]->material, e);
    s.bodies.push_back(std::move(e));
  }
  // the contact point fields of every body, and the report per coupling (several bodies) or of
  // the one-body file's [contact] (its layout: summary.json "contact", no contact_force field)
  contactPointFields<d>(model, *problem, x, out, meshes, s.contactFields);
  if (!OutputLayout(scene).perBody()) {
    for (std::vector<Field>& f : s.contactFields)  // no contact_force
      f.erase(std::find_if(f.begin(), f.end(), [](const Field& x) { return x.name == "contact_force"; }));
    s.contact = obstacleContactReport<d>(scene, *problem, x, out, OwnedPart::oneProcess(problem->numVertices()));
    return s;
  }
  const std::vector<CouplingRecord> records = couplingRecords(model, *problem, x, out);
  for (std::size_t j = 0; j < model.couplings().size(); ++j) {
    s.pairs.push_back(pairReport(records[j], couplings.sides[j].first, couplings.sides[j].second, d));
    s.pairs.back().friction = frictionReport(model.couplings()[j].friction, records[j].tangentialSlave,
                                             records[j].stickVertices, records[j].slipVertices, records[j].stickArea, d);
  }
  return s;
}

}  // namespace

SceneCouplings sceneCouplings(const Scene& scene, const std::vector<const mesh::Mesh*>& meshes,
                              const std::vector<BoundaryConditions>& bcs) {
  const std::vector<const Scene*> bodies = scene.bodyScenes();
  if (meshes.size() != bodies.size() || bcs.size() != bodies.size())
    throw Error(scene.where(0) + "internal: couplings with inconsistent body lists");
  SceneCouplings out;
  for (std::size_t i = 0; i < bodies.size(); ++i) out.spec.addBody(bodies[i]->name, bodies[i]->material, bcs[i]);
  for (const MortarPairSpec& p : scene.pairs) {
    const Scene& sb = *bodies[p.slaveIndex];
    const Scene& mb = *bodies[p.masterIndex];
    const int sid = boundaryIdOf(scene, *meshes[p.slaveIndex], p.slave, "[[contact]] slave of body '" + sb.name + "':");
    const int mid = boundaryIdOf(scene, *meshes[p.masterIndex], p.master, "[[contact]] master of body '" + mb.name + "':");
    MortarOptions o;
    o.minCoverage = p.minCoverage;
    o.searchDistance = p.searchDistance;
    const std::string slave = sideLabel(p.slaveBody, p.slave), master = sideLabel(p.masterBody, p.master);
    out.spec.addMortarPair(p.slaveIndex, sid, p.masterIndex, mid, slave + " / " + master, o);
    if (p.friction) out.spec.couplings.back().friction = p.friction->law;
    out.sides.emplace_back(slave, master);
  }
  // rigid obstacles of single bodies ([[contact]] with body = ..., or a one-body scene's [contact]),
  // after the pairs
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const Scene& body = *bodies[i];
    if (!body.contact) continue;
    out.obstacles.push_back(makeObstacle(body, meshes[i]->dimension()));
    const Obstacle& obstacle = *out.obstacles.back();
    const std::string slave = sideLabel(body.name, body.contact->boundary);
    const std::string master = "obstacle " + body.contact->obstacle;
    out.spec.addObstacleContact(static_cast<int>(i), obstacle, contactBoundaryId(body, *meshes[i]), slave + " / " + master);
    out.spec.couplings.back().contactSet = [&body, &obstacle](const mesh::Mesh& mesh) {
      return makeContactSet(body, mesh, obstacle);
    };
    if (body.contact->friction) out.spec.couplings.back().friction = body.contact->friction->law;
    out.sides.emplace_back(slave, master);
  }
  return out;
}

PairReport pairReport(const CouplingRecord& rec, const std::string& slave, const std::string& master, int dim) {
  PairReport r;
  static_cast<CouplingRecord&>(r) = rec;
  r.slave = slave;
  r.master = master;
  r.radius = dim == 3 ? std::sqrt(r.area / std::numbers::pi) : r.area / 2;
  return r;
}

bool reportsIteration(int iteration) {
  if (iteration <= 10) return iteration >= 1;
  int step = 10;
  while (iteration >= 10 * step) step *= 10;
  return iteration % step == 0;
}

SceneSolution solveScene(const Scene& scene, const std::vector<const mesh::Grid*>& grids,
                         const std::vector<const mesh::Mesh*>& meshes, const std::vector<BoundaryConditions>& bcs,
                         const IterationProgress& progress, const AssembledCallback& assembled) {
  const std::size_t n = scene.bodyScenes().size();
  if (meshes.empty() || meshes.size() != n || grids.size() != n || bcs.size() != n)
    throw Error(scene.where(0) + "internal: solve with inconsistent body lists");
  const int dim = meshes.front()->dimension();
  if (scene.hasContact())
    return dim == 2 ? solveContactModel<2>(scene, grids, meshes, bcs, progress, assembled)
                    : solveContactModel<3>(scene, grids, meshes, bcs, progress, assembled);
  SceneSolution s = dim == 2 ? solveLinear<2>(scene, *grids.front(), *meshes.front(), bcs.front(), assembled)
                             : solveLinear<3>(scene, *grids.front(), *meshes.front(), bcs.front(), assembled);
  const ElasticitySolution& e = s.bodies.front();
  s.dofs = e.dofs;
  s.freeDofs = e.freeDofs;
  s.assemblySeconds = e.assemblySeconds;
  s.solveSeconds = e.solveSeconds;
  return s;
}

}  // namespace obs::drivers
