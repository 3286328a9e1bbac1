#include "obs/obs/TNNMG.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/obs/LineSearch.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TruncatedLinearization.hpp"

namespace obs {
namespace {

using Clock = std::chrono::steady_clock;

/// Adds the seconds since t to s and restarts t.
void lap(Clock::time_point& t, double& s) {
  const auto now = Clock::now();
  s += std::chrono::duration<double>(now - t).count();
  t = now;
}

template <class Options>
void checkOptions(const Options& o) {
  if (o.preSmoothing < 0 || o.postSmoothing < 0 || o.preSmoothing + o.postSmoothing < 1)
    throw Error("TNNMG: invalid options (smoothing steps >= 0, at least one nonsmooth sweep per iteration)");
}

}  // namespace

template <int d>
TNNMG<d>::TNNMG(const mesh::Grid& grid, const Options& options)
    : TNNMG(std::vector<const mesh::Grid*>{&grid}, options) {}

template <int d>
TNNMG<d>::TNNMG(const std::vector<const mesh::Grid*>& grids, const Options& options) : options_(options) {
  checkOptions(options);
  auto mg = std::make_unique<LinearMultigrid<d>>(grids, options.multigrid);
  fineVertices_ = mg->hierarchy().numVertices(mg->hierarchy().maxLevel());
  correction_ = std::move(mg);
}

template <int d>
TNNMG<d>::TNNMG(const DistributedGrid& grid, const Options& options) : options_(options) {
  checkOptions(options);
  auto mg = std::make_unique<LinearMultigrid<d>>(grid, options.multigrid);
  const MultigridHierarchy<d>& h = mg->hierarchy();
  fineVertices_ = h.numVertices(h.maxLevel());
  halo_ = h.halo(h.maxLevel());
  comm_ = h.communicator();
  owned_ = h.ownedVertices(h.maxLevel());
  correction_ = std::move(mg);
}

template <int d>
TNNMG<d>::TNNMG(const mesh::Grid& grid, const Options& options, std::unique_ptr<LinearCorrection<d>> correction)
    : TNNMG(std::vector<const mesh::Grid*>{&grid}, options, std::move(correction)) {}

template <int d>
TNNMG<d>::TNNMG(const std::vector<const mesh::Grid*>& grids, const Options& options,
                std::unique_ptr<LinearCorrection<d>> correction)
    : options_(options), correction_(std::move(correction)) {
  checkOptions(options);
  if (!correction_) throw Error("TNNMG: no linear correction given");
  for (const mesh::Grid* grid : grids) {
    if (!grid) throw Error("TNNMG: a grid is null");
    if (grid->dimension() != d)
      throw Error("TNNMG: the grid has dimension " + std::to_string(grid->dimension()) + ", the solver " +
                  std::to_string(d));
    fineVertices_ += grid->leafView().mesh.numVertices();
  }
}

template <int d>
TNNMG<d>::TNNMG(const HaloExchange& halo, const Options& options, std::unique_ptr<LinearCorrection<d>> correction)
    : options_(options), correction_(std::move(correction)) {
  halo.communicator().collective([&] {
    checkOptions(options);
    if (!correction_) throw Error("TNNMG: no linear correction given");
  });
  fineVertices_ = halo.numLocal();
  halo_ = &halo;
  comm_ = &halo.communicator();
  owned_ = halo.numOwned();
}

template <int d>
ContactResult TNNMG<d>::solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) {
  statistics_ = Statistics();
  auto t = Clock::now();
  const bool distributed = comm_ != nullptr;
  // distributed: the work that may fail on one rank runs through Communicator::collective, so that
  // an error reaches every rank instead of leaving the others waiting in the next exchange
  const auto everywhere = [&](const std::function<void()>& work) {
    if (distributed) comm_->collective(work);
    else work();
  };
  everywhere([&] {
    if (problem.numVertices() != fineVertices_)
      throw Error("TNNMG: the problem has " + std::to_string(problem.numVertices()) +
                  " vertices, the leaf view of the solver's grid " + std::to_string(fineVertices_) +
                  " (the problem must be assembled on grid.leafView().mesh of the current grid)");
  });
  bool reuse = rotated_ && operatorId_ == problem.operatorId();
  if (distributed) reuse = comm_->max(reuse ? 0.0 : 1.0) == 0;  // rebuilt on every rank if on one
  if (reuse) {
    // same operator: only the right-hand side and the bounds change (see "Operator reuse")
    rotated_->rhs = problem.toRotated(problem.rhs());
    std::fill(rotated_->upper.begin(), rotated_->upper.end(), std::numeric_limits<double>::infinity());
    for (const auto& c : problem.constraints())
      if (c.bounded()) rotated_->upper[c.vertex] = c.gap;
    smoother_->setUpper(rotated_->upper);
    rotated_->diagonalLowerBound = problem.diagonalLowerBound();
    problem.rotateFriction(*rotated_);
    smoother_->setFriction(*rotated_);
  } else {
    operatorId_ = 0;
    diagonalTerm_ = false;  // setOperator below clears the correction's term
    smoother_.reset();
    everywhere([&] {
      rotated_ = std::make_unique<RotatedProblem<d>>(problem.rotated());
      smoother_ = std::make_unique<BlockGaussSeidelSweep<d>>(rotated_->matrix(), rotated_->upper);
      smoother_->setFriction(*rotated_);
    });
    if (distributed) {
      const BlockSparseMatrix<d>& R = rotated_->matrix();
      fineSweep_ = DistributedSweep(R.rowStarts(), R.columns(), R.sweepOrder(), *halo_);
    }
    everywhere([&] { correction_->setFineBasis(problem.basisTransformation()); });
    correction_->setOperator(rotated_->matrix(), problemRotations(problem), rotated_->prescribed);
    operatorId_ = problem.operatorId();
    const BlockSparseMatrix<d>& A = rotated_->matrix();
    const Index n = distributed ? owned_ : A.rows();
    const int nt = n >= kParallelMinRows ? threads() : 1;
    double bound = 0;  // a maximum: the same on any number of threads
#pragma omp parallel for schedule(static) num_threads(nt) reduction(max : bound) if (nt > 1)
    for (Index p = 0; p < n; ++p) {
      double s = 0;
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k) s += A.blockAt(k).norm();
      bound = std::max(bound, s);
    }
    rowSumBound_ = distributed ? comm_->max(bound) : bound;
  }
  const int baseUpdates = correction_->operatorUpdates();
  const long long baseCycles = correction_->cycles();
  const long long baseCoarse = correction_->coarseIterations();
  const RotatedProblem<d>& rot = *rotated_;
  const BlockSparseMatrix<d>& A = rot.matrix();
  problem.projectToFeasible(u);
  Eigen::VectorXd w = problem.toRotated(u);
  rot.project(w);
  const BlockGaussSeidelSweep<d>& smoother = *smoother_;
  // RotatedProblem::errorBound, fused below (not with friction); distributed: only if it holds on
  // every rank (a rank without friction vertices would otherwise stop on its own)
  bool errorBound = rot.hasErrorBound();
  if (distributed) errorBound = comm_->max(errorBound ? 0.0 : 1.0) == 0;
  const std::vector<double>& lowerBound = rot.diagonalLowerBound;

  const auto n = static_cast<Eigen::Index>(problem.numDofs());
  // distributed: sums over the owned entries (the first owned_ vertices), added over the ranks;
  // the sweeps in DistributedSweep's order (the ghosts of w stay current)
  const Index ownedDofs = distributed ? owned_ * d : static_cast<Index>(n);
  const auto total = [&](auto sums) {
    if (distributed) {
      std::vector<double> v(sums.begin(), sums.end());
      comm_->sum(v);
      std::copy(v.begin(), v.end(), sums.begin());
    }
    return sums;
  };
  // distributed: friction anywhere (a rank may hold no friction vertex) takes every rank down the
  // same path
  const bool frictional = distributed ? comm_->max(rot.frictional() ? 1.0 : 0.0) > 0 : rot.frictional();
  // the friction energy sum_p s_p |t_p| over the owned friction vertices, added over the ranks
  const auto frictionEnergy = [&](const Eigen::VectorXd& x) {
    if (!distributed) return rot.frictionEnergy(x);
    double e = 0;
    for (std::size_t f = 0; f < rot.frictionVertices.size(); ++f)
      if (rot.frictionVertices[f] < owned_) e += rot.slip[f] * rot.slipOf(f, x).norm();
    return comm_->sum(e);
  };
  const auto activeCount = [&](const Eigen::VectorXd& x) {
    if (!distributed) return rot.countActive(x);
    long long a = 0;
    for (Index p = 0; p < owned_; ++p) a += rot.bounded(p) && x[p * d] >= rot.upper[p];
    return static_cast<Index>(comm_->sum(a));
  };
  const auto sweep = [&](bool backward) {
    if (distributed)
      fineSweep_.run([&](const SweepOrder& order, bool back) { smoother_->sweep(rot.rhs, w, order, back); }, w, d, backward);
    else
      smoother_->sweep(rot.rhs, w, backward);
  };
  // without post-smoothing A (w^{k+1} - w^k) comes from the fused product (step0, Astep0 below),
  // with it from a product of delta = w^{k+1} - w^k: only one pair of vectors is needed
  const bool fused = options_.postSmoothing == 0;
  Eigen::VectorXd Aw(n), r(n), c(n), Ac(n), previous(n);
  Eigen::VectorXd step0(fused ? n : 0), Astep0(fused ? n : 0), delta(fused ? 0 : n), Adelta(fused ? 0 : n);
  bool zeroStart = w.isZero(0);  // a zero start (time steps from their predictor) needs no product
  if (zeroStart) Aw.setZero();
  else A.multiply(w, Aw);
  const auto [w0Aw0, bw0] = total(chunkedSums<2>(ownedDofs, [&](Index b, Index e) {
    return std::array<double, 2>{w.segment(b, e - b).dot(Aw.segment(b, e - b)), rot.rhs.segment(b, e - b).dot(w.segment(b, e - b))};
  }));
  IterationMonitor monitor(name(), options_, 0.5 * w0Aw0 - bw0 + frictionEnergy(w));
  TruncatedLinearization<d> linearization;
  std::vector<Index> curvatureVertices;
  std::vector<typename TruncatedLinearization<d>::Mat> curvatureBlocks;
  lap(t, statistics_.setupSeconds);

  bool converged = false;
  const double kktBound = std::max(options_.kktTolerance, options_.tolerance);
  KktResiduals kkt;
  bool haveKkt = false;
  int kktRejections = 0;
  const auto N = static_cast<Index>(n);
  // The vector work between the sweeps and products runs in fixed chunks on the threads, and its
  // sums are chunked sums (Parallel.hpp): the same bits for any thread count.
  const auto copy = [N](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    forRanges(N, [&](Index b, Index e) { y.segment(b, e - b) = x.segment(b, e - b); });
  };
  for (int k = 0; k < options_.maxIterations && !converged; ++k) {
    copy(w, previous);
    // 1. nonsmooth pre-smoothing
    for (int s = 0; s < options_.preSmoothing; ++s) {
      if (zeroStart && !distributed) smoother.sweepFromZero(rot.rhs, w);  // the first sweep on w = 0: half the blocks
      else sweep(false);
      zeroStart = false;
    }
    zeroStart = false;  // also without pre-smoothing: w changes below
    lap(t, statistics_.smoothingSeconds);
    // 2. truncation (operators updated only if the mask changed); with friction in 3D the
    // curvature of the friction term joins the correction's operator (updated with the mask)
    linearization.truncate(rot, w);
    if (d == 3 && options_.frictionCurvature && frictional) {
      linearization.curvature(rot, curvatureVertices, curvatureBlocks);
      diagonalTerm_ = correction_->setDiagonalTerm(curvatureVertices, curvatureBlocks);
    } else if (diagonalTerm_) {  // a term of an earlier frictional solve
      correction_->setDiagonalTerm({}, {});
      diagonalTerm_ = false;
    }
    const Index changes = correction_->truncate(linearization.mask);
    statistics_.truncationChanges += changes;
    lap(t, statistics_.updateSeconds);
    // without post-smoothing, w^{k+1} - w^k = (w - w^k) + alpha c up to the clamp of takeStep, so
    // A (w^{k+1} - w^k) of the stopping test is A (w - w^k) + alpha A c: A (w - w^k) is taken in the
    // pass over A that gives A w (BlockSparseMatrix::multiply of two vectors), one product less
    if (fused) {
      forRanges(N, [&](Index b, Index e) { step0.segment(b, e - b) = w.segment(b, e - b) - previous.segment(b, e - b); });
      A.multiply(w, Aw, step0, Astep0);
    } else {
      A.multiply(w, Aw);
    }
    linearization.truncatedResidual(rot, Aw, r);
    lap(t, statistics_.otherSeconds);
    // 3. linear correction on the truncated defect problem
    correction_->apply(r, c);
    lap(t, statistics_.correctionSeconds);
    // 4. projection onto the admissible set, 5. exact line search
    projectCorrection(rot, w, c);
    A.multiply(c, Ac);
    const auto [cr, cAc] = total(chunkedSums<2>(ownedDofs, [&](Index b, Index e) {
      double s0 = 0, s1 = 0;
      for (Index i = b; i < e; ++i) {
        s0 += c[i] * r[i];
        s1 += c[i] * Ac[i];
      }
      return std::array<double, 2>{s0, s1};
    }));
    // distributed: the friction line search reduces its own sums; without friction, the largest
    // feasible step over all ranks (ghost copies give their owners' values)
    LineSearchResult step = frictional
                                ? frictionLineSearch(rot, w, c, cr, cAc, linearization.slipping,
                                                     linearization.slipDirection, distributed ? owned_ : -1, comm_)
                                : exactLineSearch(rot, w, c, cr, cAc);
    if (distributed && !frictional) {
      const double alphaMax = -comm_->max(-step.alphaMax);
      if (step.alphaMax != alphaMax) step.limiting = -1;
      step.alphaMax = alphaMax;
      step.alpha = cr > 0 && cAc > 0 ? std::min(alphaMax, cr / cAc) : 0.0;
    }
    takeStep(rot, step, c, w);
    if (step.alpha != 0)
      forRanges(N, [&](Index b, Index e) { Aw.segment(b, e - b) += step.alpha * Ac.segment(b, e - b); });
    lap(t, statistics_.otherSeconds);
    if (options_.postSmoothing > 0) {
      for (int s = 0; s < options_.postSmoothing; ++s) sweep(true);
      lap(t, statistics_.smoothingSeconds);
      A.multiply(w, Aw);
    }
    // monitoring: ||w^{k+1} - w^k||_A / ||w^{k+1}||_A, energy, active set; fused, A (w^{k+1} - w^k)
    // = A (w - w^k) + alpha A c as Aw is updated above
    if (!fused) {
      forRanges(N, [&](Index b, Index e) { delta.segment(b, e - b) = w.segment(b, e - b) - previous.segment(b, e - b); });
      A.multiply(delta, Adelta);
    }
    // ||w||_A over the free components only: the prescribed ones are identity rows of A~
    // (applyDirichlet), whose unit diagonal would make the relative test depend on the unit of E
    // and, with a diagonal lower bound, the sum of RotatedProblem::errorBound (docs/theory.md#tnnmg-error-bound)
    const auto [wAw, bw, freeAw, deltaAdelta, ww, gain] = total(chunkedSums<6>(ownedDofs, [&](Index b, Index e) {
      std::array<double, 6> s{};
      for (Index i = b; i < e; ++i) {
        const double wi = w[i], Awi = Aw[i];
        s[0] += wi * Awi;
        s[1] += rot.rhs[i] * wi;
        const bool free = !rot.prescribed[static_cast<std::size_t>(i)];
        if (free) s[2] += wi * Awi;
        const double di = wi - previous[i], Adi = fused ? Astep0[i] + step.alpha * Ac[i] : Adelta[i];
        s[3] += di * Adi;
        s[4] += wi * wi;
        if (errorBound && free) {
          const auto p = static_cast<std::size_t>(i / d);
          const double room = i % d == 0 ? rot.upper[p] - wi : std::numeric_limits<double>::infinity();
          s[5] += componentGain(rot.rhs[i] - Awi, lowerBound[p], room);
        }
      }
      return s;
    }));
    const double num = std::sqrt(std::max(0.0, deltaAdelta)), den = std::sqrt(std::max(0.0, freeAw));
    const double correction = den > 0 ? num / den : (num > 0 ? 1.0 : 0.0);
    // ||w - w*||_A <= sqrt(2 gain) for the admissible w (NaN: no bound declared)
    const double bound = std::sqrt(2 * std::max(0.0, gain));
    const double relativeError = !errorBound ? std::numeric_limits<double>::quiet_NaN()
                                 : den > 0   ? bound / den
                                             : (bound > 0 ? std::numeric_limits<double>::infinity() : 0.0);
    const double friction = frictionEnergy(w);  // 0 without friction
    const bool small = monitor.record(0.5 * wAw - bw + friction, correction, activeCount(w), changes, relativeError);
    // scale of the energy's terms, including the round-off of w'Aw (<= eps |w|'|A||w|): for stiff
    // operators with soft modes (mass + tau^2 stiffness, rigid motions) it dominates |w'Aw|
    monitor.requireMonotone(0.5 * std::abs(wAw) + std::abs(bw) + friction + 1e-4 * rowSumBound_ * ww);
    // the correction bounds the step, not the error: converged also needs the KKT residual of the
    // iterate below the bound (docs/theory.md#tnnmg-stopping); evaluated only when the correction (or
    // the error bound) passed
    if (small) {
      u = problem.fromRotated(w);
      kkt = computeKktResiduals(problem, u, distributed ? owned_ : -1, comm_);
      haveKkt = true;
      converged = kkt.max() <= kktBound;
      if (!converged) ++kktRejections;
    }
    lap(t, statistics_.otherSeconds);
  }
  statistics_.operatorUpdates = correction_->operatorUpdates() - baseUpdates;
  statistics_.vcycles = correction_->cycles() - baseCycles;
  statistics_.coarseIterations = correction_->coarseIterations() - baseCoarse;
  ContactResult result = monitor.finish(converged, activeCount(w));
  if (!converged || !haveKkt) {  // the last iterate's residual (not yet computed for it)
    u = problem.fromRotated(w);
    kkt = computeKktResiduals(problem, u, distributed ? owned_ : -1, comm_);
  }
  result.kkt = kkt;
  result.kktRejections = kktRejections;
  return result;
}

template class TNNMG<2>;
template class TNNMG<3>;

}  // namespace obs
