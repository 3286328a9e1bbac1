#include "obs/estimators/DistributedAdaptiveLoop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/estimators/DistributedEstimation.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Marking.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/SolverConfig.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::estimators {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// This rank's part of the scales of computeContactOutputs' rule (to be maximised over the ranks):
/// U = max(|u|, finite gaps), F = max(|b_i|, |(A u)_i|) over the free components of the owned
/// vertices (their rows are complete).
template <int d>
std::vector<double> contactScales(const ContactProblem<d>& problem, const Eigen::VectorXd& x, Index owned) {
  const ContactSet& cs = problem.contactSet();
  const Eigen::Index n = static_cast<Eigen::Index>(owned) * d;
  std::vector<double> scales = {n > 0 ? x.head(n).lpNorm<Eigen::Infinity>() : 0.0, 0.0};
  for (Index k = 0; k < cs.size(); ++k)
    if (cs.vertex(k) < owned && std::isfinite(cs.gap(k))) scales[0] = std::max(scales[0], std::abs(cs.gap(k)));
  Eigen::VectorXd Ax;
  problem.multiply(x, Ax);
  const auto& prescribed = problem.dirichlet().constrained;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!prescribed[static_cast<std::size_t>(i)])
      scales[1] = std::max({scales[1], std::abs(problem.rhs()[i]), std::abs(Ax[i])});
  return scales;
}

}  // namespace

DistributedAdaptiveLoop::DistributedAdaptiveLoop(DistributedGrid& grid, const Material& material,
                                                 const BoundaryConditions& bc, const Obstacle& obstacle,
                                                 int boundaryId, AdaptiveLoopOptions options)
    : grid_(grid), material_(material), bc_(bc), obstacle_(obstacle), boundaryId_(boundaryId),
      options_(std::move(options)) {
  grid.communicator().collective([&] {
    if (options_.maxSteps < 1) throw Error("adaptive loop: maxSteps = " + std::to_string(options_.maxSteps) + " (>= 1)");
    if (options_.solver.kind != ContactSolverKind::TNNMG)
      throw Error("adaptive loop on ranks: the contact problems are solved by TNNMG only");
    if (options_.inexactFraction > 0) throw Error("adaptive loop on ranks: inexact solves are not distributed yet");
    // the names, checked as AdaptiveLoop checks them
    const EstimatorRegistry& registry = options_.registry ? *options_.registry : EstimatorRegistry::global();
    (void)registry.create(options_.estimator);
    if (options_.mode == RefinementMode::Adaptive) (void)MarkingStrategy(options_.marking, options_.markingParameter);
  });
}

void DistributedAdaptiveLoop::setImbalanceTolerance(double tolerance) {
  if (!(tolerance >= 1.0))
    throw Error("adaptive loop on ranks: imbalance tolerance " + std::to_string(tolerance) + " (at least 1)");
  imbalanceTolerance_ = tolerance;
}

std::vector<AdaptiveStep> DistributedAdaptiveLoop::run() {
  return grid_.grid().dimension() == 2 ? runDim<2>() : runDim<3>();
}

template <int d>
std::vector<AdaptiveStep> DistributedAdaptiveLoop::runDim() {
  const Communicator& comm = grid_.communicator();
  const bool adaptive = options_.mode == RefinementMode::Adaptive;
  const bool estimate = adaptive || options_.estimateUniform;
  const EstimatorRegistry& registry = options_.registry ? *options_.registry : EstimatorRegistry::global();
  std::unique_ptr<Estimator> estimator;
  if (estimate) estimator = registry.create(options_.estimator);
  std::optional<MarkingStrategy> marking;
  if (adaptive) marking.emplace(options_.marking, options_.markingParameter);
  grid_.setClosureRule(options_.closure);

  std::vector<AdaptiveStep> steps;
  std::vector<double> start;  // d values per vertex of the leaf view (warm start); empty: cold
  double transferSeconds = 0;
  // the balancing after the refinement that made the step's grid (step 0: measured only)
  RebalanceReport balance;
  double balanceSeconds = 0;
  std::vector<std::vector<std::uint64_t>> markedKeys;  // for the state hook: the marks of every step
  int first = 0;
  if (resume_) {  // restore(): the grid rebuilt, the records and the start of the interrupted run
    steps = resume_->steps;
    markedKeys = resume_->marked;
    transferSeconds = resume_->transferSeconds;
    first = resume_->nextStep;
    start = std::move(resumeStart_);
    balance = resumeBalance_;
    balanceSeconds = resumeBalanceSeconds_;
    resume_.reset();
  } else {
    balance = grid_.rebalance(std::numeric_limits<double>::infinity());
  }
  for (int k = first; k < options_.maxSteps; ++k) {
    AdaptiveStep rec;
    rec.step = k;
    rec.transferSeconds = transferSeconds;
    const DistributedView leaf = grid_.view();
    const Index owned = leaf.halo.numOwned();
    const auto ownedCells = static_cast<Index>(leaf.part.owned.size());
    rec.cells = static_cast<Index>(grid_.globalLeaves());
    rec.vertices = leaf.globalVertices();
    rec.unknowns = rec.vertices * d;
    rec.bodies.push_back(BodyRecord{rec.cells, rec.vertices});

    // the problem on the local mesh, the start, the solve
    auto t = Clock::now();
    std::optional<ContactSet> set;
    std::optional<ContactProblem<d>> problem;
    Eigen::VectorXd x, u0;
    comm.collective([&] {
      set.emplace(leaf.local, boundaryId_, obstacle_, true);
      problem.emplace(leaf.local, material_, bc_, *set);
      u0 = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(leaf.local.numVertices()) * d);
      if (!start.empty()) {  // on the leaf view's vertices
        const auto& held = leaf.halo.viewVertices();
        for (Index i = 0; i < leaf.local.numVertices(); ++i)
          for (int c = 0; c < d; ++c)
            u0[static_cast<Eigen::Index>(i) * d + c] = start[static_cast<std::size_t>(held[i]) * d + c];
      }
    });
    // the start's ghost entries from their owners: an owned vertex lies in old owned or ghost cells
    // only, whose vertices were all held, but a ghost may have been located in an old cell beyond
    leaf.halo.update(u0, d);
    comm.collective([&] { x = problem->fromDisplacement(u0); });
    rec.assemblySeconds = comm.max(since(t));
    t = Clock::now();
    typename TNNMG<d>::Options so = tnnmgOptions<d>(options_.solver);
    TNNMG<d> solver(grid_, so);
    const ContactResult result = solver.solve(*problem, x);
    rec.solverSeconds = comm.max(since(t));
    rec.solver = result.solver;
    rec.solverIterations = result.iterations;
    rec.solverTolerance = options_.solver.tolerance;
    rec.converged = result.converged;
    rec.kkt = result.kkt.max();
    const Eigen::VectorXd u = problem->toDisplacement(x);

    // contact figures over the owned vertices (local work in collective(), the exchanges between:
    // a rank that fails must not leave the others waiting in an exchange)
    std::optional<ContactOutputs> outputs;
    ContactNodeClasses classes;
    std::vector<double> sums(5, 0.0);  // potential, actual, semi, full, load
    std::vector<double> scales;
    comm.collective([&] {
      scales = contactScales<d>(*problem, x, owned);
      // the node classes' scale: max |u| over the vertices and the finite gaps, as one process's
      const Eigen::Index n = static_cast<Eigen::Index>(owned) * d;
      double U = n > 0 ? u.head(n).lpNorm<Eigen::Infinity>() : 0.0;
      for (Index k = 0; k < set->size(); ++k)
        if (set->vertex(k) < owned && std::isfinite(set->gap(k))) U = std::max(U, std::abs(set->gap(k)));
      scales.push_back(U);
    });
    comm.max(scales);
    // a ghost's own row is incomplete away from the owned cells: its outputs come from the owner
    Eigen::VectorXd flat = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(leaf.halo.numLocal()) * 3);
    comm.collective([&] {
      outputs = computeContactOutputs(*problem, x, options_.contactTolerance, scales[0] > 0 ? scales[0] : 1.0,
                                      scales[1]);
      for (Index q = 0; q < set->size(); ++q) {
        const auto k = static_cast<std::size_t>(q);
        const Eigen::Index at = static_cast<Eigen::Index>(set->vertex(q)) * 3;
        flat.segment<3>(at) << outputs->pressure[k], outputs->multiplier[k], outputs->inContact[k];
      }
    });
    leaf.halo.update(flat, 3);
    comm.collective([&] {
      for (Index q = 0; q < set->size(); ++q)
        if (const Index v = set->vertex(q); v >= owned) {
          const auto k = static_cast<std::size_t>(q);
          outputs->pressure[k] = flat[v * 3];
          outputs->multiplier[k] = flat[v * 3 + 1];
          outputs->inContact[k] = static_cast<char>(flat[v * 3 + 2] != 0);
        }
      classes = classifyContactNodes(leaf.local, {boundaryId_}, &*set, u, options_.contactTolerance, scales[2]);
      for (Index v = 0; v < owned; ++v) {
        const NodeClass c = classes.ofVertex[v];
        sums[0] += c != NodeClass::None;
        sums[1] += c == NodeClass::Semi || c == NodeClass::Full;
        sums[2] += c == NodeClass::Semi;
        sums[3] += c == NodeClass::Full;
      }
      for (Index q = 0; q < set->size(); ++q)
        if (set->vertex(q) < owned) sums[4] += outputs->multiplier[q];
    });
    comm.sum(sums);
    rec.potentialContact = static_cast<Index>(sums[0]);
    rec.actualContact = static_cast<Index>(sums[1]);
    rec.semiContact = static_cast<Index>(sums[2]);
    rec.fullContact = static_cast<Index>(sums[3]);
    rec.load = sums[4];
    if (reference_) {  // each contact face counted by the owner of its vertex of smallest global index
      std::vector<char> counted(static_cast<std::size_t>(leaf.local.numBoundaryFaces()), 0);
      const auto& held = leaf.halo.viewVertices();
      for (Index f = 0; f < leaf.local.numBoundaryFaces(); ++f) {
        Index first = -1, firstGlobal = std::numeric_limits<Index>::max();
        for (Index v : leaf.local.boundaryFaceVertices(f))
          if (const Index g = leaf.numbering.global[held[v]]; g < firstGlobal) {
            firstGlobal = g;
            first = v;
          }
        counted[f] = first >= 0 && first < owned;
      }
      rec.reference = referenceErrors(leaf.local, *set, *outputs, *reference_, owned, counted, comm);
    }

    // estimate (not on an unconverged solution, as serially)
    std::optional<EstimatorResult> est;
    if (estimator && rec.converged) {
      t = Clock::now();
      EstimatorInput in(leaf.local, material_, bc_, u);
      in.meshRevision = static_cast<std::uint64_t>(k);
      in.contactBoundaryIds = {boundaryId_};
      ContactData data{&*set, &*outputs, &obstacle_, nullptr, {}};
      data.contactScale = scales[2];  // the classes of one process
      in.contact = &data;
      est = estimateOwned(*estimator, in, ownedCells, comm);
      rec.estimatorSeconds = comm.max(since(t));
      rec.eta = est->total;
      rec.contributions = est->contributions;
      rec.bodies[0].eta = est->total;
      if (!steps.empty())
        rec.eoc = experimentalOrder(steps.back().eta, static_cast<double>(steps.back().vertices), rec.eta,
                                    static_cast<double>(rec.vertices));
    }

    // stop? mark with global thresholds, ties by the cells' keys
    bool last = !rec.converged || k + 1 == options_.maxSteps ||
                (options_.targetVertices > 0 && rec.vertices >= options_.targetVertices) ||
                (options_.etaTolerance > 0 && est && rec.eta <= options_.etaTolerance);
    std::vector<Index> marked;
    t = Clock::now();
    if (!last && adaptive) {
      std::vector<std::uint64_t> keys(static_cast<std::size_t>(ownedCells));
      for (Index c = 0; c < ownedCells; ++c) keys[c] = grid_.cellKey(leaf.view.elements[leaf.part.owned[c]]);
      marked = markOwned(*marking, std::span<const double>(est->indicators.data(), static_cast<std::size_t>(ownedCells)),
                         keys, comm);
      rec.marked = static_cast<Index>(comm.sum(static_cast<long long>(marked.size())));
      if (rec.marked == 0) last = true;
    } else if (!last) {
      for (Index c = 0; c < ownedCells; ++c) marked.push_back(c);
      rec.marked = rec.cells;
    }
    rec.bodies[0].marked = rec.marked;
    if (hook_ && !last) {  // the marks by cell key, of every rank (a restart replays them on any partition)
      std::vector<std::uint64_t> mine;
      for (Index c : marked) mine.push_back(grid_.cellKey(leaf.view.elements[leaf.part.owned[c]]));
      const auto all = comm.exchange(std::vector<std::vector<std::uint64_t>>(static_cast<std::size_t>(comm.size()), mine));
      std::vector<std::uint64_t>& keys = markedKeys.emplace_back();
      for (const auto& part : all) keys.insert(keys.end(), part.begin(), part.end());
      std::sort(keys.begin(), keys.end());
    }
    const double markSeconds = since(t);
    steps.push_back(rec);
    if (callback_) callback_(DistributedAdaptiveStepView{steps.back(), grid_, leaf, u, *set, *outputs, est ? &*est : nullptr, marked,
                                                balance, balanceSeconds});
    if (last) break;

    // refine; the solution on the held grid vertices, interpolated to the new ones
    t = Clock::now();
    std::vector<Index> elements;
    elements.reserve(marked.size());
    for (Index c : marked) elements.push_back(leaf.view.elements[leaf.part.owned[c]]);
    const mesh::AdaptResult ar = grid_.adapt(elements);
    AdaptiveStep& done = steps.back();
    done.refinedRed = ar.redRefined;
    done.closureRed = ar.propagated;
    done.greenClosed = ar.greenClosed;
    done.refinementSeconds = comm.max(markSeconds + since(t));
    t = Clock::now();
    if (options_.warmStart) {  // the old leaf function on the new leaf view, as serially (transferMatrix)
      comm.collective([&] {
        const mesh::GridView next = grid_.grid().leafView();
        const mesh::CsrMatrix T = mesh::transferMatrix(grid_.grid(), leaf.view, next);
        const auto& held = leaf.halo.viewVertices();
        std::vector<double> component(leaf.view.vertices.size(), 0.0), values;
        start.assign(next.vertices.size() * d, 0.0);
        for (int c = 0; c < d; ++c) {  // new held vertices lie in old owned and ghost cells: values known
          for (Index i = 0; i < leaf.local.numVertices(); ++i) component[held[i]] = u[static_cast<Eigen::Index>(i) * d + c];
          values = T * std::span<const double>(component);
          for (std::size_t v = 0; v < values.size(); ++v) start[v * d + c] = values[v];
        }
      });
    }
    transferSeconds = comm.max(since(t));
    // the parts balanced again if refinement unbalanced them; the start moves with its vertices
    t = Clock::now();
    balance = grid_.rebalance(imbalanceTolerance_, options_.warmStart ? &start : nullptr, d);
    balanceSeconds = comm.max(since(t));
    if (hook_) {  // the state after step k: the records, the marks, the start on the new leaf view
      DistributedAdaptiveLoopState state{k + 1, steps, markedKeys, transferSeconds};
      const DistributedView next = grid_.view();
      Eigen::VectorXd local;
      if (!start.empty()) {
        local.resize(static_cast<Eigen::Index>(next.local.numVertices()) * d);
        const auto& held = next.halo.viewVertices();
        for (Index i = 0; i < next.local.numVertices(); ++i)
          for (int c = 0; c < d; ++c)
            local[static_cast<Eigen::Index>(i) * d + c] = start[static_cast<std::size_t>(held[i]) * d + c];
      }
      hook_(state, next, local);
    }
  }
  return steps;
}

void DistributedAdaptiveLoop::restore(DistributedAdaptiveLoopState state,
                                      const std::function<Eigen::VectorXd(const DistributedView&)>& start) {
  const Communicator& comm = grid_.communicator();
  const int d = grid_.grid().dimension();
  comm.collective([&] {
    const auto n = static_cast<std::size_t>(std::max(state.nextStep, 0));
    if (state.nextStep < 1 || state.steps.size() != n || state.marked.size() != n)
      throw Error("adaptive loop on ranks: a state at step " + std::to_string(state.nextStep) + " with " +
                  std::to_string(state.steps.size()) + " records and the marks of " + std::to_string(state.marked.size()) +
                  " steps");
    if (state.nextStep >= options_.maxSteps)
      throw Error("adaptive loop on ranks: a state at step " + std::to_string(state.nextStep) + " of a loop of " +
                  std::to_string(options_.maxSteps) + " steps");
  });
  // the refinements of the interrupted run, each followed by its load balancing
  grid_.setClosureRule(options_.closure);
  RebalanceReport balance;
  double seconds = 0;
  for (std::vector<std::uint64_t>& keys : state.marked) {
    std::sort(keys.begin(), keys.end());
    const DistributedView leaf = grid_.view();
    std::vector<Index> elements;
    for (Index c : leaf.part.owned) {
      const Index e = leaf.view.elements[c];
      if (std::binary_search(keys.begin(), keys.end(), grid_.cellKey(e))) elements.push_back(e);
    }
    grid_.adapt(elements);
    const auto t = Clock::now();
    balance = grid_.rebalance(imbalanceTolerance_);
    seconds = comm.max(since(t));
  }
  const DistributedView next = grid_.view();
  const Eigen::VectorXd local = start(next);
  std::vector<double> values;  // on the grid's leaf view, as run() keeps its start
  comm.collective([&] {
    if (local.size() != 0 && local.size() != static_cast<Eigen::Index>(next.local.numVertices()) * d)
      throw Error("adaptive loop on ranks: a start of " + std::to_string(local.size()) + " values for " +
                  std::to_string(next.local.numVertices()) + " vertices");
    if (local.size() == 0) return;
    values.assign(grid_.grid().leafView().vertices.size() * static_cast<std::size_t>(d), 0.0);
    const auto& held = next.halo.viewVertices();
    for (Index i = 0; i < next.local.numVertices(); ++i)
      for (int c = 0; c < d; ++c)
        values[static_cast<std::size_t>(held[i]) * d + c] = local[static_cast<Eigen::Index>(i) * d + c];
  });
  resume_ = std::move(state);
  resumeStart_ = std::move(values);
  resumeBalance_ = balance;
  resumeBalanceSeconds_ = seconds;
}

template std::vector<AdaptiveStep> DistributedAdaptiveLoop::runDim<2>();
template std::vector<AdaptiveStep> DistributedAdaptiveLoop::runDim<3>();

}  // namespace obs::estimators
