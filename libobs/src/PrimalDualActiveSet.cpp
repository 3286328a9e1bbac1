#include "obs/obs/PrimalDualActiveSet.hpp"

#include <algorithm>
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

  // Tresca friction (see the file comment): per friction vertex its free tangential components, the
  // tangential multiplier lambda_T (the residual force) and c_T; the stick set and, in slip, the
  // direction e of xi = lambda_T + c_T t
  using Vec = Eigen::Matrix<double, d, 1>;
  const std::size_t nf = rot.frictionVertices.size();
  std::vector<Vec> lambdaT(nf, Vec::Zero()), direction(nf, Vec::Zero());
  std::vector<double> cT(nf, 0.0), spring(nf, 0.0);  // spring: s c_T / |xi| of a slipping vertex (3D)
  std::vector<unsigned> freeT(nf, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const Index p = rot.frictionVertices[f];
    double diag = 0;
    for (int a = 1; a < d; ++a)
      if (!rot.prescribed[static_cast<std::size_t>(p) * d + a]) {
        freeT[f] |= 1u << a;
        diag = std::max(diag, rot.matrix()(p, p)(a, a));
      }
    cT[f] = options_.c * diag;
    for (int a = 1; a < d; ++a)
      if (freeT[f] & (1u << a)) lambdaT[f][a] = residual[p * d + a];
  }
  const auto originOf = [&](Index p, int a) {
    return rot.origin.size() > 0 ? rot.origin[p * d + a] : 0.0;
  };

  IterationMonitor monitor(name(), options_, rot.energy(w));
  std::vector<char> active(bounded.size() + nf), previous;
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
  int cReductions = 0;
  double lastCorrection = std::numeric_limits<double>::infinity();
  const auto slipping = [](const std::vector<char>& states, std::size_t first) {
    return std::any_of(states.begin() + static_cast<std::ptrdiff_t>(first), states.end(), [](char s) { return s >= 2; });
  };
  for (int k = 0;; ++k) {
    Index activeCount = 0;
    for (std::size_t i = 0; i < bounded.size(); ++i) {
      const Index p = bounded[i];
      const double indicator = mu[i] + cp[i] * (w[p * d] - rot.upper[p]);
      active[i] = indicator > 0 || (k == 0 && std::abs(indicator) <= tie);
      activeCount += active[i];
    }
    // stick where |lambda_T + c_T t| <= s, else slip with the direction of that vector
    for (std::size_t f = 0; f < nf; ++f) {
      const Index p = rot.frictionVertices[f];
      Vec xi = Vec::Zero();
      for (int a = 1; a < d; ++a)
        if (freeT[f] & (1u << a)) xi[a] = lambdaT[f][a] + cT[f] * (w[p * d + a] - originOf(p, a));
      const double norm = xi.norm();
      const bool stick = norm <= rot.slip[f];
      if (!stick) {
        direction[f] = xi / norm;
        spring[f] = rot.slip[f] * cT[f] / norm;
      }
      // the state of the vertex: 1 stick, 2 / 3 slip in the positive / negative tangential direction
      // (in 3D 2: the direction is a continuous unknown, converged by the Newton steps below)
      active[bounded.size() + f] = stick ? 1 : (d == 3 || direction[f].sum() > 0 ? 2 : 3);
    }
    // in 3D with slipping vertices the same states are not enough: their directions must have
    // converged too, which the relative correction of the last step measures
    bool directions = d == 2 || !slipping(active, bounded.size());
    if (!directions && k > 0 && active == previous && lastCorrection <= options_.tolerance) {
      // the directions have settled to the tolerance; stop when the KKT conditions hold as well
      const Eigen::VectorXd x = problem.fromRotated(w);
      directions = computeKktResiduals(problem, x).max() <= options_.kktTolerance;
    }
    if (k > 0 && active == previous && directions) {
      setRepeated = true;
      break;
    }
    if (k > 0 && active != previous && seen.count(active)) {
      // with friction, a cycle is broken by a smaller c (at most three times; see the header)
      if (nf > 0 && cReductions < 3) {
        ++cReductions;
        for (double& c : cp) c *= 0.1;
        for (double& c : cT) c *= 0.1;
        seen.clear();
      } else {
        throw Error(name() + ", iteration " + std::to_string(k) + ": the active set (" + std::to_string(activeCount) +
                    " nodes) repeats an earlier one: the iteration cycles (try a smaller c or another solver)");
      }
    }
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
    // friction: stick fixes the free tangential components at the origin, slip applies the force
    // -s e (the residual b - A w is lambda_T = s e there); in 3D the direction is linearised in the
    // slip: lambda_T = s e + K (t^{k+1} - t^k), K = (s c_T / |xi|) (I - e e') on the free tangential
    // components, a symmetric positive semidefinite block added to A_pp (see the header)
    for (std::size_t f = 0; f < nf; ++f) {
      const Index p = rot.frictionVertices[f];
      const bool slips = active[bounded.size() + f] != 1;
      Eigen::Matrix<double, d, d> K = Eigen::Matrix<double, d, d>::Zero();
      if (d == 3 && slips) {
        for (int a = 1; a < d; ++a)
          if (freeT[f] & (1u << a)) K(a, a) = 1;
        K = spring[f] * (K - direction[f] * direction[f].transpose());
        Ak.blockAt(Ak.diagonal(p)) += K;
        bk.template segment<d>(static_cast<Eigen::Index>(p) * d) += K * w.template segment<d>(static_cast<Eigen::Index>(p) * d);
      }
      for (int a = 1; a < d; ++a) {
        if (!(freeT[f] & (1u << a))) continue;
        if (!slips) {
          fixed.constrained[static_cast<std::size_t>(p) * d + a] = 1;
          fixed.values[p * d + a] = originOf(p, a);
        } else {
          bk[p * d + a] -= rot.slip[f] * direction[f][a];
        }
      }
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
    for (std::size_t f = 0; f < nf; ++f)  // sticking exactly at the origin
      if (active[bounded.size() + f] == 1)
        for (int a = 1; a < d; ++a)
          if (freeT[f] & (1u << a)) next[rot.frictionVertices[f] * d + a] = originOf(rot.frictionVertices[f], a);

    const Eigen::VectorXd Anext = rot.matrix() * next;
    residual = rot.rhs - Anext;
    for (std::size_t i = 0; i < bounded.size(); ++i) mu[i] = active[i] ? residual[bounded[i] * d] : 0.0;
    for (std::size_t f = 0; f < nf; ++f)
      for (int a = 1; a < d; ++a)
        if (freeT[f] & (1u << a)) lambdaT[f][a] = residual[rot.frictionVertices[f] * d + a];
    const Eigen::VectorXd delta = next - w;
    const double num = std::sqrt(std::max(0.0, rot.matrix().energy(delta)));
    const double den = std::sqrt(std::max(0.0, next.dot(Anext)));
    const double correction = den > 0 ? num / den : (num > 0 ? 1.0 : 0.0);
    w = std::move(next);
    lastCorrection = correction;
    monitor.record(0.5 * w.dot(Anext) - rot.rhs.dot(w) + rot.frictionEnergy(w), correction, activeCount);
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
