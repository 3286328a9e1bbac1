#include "obs/obs/Friction.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs {

std::vector<double> trescaSlipBounds(const ContactSet& contact, double bound) {
  if (!(bound >= 0) || !std::isfinite(bound))
    throw Error("Tresca friction: the slip bound must be finite and >= 0, got " + std::to_string(bound));
  std::vector<double> s(static_cast<std::size_t>(contact.size()));
  for (Index k = 0; k < contact.size(); ++k) s[static_cast<std::size_t>(k)] = bound * contact.boundaryMass(k);
  return s;
}

bool NodalFriction::coulomb() const {
  return std::any_of(mu.begin(), mu.end(), [](double m) { return m > 0; });
}

namespace {

/// Node k of `contact` under `law` (f sized to the set): the one place the nodal values are made.
void setNode(NodalFriction& f, const FrictionLaw& law, const ContactSet& contact, Index k) {
  const auto i = static_cast<std::size_t>(k);
  if (law.type == FrictionLaw::Type::Tresca) f.bound[i] = law.value * contact.boundaryMass(k);
  if (law.type == FrictionLaw::Type::Coulomb) f.mu[i] = law.value;
}

NodalFriction sized(const ContactSet& contact) {
  NodalFriction f;
  f.bound.assign(static_cast<std::size_t>(contact.size()), 0.0);
  f.mu.assign(f.bound.size(), 0.0);
  return f;
}

}  // namespace

NodalFriction nodalFriction(const FrictionLaw& law, const ContactSet& contact) {
  if (law.type == FrictionLaw::Type::None) return {};
  NodalFriction f = sized(contact);
  for (Index k = 0; k < contact.size(); ++k) setNode(f, law, contact, k);
  return f;
}

template <int d>
NodalFriction nodalFriction(const ContactModel<d>& model, const ContactSet& contact) {
  if (!model.frictional()) return {};
  NodalFriction f = sized(contact);
  for (const auto& c : model.couplings())
    for (const Index k : c.nodes) {
      if (k < 0 || k >= contact.size())
        throw Error("friction: coupling '" + c.label + "' has a node outside the contact set");
      setNode(f, c.friction, contact, k);
    }
  return f;
}

namespace {

/// The values of the contact nodes of ghost vertices replaced by their owners' (one value per node).
template <int d>
void ghostsFromOwners(const ContactProblem<d>& problem, const HaloExchange& halo, std::vector<double>& values) {
  Eigen::VectorXd v = Eigen::VectorXd::Zero(halo.numLocal());
  for (std::size_t k = 0; k < values.size(); ++k) v[problem.constraint(static_cast<Index>(k)).vertex] = values[k];
  halo.update(v);
  for (std::size_t k = 0; k < values.size(); ++k) values[k] = v[problem.constraint(static_cast<Index>(k)).vertex];
}

/// bound_k + mu_k (lambda_k)^+, the Coulomb part (if `coulomb`: some node on some rank has mu > 0)
/// only at the nodes whose gap is closed (relative to the displacement scale). Distributed (halo
/// given): the nodes of owned vertices from their complete rows, with the displacement scale over
/// all ranks; the ghosts' are left for ghostsFromOwners.
template <int d>
std::vector<double> slipBounds(const ContactProblem<d>& problem, const Eigen::VectorXd& u, const NodalFriction& f,
                               bool coulomb, const HaloExchange* halo) {
  std::vector<double> s = f.bound;
  if (!coulomb) return s;
  const Index owned = halo ? halo->numOwned() : problem.numVertices();
  const Eigen::VectorXd lambda = problem.multipliers(u);
  double U = u.head(static_cast<Eigen::Index>(owned) * d).lpNorm<Eigen::Infinity>();
  for (const auto& c : problem.constraints())
    if (c.bounded() && c.vertex < owned) U = std::max(U, std::abs(c.gap));
  if (halo) U = halo->communicator().max(U);
  if (!(U > 0)) U = 1;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const auto& c = problem.constraint(static_cast<Index>(k));
    if (!c.bounded() || !(f.mu[k] > 0) || c.vertex >= owned) continue;
    const double slack = c.gap - c.direction.dot(u.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d));
    if (slack <= 1e-10 * U) s[k] += f.mu[k] * std::max(0.0, lambda[static_cast<Eigen::Index>(k)]);
  }
  return s;
}

}  // namespace

template <int d>
CoulombResult solveFriction(ContactProblem<d>& problem, ContactSolver<d>& solver, Eigen::VectorXd& u,
                            const NodalFriction& friction, const CoulombOptions& options, const Eigen::VectorXd& origin,
                            const HaloExchange* halo) {
  const std::size_t n = problem.constraints().size();
  // distributed: the same decisions on every rank (a rank may hold no contact node), and an error
  // on one rank reaches all
  const auto anywhere = [&](bool x) { return halo ? halo->communicator().max(x ? 1.0 : 0.0) > 0 : x; };
  const auto everywhere = [&](const std::function<void()>& work) {
    if (halo) halo->communicator().collective(work);
    else work();
  };
  const bool empty = !anywhere(!(friction.bound.empty() && friction.mu.empty()));  // frictionless
  everywhere([&] {
    if (!empty && (friction.bound.size() != n || friction.mu.size() != n))
      throw Error("friction: " + std::to_string(friction.bound.size()) + " slip bounds and " +
                  std::to_string(friction.mu.size()) + " coefficients for " + std::to_string(n) + " contact nodes");
    for (std::size_t k = 0; k < friction.mu.size(); ++k)
      if (!(friction.mu[k] >= 0) || !std::isfinite(friction.mu[k]))
        throw Error("Coulomb friction: the friction coefficient must be finite and >= 0, got " +
                    std::to_string(friction.mu[k]) + " at contact node " + std::to_string(k));
    if (options.maxIterations < 1 || !(options.tolerance > 0))
      throw Error("Coulomb friction: invalid options (maxIterations >= 1, tolerance > 0)");
    if (!options.initialBounds.empty()) {
      if (options.initialBounds.size() != n)
        throw Error("friction: " + std::to_string(options.initialBounds.size()) + " initial slip bounds for " +
                    std::to_string(n) + " contact nodes");
      for (double b : options.initialBounds)
        if (!(b >= 0) || !std::isfinite(b)) throw Error("friction: an initial slip bound is negative or not finite");
    }
  });
  const auto start = std::chrono::steady_clock::now();
  CoulombResult result;
  problem.projectToFeasible(u);
  const bool fixedPoint = anywhere(friction.coulomb());
  const bool initial = anywhere(!options.initialBounds.empty());
  std::vector<double> s = empty                    ? std::vector<double>{}
                          : (fixedPoint && initial) ? options.initialBounds
                                                    : slipBounds(problem, u, friction, fixedPoint, halo);
  if (halo && !empty) ghostsFromOwners(problem, *halo, s);  // (Tresca bounds: from incomplete ghost masses)
  for (int i = 0; i < options.maxIterations; ++i) {
    problem.setFriction(s, origin);
    result.last = solver.solve(problem, u);
    result.bounds = s;
    ++result.iterations;
    result.innerIterations += result.last.iterations;
    if (!fixedPoint) {  // Tresca or frictionless: the bounds do not depend on u
      result.converged = result.last.converged;
      result.changes.push_back(0);
      break;
    }
    std::vector<double> next = slipBounds(problem, u, friction, fixedPoint, halo);
    double change = 0, scale = 0;
    for (std::size_t k = 0; k < s.size(); ++k) {
      if (halo && problem.constraint(static_cast<Index>(k)).vertex >= halo->numOwned()) continue;
      change = std::max(change, std::abs(next[k] - s[k]));
      scale = std::max(scale, next[k]);
    }
    if (halo) {
      change = halo->communicator().max(change);
      scale = halo->communicator().max(scale);
    }
    const double relative = scale > 0 ? change / scale : (change > 0 ? 1.0 : 0.0);
    if (result.changes.size() >= 2 && relative >= result.changes.back()) result.contracting = false;
    result.changes.push_back(relative);
    if (relative <= options.tolerance) {
      result.converged = result.last.converged;
      break;
    }
    if (halo) ghostsFromOwners(problem, *halo, next);
    s = std::move(next);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

template <int d>
CoulombResult solveCoulomb(ContactProblem<d>& problem, ContactSolver<d>& solver, Eigen::VectorXd& u,
                           const CoulombOptions& options, const Eigen::VectorXd& origin) {
  if (!(options.mu >= 0) || !std::isfinite(options.mu))
    throw Error("Coulomb friction: the friction coefficient must be finite and >= 0, got " + std::to_string(options.mu));
  const std::size_t n = problem.constraints().size();
  NodalFriction f;
  f.bound.assign(n, 0.0);
  f.mu.assign(n, options.mu);
  return solveFriction(problem, solver, u, f, options, origin);
}

template NodalFriction nodalFriction<2>(const ContactModel<2>&, const ContactSet&);
template NodalFriction nodalFriction<3>(const ContactModel<3>&, const ContactSet&);
template CoulombResult solveFriction<2>(ContactProblem<2>&, ContactSolver<2>&, Eigen::VectorXd&, const NodalFriction&,
                                        const CoulombOptions&, const Eigen::VectorXd&, const HaloExchange*);
template CoulombResult solveFriction<3>(ContactProblem<3>&, ContactSolver<3>&, Eigen::VectorXd&, const NodalFriction&,
                                        const CoulombOptions&, const Eigen::VectorXd&, const HaloExchange*);
template CoulombResult solveCoulomb<2>(ContactProblem<2>&, ContactSolver<2>&, Eigen::VectorXd&, const CoulombOptions&,
                                       const Eigen::VectorXd&);
template CoulombResult solveCoulomb<3>(ContactProblem<3>&, ContactSolver<3>&, Eigen::VectorXd&, const CoulombOptions&,
                                       const Eigen::VectorXd&);

}  // namespace obs
