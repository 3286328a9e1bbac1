#include "obs/obs/KktResiduals.hpp"

#include <cmath>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
KktResiduals computeKktResiduals(const ContactProblem<d>& problem, const Eigen::VectorXd& u, Index ownedVertices,
                                 const Communicator* comm) {
  if (u.size() != static_cast<Eigen::Index>(problem.numDofs()))
    throw Error("KKT residuals: displacement vector of wrong size");
  const auto& dir = problem.dirichlet();
  Eigen::VectorXd Au;
  problem.multiply(u, Au);
  Eigen::VectorXd r = problem.rhs() - Au;

  KktResiduals k;
  const Index owned = ownedVertices < 0 ? problem.numVertices() : ownedVertices;
  const auto n = static_cast<Eigen::Index>(owned) * d;
  const auto largest = [&](double x) { return comm ? comm->max(x) : x; };
  double U = u.head(n).lpNorm<Eigen::Infinity>(), F = 0;
  for (const auto& c : problem.constraints())
    if (c.bounded() && c.vertex < owned) U = std::max(U, std::abs(c.gap));
  for (Eigen::Index i = 0; i < n; ++i)
    if (!dir.constrained[static_cast<std::size_t>(i)])
      F = std::max({F, std::abs(problem.rhs()[i]), std::abs(Au[i])});
  U = largest(U);
  F = largest(F);
  k.displacementScale = U > 0 ? U : 1;
  k.forceScale = F > 0 ? F : 1;

  const std::vector<double>& slip = problem.slipBounds();
  for (std::size_t node = 0; node < problem.constraints().size(); ++node) {
    const auto& c = problem.constraint(static_cast<Index>(node));
    if (!c.bounded() || c.vertex >= owned) continue;
    auto rp = r.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d);
    const double mu = c.direction.dot(rp);
    const double slack = c.gap - c.direction.dot(u.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d));
    k.primalFeasibility = std::max(k.primalFeasibility, -slack / k.displacementScale);
    k.dualSign = std::max(k.dualSign, -mu / k.forceScale);
    k.complementarity = std::max(k.complementarity, std::abs(mu * slack) / (k.forceScale * k.displacementScale));
    rp -= mu * c.direction;  // what is left must vanish (tangential part) ...
    if (!slip.empty() && slip[node] > 0) {
      // ... but for the friction force f (rotated frame): s t/|t| in slip, in stick the tangential
      // residual q cut to the disk |f| <= s (what exceeds it remains)
      using Vec = Eigen::Matrix<double, d, 1>;
      const Vec t = problem.tangentialSlip(static_cast<Index>(node), u);
      Vec q = c.rotation.transpose() * Vec(rp);
      q[0] = 0;
      for (int a = 1; a < d; ++a)
        if (problem.prescribedRotated()[static_cast<std::size_t>(c.vertex) * d + a]) q[a] = 0;
      Vec f;
      const double s = slip[node];
      if (t.norm() > 1e-12 * k.displacementScale) f = s * t / t.norm();
      else f = q.norm() > s ? Vec(q * (s / q.norm())) : q;
      rp -= c.rotation * f;
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (dir.constrained[static_cast<std::size_t>(i)])
      k.dirichlet = std::max(k.dirichlet, std::abs(u[i] - dir.values[i]) / k.displacementScale);
    else
      k.stationarity = std::max(k.stationarity, std::abs(r[i]) / k.forceScale);
  }
  if (comm)
    for (double* r : {&k.primalFeasibility, &k.dualSign, &k.complementarity, &k.stationarity, &k.dirichlet}) *r = comm->max(*r);
  if (!std::isfinite(k.max()))
    throw Error("KKT residuals: the displacement contains NaN or Inf");
  return k;
}

template KktResiduals computeKktResiduals<2>(const ContactProblem<2>&, const Eigen::VectorXd&, Index, const Communicator*);
template KktResiduals computeKktResiduals<3>(const ContactProblem<3>&, const Eigen::VectorXd&, Index, const Communicator*);

}  // namespace obs
