#pragma once
/// \file TruncatedLinearization.hpp
/// The truncated linearization of TNNMG at an iterate w (docs/theory.md#tnnmg-truncation; Graeser, Sack,
/// Sander 2009, Sec. 4): the energy J(w) = 1/2 w'Aw - b'w is quadratic, so its linearization is J itself
/// restricted to the components that are not truncated. Truncated are
///   - prescribed (Dirichlet) components: identity rows of A, fixed at their values;
///   - active bounds: w_{p,1} >= upper_p (the smoother puts active components exactly on the bound).
/// The truncated defect problem is A_T c = r_T with r_T = b - A w zeroed at truncated components and
/// A_T = A with truncated rows and columns replaced by the identity (its solution is zero there).
#include <Eigen/Core>

#include <vector>

#include "obs/obs/ContactProblem.hpp"

namespace obs {

template <int d>
struct TruncatedLinearization {
  std::vector<char> mask;  ///< per component, 1 = truncated
  Index active = 0;        ///< number of active bounds

  /// Mask at w: prescribed components and active bounds of the rotated problem.
  void truncate(const RotatedProblem<d>& problem, const Eigen::VectorXd& w) {
    const Index n = problem.numVertices();
    mask.assign(problem.prescribed.begin(), problem.prescribed.end());
    active = 0;
    for (Index p = 0; p < n; ++p)
      if (problem.bounded(p) && w[static_cast<Eigen::Index>(p) * d] >= problem.upper[p]) {
        mask[static_cast<std::size_t>(p) * d] = 1;
        ++active;
      }
  }
  /// r = b - A w (given Aw) with truncated components set to zero.
  void truncatedResidual(const RotatedProblem<d>& problem, const Eigen::VectorXd& Aw, Eigen::VectorXd& r) const {
    r.resize(Aw.size());
    forRanges(static_cast<Index>(Aw.size()), [&](Index b, Index e) {
      for (Index i = b; i < e; ++i) r[i] = mask[static_cast<std::size_t>(i)] ? 0.0 : problem.rhs[i] - Aw[i];
    });
  }
};

}  // namespace obs
