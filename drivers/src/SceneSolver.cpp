#include "obs/drivers/SceneSolver.hpp"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <memory>
#include <sstream>

#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::drivers {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr double kDefaultTolerance = 1e-10;
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

template <int d>
SceneSolution solveLinear(const Scene& scene, const mesh::Grid& grid, const mesh::Mesh& mesh,
                          const BoundaryConditions& bc, const AssembledCallback& assembled) {
  SceneSolution s;
  const std::string type = scene.solverType();
  s.solver.type = type;
  if (type == "direct") {
    s.elasticity = solveLinearElasticity(mesh, scene.material, bc);
    s.solver.iterations = 1;
    s.solver.seconds = s.elasticity.solveSeconds;
    if (assembled) assembled(s.elasticity);
    return s;
  }
  // multigrid
  auto t0 = Clock::now();
  auto A = assembleStiffness<d>(mesh, scene.material);
  Eigen::VectorXd b = assembleLoad<d>(mesh, bc);
  const DirichletValues g = collectDirichlet(mesh, bc.dirichlet);
  applyDirichlet(A, b, g);
  ElasticitySolution& e = s.elasticity;
  e.dimension = d;
  e.assemblySeconds = since(t0);
  e.dofs = static_cast<long long>(mesh.numVertices()) * d;
  e.freeDofs = e.dofs - g.count();
  if (assembled) assembled(e);

  t0 = Clock::now();
  LinearMultigridOptions options;
  options.tolerance = scene.solver.tolerance.value_or(kDefaultTolerance);
  options.maxIterations = scene.solver.maxIterations.value_or(100);
  LinearSolverResult r;
  try {
    LinearMultigrid<d> mg(grid, options);
    mg.setOperator(A);
    mg.truncate(g.constrained);
    r = mg.solve(b, e.displacement);
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

template <int d>
std::unique_ptr<ContactSolver<d>> makeContactSolver(const Scene& scene, const mesh::Grid& grid,
                                                    const IterationProgress& progress,
                                                    double& tolerance) {
  const std::string type = scene.solverType();
  const SolverSpec& spec = scene.solver;
  auto common = [&](ContactSolverOptions& o, int maxIterations) {
    o.tolerance = spec.tolerance.value_or(kDefaultTolerance);
    o.maxIterations = spec.maxIterations.value_or(maxIterations);
    o.onIteration = iterationLines(type, progress);
    tolerance = o.tolerance;
  };
  if (type == "tnnmg") {
    typename TNNMG<d>::Options o;
    common(o, 200);
    o.preSmoothing = spec.preSmoothing.value_or(o.preSmoothing);
    o.postSmoothing = spec.postSmoothing.value_or(o.postSmoothing);
    return std::make_unique<TNNMG<d>>(grid, o);
  }
  if (type == "pdas") {
    typename PrimalDualActiveSet<d>::Options o;
    common(o, o.maxIterations);
    tolerance = 0;  // exact stopping rule: the active set repeats
    return std::make_unique<PrimalDualActiveSet<d>>(o);
  }
  if (type == "pgs") {
    typename ProjectedGaussSeidel<d>::Options o;
    common(o, 10000);
    return std::make_unique<ProjectedGaussSeidel<d>>(o);
  }
  throw Error(scene.where(spec.line) + "[solver] type = \"" + type +
              "\" cannot solve contact problems (known: tnnmg, pdas, pgs)");
}

template <int d>
SceneSolution solveContact(const Scene& scene, const mesh::Grid& grid, const mesh::Mesh& mesh,
                           const BoundaryConditions& bc, const IterationProgress& progress,
                           const AssembledCallback& assembled) {
  SceneSolution s;
  const std::string type = scene.solverType();
  ElasticitySolution& e = s.elasticity;
  e.dimension = d;

  auto t0 = Clock::now();
  const auto obstacle = makeObstacle(scene, d);
  const ContactSet contactSet = makeContactSet(scene, mesh, *obstacle);
  const ContactProblem<d> problem(mesh, scene.material, bc, contactSet);
  e.assemblySeconds = since(t0);
  e.dofs = static_cast<long long>(mesh.numVertices()) * d;
  e.freeDofs = e.dofs - problem.dirichlet().count();
  if (assembled) assembled(e);

  t0 = Clock::now();
  double tolerance = 0;
  ContactResult result;
  try {
    const auto solver = makeContactSolver<d>(scene, grid, progress, tolerance);
    result = solver->solve(problem, e.displacement);
  } catch (const Error& err) {
    solverFailed(scene, type, err);
  }
  e.solveSeconds = since(t0);
  if (!e.displacement.allFinite())
    throw Error(scene.where(scene.solver.line) + "[solver] " + type +
                " failed: NaN or Inf in the solution");
  recoverStresses(mesh, scene.material, e);

  s.solver.type = type;
  s.solver.iterations = result.iterations;
  s.solver.converged = result.converged;
  s.solver.seconds = e.solveSeconds;
  s.solver.tolerance = tolerance;
  s.solver.correction = result.correction;
  s.solver.convergenceRate = result.convergenceRate;
  s.solver.kkt = result.kkt;

  // contact quantities
  const ContactOutputs out = computeContactOutputs(problem, e.displacement, kContactTolerance);
  ContactReport c;
  c.obstacle = scene.contact->obstacle;
  c.boundary = scene.contact->boundary.name.empty() ? std::to_string(scene.contact->boundary.id)
                                                    : scene.contact->boundary.name;
  c.boundaryVertices = contactSet.size();
  for (const auto& k : problem.constraints()) c.potentialVertices += k.bounded();
  c.actualVertices = out.contactNodes;
  for (int i = 0; i < 3; ++i) c.force[i] = out.force[i];
  Point centre = Point::Zero(), normal = Point::Zero();
  double weight = 0;
  for (Index k = 0; k < contactSet.size(); ++k) {
    c.load += out.multiplier[k];
    if (!out.inContact[k]) continue;
    const double w = std::max(out.multiplier[k], 0.0);
    centre += w * contactSet.position(k);
    weight += w;
    normal += contactSet.direction(k);
  }
  if (c.actualVertices > 0) {
    if (weight > 0) {
      centre /= weight;
    } else {  // no force: the plain mean of the contact vertices
      centre.setZero();
      for (Index k = 0; k < contactSet.size(); ++k)
        if (out.inContact[k]) centre += contactSet.position(k) / static_cast<double>(c.actualVertices);
    }
    if (normal.norm() > 0) normal.normalize();
    for (Index k = 0; k < contactSet.size(); ++k) {
      if (!out.inContact[k]) continue;
      const Point r = contactSet.position(k) - centre;
      c.radiusNodes = std::max(c.radiusNodes, (r - r.dot(normal) * normal).norm());
    }
  }
  c.area = out.contactArea;
  c.radius = out.contactRadius;
  c.maxViolation = problem.maxViolation(e.displacement);
  s.contact = c;

  // point fields
  const std::size_t n = static_cast<std::size_t>(mesh.numVertices());
  Field gap{"gap", 1, std::vector<double>(n, 0.0), false};
  Field normalDisplacement{"normal_displacement", 1, std::vector<double>(n, 0.0), false};
  Field pressure{"contact_pressure", 1, std::vector<double>(n, 0.0), false};
  Field state{"contact_state", 1, std::vector<double>(n, 0.0), true};
  Field direction{"constraint_direction", 3, std::vector<double>(3 * n, 0.0), false};
  for (Index k = 0; k < contactSet.size(); ++k) {
    const auto v = static_cast<std::size_t>(contactSet.vertex(k));
    const Point& nu = contactSet.direction(k);
    for (int i = 0; i < 3; ++i) direction.values[3 * v + i] = nu[i];
    normalDisplacement.values[v] =
        nu.template head<d>().dot(e.displacement.template segment<d>(static_cast<Eigen::Index>(v) * d));
    if (!problem.constraint(k).bounded()) continue;
    gap.values[v] = contactSet.gap(k);
    pressure.values[v] = out.pressure[k];
    state.values[v] = out.inContact[k] ? 2 : 1;
  }
  s.contactFields = {std::move(gap), std::move(normalDisplacement), std::move(pressure),
                     std::move(state), std::move(direction)};
  return s;
}

template <int d>
SceneSolution solve(const Scene& scene, const mesh::Grid& grid, const mesh::Mesh& mesh,
                    const BoundaryConditions& bc, const IterationProgress& progress,
                    const AssembledCallback& assembled) {
  return scene.contact ? solveContact<d>(scene, grid, mesh, bc, progress, assembled)
                       : solveLinear<d>(scene, grid, mesh, bc, assembled);
}

}  // namespace

bool reportsIteration(int iteration) {
  if (iteration <= 10) return iteration >= 1;
  int step = 10;
  while (iteration >= 10 * step) step *= 10;
  return iteration % step == 0;
}

SceneSolution solveScene(const Scene& scene, const mesh::Grid& grid, const mesh::Mesh& mesh,
                         const BoundaryConditions& bc, const IterationProgress& progress,
                         const AssembledCallback& assembled) {
  return mesh.dimension() == 2 ? solve<2>(scene, grid, mesh, bc, progress, assembled)
                               : solve<3>(scene, grid, mesh, bc, progress, assembled);
}

}  // namespace obs::drivers
