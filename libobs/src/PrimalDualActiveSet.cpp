#include "obs/obs/PrimalDualActiveSet.hpp"

#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"

namespace obs {

template <int d>
ContactResult PrimalDualActiveSet<d>::solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) {
  if (!(options_.c > 0)) throw Error(name() + ": the complementarity constant c must be positive");
  if (problem.frictional())
    throw Error(name() + ": friction is not supported by the primal-dual active set solver (use tnnmg or "
                "projected-gauss-seidel)");
  factorSeconds_ = 0;
  const RotatedProblem<d> rot = problem.rotated();
  const Index n = rot.numVertices();
  problem.projectToFeasible(u);
  Eigen::VectorXd w = problem.toRotated(u);
  rot.project(w);

  std::vector<Index> bounded;
  std::vector<double> cp;
  for (Index p = 0; p < n; ++p)
    if (rot.bounded(p)) {
      bounded.push_back(p);
      cp.push_back(options_.c * rot.matrix()(p, p)(0, 0));
    }
  // multipliers from the residual of the start
  Eigen::VectorXd residual = rot.rhs - rot.matrix() * w;
  std::vector<double> mu(bounded.size());
  for (std::size_t i = 0; i < bounded.size(); ++i) mu[i] = residual[bounded[i] * d];

  IterationMonitor monitor(name(), options_, rot.energy(w));
  std::vector<char> active(bounded.size()), previous;
  std::set<std::vector<char>> seen;
  bool setRepeated = false;
  // The active set only changes values (Dirichlet rows/columns), never the pattern: the ordering and
  // symbolic analysis of the first step are reused by every later factorisation.
  std::optional<CholmodSolver> cholmod;
  // A start node that touches its bound with no force on it (indicator zero up to the rounding of
  // the gap and the residual) starts active: a body held only by contact (the upper body of two
  // touching blocks) is otherwise left floating, and the first Newton matrix singular, whenever the
  // rounding of its zero gaps happens to fall on the inactive side.
  const double tie = 1e-12 * std::max(rot.rhs.template lpNorm<Eigen::Infinity>(), std::numeric_limits<double>::min());
  for (int k = 0;; ++k) {
    Index activeCount = 0;
    for (std::size_t i = 0; i < bounded.size(); ++i) {
      const Index p = bounded[i];
      const double indicator = mu[i] + cp[i] * (w[p * d] - rot.upper[p]);
      active[i] = indicator > 0 || (k == 0 && std::abs(indicator) <= tie);
      activeCount += active[i];
    }
    if (k > 0 && active == previous) {
      setRepeated = true;
      break;
    }
    if (k > 0 && seen.count(active))
      throw Error(name() + ", iteration " + std::to_string(k) + ": the active set (" + std::to_string(activeCount) +
                  " nodes) repeats an earlier one: the iteration cycles (try a smaller c or another solver)");
    if (k >= options_.maxIterations) break;
    seen.insert(active);
    previous = active;

    // Newton step: A w = b with w_{p,1} = g_p on the active set (symmetric elimination)
    BlockSparseMatrix<d> Ak = rot.matrix();
    Eigen::VectorXd bk = rot.rhs;
    DirichletValues fixed;
    fixed.constrained.assign(static_cast<std::size_t>(n) * d, 0);
    fixed.values = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * d);
    for (std::size_t i = 0; i < bounded.size(); ++i)
      if (active[i]) {
        fixed.constrained[static_cast<std::size_t>(bounded[i]) * d] = 1;
        fixed.values[bounded[i] * d] = rot.upper[bounded[i]];
      }
    applyDirichlet(Ak, bk, fixed);
    if (cholmod)
      cholmod->refactorize(Ak);
    else
      cholmod.emplace(Ak);
    factorSeconds_ += cholmod->factorSeconds();
    Eigen::VectorXd next = cholmod->solve(bk);
    for (std::size_t i = 0; i < bounded.size(); ++i)
      if (active[i]) next[bounded[i] * d] = rot.upper[bounded[i]];  // exactly on the bound

    const Eigen::VectorXd Anext = rot.matrix() * next;
    residual = rot.rhs - Anext;
    for (std::size_t i = 0; i < bounded.size(); ++i) mu[i] = active[i] ? residual[bounded[i] * d] : 0.0;
    const Eigen::VectorXd delta = next - w;
    const double num = std::sqrt(std::max(0.0, rot.matrix().energy(delta)));
    const double den = std::sqrt(std::max(0.0, next.dot(Anext)));
    const double correction = den > 0 ? num / den : (num > 0 ? 1.0 : 0.0);
    w = std::move(next);
    monitor.record(0.5 * w.dot(Anext) - rot.rhs.dot(w), correction, activeCount);
    monitor.progressed();  // progress of this method = a new active set (cycling is caught above)
  }
  u = problem.fromRotated(w);
  ContactResult result = monitor.finish(false, rot.countActive(w));
  result.kkt = computeKktResiduals(problem, u);
  result.converged = setRepeated && result.kkt.max() <= options_.kktTolerance;
  return result;
}

template class PrimalDualActiveSet<2>;
template class PrimalDualActiveSet<3>;

}  // namespace obs
