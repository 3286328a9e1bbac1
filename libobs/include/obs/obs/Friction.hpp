#pragma once
/// \file Friction.hpp
/// Friction laws on top of the Tresca problem of ContactProblem::setFriction (docs/theory.md#friction).
///
///  - Tresca: a given slip bound g (a traction, Pa) gives the nodal bounds s_k = g m_k with the
///    boundary masses m_k of the contact nodes (ContactSet::boundaryMass, the weights that turn
///    nodal forces into pressures, docs/theory.md#contact-pressure): trescaSlipBounds.
///  - Coulomb: s_k = mu lambda_k with the normal nodal force lambda_k of the solution itself. The
///    problem is no longer a minimisation; solveCoulomb iterates Tresca problems,
///      s^0 = mu (lambda(u^0))^+ at the nodes whose gap is closed,   u^i = Tresca solution for s^(i-1),
///      s^i = mu (lambda(u^i))^+,
///    and stops when the bounds no longer change, max_k |s^i_k - s^(i-1)_k| <= tolerance max_k s^i_k:
///    u^i then solves the Coulomb problem up to that relative change of its slip bounds. The map
///    s -> mu lambda(u(s)) is a contraction only for small enough mu (docs/theory.md#friction-coulomb);
///    solveCoulomb reports whether the changes decreased (CoulombResult::contracting) and returns
///    converged = false after maxIterations; it never throws for a non-contracting iteration.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSolver.hpp"
#include "obs/obs/HaloExchange.hpp"

namespace obs {

/// s_k = bound * m_k (ContactSet numbering; bound >= 0 a traction). Throws obs::Error for a negative
/// or non-finite bound.
std::vector<double> trescaSlipBounds(const ContactSet& contact, double bound);

/// Friction per contact node (ContactSet numbering): the slip bound is
///   s_k = bound_k + mu_k (lambda_k)^+,
/// Tresca nodes with mu_k = 0, Coulomb nodes with bound_k = 0 (a model may mix couplings of both
/// laws; frictionless nodes have both zero). Empty vectors: frictionless.
struct NodalFriction {
  std::vector<double> bound;
  std::vector<double> mu;
  /// True if some mu_k > 0 (the bounds depend on the solution: a fixed point).
  bool coulomb() const;
};

/// The NodalFriction of one law at every node of `contact` (Tresca: bound law.value m_k; Coulomb:
/// mu_k = law.value; FrictionLaw::Type::None: empty, frictionless), e.g. of a contact set that is
/// one coupling's.
NodalFriction nodalFriction(const FrictionLaw& law, const ContactSet& contact);

/// The NodalFriction of a model's couplings (ContactModel::Coupling::friction) on its merged
/// contact set (after assemble()/assembleParts(); `contact` is that set).
template <int d>
NodalFriction nodalFriction(const ContactModel<d>& model, const ContactSet& contact);

struct CoulombOptions {
  double mu = 0;           ///< solveCoulomb: the friction coefficient (>= 0; 0: one frictionless solve)
  int maxIterations = 50;  ///< fixed-point iterations (each one solve of a Tresca problem)
  /// On the relative change of the slip bounds (see the file comment). The bounds are only as accurate
  /// as the multipliers of the inexact Tresca solves: at TNNMG's tolerance 1e-10 the change stagnates
  /// near 5e-8 on a nearly incompressible body (nu = 0.4999), so the default leaves a margin.
  double tolerance = 1e-6;
  /// s^0 (ContactSet numbering; empty: from the start u as in the file comment), e.g. the bounds of
  /// the previous time step (CoulombResult::bounds).
  std::vector<double> initialBounds;
};

struct CoulombResult {
  bool converged = false;
  int iterations = 0;             ///< Tresca solves
  std::vector<double> changes;    ///< relative change of the slip bounds after each solve
  bool contracting = true;        ///< every change from the third on below the one before
  long long innerIterations = 0;  ///< solver iterations over all solves
  std::vector<double> bounds;     ///< the slip bounds of the last solve
  double seconds = 0;
  ContactResult last;             ///< the last Tresca solve
};

/// Solves the problem with the friction of `friction` (one Tresca solve if no node has mu_k > 0,
/// else the fixed point of the file comment; options.mu is not used) on `problem`, whose slip
/// bounds are overwritten; origin as for solveCoulomb. Throws obs::Error for vectors of the wrong
/// size, negative or non-finite entries or invalid options, and what the solver throws.
///
/// Distributed (`halo` of the rank's leaf view given; `problem` assembled on its local mesh, owned
/// vertices first; `solver` a distributed one, e.g. TNNMG(const DistributedGrid&)): the bounds of
/// the owned vertices' nodes come from their complete rows, the ghosts' from their owners, and the
/// displacement scale and the change of the bounds are maxima over the ranks, so every rank takes
/// the same number of Tresca solves. Every rank must call it.
template <int d>
CoulombResult solveFriction(ContactProblem<d>& problem, ContactSolver<d>& solver, Eigen::VectorXd& u,
                            const NodalFriction& friction, const CoulombOptions& options,
                            const Eigen::VectorXd& origin = {}, const HaloExchange* halo = nullptr);

/// Solves the Coulomb problem on `problem` (its slip bounds are overwritten; the origin o, e.g. the
/// displacement of the previous load increment, is the same for every solve) with `solver`, from
/// and into u. Throws obs::Error for a negative or non-finite mu or invalid options, and what the
/// solver throws.
template <int d>
CoulombResult solveCoulomb(ContactProblem<d>& problem, ContactSolver<d>& solver, Eigen::VectorXd& u,
                           const CoulombOptions& options, const Eigen::VectorXd& origin = {});

extern template NodalFriction nodalFriction<2>(const ContactModel<2>&, const ContactSet&);
extern template NodalFriction nodalFriction<3>(const ContactModel<3>&, const ContactSet&);
extern template CoulombResult solveFriction<2>(ContactProblem<2>&, ContactSolver<2>&, Eigen::VectorXd&,
                                               const NodalFriction&, const CoulombOptions&, const Eigen::VectorXd&,
                                               const HaloExchange*);
extern template CoulombResult solveFriction<3>(ContactProblem<3>&, ContactSolver<3>&, Eigen::VectorXd&,
                                               const NodalFriction&, const CoulombOptions&, const Eigen::VectorXd&,
                                               const HaloExchange*);
extern template CoulombResult solveCoulomb<2>(ContactProblem<2>&, ContactSolver<2>&, Eigen::VectorXd&,
                                              const CoulombOptions&, const Eigen::VectorXd&);
extern template CoulombResult solveCoulomb<3>(ContactProblem<3>&, ContactSolver<3>&, Eigen::VectorXd&,
                                              const CoulombOptions&, const Eigen::VectorXd&);

}  // namespace obs
