#include "obs/estimators/AdaptiveLoop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Marking.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::estimators {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

const EstimatorRegistry& registryOf(const AdaptiveLoopOptions& o) {
  return o.registry ? *o.registry : EstimatorRegistry::global();
}

/// Interpolates a vertex-major vector with `components` per vertex by the transfer matrix T.
Eigen::VectorXd transfer(const mesh::CsrMatrix& T, const Eigen::VectorXd& u, int components) {
  Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(T.rows) * components);
  for (Index i = 0; i < T.rows; ++i)
    for (Index k = T.rowStart[i]; k < T.rowStart[i + 1]; ++k)
      r.segment(static_cast<Eigen::Index>(i) * components, components) +=
          T.values[k] * u.segment(static_cast<Eigen::Index>(T.columns[k]) * components, components);
  return r;
}

}  // namespace

double experimentalOrder(double eta0, double n0, double eta1, double n1) {
  if (!(eta0 > 0) || !(eta1 > 0) || !(n0 > 0) || !(n1 > n0)) return std::numeric_limits<double>::quiet_NaN();
  return (std::log(eta0) - std::log(eta1)) / (std::log(n1) - std::log(n0));
}

ReferenceErrors referenceErrors(const mesh::Mesh& mesh, const ContactSet& set, const ContactOutputs& outputs,
                                const ContactReference& reference) {
  if (!reference.pressure) throw Error("contact reference: no pressure function given");
  if (set.numMeshVertices() != mesh.numVertices() || outputs.pressure.size() != static_cast<std::size_t>(set.size()))
    throw Error("contact reference: contact set, outputs and mesh do not belong together");
  ReferenceErrors r;
  for (double mu : outputs.multiplier) r.load += mu;
  // relative L2 error of s_m on Gamma_C
  double err2 = 0, norm2 = 0, shape[4], grad[8];
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    if (mesh.boundaryFaceId(f) != set.boundaryId()) continue;
    const auto fv = mesh.boundaryFaceVertices(f);
    const mesh::CellType ft = mesh::faceTypeFromVertexCount(static_cast<int>(fv.size()));
    const auto& ref = mesh::referenceElement(ft);
    const auto& rule = mesh::quadratureRule(ft, reference.quadratureDegree);
    for (std::size_t q = 0; q < rule.size(); ++q) {
      ref.values(rule.points[q], std::span<double>(shape, fv.size()));
      ref.gradients(rule.points[q], std::span<double>(grad, fv.size() * ref.dim));
      Point x = Point::Zero(), ds = Point::Zero(), dt = Point::Zero();
      double sm = 0;
      for (std::size_t i = 0; i < fv.size(); ++i) {
        x += shape[i] * mesh.vertex(fv[i]);
        ds += grad[i * ref.dim] * mesh.vertex(fv[i]);
        if (ref.dim == 2) dt += grad[i * ref.dim + 1] * mesh.vertex(fv[i]);
        sm += shape[i] * outputs.pressure[static_cast<std::size_t>(set.nodeOf(fv[i]))];
      }
      const double w = rule.weights[q] * (ref.dim == 1 ? ds.norm() : ds.cross(dt).norm());
      const double p = reference.pressure(x, r.load);
      err2 += w * (sm - p) * (sm - p);
      norm2 += w * p * p;
    }
  }
  r.pressureError = norm2 > 0 ? std::sqrt(err2 / norm2) : std::numeric_limits<double>::quiet_NaN();
  // contact radius and centre node
  double best = std::numeric_limits<double>::infinity();
  for (Index k = 0; k < set.size(); ++k) {
    const double dist = (set.position(k) - reference.centre).norm();
    if (outputs.inContact[static_cast<std::size_t>(k)]) r.radius = std::max(r.radius, dist);
    if (dist < best) {
      best = dist;
      r.centreVertex = set.vertex(k);
      r.centrePressure = outputs.pressure[static_cast<std::size_t>(k)];
      r.exactCentrePressure = reference.pressure(set.position(k), r.load);
    }
  }
  r.exactRadius = reference.radius ? reference.radius(r.load) : std::numeric_limits<double>::quiet_NaN();
  r.radiusError = std::abs(r.radius - r.exactRadius) / r.exactRadius;
  r.centreError = std::abs(r.centrePressure - r.exactCentrePressure) / std::abs(r.exactCentrePressure);
  return r;
}

AdaptiveLoop::AdaptiveLoop(mesh::Grid& grid, const Material& material, const BoundaryConditions& bc,
                           AdaptiveLoopOptions options)
    : grid_(grid), material_(material), bc_(bc), options_(std::move(options)) {
  if (options_.maxSteps < 1)
    throw Error("adaptive loop: maxSteps must be at least 1, got " + std::to_string(options_.maxSteps));
  material_.validate();
  const bool needEstimator = options_.mode == RefinementMode::Adaptive || options_.estimateUniform;
  if (needEstimator) registryOf(options_).description(options_.estimator);  // throws, listing the names
  if (options_.mode == RefinementMode::Adaptive) MarkingStrategy(options_.marking, options_.markingParameter);
}

void AdaptiveLoop::setContact(const Obstacle& obstacle, int boundaryId) {
  obstacle_ = &obstacle;
  contactId_ = boundaryId;
}

void AdaptiveLoop::setReference(ContactReference reference) { reference_ = std::move(reference); }

void AdaptiveLoop::setCallback(Callback callback) { callback_ = std::move(callback); }

std::vector<AdaptiveStep> AdaptiveLoop::run() {
  return grid_.dimension() == 2 ? runDim<2>() : runDim<3>();
}

namespace {

/// sqrt(sum over free components i of u_i (A u)_i): the energy norm TNNMG's relative stopping
/// test divides by (prescribed rows of A are identity rows, left out).
template <int d>
double freeEnergyNorm(const BlockSparseMatrix<d>& A, const Eigen::VectorXd& u, const DirichletValues& dirichlet) {
  const Eigen::VectorXd Au = A * u;
  double s = 0;
  for (Eigen::Index i = 0; i < u.size(); ++i)
    if (!dirichlet.constrained[static_cast<std::size_t>(i)]) s += u[i] * Au[i];
  return std::sqrt(std::max(0.0, s));
}

}  // namespace

double AdaptiveLoop::inexactTolerance(const std::vector<AdaptiveStep>& steps, const AdaptiveStep& rec, int d) const {
  const double base = options_.solverTolerance;
  if (!(options_.inexactFraction > 0) || steps.empty()) return base;
  const bool knownLast = rec.step + 1 == options_.maxSteps ||
                         (options_.targetVertices > 0 && rec.vertices >= options_.targetVertices);
  const AdaptiveStep& previous = steps.back();
  if (knownLast || !(previous.eta > 0) || !(lastEnergyNorm_ > 0)) return base;
  // predicted eta of this step: eta ~ N^(-eoc), eoc of the last step (1/d, the optimal order for
  // first-order elements, until there is one), clamped to [0, 1]
  const double eoc = std::isfinite(previous.eoc) ? std::clamp(previous.eoc, 0.0, 1.0) : 1.0 / d;
  const double predicted = previous.eta * std::pow(static_cast<double>(previous.vertices) / rec.vertices, eoc);
  // algebraic error ~ rho / (1 - rho) * last correction (geometric convergence with rate rho)
  const double rho = std::clamp(lastRate_, 0.05, 0.9);
  const double tolerance = options_.inexactFraction * predicted / lastEnergyNorm_ * (1 - rho) / rho;
  return std::clamp(tolerance, base, 1e-2);
}

template <int d>
std::vector<AdaptiveStep> AdaptiveLoop::runDim() {
  const bool adaptive = options_.mode == RefinementMode::Adaptive;
  const bool estimate = adaptive || options_.estimateUniform;
  std::unique_ptr<Estimator> estimator;
  if (estimate) estimator = registryOf(options_).create(options_.estimator);
  std::optional<MarkingStrategy> marking;
  if (adaptive) marking.emplace(options_.marking, options_.markingParameter);

  std::vector<AdaptiveStep> steps;
  lastRate_ = lastEnergyNorm_ = 0;
  mesh::GridView view = grid_.leafView();
  Eigen::VectorXd start;  // empty: cold start
  double transferSeconds = 0;
  for (int k = 0; k < options_.maxSteps; ++k) {
    AdaptiveStep rec;
    rec.step = k;
    rec.transferSeconds = transferSeconds;
    const mesh::Mesh& m = view.mesh;
    rec.cells = m.numCells();
    rec.vertices = m.numVertices();
    rec.unknowns = m.numVertices() * d;

    // assemble and solve
    auto t = Clock::now();
    std::optional<ContactSet> set;
    std::optional<ContactProblem<d>> problem;
    Eigen::VectorXd u = options_.warmStart && start.size() == rec.unknowns
                            ? start
                            : Eigen::VectorXd::Zero(rec.unknowns);
    if (obstacle_) {
      set.emplace(m, contactId_, *obstacle_);
      {  // the one-body contact model, as in static and dynamic runs
        ContactModel<d> model;
        model.addBody("body", m, material_, bc_);
        model.addObstacleContact(0, *set, set->boundaryLabel());
        problem.emplace(model.assemble());
      }
      rec.assemblySeconds = since(t);
      t = Clock::now();
      ContactResult result;
      rec.solverTolerance = options_.solverTolerance;
      if (options_.solver == ContactSolverKind::TNNMG) {
        typename TNNMG<d>::Options o;
        o.tolerance = rec.solverTolerance = inexactTolerance(steps, rec, d);
        o.maxIterations = options_.maxSolverIterations;
        o.preSmoothing = options_.preSmoothing;
        o.postSmoothing = options_.postSmoothing;
        o.recordHistory = false;
        TNNMG<d> solver(grid_, o);
        result = solver.solve(*problem, u);
      } else {
        typename PrimalDualActiveSet<d>::Options o;
        o.tolerance = options_.solverTolerance;
        o.maxIterations = options_.maxSolverIterations;
        o.recordHistory = false;
        PrimalDualActiveSet<d> solver(o);
        result = solver.solve(*problem, u);
      }
      rec.solverSeconds = since(t);
      rec.solver = result.solver;
      rec.solverIterations = result.iterations;
      rec.converged = result.converged;
      rec.kkt = result.kkt.max();
      if (options_.inexactFraction > 0) {  // inputs of the next step's tolerance (inexactTolerance)
        lastRate_ = result.convergenceRate;
        lastEnergyNorm_ = freeEnergyNorm<d>(problem->matrix(), u, collectDirichlet(m, bc_.dirichlet));
      }
    } else {
      BlockSparseMatrix<d> A = assembleStiffness<d>(m, material_);
      Eigen::VectorXd b = assembleLoad<d>(m, bc_);
      const DirichletValues dirichlet = collectDirichlet(m, bc_.dirichlet);
      applyDirichlet(A, b, dirichlet);
      rec.assemblySeconds = since(t);
      t = Clock::now();
      const CholmodSolver cholmod(A);
      u = cholmod.solve(b);
      rec.solverSeconds = since(t);
      rec.solver = "cholmod";
      rec.solverIterations = 1;
      rec.converged = u.allFinite();
      if (!rec.converged) throw Error("adaptive loop, step " + std::to_string(k) + ": the direct solve gave NaN");
    }

    // contact quantities
    std::optional<ContactOutputs> outputs;
    if (problem) outputs = computeContactOutputs(*problem, u, options_.contactTolerance);
    const ContactNodeClasses classes =
        classifyContactNodes(m, obstacle_ ? std::vector<int>{contactId_} : std::vector<int>{},
                             set ? &*set : nullptr, u, options_.contactTolerance);
    rec.potentialContact = classes.potential;
    rec.actualContact = classes.actual;
    rec.semiContact = classes.semi;
    rec.fullContact = classes.full;
    if (outputs)
      for (double mu : outputs->multiplier) rec.load += mu;
    if (reference_ && outputs) rec.reference = referenceErrors(m, *set, *outputs, *reference_);

    // estimate (not on an unconverged solution: its residual is the solver's, not the
    // discretisation's, and marking on it would refine the wrong cells; the loop stops there)
    std::optional<EstimatorResult> result;
    if (estimator && rec.converged) {
      t = Clock::now();
      EstimatorInput in(m, material_, bc_, u);
      in.meshRevision = static_cast<std::uint64_t>(k);
      ContactData data;
      if (set) {
        data = ContactData{&*set, &*outputs, obstacle_};
        in.contact = &data;
      }
      result = estimator->estimate(in);
      rec.estimatorSeconds = since(t);
      rec.eta = result->total;
      rec.contributions = result->contributions;
      if (!steps.empty())
        rec.eoc = experimentalOrder(steps.back().eta, static_cast<double>(steps.back().vertices), rec.eta,
                                    static_cast<double>(rec.vertices));
    }

    // stop?
    bool last = !rec.converged || k + 1 == options_.maxSteps ||
                (options_.targetVertices > 0 && rec.vertices >= options_.targetVertices) ||
                (options_.etaTolerance > 0 && result && rec.eta <= options_.etaTolerance);
    // marking (the refinement itself follows the callback, so that it sees the grid of the step)
    std::vector<Index> cells;
    double markSeconds = 0;
    if (!last && adaptive) {
      t = Clock::now();
      cells = marking->mark(result->indicators);
      rec.marked = static_cast<Index>(cells.size());
      if (cells.empty()) last = true;
      markSeconds = since(t);
    } else if (!last) {
      rec.marked = m.numCells();
    }

    steps.push_back(rec);
    if (callback_)
      callback_(AdaptiveStepView{steps.back(), grid_, view, u, set ? &*set : nullptr,
                                 outputs ? &*outputs : nullptr, classes, result ? &*result : nullptr});
    if (last) {
      u_ = std::move(u);
      break;
    }
    t = Clock::now();
    if (adaptive) {
      for (Index c : cells) grid_.mark(view.elements[c]);
      grid_.adapt();
    } else {
      grid_.refineUniformly();
    }
    steps.back().refinementSeconds = markSeconds + since(t);

    // the next leaf view and the start vector on it
    mesh::GridView next = grid_.leafView();
    t = Clock::now();
    start.resize(0);
    if (options_.warmStart) start = transfer(mesh::transferMatrix(grid_, view, next), u, d);
    transferSeconds = since(t);
    view = std::move(next);
    u_ = std::move(u);
  }
  return steps;
}

template std::vector<AdaptiveStep> AdaptiveLoop::runDim<2>();
template std::vector<AdaptiveStep> AdaptiveLoop::runDim<3>();

}  // namespace obs::estimators
