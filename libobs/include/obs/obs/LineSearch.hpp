#pragma once
/// \file LineSearch.hpp
/// Defect projection and exact line search of TNNMG (docs/theory.md#tnnmg-line-search), for the rotated
/// problem min 1/2 w'Aw - b'w s.t. w_{p,1} <= upper_p:
///  - projectCorrection: clip the correction so that w + c stays admissible, componentwise on the
///    bound components, c_{p,1} <- min(c_{p,1}, upper_p - w_{p,1});
///  - exactLineSearch: alpha_max = min over c_{p,1} > 0 of (upper_p - w_{p,1}) / c_{p,1} (the largest
///    feasible step, >= 1 after the projection; +inf if no component moves towards its bound) and
///      alpha = min(alpha_max, c'r / c'Ac),  r = b - A w,
///    the minimiser of the convex quadratic J(w + alpha c) on [0, alpha_max] (alpha = 0 if c'r <= 0
///    or c'Ac <= 0), so J(w + alpha c) <= J(w): the step never increases the energy.
/// takeStep adds alpha c and, when alpha = alpha_max, puts the limiting component exactly on its
/// bound (so that it is recognised as active by the next truncation).
///
/// With Tresca friction (docs/theory.md#friction-tnnmg) the energy along the line,
///   phi(alpha) = J(w + alpha c) - J(w) = alpha^2/2 c'Ac - alpha c'(b - Aw) + sum_p s_p (|t_p + alpha c_p| - |t_p|)
/// (t_p = (w_p - o_p)_T, c_p = (c_p)_T; sticking vertices have c_p = 0 after the truncation), is
/// convex but no longer quadratic: frictionLineSearch finds its minimiser on [0, alpha_max] by
/// bisection on the nondecreasing phi'. Where phi' jumps over zero at a kink t_p + alpha c_p = 0
/// (a vertex that stops slipping), the step is that kink, and takeStep sets t_p exactly to zero
/// (so that the next truncation sees the vertex stick).
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"

namespace obs {

template <int d>
void projectCorrection(const RotatedProblem<d>& problem, const Eigen::VectorXd& w, Eigen::VectorXd& c) {
  for (Index p = 0; p < problem.numVertices(); ++p)
    if (problem.bounded(p)) {
      const auto i = static_cast<Eigen::Index>(p) * d;
      c[i] = std::min(c[i], problem.upper[p] - w[i]);
    }
}

struct LineSearchResult {
  double alpha = 0;
  double alphaMax = std::numeric_limits<double>::infinity();
  Index limiting = -1;  ///< vertex whose bound gives alpha_max, or -1
  std::ptrdiff_t stops = -1;  ///< friction vertex (RotatedProblem numbering) whose slip the step ends, or -1
};

/// alpha_max and its limiting vertex (see the file comment).
template <int d>
LineSearchResult largestFeasibleStep(const RotatedProblem<d>& problem, const Eigen::VectorXd& w, const Eigen::VectorXd& c) {
  LineSearchResult s;
  for (Index p = 0; p < problem.numVertices(); ++p) {
    const auto i = static_cast<Eigen::Index>(p) * d;
    if (problem.bounded(p) && c[i] > 0) {
      const double a = (problem.upper[p] - w[i]) / c[i];
      if (a < s.alphaMax) {
        s.alphaMax = a;
        s.limiting = p;
      }
    }
  }
  s.alphaMax = std::max(s.alphaMax, 0.0);
  return s;
}

/// cr = c'r, cAc = c'Ac for r = b - A w.
template <int d>
LineSearchResult exactLineSearch(const RotatedProblem<d>& problem, const Eigen::VectorXd& w, const Eigen::VectorXd& c,
                                 double cr, double cAc) {
  LineSearchResult s = largestFeasibleStep(problem, w, c);
  if (cr > 0 && cAc > 0) s.alpha = std::min(s.alphaMax, cr / cAc);
  return s;
}

/// The line search with friction: cr = c'r for the truncated defect r of TruncatedLinearization
/// (which contains the friction gradient of the slipping vertices), cAc = c'Ac; `slipping` and
/// `direction` as TruncatedLinearization::slipping / slipDirection. Without slipping vertices the
/// energy along the line is quadratic: the step of exactLineSearch.
///
/// Distributed (comm given; w, c with current ghosts, cr and cAc already summed over the ranks):
/// alpha_max is the minimum over the ranks (`limiting` stays only where it is attained), the
/// slope's friction terms are summed over the friction vertices below `owned` and over the ranks,
/// so every rank bisects the same function to the same alpha, and a kink found on any rank (the
/// smallest) is the step of all; the ranks holding that vertex (its owner and its ghost copies) mark
/// it in `stops`. On one process the same code runs with the local sums.
template <int d>
LineSearchResult frictionLineSearch(const RotatedProblem<d>& problem, const Eigen::VectorXd& w, const Eigen::VectorXd& c,
                                    double cr, double cAc, const std::vector<std::size_t>& slipping,
                                    const std::vector<Eigen::Matrix<double, d, 1>>& direction, Index owned = -1,
                                    const Communicator* comm = nullptr) {
  using Vec = Eigen::Matrix<double, d, 1>;
  LineSearchResult s = largestFeasibleStep(problem, w, c);
  if (comm) {
    const double alphaMax = -comm->max(-s.alphaMax);
    if (s.alphaMax != alphaMax) s.limiting = -1;
    s.alphaMax = alphaMax;
  }
  // the slipping terms: bound, t_p, c_p and c_p.e_p (phi'(0) = -cr already contains -s_p c_p.e_p)
  struct Term {
    std::size_t f;
    bool counted;  ///< owned: enters the slope's sum
    double slip;
    Vec t, c;
    double ce;
  };
  std::vector<Term> terms;
  for (std::size_t k = 0; k < slipping.size(); ++k) {
    const std::size_t f = slipping[k];
    const Index p = problem.frictionVertices[f];
    const auto i = static_cast<Eigen::Index>(p) * d;
    Vec cp = c.template segment<d>(i);
    cp[0] = 0;
    for (int a = 1; a < d; ++a)
      if (problem.prescribed[static_cast<std::size_t>(i + a)]) cp[a] = 0;
    if (cp.isZero(0)) continue;
    terms.push_back({f, owned < 0 || p < owned, problem.slip[f], problem.slipOf(f, w), cp, cp.dot(direction[k])});
  }
  const bool anyTerm = comm ? comm->max(terms.empty() ? 0.0 : 1.0) > 0 : !terms.empty();
  if (!anyTerm) {  // quadratic along the line
    if (cr > 0 && cAc > 0) s.alpha = std::min(s.alphaMax, cr / cAc);
    return s;
  }
  if (!(cr > 0) || !(cAc > 0)) return s;  // phi'(0) = -cr >= 0, or no curvature: no descent
  const auto slope = [&](double alpha) {  // phi'(alpha), the left derivative at a kink
    double g = comm ? 0.0 : alpha * cAc - cr;  // (one process: the sum in the order of the serial code)
    for (const Term& term : terms) {
      if (!term.counted) continue;
      const Vec x = term.t + alpha * term.c;
      const double n = x.norm();
      g += term.slip * ((n > 0 ? x.dot(term.c) / n : -term.c.norm()) - term.ce);
    }
    return comm ? alpha * cAc - cr + comm->sum(g) : g;
  };
  double lo = 0, hi = s.alphaMax;
  if (std::isfinite(hi)) {
    if (slope(hi) <= 0) {
      s.alpha = hi;
      return s;
    }
  } else {  // phi' grows like alpha c'Ac: double a start until it is positive
    hi = cr / cAc;
    for (int k = 0; k < 200 && slope(hi) <= 0; ++k) hi *= 2;
  }
  for (int k = 0; k < 200 && hi - lo > 1e-15 * hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (slope(mid) <= 0 ? lo : hi) = mid;
  }
  s.alpha = lo;
  // a kink in [lo, hi]: phi' jumps over zero there, so it is the minimiser; the vertex stops (the
  // smallest such step, over the ranks)
  const auto kinkOf = [&](const Term& term) { return -term.t.dot(term.c) / term.c.squaredNorm(); };
  const auto isKink = [&](const Term& term, double a) {
    return a >= lo && a <= hi && (term.t + a * term.c).norm() <= 1e-12 * term.t.norm();
  };
  double kink = std::numeric_limits<double>::infinity();
  for (const Term& term : terms)
    if (const double a = kinkOf(term); isKink(term, a)) kink = std::min(kink, a);
  if (comm) kink = -comm->max(-kink);
  if (std::isfinite(kink)) {
    s.alpha = kink;
    for (const Term& term : terms)
      if (kinkOf(term) == kink && isKink(term, kink)) {
        s.stops = static_cast<std::ptrdiff_t>(term.f);
        break;
      }
  }
  return s;
}

/// w += alpha c, exactly onto the limiting bound if alpha = alpha_max.
template <int d>
void takeStep(const RotatedProblem<d>& problem, const LineSearchResult& s, const Eigen::VectorXd& c, Eigen::VectorXd& w) {
  if (s.alpha == 0) return;
  forRanges(static_cast<Index>(w.size()), [&](Index b, Index e) { w.segment(b, e - b) += s.alpha * c.segment(b, e - b); });
  if (s.limiting >= 0 && s.alpha == s.alphaMax) w[static_cast<Eigen::Index>(s.limiting) * d] = problem.upper[s.limiting];
  if (s.stops >= 0) {  // exactly onto the kink: t_p = 0
    const auto f = static_cast<std::size_t>(s.stops);
    const auto i = static_cast<Eigen::Index>(problem.frictionVertices[f]) * d;
    for (int a = 1; a < d; ++a)
      if (!problem.prescribed[static_cast<std::size_t>(i + a)]) w[i + a] = problem.origin.size() > 0 ? problem.origin[i + a] : 0.0;
  }
  // round-off must not leave the admissible set
  for (Index p = 0; p < problem.numVertices(); ++p)
    if (problem.bounded(p)) {
      const auto i = static_cast<Eigen::Index>(p) * d;
      w[i] = std::min(w[i], problem.upper[p]);
    }
}

}  // namespace obs
