#include "obs/obs/LinearMultigrid.hpp"

#include <chrono>
#include <cmath>
#include <functional>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/DistributedCoarseSolver.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {

namespace {

/// The options' checks, the same for every hierarchy (distributed: the Gauss-Seidel smoother only).
void checkOptions(const LinearMultigridOptions& options, bool distributed) {
  if (options.preSmoothing < 0 || options.postSmoothing < 0 || options.cycles < 1 || options.cycleIndex < 1 || options.maxIterations < 0 ||
      !(options.tolerance >= 0) || options.krylovSteps < 0 || (options.krylovSteps > 0 && options.cycles > 1))
    throw Error("linear multigrid: invalid options (smoothing steps >= 0, cycles >= 1, maxIterations >= 0, "
                "tolerance >= 0, krylovSteps >= 0 and cycles = 1 with krylovSteps > 0 required)");
  if (distributed && options.smoother != LinearSmoother::GaussSeidel)
    throw Error("linear multigrid: a distributed hierarchy runs the Gauss-Seidel smoother only "
                "(the vertex-patch smoother is not distributed yet)");
}

}  // namespace

template <int d>
LinearMultigrid<d>::LinearMultigrid(const mesh::Grid& grid, const Options& options)
    : LinearMultigrid(std::vector<const mesh::Grid*>{&grid}, options) {}

template <int d>
LinearMultigrid<d>::LinearMultigrid(const std::vector<const mesh::Grid*>& grids, const Options& options)
    : options_(options), hierarchy_(grids) {
  checkOptions(options, false);
}

template <int d>
LinearMultigrid<d>::LinearMultigrid(const DistributedGrid& grid, const Options& options)
    : LinearMultigrid(std::vector<const DistributedGrid*>{&grid}, {}, options) {}

template <int d>
LinearMultigrid<d>::LinearMultigrid(const std::vector<const DistributedGrid*>& grids,
                                    const std::vector<Index>& fineExtras, const Options& options)
    : options_(options), hierarchy_(grids, fineExtras) {
  checkOptions(options, hierarchy_.distributed());
}

template <int d>
double LinearMultigrid<d>::fineDot(const Eigen::VectorXd& x, const Eigen::VectorXd& y) const {
  if (!hierarchy_.distributed()) return x.dot(y);
  const auto n = static_cast<Eigen::Index>(hierarchy_.ownedVertices(hierarchy_.maxLevel())) * d;
  return hierarchy_.communicator()->sum(x.head(n).dot(y.head(n)));
}

template <int d>
bool carrySweepPartition(const MultigridHierarchy<d>& h, const BlockSparseMatrix<d>& A) {
  const int L = h.maxLevel();
  const int parts = threads();
  if (L < 1 || parts < 2 || A.rows() < kParallelMinRows) return false;
  const auto level = [&](int l) -> const BlockSparseMatrix<d>& { return l == L ? A : h.coarseOperator(l); };
  // the base: the lowest level with a threaded sweep, at most L - 1
  int base = L - 1;
  while (base > 0 && level(base - 1).rows() >= kParallelMinRows) --base;
  if (level(base).rows() < 2 * parts) return false;
  // parent[l][p]: the coarse vertex (level l - 1) of fine vertex p's largest prolongation weight
  std::vector<std::vector<Index>> parent(static_cast<std::size_t>(L) + 1);
  for (int l = base + 1; l <= L; ++l) {
    const mesh::CsrMatrix& P = h.prolongation(l - 1);
    if (P.rows != level(l).rows() || P.cols != level(l - 1).rows()) return false;
    auto& up = parent[static_cast<std::size_t>(l)];
    up.resize(static_cast<std::size_t>(P.rows));
    for (Index p = 0; p < P.rows; ++p) {
      Index best = -1;
      for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k)
        if (best < 0 || P.values[k] > P.values[best]) best = k;
      if (best < 0) return false;  // a vertex without a parent: leave the orders to METIS on each level
      up[static_cast<std::size_t>(p)] = P.columns[best];
    }
  }
  // the base vertices weigh as many as their fine descendants, so that the fine parts are balanced
  std::vector<Index> weight(static_cast<std::size_t>(level(base).rows()), 0);
  for (Index p = 0; p < A.rows(); ++p) {
    Index q = p;  // p's ancestor on the base level
    for (int l = L; l > base; --l) q = parent[static_cast<std::size_t>(l)][static_cast<std::size_t>(q)];
    ++weight[static_cast<std::size_t>(q)];
  }
  const BlockSparseMatrix<d>& B = level(base);
  std::vector<int> part = partitionPattern(B.rowStarts(), B.columns(), parts, weight);
  if (part.empty()) return false;
  // carried up level by level; levels whose order is known keep it
  for (int l = base;; ++l) {
    const BlockSparseMatrix<d>& C = level(l);
    if (!C.hasSweepOrder()) C.setSweepPartition(part);
    if (l == L) break;
    const auto& up = parent[static_cast<std::size_t>(l) + 1];
    std::vector<int> next(up.size());
    for (std::size_t p = 0; p < up.size(); ++p) next[p] = part[static_cast<std::size_t>(up[p])];
    part = std::move(next);
  }
  return true;
}

template bool carrySweepPartition<2>(const MultigridHierarchy<2>&, const BlockSparseMatrix<2>&);
template bool carrySweepPartition<3>(const MultigridHierarchy<3>&, const BlockSparseMatrix<3>&);

template <int d>
LinearMultigrid<d>::~LinearMultigrid() = default;

template <int d>
void LinearMultigrid<d>::setOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>> rotations,
                                     const std::vector<char>& mask) {
  hierarchy_.setFineOperator(A, std::move(rotations), mask);
  const int L = hierarchy_.maxLevel();
  smoothers_.assign(L + 1, TruncatedGaussSeidel<d>());
  patchSmoothers_.assign(L + 1, VertexPatchSmoother<d>());
  rhs_.assign(L + 1, Eigen::VectorXd());
  sol_.assign(L + 1, Eigen::VectorXd());
  work_.assign(L + 1, Eigen::VectorXd());
  levelSeconds_.assign(static_cast<std::size_t>(L) + 1, LevelSeconds{});
  for (int l = 0; l <= L; ++l) {
    const auto n = static_cast<Eigen::Index>(hierarchy_.numVertices(l)) * d;
    rhs_[l].setZero(n);
    sol_[l].setZero(n);
    work_[l].setZero(n);
  }
  carrySweepPartition(hierarchy_, A);
  if (L > 0) {
    setSmootherMatrix(L, A, &hierarchy_.truncationBits(), "the fine operator");
    if (options_.smoother == LinearSmoother::GaussSeidel)
      smoothers_[L].setDiagonalTerm(&hierarchy_.fineDiagonalSlot(), &hierarchy_.fineDiagonalBlocks());
  }
  coarseSolver_.reset();
  distributedCoarse_.reset();
  updateCoarse();
  schedules_.clear();
  if (hierarchy_.distributed()) {  // the sweeps of the distributed levels (patterns fixed from here on)
    schedules_.resize(static_cast<std::size_t>(L) + 1);
    for (int l = 1; l <= L; ++l)
      if (const HaloExchange* halo = hierarchy_.halo(l)) {
        const BlockSparseMatrix<d>& Al = levelOperator(l);
        schedules_[l] = DistributedSweep(Al.rowStarts(), Al.columns(), Al.sweepOrder(), *halo);
      }
    localRows_.assign(static_cast<std::size_t>(L) + 1, {});
    local_.assign(static_cast<std::size_t>(L) + 1, 0);  // no local smoothing
    return;
  }
  setLocalSmoothing();
}

template <int d>
void LinearMultigrid<d>::setLocalSmoothing() {
  const int L = hierarchy_.maxLevel();
  localRows_.assign(static_cast<std::size_t>(L) + 1, {});
  local_.assign(static_cast<std::size_t>(L) + 1, 0);
  if (!options_.localSmoothing || options_.smoother != LinearSmoother::GaussSeidel) return;
  for (int l = 1; l < L; ++l) {
    const std::vector<char>& member = hierarchy_.newBasis(l);
    smoothers_[l].setSubset(member);
    if (smoothers_[l].sweptVertices() == hierarchy_.numVertices(l)) continue;  // every basis function new
    local_[l] = 1;
    // the rows that see a swept vertex (the pattern is symmetric)
    const BlockSparseMatrix<d>& A = hierarchy_.coarseOperator(l);
    auto& rows = localRows_[l];
    for (Index p = 0; p < A.rows(); ++p)
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
        if (member[static_cast<std::size_t>(A.column(k))]) {
          rows.push_back(p);
          break;
        }
  }
}

template <int d>
Index LinearMultigrid<d>::smoothedVerticesPerSweep() const {
  Index n = 0;
  for (int l = 1; l <= hierarchy_.maxLevel(); ++l)
    n += options_.smoother == LinearSmoother::GaussSeidel && smoothers_[l].hasMatrix() ? smoothers_[l].sweptVertices()
                                                                                     : hierarchy_.numVertices(l);
  return n;
}

template <int d>
void LinearMultigrid<d>::updateCoarse() {
  const int L = hierarchy_.maxLevel();
  for (int l = 1; l < L; ++l)
    if (hierarchy_.fullUpdate(l) || !smootherReady(l))
      setSmootherMatrix(l, hierarchy_.coarseOperator(l), nullptr, "the level " + std::to_string(l) + " operator");
    else
      updateSmoother(l, hierarchy_.updatedRows(l));
  const auto t0 = std::chrono::steady_clock::now();
  const BlockSparseMatrix<d>* A0 = &hierarchy_.coarseOperator(0);
  if (L > 0) {
    // Truncated Galerkin operators may be singular (positive semidefinite): P~_T need not have full
    // column rank. Its null space is prolongated to zero and the restricted defects are orthogonal
    // to it, so any solution serves; a relative diagonal shift makes the factorisation safe.
    shifted_ = *A0;
    for (Index i = 0; i < shifted_.rows(); ++i) {
      auto& D = shifted_.blockAt(shifted_.diagonal(i));
      D.diagonal() *= 1 + kCoarseShift;
    }
    A0 = &shifted_;
  }
  if (distributedCoarseLevel()) {
    if (distributedCoarse_) distributedCoarse_->refactorize(*A0);
    else distributedCoarse_ = std::make_unique<DistributedCoarseSolver>(*A0, hierarchy_.globalVertices(0), *hierarchy_.halo(0));
  } else if (coarseSolver_) {
    coarseSolver_->refactorize(*A0);
  } else {
    coarseSolver_ = std::make_unique<CholmodSolver>(*A0);
  }
  factorSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int d>
long long LinearMultigrid<d>::coarseIterations() const {
  return distributedCoarse_ ? distributedCoarse_->totalIterations() : 0;
}

template <int d>
bool LinearMultigrid<d>::setDiagonalTerm(std::vector<Index> vertices, std::vector<Eigen::Matrix<double, d, d>> blocks) {
  if (options_.smoother != LinearSmoother::GaussSeidel) return false;
  hierarchy_.setFineDiagonal(std::move(vertices), std::move(blocks));
  return true;
}

template <int d>
Index LinearMultigrid<d>::truncate(const std::vector<char>& mask) {
  const Index changes = hierarchy_.truncate(mask);
  if (hierarchy_.changedAnywhere()) {  // the mask or the diagonal term changed (on any rank)
    const int L = hierarchy_.maxLevel();
    if (L > 0) updateSmoother(L, hierarchy_.changedVertices());
    updateCoarse();
  }
  return changes;
}

template <int d>
void LinearMultigrid<d>::defect(int level, const Eigen::VectorXd& r, const Eigen::VectorXd& x,
                                Eigen::VectorXd& out) const {
  // On the finest level x is zero at truncated components, so A x = A_T x off the truncated rows;
  // the truncated rows of the defect are removed by the restriction (E_p = Q_p T_p).
  levelOperator(level).multiply(x, out);
  if (level == hierarchy_.maxLevel()) hierarchy_.addFineDiagonal(x, out);  // A + K
  const auto n = static_cast<Index>(out.size());
  forRanges(n, [&](Index b, Index e) { out.segment(b, e - b) = r.segment(b, e - b) - out.segment(b, e - b); });
}

template <int d>
void LinearMultigrid<d>::localDefect(int level, const Eigen::VectorXd& r, const Eigen::VectorXd& x,
                                     Eigen::VectorXd& out) const {
  const BlockSparseMatrix<d>& A = levelOperator(level);
  const std::vector<Index>& rows = localRows_[level];
  out = r;
  const auto n = static_cast<Index>(rows.size());
  const int nt = n >= kParallelMinRows ? threads() : 1;
  A.withBlocks([&](const auto blocks) {
#pragma omp parallel for schedule(dynamic, kRowChunk) num_threads(nt) if (nt > 1)
    for (Index i = 0; i < n; ++i) {
      const Index p = rows[i];
      Eigen::Matrix<double, d, 1> s = Eigen::Matrix<double, d, 1>::Zero();
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
        s.noalias() += blocks[k] * x.template segment<d>(static_cast<Eigen::Index>(A.column(k)) * d);
      out.template segment<d>(static_cast<Eigen::Index>(p) * d) -= s;
    }
  });
}

template <int d>
void LinearMultigrid<d>::cycle(int l, const Eigen::VectorXd& r, Eigen::VectorXd& x) {
  using Clock = std::chrono::steady_clock;
  const auto seconds = [](Clock::time_point& t) {  // since t, and t moved to now
    const Clock::time_point now = Clock::now();
    const double s = std::chrono::duration<double>(now - t).count();
    t = now;
    return s;
  };
  LevelSeconds& spent = levelSeconds_[static_cast<std::size_t>(l)];
  Clock::time_point t = Clock::now();
  const int L = hierarchy_.maxLevel();
  if (l == 0) {
    if (L == 0) {  // the explicit truncated fine operator: zero right-hand side at truncated rows
      work_[0] = r;
      const auto& bits = hierarchy_.truncationBits();
      for (std::size_t p = 0; p < bits.size(); ++p)
        for (int c = 0; c < d; ++c)
          if (bits[p] & (1u << c)) work_[0][static_cast<Eigen::Index>(p) * d + c] = 0;
      coarseSolver_->solve(work_[0], x);
    } else if (distributedCoarse_) {
      distributedCoarse_->solve(r, x);
    } else {
      coarseSolver_->solve(r, x);
    }
    spent.coarseSolve += seconds(t);
    return;
  }
  x.resize(r.size());
  if (options_.preSmoothing > 0) smoothFromZero(l, r, x);
  else x.setZero();
  for (int s = 1; s < options_.preSmoothing; ++s) smooth(l, r, x, false);
  spent.smoothing += seconds(t);
  // coarse-grid correction, gamma times below the finest level (gamma = 1: V-cycle, 2: W-cycle)
  const int gamma = l == 1 ? 1 : options_.cycleIndex;
  for (int g = 0; g < gamma; ++g) {
    // x is zero outside the local smoothing set until the first coarse correction
    if (g == 0 && local_[l]) localDefect(l, r, x, work_[l]);
    else defect(l, r, x, work_[l]);
    spent.defect += seconds(t);
    hierarchy_.restrict(l - 1, work_[l], rhs_[l - 1]);
    spent.restriction += seconds(t);
    cycle(l - 1, rhs_[l - 1], sol_[l - 1]);
    t = Clock::now();
    hierarchy_.prolongateAdd(l - 1, sol_[l - 1], x);
    spent.prolongation += seconds(t);
  }
  for (int s = 0; s < options_.postSmoothing; ++s) smooth(l, r, x, true);
  spent.smoothing += seconds(t);
}

template <int d>
bool LinearMultigrid<d>::smootherReady(int l) const {
  return options_.smoother == LinearSmoother::VertexPatch ? patchSmoothers_[l].hasMatrix() : smoothers_[l].hasMatrix();
}

template <int d>
void LinearMultigrid<d>::setSmootherMatrix(int l, const BlockSparseMatrix<d>& A, const std::vector<std::uint8_t>* bits,
                                           std::string what) {
  everywhere([&] {  // a block that is not positive definite on one rank stops every rank
    if (options_.smoother == LinearSmoother::VertexPatch) patchSmoothers_[l].setMatrix(A, bits, std::move(what));
    else smoothers_[l].setMatrix(A, bits, std::move(what));
  });
}

template <int d>
void LinearMultigrid<d>::updateSmoother(int l, std::span<const Index> vertices) {
  everywhere([&] {
    if (options_.smoother == LinearSmoother::VertexPatch) patchSmoothers_[l].updateVertices(vertices);
    else smoothers_[l].updateVertices(vertices);
  });
}

template <int d>
void LinearMultigrid<d>::everywhere(const std::function<void()>& work) const {
  if (const Communicator* comm = hierarchy_.communicator()) comm->collective(work);
  else work();
}

template <int d>
void LinearMultigrid<d>::smoothFromZero(int l, const Eigen::VectorXd& r, Eigen::VectorXd& x) const {
  if (!schedules_.empty() && hierarchy_.halo(l)) {
    x.setZero();
    smooth(l, r, x, false);
    return;
  }
  if (options_.smoother == LinearSmoother::VertexPatch) patchSmoothers_[l].sweepFromZero(r, x);
  else smoothers_[l].sweepFromZero(r, x);
}

template <int d>
void LinearMultigrid<d>::smooth(int l, const Eigen::VectorXd& r, Eigen::VectorXd& x, bool backward) const {
  if (!schedules_.empty() && hierarchy_.halo(l)) {  // DistributedSweep: interiors, interfaces by colour
    const TruncatedGaussSeidel<d>& smoother = smoothers_[l];
    schedules_[l].run([&](const SweepOrder& order, bool back) { smoother.sweep(r, x, order, back); }, x, d, backward);
    return;
  }
  if (options_.smoother == LinearSmoother::VertexPatch) patchSmoothers_[l].sweep(r, x, backward);
  else smoothers_[l].sweep(r, x, backward);
}

template <int d>
std::size_t LinearMultigrid<d>::smootherMemoryBytes() const {
  std::size_t bytes = 0;
  for (const auto& s : patchSmoothers_) bytes += s.memoryBytes();
  // point Gauss-Seidel: one inverted d x d block and a diagonal position per vertex
  if (options_.smoother == LinearSmoother::GaussSeidel)
    for (int l = 1; l <= hierarchy_.maxLevel(); ++l)
      bytes += static_cast<std::size_t>(hierarchy_.numVertices(l)) * (sizeof(Eigen::Matrix<double, d, d>) + sizeof(Index));
  return bytes;
}

template <int d>
void LinearMultigrid<d>::vcycle(const Eigen::VectorXd& r, Eigen::VectorXd& c) {
  if (!hierarchy_.hasFineOperator()) throw Error("linear multigrid: vcycle() before setOperator()");
  const int L = hierarchy_.maxLevel();
  if (r.size() != static_cast<Eigen::Index>(hierarchy_.numVertices(L)) * d)
    throw Error("linear multigrid: right-hand side of wrong size");
  ++vcycles_;
  cycle(L, r, c);
}

template <int d>
void LinearMultigrid<d>::truncateFine(Eigen::VectorXd& v) const {
  const auto& bits = hierarchy_.truncationBits();
  for (std::size_t p = 0; p < bits.size(); ++p)
    if (bits[p])
      for (int c = 0; c < d; ++c)
        if (bits[p] & (1u << c)) v[static_cast<Eigen::Index>(p) * d + c] = 0;
}

template <int d>
void LinearMultigrid<d>::conjugateGradients(const Eigen::VectorXd& r, Eigen::VectorXd& c) {
  // preconditioned CG on A_T c = r from c = 0 with the V-cycle as preconditioner; every vector lives
  // in the untruncated subspace (r, the V-cycle's output and A x with truncated rows zeroed)
  const BlockSparseMatrix<d>& A = hierarchy_.fineOperator();
  Eigen::VectorXd& res = cgResidual_;
  Eigen::VectorXd& z = cgPreconditioned_;
  Eigen::VectorXd& p = cgDirection_;
  Eigen::VectorXd& q = cgProduct_;
  res = r;
  truncateFine(res);
  c.setZero(r.size());
  vcycle(res, z);
  p = z;
  // distributed: the products' owned rows are complete (the ghosts of p are current: p is made of
  // V-cycle outputs), and the dot products run over the owned entries (fineDot)
  double rz = fineDot(res, z);
  for (int k = 0; k < options_.krylovSteps && rz > 0; ++k) {
    A.multiply(p, q);
    hierarchy_.addFineDiagonal(p, q);
    truncateFine(q);
    const double pq = fineDot(p, q);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    c += alpha * p;
    if (k + 1 == options_.krylovSteps) break;
    res -= alpha * q;
    vcycle(res, z);
    const double next = fineDot(res, z);
    p = z + (next / rz) * p;
    rz = next;
  }
}

template <int d>
void LinearMultigrid<d>::apply(const Eigen::VectorXd& r, Eigen::VectorXd& c) {
  if (options_.krylovSteps > 0) {
    conjugateGradients(r, c);
    return;
  }
  vcycle(r, c);
  const int L = hierarchy_.maxLevel();
  for (int k = 1; k < options_.cycles; ++k) {
    // c += V(r - A_T c): the defect is truncated by the next cycle's smoother and restriction
    Eigen::VectorXd& dr = rhs_[L];
    defect(L, r, c, dr);
    vcycle(dr, sol_[L]);
    c += sol_[L];
  }
}

template <int d>
LinearSolverResult LinearMultigrid<d>::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!hierarchy_.hasFineOperator()) throw Error("linear multigrid: solve() before setOperator()");
  const BlockSparseMatrix<d>& A = hierarchy_.fineOperator();
  const auto n = static_cast<Eigen::Index>(A.rows()) * d;
  if (b.size() != n) throw Error("linear multigrid: right-hand side of wrong size");
  const auto& bits = hierarchy_.truncationBits();
  auto truncateVector = [&](Eigen::VectorXd& v) {
    for (std::size_t p = 0; p < bits.size(); ++p)
      if (bits[p])
        for (int c = 0; c < d; ++c)
          if (bits[p] & (1u << c)) v[static_cast<Eigen::Index>(p) * d + c] = 0;
  };
  if (x.size() != n) {
    x = Eigen::VectorXd::Zero(n);
    for (std::size_t p = 0; p < bits.size(); ++p)
      for (int c = 0; c < d; ++c)
        if (bits[p] & (1u << c)) x[static_cast<Eigen::Index>(p) * d + c] = b[static_cast<Eigen::Index>(p) * d + c];
  }
  LinearSolverResult result;
  Eigen::VectorXd Ax = A * x, r = b - Ax, c(n), Ac(n);
  truncateVector(r);
  const double r0 = std::sqrt(fineDot(r, r));
  double first = 0;
  for (int k = 0; k < options_.maxIterations; ++k) {
    if (options_.krylovSteps > 0) conjugateGradients(r, c);
    else vcycle(r, c);
    A.multiply(c, Ac);
    x += c;
    Ax += Ac;
    r -= Ac;  // recursive residual, truncated rows stay zero (c is zero there, Ac is not)
    truncateVector(r);
    const double num = std::sqrt(std::max(0.0, fineDot(c, Ac))), den = std::sqrt(std::max(0.0, fineDot(x, Ax)));
    const double correction = den > 0 ? num / den : (num > 0 ? 1.0 : 0.0);
    if (!std::isfinite(correction)) throw Error("linear multigrid: NaN or Inf in iteration " + std::to_string(k + 1));
    result.history.push_back(correction);
    ++result.iterations;
    if (k == 0) first = correction;
    result.correction = correction;
    if (correction < options_.tolerance) {
      result.converged = true;
      break;
    }
  }
  if (result.iterations >= 2 && first > 0 && result.correction > 0)
    result.convergenceRate = std::pow(result.correction / first, 1.0 / (result.iterations - 1));
  result.residualReduction = r0 > 0 ? std::sqrt(fineDot(r, r)) / r0 : 0.0;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

template class LinearMultigrid<2>;
template class LinearMultigrid<3>;

}  // namespace obs
