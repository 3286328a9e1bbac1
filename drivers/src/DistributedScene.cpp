#include "DistributedScene.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>

#include "DistributedOutput.hpp"
#include "ContactReports.hpp"
#include "RunSupport.hpp"
#include "obs/drivers/AdaptiveScene.hpp"
#include "obs/drivers/DynamicScene.hpp"
#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/SolutionFields.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/DistributedMultiBody.hpp"
#include "obs/obs/LinearCorrection.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/SolverConfig.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::drivers {
namespace {

using Progress = std::function<void(const std::string&)>;

std::string notDistributedBodies(const Scene& scene);

/// What of the scene is not distributed yet ("" if it can run), the solver aside (baselineSolver).
std::string notDistributed(const Scene& scene) {
  if (scene.adaptivity) {
    if (scene.multiBody()) {
      if (std::string what = notDistributedBodies(scene); !what.empty()) return what;
    } else if (!scene.contact) {
      return "[adaptivity] without [contact]";
    }
    if (scene.frictional()) return "[adaptivity] with friction";
    if (scene.adaptivity->inexact > 0) return "[adaptivity] inexact";
    return "";
  }
  if (scene.dynamics && scene.multiBody()) {
    if (std::string what = notDistributedBodies(scene); !what.empty()) return what;
    return scene.frictional() ? "[dynamics] with friction on a mortar pair" : "";
  }
  if (scene.dynamics) return scene.contact ? "" : "[dynamics] without [contact]";
  if (scene.multiBody()) return notDistributedBodies(scene);
  return "";
}

/// The one-process baseline solver a scene asks for (docs/architecture.md#one-path), as one line
/// naming the distributed solver to use instead ("" for tnnmg, multigrid and the defaults).
std::string baselineSolver(const Scene& scene, const Communicator& comm) {
  const std::string& type = scene.solver.type;
  if (type != "pgs" && type != "pdas" && type != "direct") return "";
  return scene.fileName + ": [solver] type = \"" + type + "\" is a one-process baseline; on " +
         std::to_string(comm.size()) + " MPI ranks use type = \"" + (type == "direct" ? "multigrid" : "tnnmg") +
         "\" (or run without mpirun)";
}

/// The sizes and assembly time of a distributed problem in r (freeOwned: this rank's free owned
/// unknowns; t: when the assembly began) and the "assembled" progress line. Collective.
void reportAssembly(const Communicator& comm, const DistributedView& leaf, int d, long long freeOwned,
                    Clock::time_point t, const Progress& progress, RunResult& r) {
  r.assemblySeconds = comm.max(secondsSince(t));
  r.dofs = static_cast<long long>(d) * leaf.globalVertices();
  r.freeDofs = comm.sum(freeOwned);
  progress("assembled: " + std::to_string(r.dofs) + " dofs (" + std::to_string(r.freeDofs) + " free) on " +
           std::to_string(comm.size()) + " ranks");
}

/// The boundary conditions at the load parameter t of [loading] (resolved on the coarse mesh).
using BoundaryConditionsAt = std::function<BoundaryConditions(double)>;

/// A [loading] increment's report from the owned contact nodes (ContactReports.hpp), with the
/// contact decisions at the global scales of the KKT residuals; its progress line; appended to
/// r.increments. Collective.
template <int d>
void reportIncrement(const ContactProblem<d>& problem, const Eigen::VectorXd& u, const ContactResult& result,
                     Index owned, const Communicator& comm, int step, int steps, long long iterations,
                     const Progress& progress, RunResult& r) {
  OwnedPart part;
  part.owned = owned;
  part.comm = comm;
  const ContactOutputs o = computeContactOutputs(problem, u, 1e-8, result.kkt.displacementScale, result.kkt.forceScale);
  r.increments.push_back(incrementReport(problem.contactSet(), o, part, step, steps, iterations, result.converged));
  progress(incrementLine(r.increments.back(), steps));
}

/// The solver report of a distributed TNNMG run in r: the solve time (from t, without the assembly
/// of later increments, maxima over the ranks), the last solve's result and rank 0's phases of it
/// (every rank runs the same phases; each waits for the others in them).
template <int d>
void reportTnnmg(const ContactResult& result, const typename TNNMG<d>::Statistics& st, double tolerance,
                 double laterAssembly, Clock::time_point t, const Communicator& comm, RunResult& r) {
  r.assemblySeconds += comm.max(laterAssembly);
  t += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(laterAssembly));
  r.solveSeconds = comm.max(secondsSince(t));
  r.solver.type = "tnnmg";
  reportContactResult(result, r.solveSeconds, tolerance, r.solver);
  reportTnnmgPhases(st, r.solver);
}

/// The scene's obstacle problem solved by distributed TNNMG: the displacement on the rank's local
/// mesh (ghost entries current), the assembly, solver and contact reports in r, and the contact
/// point fields of the serial one-body output on the local vertices in `fields` (exact on the
/// vertices of owned cells: every cell around such a vertex is held, so its row is complete).
template <int d>
Eigen::VectorXd solveContact(const Scene& scene, const Communicator& comm, const DistributedGrid& dg,
                             const DistributedView& leaf, const BoundaryConditionsAt& bcAt, int contactId,
                             const Progress& progress, RunResult& r, std::vector<Field>& fields, RankLoad& load) {
  const Index owned = leaf.halo.numOwned();
  // [loading] steps = N: the boundary conditions at t = i/N, one problem per increment (as serially)
  const int steps = scene.loading ? scene.loading->steps : 1;
  const auto loadAt = [&](int step) { return scene.loading ? static_cast<double>(step) / steps : 0.0; };
  // the problem on the rank's local mesh (its owned rows complete)
  auto t = Clock::now();
  std::optional<ContactSet> set;
  std::optional<ContactProblem<d>> problem;
  BoundaryConditions bc;
  comm.collective([&] {
    const std::unique_ptr<Obstacle> obstacle = makeObstacle(scene, d);
    set.emplace(leaf.local, contactId, *obstacle, true);
    bc = bcAt(loadAt(1));
    problem.emplace(leaf.local, scene.material, bc, *set);
  });
  long long boundaryOwned = 0, freeOwned = 0;
  for (Index k = 0; k < set->size(); ++k) boundaryOwned += set->vertex(k) < owned ? 1 : 0;
  for (Index i = 0; i < owned * d; ++i) freeOwned += problem->dirichlet().constrained[static_cast<std::size_t>(i)] ? 0 : 1;
  load.add("contact_vertices", static_cast<double>(boundaryOwned));
  boundaryOwned = comm.sum(boundaryOwned);
  if (boundaryOwned == 0)
    throw Error(scene.where(scene.contact->line) + "[contact]: the contact boundary has no faces");
  reportAssembly(comm, leaf, d, freeOwned, t, progress, r);

  // distributed TNNMG
  const SolverConfig config = solverConfig(scene);
  typename TNNMG<d>::Options o = tnnmgOptions<d>(config);
  o.tolerance = config.tolerance;
  o.maxIterations = config.iterationCap();
  t = Clock::now();
  double laterAssembly = 0;  // of the increments after the first (not solve time)
  TNNMG<d> solver(dg, o);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(problem->numDofs());
  ContactResult result;
  const std::optional<NodalFriction> friction =
      scene.contact->friction ? std::optional(nodalFriction(scene.contact->friction->law, *set)) : std::nullopt;
  for (int step = 1; step <= steps; ++step) {
    if (step > 1) {
      const auto ta = Clock::now();
      comm.collective([&] {
        problem.reset();
        bc = bcAt(loadAt(step));
        problem.emplace(leaf.local, scene.material, bc, *set);
      });
      laterAssembly += secondsSince(ta);
    }
    long long stepIterations = 0;
    std::tie(result, stepIterations) = solveIncrement<d>(*problem, solver, u, friction ? &*friction : nullptr, config.tolerance,
                                                         step, &leaf.halo, r.solver.friction, progress);
    if (scene.loading) reportIncrement<d>(*problem, u, result, owned, comm, step, steps, stepIterations, progress, r);
  }
  reportTnnmg<d>(result, solver.statistics(), config.tolerance, laterAssembly, t, comm, r);
  r.solver.coarseSolver = dg.partition().level == 0 ? "hypre" : "cholmod";
  if (dg.partition().level == 0) r.solver.coarseIterations = solver.statistics().coarseIterations;

  // the contact report from the owned contact nodes, reduced (ContactReports.hpp), with the contact
  // decisions at the global scales of the KKT residuals, so that every rank uses the same thresholds
  const ContactOutputs out =
      computeContactOutputs(*problem, u, 1e-8, result.kkt.displacementScale, result.kkt.forceScale);
  std::vector<char> stickSlip;  // the nodes' states as their owners decided them
  OwnedPart part;
  part.owned = owned;
  part.comm = comm;
  part.halo = &leaf.halo;
  part.global.resize(static_cast<std::size_t>(leaf.halo.numLocal()));
  for (Index v = 0; v < leaf.halo.numLocal(); ++v)
    part.global[static_cast<std::size_t>(v)] = leaf.numbering.global[leaf.halo.viewVertices()[v]];
  r.contact = obstacleContactReport<d>(scene, *problem, u, out, part, &stickSlip);
  // the point fields (SolutionFields.hpp: the obstacle layout of contactPointFields)
  {
    const auto n = static_cast<std::size_t>(leaf.local.numVertices());
    fields = {Field{"gap", 1, std::vector<double>(n, 0.0), false},
              Field{"normal_displacement", 1, std::vector<double>(n, 0.0), false},
              Field{"contact_pressure", 1, std::vector<double>(n, 0.0), false},
              Field{"contact_state", 1, std::vector<double>(n, 0.0), true},
              Field{"constraint_direction", 3, std::vector<double>(3 * n, 0.0), false}};
    if (scene.contact->friction) {
      fields.push_back(Field{"friction_force", 3, std::vector<double>(3 * n, 0.0), false});
      fields.push_back(Field{"slip", 1, std::vector<double>(n, 0.0), false});
      fields.push_back(Field{"stick_slip", 1, std::vector<double>(n, 0.0), true});
    }
    for (Index k = 0; k < set->size(); ++k) {
      const auto v = static_cast<std::size_t>(set->vertex(k));
      const Point& nu = set->direction(k);
      for (int a = 0; a < 3; ++a) fields[4].values[3 * v + a] = nu[a];
      fields[1].values[v] = nu.head<d>().dot(u.template segment<d>(static_cast<Eigen::Index>(v) * d));
      if (!std::isfinite(set->gap(k))) continue;
      fields[0].values[v] = set->gap(k);
      fields[2].values[v] = out.pressure[k];
      fields[3].values[v] = stickSlip[k] != 0 ? 2 : 1;
      if (!scene.contact->friction) continue;
      for (int a = 0; a < d; ++a) fields[5].values[3 * v + a] = -out.tangential[k][a];
      fields[6].values[v] = out.slip[k];
      fields[7].values[v] = stickSlip[k];
    }
  }
  return u;
}

/// A scene without contact solved by the distributed multigrid's V-cycles (Gauss-Seidel smoothing,
/// the coarse level on every rank) to the [solver] tolerance: the displacement on the rank's local
/// mesh (ghost entries current), the assembly and solver reports in r.
template <int d>
Eigen::VectorXd solveLinear(const Scene& scene, const Communicator& comm, const DistributedGrid& dg,
                            const DistributedView& leaf, const BoundaryConditions& bc, const Progress& progress,
                            RunResult& r) {
  const Index owned = leaf.halo.numOwned();
  auto t = Clock::now();
  BlockSparseMatrix<d> A;
  Eigen::VectorXd b;
  DirichletValues g;
  comm.collective([&] {
    A = assembleStiffness<d>(leaf.local, scene.material);
    b = assembleLoad<d>(leaf.local, bc);
    g = collectDirichlet(leaf.local, bc.dirichlet);
    applyDirichlet(A, b, g);
  });
  long long freeOwned = 0;
  for (Index i = 0; i < owned * d; ++i) freeOwned += g.constrained[static_cast<std::size_t>(i)] ? 0 : 1;
  reportAssembly(comm, leaf, d, freeOwned, t, progress, r);

  const SolverConfig config = solverConfig(scene);
  LinearMultigridOptions o = config.multigrid;
  o.tolerance = config.tolerance;
  o.maxIterations = config.maxIterations.value_or(o.maxIterations);
  t = Clock::now();
  // the start: the prescribed values on the owned vertices, the ghosts' from their owners (a ghost
  // may lie on a Dirichlet face this rank does not hold)
  Eigen::VectorXd u = Eigen::VectorXd::Zero(b.size());
  for (Index i = 0; i < owned * d; ++i)
    if (g.constrained[static_cast<std::size_t>(i)]) u[i] = g.values[i];
  leaf.halo.update(u, d);
  LinearSolverResult result;
  std::optional<LinearMultigrid<d>> mg;
  comm.collective([&] { mg.emplace(dg, o); });
  mg->setOperator(A, {}, g.constrained);
  result = mg->solve(b, u);
  r.solveSeconds = comm.max(secondsSince(t));
  r.solver.type = "multigrid";
  r.solver.iterations = result.iterations;
  r.solver.converged = result.converged;
  r.solver.seconds = r.solveSeconds;
  r.solver.tolerance = o.tolerance;
  r.solver.correction = result.correction;
  r.solver.convergenceRate = result.convergenceRate;
  r.solver.vcycles = mg->vcycles();
  r.solver.coarseSolver = mg->distributedCoarseLevel() ? "hypre" : "cholmod";
  if (mg->distributedCoarseLevel()) r.solver.coarseIterations = mg->coarseIterations();
  return u;
}

/// The scene solved on the ranks (solveContact or solveLinear); the largest displacement and von
/// Mises stress reduced over the owned vertices and cells; each rank's piece of the solution and
/// rank 0's .pvtu and .pvd.
template <int d>
void solveDistributed(const Scene& scene, const RunOptions& options, const Communicator& comm, const DistributedGrid& dg,
                      const DistributedView& leaf, const BoundaryConditionsAt& bcAt, int contactId,
                      const std::filesystem::path& dir, RunResult& r, RankLoad& load) {
  const Progress progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  const Index owned = leaf.halo.numOwned();
  load.add("owned_vertices", static_cast<double>(owned));
  load.add("ghost_vertices", static_cast<double>(leaf.halo.numLocal() - owned));
  load.add("owned_cells", static_cast<double>(leaf.part.owned.size()));
  std::vector<Field> contactFields;
  const Eigen::VectorXd u = scene.contact
                                ? solveContact<d>(scene, comm, dg, leaf, bcAt, contactId, progress, r, contactFields, load)
                                : solveLinear<d>(scene, comm, dg, leaf, bcAt(0), progress, r);
  // displacement and stresses of the owned vertices and cells
  ElasticitySolution e;
  e.dimension = d;
  e.displacement = u;
  recoverStresses(leaf.local, scene.material, e);
  double maxU = 0, maxMises = 0;
  for (Index v = 0; v < owned; ++v) maxU = std::max(maxU, u.template segment<d>(static_cast<Eigen::Index>(v) * d).norm());
  const auto ownedCells = static_cast<Index>(leaf.part.owned.size());
  for (Index cell = 0; cell < ownedCells; ++cell) maxMises = std::max(maxMises, vonMises(e.cellStress[cell]));
  r.maxDisplacement = comm.max(maxU);
  r.maxVonMises = comm.max(maxMises);
  {
    std::ostringstream os;
    os << "solved in " << std::setprecision(3) << r.solveSeconds << " s (" << r.solver.type << ", "
       << r.solver.iterations << " iterations" << (r.solver.converged ? "" : ", NOT converged") << ", " << comm.size()
       << " ranks): max |u| = " << std::setprecision(6) << r.maxDisplacement << ", max von Mises = " << r.maxVonMises;
    if (r.contact)
      os << "; contact: " << r.contact->actualVertices << " of " << r.contact->potentialVertices
         << " vertices, P = " << r.contact->load;
    progress(os.str());
  }

  // the solution: each rank its owned cells, rank 0 the .pvtu
  if (!scene.output.vtk) return;
  const std::string stem = OutputLayout(scene).staticVtu(0);
  const std::string base = std::filesystem::path(stem).stem().string();
  std::vector<Field> pf = pointFields(leaf.local, e), cf = cellFields(leaf.local, e);
  for (Field& f : contactFields) pf.push_back(std::move(f));
  for (auto& f : writePieces(dir, base, leaf.local, ownedCells, pf, cf, comm)) r.outputFiles.push_back(f);
  comm.collective([&] {
    if (comm.rank() == 0) writePvdCollection(dir / (base + ".pvd"), {PvdEntry{0, 0, base + ".pvtu"}});
  });
  if (comm.rank() == 0) r.outputFiles.push_back(dir / (base + ".pvd"));
}

/// What of a multi-body scene is not distributed yet ("" if it can run).
/// The measure of a boundary face from its corners (2D: a segment; 3D: a triangle, or a bilinear
/// quadrilateral with corners in cyclic order by 2 x 2 Gauss points, exact where it is planar).
double faceMeasure(const std::vector<Point>& x, int d) {
  if (d == 2) return (x[1] - x[0]).norm();
  if (x.size() == 3) return 0.5 * (x[1] - x[0]).cross(x[2] - x[0]).norm();
  const double g[2] = {0.5 - 0.5 / std::sqrt(3.0), 0.5 + 0.5 / std::sqrt(3.0)};
  double area = 0;
  for (double s : g)
    for (double t : g) {
      const Point xs = (1 - t) * (x[1] - x[0]) + t * (x[2] - x[3]);
      const Point xt = (1 - s) * (x[3] - x[0]) + s * (x[2] - x[1]);
      area += 0.25 * xs.cross(xt).norm();
    }
  return area;
}

std::string notDistributedBodies(const Scene& scene) {
  if (scene.bodies.size() != 2 || scene.pairs.size() != 1)
    return std::to_string(scene.bodies.size()) + " [[body]] entries and " + std::to_string(scene.pairs.size()) +
           " mortar [[contact]] pairs (distributed: two bodies and one pair)";
  for (const Scene& b : scene.bodies)
    if (b.contact) return "an obstacle [[contact]] of body '" + b.name + "'";
  return "";
}

/// A two-body scene on the ranks (docs/architecture.md#distributed-two-body): each body a
/// DistributedGrid, their dual-mortar coupling (DistributedMortar) and transformed problem
/// (DistributedMultiBody), solved by TNNMG with the stacked distributed multigrid correction;
/// the report of the pair (summary.json "pairs") and of each body, each body's pieces and .pvtu and
/// the scene's .pvd of the bodies.
template <int d>
void solveBodies(const Scene& scene, const RunOptions& options, const Communicator& comm,
                 const std::vector<std::unique_ptr<DistributedGrid>>& grids, const std::vector<DistributedView>& views,
                 const std::vector<mesh::Mesh>& coarseMeshes,
                 int slaveId, int masterId, const std::filesystem::path& dir, RunResult& r, RankLoad& load) {
  const Progress progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  const std::vector<const Scene*> bodies = scene.bodyScenes();
  const MortarPairSpec& pair = scene.pairs.front();
  const int s = pair.slaveIndex, m = pair.masterIndex;
  // [loading] steps = N: the boundary conditions at t = i/N, one problem per increment (as serially)
  const int steps = scene.loading ? scene.loading->steps : 1;
  const auto loadAt = [&](int step) { return scene.loading ? static_cast<double>(step) / steps : 0.0; };
  auto t = Clock::now();
  // the mortar pair (errors name the [[contact]] line, as serially); it does not change with the load
  const auto side = [](const std::string& body, const BoundaryRef& ref) {  // "body:boundary", as serially
    return body + ":" + (ref.name.empty() ? std::to_string(ref.id) : ref.name);
  };
  const std::string slaveLabel = side(pair.slaveBody, pair.slave), masterLabel = side(pair.masterBody, pair.master);
  const Index offsets[2] = {0, views[0].globalVertices()};
  MortarOptions mo;
  mo.minCoverage = pair.minCoverage;
  mo.searchDistance = pair.searchDistance;
  std::optional<DistributedMortar> mortar;
  try {
    mortar.emplace(DistributedMortarSurface{&views[s], slaveId, offsets[s], slaveLabel},
                   DistributedMortarSurface{&views[m], masterId, offsets[m], masterLabel}, mo);
  } catch (const Error& e) {
    throw Error(scene.where(pair.line) + "[[contact]] " + e.what());
  }
  const double mortarSeconds = comm.max(secondsSince(t));
  // the bodies' systems at load parameter lt and their transformed problem
  std::vector<BodySystem<d>> systems(2);
  std::optional<DistributedMultiBody<d>> multi;
  const auto build = [&](double lt) {
    multi.reset();
    comm.collective([&] {
      for (std::size_t i = 0; i < 2; ++i)
        systems[i] = assembleBody<d>(views[i].local, bodies[i]->material, makeBoundaryConditions(*bodies[i], coarseMeshes[i], lt));
    });
    try {
      multi.emplace(std::vector<DistributedBody<d>>{{&views[0], &systems[0]}, {&views[1], &systems[1]}}, *mortar, s, m);
      for (auto& sys : systems) sys = BodySystem<d>();  // in T'AT now (DistributedMultiBody reads them once)
    } catch (const Error& e) {
      throw Error(scene.where(pair.line) + "[[contact]] " + e.what());
    }
  };
  build(loadAt(1));
  {
    const Index owned = multi->numOwned();
    long long freeOwned = 0;
    for (Index i = 0; i < owned * d; ++i)
      freeOwned += multi->problem().dirichlet().constrained[static_cast<std::size_t>(i)] ? 0 : 1;
    r.assemblySeconds = comm.max(secondsSince(t));
    r.dofs = static_cast<long long>(d) * multi->globalVertices();
    r.freeDofs = comm.sum(freeOwned);
    // the rank's work: its vertices and cells of both bodies, the slave vertices it owns (the
    // mortar rows), and the coupling's extra ghosts and received blocks of T'AT
    double cells = 0;
    for (const auto& v : views) cells += static_cast<double>(v.part.owned.size());
    const auto slaves = static_cast<double>(mortar->rows().size());  // (rows of owned slave vertices)
    load.add("owned_vertices", static_cast<double>(owned));
    load.add("ghost_vertices", static_cast<double>(multi->numLocal() - owned - multi->extraGhosts()));
    load.add("owned_cells", cells);
    load.add("slave_vertices", slaves);
    load.add("extra_ghosts", static_cast<double>(multi->extraGhosts()));
    load.add("received_blocks", static_cast<double>(multi->receivedTerms()));
  }
  progress("assembled: " + std::to_string(r.dofs) + " dofs (" + std::to_string(r.freeDofs) + " free, " +
           std::to_string(mortar->globalSize()) + " constrained slave vertices) on " + std::to_string(comm.size()) +
           " ranks");

  // TNNMG with the stacked multigrid correction ((I - C) P on the fine level); Tresca friction in one solve, Coulomb by
  // the fixed point over Tresca solves (as for one body)
  const SolverConfig config = solverConfig(scene);
  typename TNNMG<d>::Options o = tnnmgOptions<d>(config);
  o.tolerance = config.tolerance;
  o.maxIterations = config.iterationCap();
  const FrictionLaw law = pair.friction ? pair.friction->law : FrictionLaw{};
  t = Clock::now();
  double laterAssembly = 0;  // of the increments after the first (not solve time)
  std::optional<TNNMG<d>> solver;
  Eigen::VectorXd x;
  ContactResult result;
  for (int step = 1; step <= steps; ++step) {
    if (step > 1) {
      const auto ta = Clock::now();
      solver.reset();  // (it holds the halo of the previous problem)
      const Eigen::VectorXd previous = x;
      build(loadAt(step));
      x = previous;  // the warm start: the same numbering, as the mortar pair is the same
      laterAssembly += secondsSince(ta);
    }
    ContactProblem<d>& problem = multi->problem();
    if (x.size() != problem.numDofs()) x = Eigen::VectorXd::Zero(problem.numDofs());
    std::vector<const DistributedGrid*> stacked;
    for (const auto& g : grids) stacked.push_back(g.get());
    solver.emplace(multi->halo(), o,
                   std::make_unique<LinearMultigrid<d>>(stacked, multi->extraGhostGlobals(), o.multigrid));
    const std::optional<NodalFriction> friction =
        pair.friction ? std::optional(nodalFriction(law, problem.contactSet())) : std::nullopt;
    long long stepIterations = 0;
    std::tie(result, stepIterations) = solveIncrement<d>(problem, *solver, x, friction ? &*friction : nullptr, config.tolerance,
                                                         step, &multi->halo(), r.solver.friction, progress);
    if (scene.loading)
      reportIncrement<d>(problem, x, result, multi->numOwned(), comm, step, steps, stepIterations, progress, r);
  }
  const ContactProblem<d>& problem = multi->problem();
  reportTnnmg<d>(result, solver->statistics(), config.tolerance, laterAssembly, t, comm, r);
  // the coarse level: replicated (CHOLMOD on every rank) unless a body is partitioned on level 0
  bool replicatedCoarse = true;
  for (const auto& g : grids) replicatedCoarse = replicatedCoarse && g->partition().level > 0;
  r.solver.coarseSolver = replicatedCoarse ? "cholmod" : "hypre";
  if (!replicatedCoarse) r.solver.coarseIterations = solver->statistics().coarseIterations;
  solver.reset();  // its hierarchy and rotated copy are not needed for the outputs

  // the pair's report from the owned constrained slave vertices, reduced (the contact decisions with
  // the global scales of the KKT residuals)
  const ContactOutputs out = computeContactOutputs(problem, x, 1e-8, result.kkt.displacementScale, result.kkt.forceScale);
  const ContactSet& cs = problem.contactSet();
  PairReport pr;
  pr.label = slaveLabel + " / " + masterLabel;
  pr.mortar = true;
  pr.slaveBody = s;
  pr.masterBody = m;
  pr.slave = slaveLabel;
  pr.master = masterLabel;
  // per stacked local vertex: gap, normal displacement, pressure, state, direction (3), force (3),
  // and with friction the friction force (3), slip and stick/slip state
  constexpr int W = 15;
  std::vector<double> tangential(3, 0.0);
  long long stick = 0, slip = 0;
  Eigen::VectorXd F = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(multi->numLocal()) * W);
  std::vector<double> sums(6, 0.0);  // force on the slave, on the master
  double pmin = std::numeric_limits<double>::infinity(), pmax = -pmin;
  long long potential = 0, actual = 0;
  Eigen::VectorXd y = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(mortar->rows().size()) * d);
  for (std::size_t j = 0; j < mortar->rows().size(); ++j) {
    const Index l = multi->local(s, mortar->rows()[j].local);
    const Index k = cs.nodeOf(l);
    if (k < 0 || !problem.constraint(k).bounded()) continue;
    const Point& nu = cs.direction(k);
    const double mu = out.multiplier[k];
    ++potential;
    pr.load += mu;
    for (int a = 0; a < d; ++a) {
      sums[static_cast<std::size_t>(a)] -= mu * nu[a];
      y[static_cast<Eigen::Index>(j) * d + a] = mu * nu[a];
    }
    const double xn = nu.head<d>().dot(x.template segment<d>(static_cast<Eigen::Index>(l) * d));
    pr.maxViolation = std::max(pr.maxViolation, xn - cs.gap(k));
    if (out.inContact[k]) {
      ++actual;
      pmin = std::min(pmin, out.pressure[k]);
      pmax = std::max(pmax, out.pressure[k]);
    }
    double* f = F.data() + static_cast<std::ptrdiff_t>(l) * W;
    f[0] = cs.gap(k);
    f[1] = xn;
    f[2] = out.pressure[k];
    f[3] = out.inContact[k] ? 2 : 1;
    for (int a = 0; a < 3; ++a) f[4 + a] = nu[a];
    for (int a = 0; a < d; ++a) f[7 + a] = -mu * nu[a];
    for (int a = 0; a < d; ++a) {
      f[10 + a] = -out.tangential[k][a];
      tangential[static_cast<std::size_t>(a)] -= out.tangential[k][a];
    }
    f[13] = out.slip[k];
    f[14] = out.state[k];
    stick += out.state[k] == 1;
    slip += out.state[k] == 2;
  }
  // the master forces C'(mu n), the owners' sums at the master vertices
  Eigen::VectorXd fm = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(views[m].halo.numLocal()) * d);
  mortar->addTransposedTransformation(y, fm, d);
  for (Index v = 0; v < views[m].halo.numOwned(); ++v) {
    double* f = F.data() + static_cast<std::ptrdiff_t>(multi->local(m, v)) * W;
    for (int a = 0; a < d; ++a) {
      f[7 + a] += fm[static_cast<Eigen::Index>(v) * d + a];
      sums[static_cast<std::size_t>(3 + a)] += fm[static_cast<Eigen::Index>(v) * d + a];
    }
  }
  comm.sum(sums);
  for (int a = 0; a < 3; ++a) {
    pr.forceSlave[a] = sums[static_cast<std::size_t>(a)];
    pr.forceMaster[a] = sums[static_cast<std::size_t>(3 + a)];
  }
  pr.potentialVertices = comm.sum(potential);
  pr.actualVertices = comm.sum(actual);
  pr.load = comm.sum(pr.load);
  pr.maxViolation = std::max(0.0, comm.max(pr.maxViolation));
  pr.pressureMin = pr.actualVertices > 0 ? -comm.max(-pmin) : 0.0;
  pr.pressureMax = pr.actualVertices > 0 ? comm.max(pmax) : 0.0;
  multi->halo().update(F, W);  // the ghosts' fields (and states) from their owners
  // the contact area: slave faces with all vertices in contact, each counted by the owner of its
  // vertex of smallest global index (every face around an owned vertex is held); the slave vertices
  long long slaveOwned = 0;
  {
    const DistributedView& sv = views[s];
    const mesh::Mesh& lm = sv.local;
    std::vector<char> onSlave(static_cast<std::size_t>(lm.numVertices()), 0);
    double area = 0, stickArea = 0;
    for (Index f = 0; f < lm.numBoundaryFaces(); ++f) {
      if (lm.boundaryFaceId(f) != slaveId) continue;
      const auto vertices = lm.boundaryFaceVertices(f);
      bool contact = true, sticking = true;
      Index first = -1, firstGlobal = std::numeric_limits<Index>::max();
      std::vector<Point> corners;
      for (Index v : vertices) {
        onSlave[static_cast<std::size_t>(v)] = 1;
        contact = contact && F[static_cast<Eigen::Index>(multi->local(s, v)) * W + 3] == 2;
        sticking = sticking && F[static_cast<Eigen::Index>(multi->local(s, v)) * W + 14] == 1;
        const Index g = multi->global()[static_cast<std::size_t>(multi->local(s, v))];
        if (g < firstGlobal) {
          firstGlobal = g;
          first = v;
        }
        corners.push_back(lm.vertex(v));
      }
      if (first >= sv.halo.numOwned()) continue;
      if (contact) area += faceMeasure(corners, d);
      if (sticking) stickArea += faceMeasure(corners, d);
    }
    for (Index v = 0; v < sv.halo.numOwned(); ++v) slaveOwned += onSlave[static_cast<std::size_t>(v)];
    pr.area = comm.sum(area);
    pr.stickArea = comm.sum(stickArea);
  }
  if (pair.friction) {
    comm.sum(tangential);
    for (int a = 0; a < 3; ++a) pr.tangentialSlave[a] = tangential[static_cast<std::size_t>(a)];
    pr.stickVertices = comm.sum(stick);
    pr.slipVertices = comm.sum(slip);
    pr.friction = frictionReport(law, pr.tangentialSlave, pr.stickVertices, pr.slipVertices, pr.stickArea, d);
  }
  pr.slaveVertices = comm.sum(slaveOwned);
  pr.uncovered = pr.slaveVertices - mortar->globalSize();
  pr.segments = -1;  // not counted: the ranks' local couplings share the faces at their boundaries (null)
  pr.mortarSeconds = mortarSeconds;
  pr.radius = d == 3 ? std::sqrt(pr.area / std::numbers::pi) : pr.area / 2;
  r.pairs.push_back(pr);

  // displacements, stresses and pieces per body
  multi->halo().update(x, d);
  const Eigen::VectorXd u = multi->toDisplacement(x);
  const OutputLayout layout(scene);
  std::vector<PvdEntry> parts;
  for (int b = 0; b < 2; ++b) {
    const DistributedView& view = views[static_cast<std::size_t>(b)];
    ElasticitySolution e;
    e.dimension = d;
    e.displacement = multi->bodyPart(b, u, d);
    recoverStresses(view.local, bodies[b]->material, e);
    BodyReport br;
    br.name = bodies[b]->name;
    br.vertices = view.globalVertices();
    br.cells = grids[b]->globalLeaves();
    double maxU = 0, maxMises = 0;
    for (Index v = 0; v < view.halo.numOwned(); ++v)
      maxU = std::max(maxU, e.displacement.template segment<d>(static_cast<Eigen::Index>(v) * d).norm());
    const auto ownedCells = static_cast<Index>(view.part.owned.size());
    for (Index cell = 0; cell < ownedCells; ++cell) maxMises = std::max(maxMises, vonMises(e.cellStress[cell]));
    br.maxDisplacement = comm.max(maxU);
    br.maxVonMises = comm.max(maxMises);
    r.maxDisplacement = std::max(r.maxDisplacement, br.maxDisplacement);
    r.maxVonMises = std::max(r.maxVonMises, br.maxVonMises);
    r.bodies.push_back(br);
    if (!scene.output.vtk) continue;
    const Eigen::VectorXd fb = multi->bodyPart(b, F, W);
    const auto n = static_cast<std::size_t>(view.local.numVertices());
    std::vector<Field> pf = pointFields(view.local, e);
    const char* names[] = {"gap", "normal_displacement", "contact_pressure", "contact_state", "constraint_direction",
                           "contact_force", "friction_force", "slip", "stick_slip"};
    const int components[] = {1, 1, 1, 1, 3, 3, 3, 1, 1}, first[] = {0, 1, 2, 3, 4, 7, 10, 13, 14};
    for (int k = 0; k < (pair.friction ? 9 : 6); ++k) {
      Field f{names[k], components[k], std::vector<double>(n * static_cast<std::size_t>(components[k]), 0.0),
              k == 3 || k == 8};
      for (std::size_t v = 0; v < n; ++v)
        for (int c = 0; c < components[k]; ++c)
          f.values[v * static_cast<std::size_t>(components[k]) + static_cast<std::size_t>(c)] =
              fb[static_cast<Eigen::Index>(v) * W + first[k] + c];
      pf.push_back(std::move(f));
    }
    const std::string base = std::filesystem::path(layout.staticVtu(static_cast<std::size_t>(b))).stem().string();
    for (auto& f : writePieces(dir, base, view.local, ownedCells, pf, cellFields(view.local, e), comm))
      r.outputFiles.push_back(f);
    parts.push_back(PvdEntry{0, b, base + ".pvtu"});
  }
  if (scene.output.vtk) {
    comm.collective([&] {
      if (comm.rank() == 0) writePvdCollection(dir / (scene.name + ".pvd"), parts);
    });
    if (comm.rank() == 0) r.outputFiles.push_back(dir / (scene.name + ".pvd"));
  }
  std::ostringstream os;
  os << "solved in " << std::setprecision(3) << r.solveSeconds << " s (tnnmg, " << r.solver.iterations << " iterations"
     << (r.solver.converged ? "" : ", NOT converged") << ", " << comm.size() << " ranks): max |u| = "
     << std::setprecision(6) << r.maxDisplacement << ", max von Mises = " << r.maxVonMises << "; " << pr.slave << " / "
     << pr.master << ": " << pr.actualVertices << " of " << pr.potentialVertices << " slave vertices in contact, P = "
     << pr.load;
  progress(os.str());
}

/// A multi-body scene on the ranks (solveBodies); the grids from the bodies' coarse meshes.
RunResult runDistributedBodies(const Scene& scene, const RunOptions& options, const Communicator& comm,
                               Clock::time_point start) {
  const auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  RunResult r;
  r.scene = scene.fileName;
  auto t = Clock::now();
  std::optional<BodyGrids> coarse;
  int slaveId = -1, masterId = -1;
  const MortarPairSpec& pair = scene.pairs.front();
  comm.collective([&] {  // every body's coarse grid, validated, and the pair's boundaries
    coarse.emplace(buildBodyGrids(scene, 0));
    const std::vector<const Scene*> bodies = scene.bodyScenes();
    slaveId = boundaryIdOf(scene, coarse->meshes[static_cast<std::size_t>(pair.slaveIndex)], pair.slave,
                           "[[contact]] slave of body '" + bodies[pair.slaveIndex]->name + "':");
    masterId = boundaryIdOf(scene, coarse->meshes[static_cast<std::size_t>(pair.masterIndex)], pair.master,
                            "[[contact]] master of body '" + bodies[pair.masterIndex]->name + "':");
  });
  const std::vector<const Scene*> bodies = scene.bodyScenes();
  // each body refined as serially: --refine, else its own [mesh] refine
  for (const Scene* body : bodies)
    if (options.refine.value_or(body->mesh.refine) < 1)
      throw Error(scene.where(body->bodyLine) + "[[body]] '" + body->name +
                  "': a distributed run needs refine >= 1 (the coarse mesh is solved on every rank; --refine 1 or its "
                  "[mesh] refine)");
  ForestPartitionOptions partition;
  if (options.partitionLevel) partition.level = *options.partitionLevel;
  std::vector<std::unique_ptr<DistributedGrid>> grids;
  for (std::size_t i = 0; i < bodies.size(); ++i)
    grids.push_back(std::make_unique<DistributedGrid>(std::move(coarse->grids[i]),
                                                      options.refine.value_or(bodies[i]->mesh.refine), comm, partition));
  r.meshSeconds = comm.max(secondsSince(t));
  r.dimension = coarse->meshes.front().dimension();
  r.refine = options.refine.value_or(bodies.front()->mesh.refine);
  std::vector<double> perType(r.cellsPerType.size(), 0.0);
  std::vector<DistributedView> views;  // the leaf views (collective), the problem's numbering
  for (const auto& g : grids) {
    const DistributedView& leaf = views.emplace_back(g->view());
    r.vertices += leaf.globalVertices();
    r.cells += g->globalLeaves();
    for (Index cell = 0; cell < static_cast<Index>(leaf.part.owned.size()); ++cell)
      perType[static_cast<std::size_t>(leaf.local.cellType(cell))] += 1;
  }
  comm.sum(perType);
  for (std::size_t k = 0; k < perType.size(); ++k) r.cellsPerType[k] = static_cast<long long>(perType[k]);
  progress("meshes built: " + std::to_string(bodies.size()) + " bodies, " + std::to_string(r.cells) + " cells / " +
           std::to_string(r.vertices) + " vertices (" + std::to_string(r.dimension) + "D) on " +
           std::to_string(comm.size()) + " ranks (" + std::to_string(r.meshSeconds) + " s)");
  if (scene.adaptivity || scene.dynamics) {  // the bodies' conditions resolved on their coarse meshes
    std::vector<const mesh::Mesh*> meshes;
    std::vector<BoundaryConditions> bcs;
    comm.collective([&] {
      for (std::size_t i = 0; i < bodies.size(); ++i) bcs.push_back(makeBoundaryConditions(*bodies[i], coarse->meshes[i], 0));
    });
    for (const mesh::Mesh& m : coarse->meshes) meshes.push_back(&m);
    if (scene.adaptivity) {
      std::vector<DistributedGrid*> dgs;
      for (const auto& g : grids) dgs.push_back(g.get());
      return runDistributedAdaptiveScene(scene, dgs, bcs, meshes, options, std::move(r), start);
    }
    std::vector<const DistributedGrid*> dgs;
    std::vector<const DistributedView*> leaves;
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      dgs.push_back(grids[i].get());
      leaves.push_back(&views[i]);
    }
    return runDistributedDynamicScene(scene, dgs, leaves, meshes, bcs, options, std::move(r), start);
  }
  const std::filesystem::path dir = options.outputDirectory.value_or(scene.output.directory);
  comm.collective([&] {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw Error(dir.string() + ": cannot create the output directory (" + ec.message() + ")");
  });
  RankLoad load;
  if (r.dimension == 2) solveBodies<2>(scene, options, comm, grids, views, coarse->meshes, slaveId, masterId, dir, r, load);
  else solveBodies<3>(scene, options, comm, grids, views, coarse->meshes, slaveId, masterId, dir, r, load);

  nlohmann::json extra;
  addDistributedSummary(extra, comm, grids.front()->partition().level, load);
  comm.collective([&] {
    if (comm.rank() != 0) return;
    const auto outputs = Clock::now();
    writeIncrementsCsv(dir, r);
    finishRun(scene, options, dir, r, outputs, start, extra);
  });
  throwIfNotConverged(scene, r, dir);
  return r;
}

}  // namespace

RunResult runDistributedScene(const Scene& scene, const RunOptions& options, const Communicator& comm) {
  const auto start = Clock::now();
  if (const std::string what = notDistributed(scene); !what.empty())
    throw Error(scene.fileName + ": distributed runs (" + std::to_string(comm.size()) +
                " MPI ranks) solve static scenes with TNNMG so far (one body, with an obstacle or without contact, or two bodies with "
                "one mortar pair), adaptive scenes of one body against an obstacle or of two bodies with one frictionless mortar pair, and dynamic scenes of one body or two bodies with one frictionless mortar pair; this scene has " + what +
                " (run it without mpirun, and use --threads N for the cores of one machine)");
  if (const std::string baseline = baselineSolver(scene, comm); !baseline.empty()) throw Error(baseline);
  const auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  if (scene.multiBody()) return runDistributedBodies(scene, options, comm, start);
  RunResult r;
  r.scene = scene.fileName;
  auto t = Clock::now();
  // the coarse grid (with the scene's boundary projections) and its distributed refinement
  // the boundary conditions and the contact boundary are resolved on the coarse mesh (the same on
  // every rank; a rank's local mesh may have no face of a boundary)
  std::optional<mesh::Grid> coarse;
  std::optional<mesh::Mesh> coarseMesh;
  int contactId = -1;
  comm.collective([&] {  // e.g. a mesh file one rank cannot read: every rank stops
    coarse.emplace(buildGrid(scene, 0));
    coarseMesh.emplace(coarse->leafView().mesh);
    validateScene(scene, *coarseMesh);
    makeBoundaryConditions(scene, *coarseMesh, 0);  // its errors here, before the grid is refined
    if (scene.contact) contactId = contactBoundaryId(scene, *coarseMesh);
  });
  const BoundaryConditionsAt bcAt = [&](double t) { return makeBoundaryConditions(scene, *coarseMesh, t); };
  const int refine = options.refine.value_or(scene.mesh.refine);
  if (refine < 1)
    throw Error(scene.fileName + ": a distributed run needs refine >= 1 (the coarse mesh is solved on every rank; --refine 1 or [mesh] refine)");
  ForestPartitionOptions partition;
  if (options.partitionLevel) partition.level = *options.partitionLevel;
  DistributedGrid dg(std::move(*coarse), refine, comm, partition);
  const DistributedView leaf = dg.view();
  r.meshSeconds = comm.max(secondsSince(t));
  r.dimension = leaf.local.dimension();
  r.refine = refine;
  r.vertices = leaf.globalVertices();
  r.cells = dg.globalLeaves();
  {
    std::vector<double> perType(r.cellsPerType.size(), 0.0);
    for (Index cell = 0; cell < static_cast<Index>(leaf.part.owned.size()); ++cell)
      perType[static_cast<std::size_t>(leaf.local.cellType(cell))] += 1;
    comm.sum(perType);
    for (std::size_t k = 0; k < perType.size(); ++k) r.cellsPerType[k] = static_cast<long long>(perType[k]);
  }
  progress("mesh built: " + std::to_string(r.cells) + " cells / " + std::to_string(r.vertices) + " vertices (" +
           std::to_string(r.dimension) + "D) on " + std::to_string(comm.size()) + " ranks, partition level " +
           std::to_string(dg.partition().level) + " (" + std::to_string(r.meshSeconds) + " s)");

  if (scene.dynamics)
    return runDistributedDynamicScene(scene, {&dg}, {&leaf}, {&*coarseMesh}, {bcAt(0)}, options, std::move(r), start);
  if (scene.adaptivity) return runDistributedAdaptiveScene(scene, {&dg}, {bcAt(0)}, {&*coarseMesh}, options, std::move(r), start);

  const std::filesystem::path dir = options.outputDirectory.value_or(scene.output.directory);
  comm.collective([&] {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw Error(dir.string() + ": cannot create the output directory (" + ec.message() + ")");
  });
  RankLoad load;
  if (r.dimension == 2) solveDistributed<2>(scene, options, comm, dg, leaf, bcAt, contactId, dir, r, load);
  else solveDistributed<3>(scene, options, comm, dg, leaf, bcAt, contactId, dir, r, load);

  // summary.json from rank 0: the figures above are reduced over the ranks; the memory per rank
  nlohmann::json extra;
  addDistributedSummary(extra, comm, dg.partition().level, load);
  comm.collective([&] {
    if (comm.rank() != 0) return;
    const auto outputs = Clock::now();
    writeIncrementsCsv(dir, r);
    finishRun(scene, options, dir, r, outputs, start, extra);
  });
  throwIfNotConverged(scene, r, dir);  // (every rank: the same figures)
  return r;
}

}  // namespace obs::drivers
