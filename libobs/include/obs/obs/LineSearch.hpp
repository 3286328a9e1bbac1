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
#include <Eigen/Core>

#include <algorithm>
#include <limits>

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
};

/// cr = c'r, cAc = c'Ac for r = b - A w.
template <int d>
LineSearchResult exactLineSearch(const RotatedProblem<d>& problem, const Eigen::VectorXd& w, const Eigen::VectorXd& c,
                                 double cr, double cAc) {
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
  if (cr > 0 && cAc > 0) s.alpha = std::min(s.alphaMax, cr / cAc);
  return s;
}

/// w += alpha c, exactly onto the limiting bound if alpha = alpha_max.
template <int d>
void takeStep(const RotatedProblem<d>& problem, const LineSearchResult& s, const Eigen::VectorXd& c, Eigen::VectorXd& w) {
  if (s.alpha == 0) return;
  forRanges(static_cast<Index>(w.size()), [&](Index b, Index e) { w.segment(b, e - b) += s.alpha * c.segment(b, e - b); });
  if (s.limiting >= 0 && s.alpha == s.alphaMax) w[static_cast<Eigen::Index>(s.limiting) * d] = problem.upper[s.limiting];
  // round-off must not leave the admissible set
  for (Index p = 0; p < problem.numVertices(); ++p)
    if (problem.bounded(p)) {
      const auto i = static_cast<Eigen::Index>(p) * d;
      w[i] = std::min(w[i], problem.upper[p]);
    }
}

}  // namespace obs
