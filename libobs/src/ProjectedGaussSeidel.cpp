#include "obs/obs/ProjectedGaussSeidel.hpp"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>

#include "obs/mesh/Error.hpp"
#include "obs/obs/FrictionBlock.hpp"

namespace obs {

template <int d>
BlockLocalSolver<d>::BlockLocalSolver(const BlockSparseMatrix<d>& A, std::vector<double> upper)
    : upper_(std::move(upper)) {
  const Index n = A.rows();
  if (static_cast<Index>(upper_.size()) != n)
    throw Error("block Gauss-Seidel: " + std::to_string(upper_.size()) + " bounds for " + std::to_string(n) +
                " vertices");
  inverse_.resize(n);
  tail_.resize(n);
  coupling_.resize(n);
  // on threads() threads; the first vertex whose block is not positive definite is reported
  Index failed = n;
  const int nt = n >= kParallelMinRows ? threads() : 1;
#pragma omp parallel for schedule(static) num_threads(nt) reduction(min : failed) if (nt > 1)
  for (Index p = 0; p < n; ++p) {
    const Index k = A.diagonal(p);
    const Mat D = k >= 0 ? A.blockAt(k) : Mat::Zero();
    Eigen::LLT<Mat> llt(D);
    if (k < 0 || llt.info() != Eigen::Success || !(D.diagonal().minCoeff() > 0)) {
      failed = std::min(failed, p);
      continue;
    }
    inverse_[p] = llt.solve(Mat::Identity());
    // the trailing part for every vertex (also unbounded ones), so that setUpper() may bound any
    // vertex; a principal submatrix of a positive definite block is positive definite
    const Tail T = D.template bottomRightCorner<d - 1, d - 1>();
    tail_[p] = Eigen::LLT<Tail>(T).solve(Tail::Identity());
    coupling_[p] = D.template block<d - 1, 1>(1, 0);
  }
  if (failed < n)
    throw Error("block Gauss-Seidel: the diagonal block of vertex " + std::to_string(failed) +
                " is not positive definite");
}

template <int d>
void BlockLocalSolver<d>::setUpper(std::vector<double> upper) {
  if (upper.size() != upper_.size())
    throw Error("block Gauss-Seidel: " + std::to_string(upper.size()) + " bounds for " +
                std::to_string(upper_.size()) + " vertices");
  upper_ = std::move(upper);
}

template <int d>
void BlockLocalSolver<d>::setFriction(const BlockSparseMatrix<d>& A, const RotatedProblem<d>& problem) {
  slot_.clear();
  friction_.clear();
  if (!problem.frictional()) return;
  if (A.rows() != static_cast<Index>(upper_.size()))
    throw Error("block Gauss-Seidel: friction data of another matrix");
  slot_.assign(upper_.size(), -1);
  friction_.resize(problem.frictionVertices.size());
  for (std::size_t f = 0; f < friction_.size(); ++f) {
    const Index p = problem.frictionVertices[f];
    Friction& F = friction_[f];
    F.D = A.blockAt(A.diagonal(p));
    F.slip = problem.slip[f];
    F.origin.setZero();
    for (int a = 1; a < d; ++a)
      if (!problem.prescribed[static_cast<std::size_t>(p) * d + a]) {
        F.freeTangential |= 1u << (a - 1);
        if (problem.origin.size() > 0) F.origin[a] = problem.origin[static_cast<Eigen::Index>(p) * d + a];
      }
    slot_[p] = static_cast<int>(f);
  }
}

template <int d>
typename BlockLocalSolver<d>::Vec BlockLocalSolver<d>::solveFriction(int f, const Vec& r, double upper) const {
  const Friction& F = friction_[static_cast<std::size_t>(f)];
  // in v - o the term is s |(v - o)_T|: shift the right-hand side (o has no normal component)
  const Vec q = r - F.D * F.origin;
  Vec v;
  if (d == 2 || F.freeTangential == (1u << (d - 1)) - 1) {
    v = solveFrictionBlock<d>(F.D, q, upper, F.slip);
  } else {  // d = 3 with one prescribed tangential component o (an identity row): fixed, the rest 2 x 2
    const int j = (F.freeTangential & 1u) ? 1 : 2, o = 3 - j;
    v[o] = q[o] / F.D(o, o);
    Eigen::Matrix2d D2;
    D2 << F.D(0, 0), F.D(0, j), F.D(j, 0), F.D(j, j);
    const Eigen::Vector2d q2(q[0] - F.D(0, o) * v[o], q[j] - F.D(j, o) * v[o]);
    const Eigen::Vector2d x = solveFrictionBlock<2>(D2, q2, upper, F.slip);
    v[0] = x[0];
    v[j] = x[1];
  }
  return v + F.origin;
}

template <int d>
void BlockGaussSeidelSweep<d>::sweep(const Eigen::VectorXd& b, Eigen::VectorXd& w, bool backward) const {
  sweep(b, w, A_.sweepOrder(), backward);
}

template <int d>
void BlockGaussSeidelSweep<d>::sweep(const Eigen::VectorXd& b, Eigen::VectorXd& w, const SweepOrder& order,
                                     bool backward) const {
  using Vec = typename BlockLocalSolver<d>::Vec;
  A_.withBlocks([&](const auto blocks) {
    const auto row = [&](Index p) {
      // r = b_p - sum_{q != p} A_pq w_q
      Vec r = b.template segment<d>(static_cast<Eigen::Index>(p) * d);
      for (Index k = A_.rowBegin(p); k < A_.rowEnd(p); ++k) {
        const Index q = A_.column(k);
        if (q != p) r.noalias() -= blocks[k] * w.template segment<d>(static_cast<Eigen::Index>(q) * d);
      }
      w.template segment<d>(static_cast<Eigen::Index>(p) * d) = local_.solve(p, r);
    };
    if (backward) order.backward(A_.rows(), row);
    else order.forward(A_.rows(), row);
  });
}

template <int d>
void BlockGaussSeidelSweep<d>::sweepFromZero(const Eigen::VectorXd& b, Eigen::VectorXd& w) const {
  using Vec = typename BlockLocalSolver<d>::Vec;
  // `full`: the whole row (unswept neighbours hold zeros), else the blocks left of the diagonal
  // (SweepOrder::forwardFromZero)
  A_.withBlocks([&](const auto blocks) {
    const auto row = [&](Index p, bool full) {
      Vec r = b.template segment<d>(static_cast<Eigen::Index>(p) * d);
      for (Index k = A_.rowBegin(p); k < A_.rowEnd(p) && (full || A_.column(k) < p); ++k)
        if (A_.column(k) != p)
          r.noalias() -= blocks[k] * w.template segment<d>(static_cast<Eigen::Index>(A_.column(k)) * d);
      w.template segment<d>(static_cast<Eigen::Index>(p) * d) = local_.solve(p, r);
    };
    A_.sweepOrder().forwardFromZero(A_.rows(), row, [&](Index p) {
      w.template segment<d>(static_cast<Eigen::Index>(p) * d).setZero();
    });
  });
}

template <int d>
ContactResult ProjectedGaussSeidel<d>::solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) {
  const RotatedProblem<d> rot = problem.rotated();
  problem.projectToFeasible(u);
  Eigen::VectorXd w = problem.toRotated(u);
  rot.project(w);
  BlockGaussSeidelSweep<d> gs(rot.matrix(), rot.upper);
  gs.setFriction(rot);

  Eigen::VectorXd Aw = rot.matrix() * w;
  IterationMonitor monitor(name(), options_, 0.5 * w.dot(Aw) - rot.rhs.dot(w) + rot.frictionEnergy(w));
  bool converged = false;
  Eigen::VectorXd previous;
  for (int k = 0; k < options_.maxIterations && !converged; ++k) {
    previous = w;
    gs.sweep(rot.rhs, w);
    if (options_.symmetric) gs.sweep(rot.rhs, w, true);
    rot.matrix().multiply(w, Aw);
    const double wAw = w.dot(Aw), bw = rot.rhs.dot(w);
    const Eigen::VectorXd delta = w - previous;
    const double num = std::sqrt(std::max(0.0, rot.matrix().energy(delta)));
    // ||w||_A over the free components (prescribed ones are identity rows of A~, whose unit
    // diagonal would make the test depend on the unit of E; the same measure as TNNMG)
    double freeAw = 0;
    for (Eigen::Index i = 0; i < w.size(); ++i)
      if (!rot.prescribed[static_cast<std::size_t>(i)]) freeAw += w[i] * Aw[i];
    const double den = std::sqrt(std::max(0.0, freeAw));
    const double correction = den > 0 ? num / den : (num > 0 ? 1.0 : 0.0);
    const double friction = rot.frictionEnergy(w);  // 0 without friction
    converged = monitor.record(0.5 * wAw - bw + friction, correction, rot.countActive(w));
    monitor.requireMonotone(0.5 * std::abs(wAw) + std::abs(bw) + friction);
  }
  u = problem.fromRotated(w);
  ContactResult result = monitor.finish(converged, rot.countActive(w));
  if (options_.computeKkt) result.kkt = computeKktResiduals(problem, u);
  else result.kkt = notComputedKktResiduals();
  return result;
}

template class BlockLocalSolver<2>;
template class BlockLocalSolver<3>;
template class BlockGaussSeidelSweep<2>;
template class BlockGaussSeidelSweep<3>;
template class ProjectedGaussSeidel<2>;
template class ProjectedGaussSeidel<3>;

}  // namespace obs
