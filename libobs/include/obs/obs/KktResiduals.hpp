#pragma once
/// \file KktResiduals.hpp
/// Optimality measures of an approximate solution u of the contact problem
/// (docs/theory.md#signorini-discrete): the KKT
/// conditions  A u - b + mu_p nu_p = 0 at contact nodes, A u - b = 0 elsewhere (free components),
/// nu_p'u_p <= g_p, mu_p >= 0, mu_p (g_p - nu_p'u_p) = 0, with mu_p = (b - A u)_p . nu_p read off
/// the residual (effective constraints of ContactProblem; nodes with gap +inf count as free).
///
/// All residuals are dimensionless maxima over nodes, scaled by
///   U = max(|u|_inf, max over finite gaps |g_p|)            (displacement scale, 1 if zero)
///   F = max(|b_i|, |(A u)_i|) over non-Dirichlet components  (force scale, 1 if zero):
///   primalFeasibility = max_p (nu_p'u_p - g_p)^+ / U
///   dualSign          = max_p (-mu_p)^+ / F
///   complementarity   = max_p |mu_p (g_p - nu_p'u_p)| / (F U)
///   stationarity      = max over free components i of |r_i| / F, r = b - A u - sum_p mu_p nu_p
///                       (the tangential components at contact nodes and everything elsewhere)
///   dirichlet         = max over prescribed components |u_i - u_D,i| / U
/// At an exact solution all are zero (round-off: ~1e-13 for a direct solve).
#include <Eigen/Core>

#include <algorithm>
#include <limits>

#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"

namespace obs {

struct KktResiduals {
  double primalFeasibility = 0;
  double dualSign = 0;
  double complementarity = 0;
  double stationarity = 0;
  double dirichlet = 0;
  double displacementScale = 1;  ///< U
  double forceScale = 1;         ///< F

  /// The largest of the five residuals.
  double max() const {
    return std::max({primalFeasibility, dualSign, complementarity, stationarity, dirichlet});
  }
};

/// The residuals of a result whose KKT residuals were not computed (ContactSolverOptions::
/// computeKkt): all five and both scales NaN, so that max() is NaN and no test passes by accident.
inline KktResiduals notComputedKktResiduals() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return KktResiduals{nan, nan, nan, nan, nan, nan, nan};
}

/// Distributed (comm non-null): the problem and u on a rank's local vertices, the first
/// `ownedVertices` of them owned (their rows complete); the scales and residuals are maxima over
/// the owned entries of all ranks. ownedVertices < 0: all vertices, one process.
template <int d>
KktResiduals computeKktResiduals(const ContactProblem<d>& problem, const Eigen::VectorXd& u, Index ownedVertices = -1,
                                 const Communicator* comm = nullptr);

}  // namespace obs
