#pragma once
/// \file TruncatedLinearization.hpp
/// The truncated linearization of TNNMG at an iterate w (docs/theory.md#tnnmg-truncation; Graeser, Sack,
/// Sander 2009, Sec. 4): the energy J(w) = 1/2 w'Aw - b'w is quadratic, so its linearization is J itself
/// restricted to the components that are not truncated. Truncated are
///   - prescribed (Dirichlet) components: identity rows of A, fixed at their values;
///   - active bounds: w_{p,1} >= upper_p (the smoother puts active components exactly on the bound).
/// The truncated defect problem is A_T c = r_T with r_T = b - A w zeroed at truncated components and
/// A_T = A with truncated rows and columns replaced by the identity (its solution is zero there).
///
/// Tresca friction (docs/theory.md#friction-tnnmg): the term s_p |t_p|, t_p = (w_p - o_p)_T, is not
/// differentiable where t_p = 0 (stick; the smoother sets t_p exactly to zero there) and smooth in
/// slip. Sticking vertices truncate their free tangential components as well; at slipping vertices
/// the defect is the negative gradient of the whole energy, r_T = b - A w - s_p t_p / |t_p| on the
/// tangential components. The Hessian of the term at a slipping vertex is its curvature
/// K_p = s_p (P_T - e e')/|t_p| (P_T the projector onto the free tangential components, e = t_p/|t_p|),
/// zero in 2D, where the tangential space is one-dimensional; curvature() gives the blocks, which
/// TNNMG adds to the operator of the linear correction.
#include <Eigen/Core>

#include <vector>

#include "obs/obs/ContactProblem.hpp"

namespace obs {

template <int d>
struct TruncatedLinearization {
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;
  std::vector<char> mask;  ///< per component, 1 = truncated
  Index active = 0;        ///< number of active bounds
  Index sticking = 0;      ///< friction vertices with t_p = 0
  std::vector<std::size_t> slipping;  ///< friction vertices (RotatedProblem numbering f) with t_p != 0
  std::vector<Vec> slipDirection;     ///< t_p / |t_p| of each
  std::vector<double> slipNorm;       ///< |t_p| of each

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
    sticking = 0;
    slipping.clear();
    slipDirection.clear();
    slipNorm.clear();
    for (std::size_t f = 0; f < problem.frictionVertices.size(); ++f) {
      const Vec t = problem.slipOf(f, w);
      const double norm = t.norm();
      if (norm > 0) {
        slipping.push_back(f);
        slipDirection.push_back(t / norm);
        slipNorm.push_back(norm);
        continue;
      }
      ++sticking;
      const auto i = static_cast<std::size_t>(problem.frictionVertices[f]) * d;
      for (int a = 1; a < d; ++a) mask[i + a] = 1;  // prescribed ones are truncated already
    }
  }
  /// The curvature blocks K_p of the slipping vertices (rotated frame; see the file comment):
  /// their vertices and blocks, both empty in 2D.
  void curvature(const RotatedProblem<d>& problem, std::vector<Index>& vertices, std::vector<Mat>& blocks) const {
    vertices.clear();
    blocks.clear();
    if constexpr (d == 2) return;
    for (std::size_t k = 0; k < slipping.size(); ++k) {
      const std::size_t f = slipping[k];
      const Index p = problem.frictionVertices[f];
      Mat P = Mat::Zero();
      for (int a = 1; a < d; ++a)
        if (!problem.prescribed[static_cast<std::size_t>(p) * d + a]) P(a, a) = 1;
      const Vec& e = slipDirection[k];  // zero in prescribed components (RotatedProblem::slipOf)
      vertices.push_back(p);
      blocks.push_back(problem.slip[f] / slipNorm[k] * (P - e * e.transpose()));
    }
  }
  /// r = b - A w (given Aw) with truncated components set to zero.
  void truncatedResidual(const RotatedProblem<d>& problem, const Eigen::VectorXd& Aw, Eigen::VectorXd& r) const {
    r.resize(Aw.size());
    forRanges(static_cast<Index>(Aw.size()), [&](Index b, Index e) {
      for (Index i = b; i < e; ++i) r[i] = mask[static_cast<std::size_t>(i)] ? 0.0 : problem.rhs[i] - Aw[i];
    });
    for (std::size_t k = 0; k < slipping.size(); ++k) {  // the gradient of the friction term in slip
      const std::size_t f = slipping[k];
      const auto i = static_cast<Eigen::Index>(problem.frictionVertices[f]) * d;
      for (int a = 1; a < d; ++a) r[i + a] -= problem.slip[f] * slipDirection[k][a];
    }
  }
};

}  // namespace obs
