#pragma once
/// \file FrictionBlock.hpp
/// The local problem of a contact vertex with Tresca friction, the block step of the nonsmooth
/// Gauss-Seidel smoother with friction (BlockLocalSolver, docs/theory.md#friction-tnnmg). In the
/// rotated coordinates of a contact vertex (component 1 along the constraint
/// direction, components 2..d tangential; ContactProblem.hpp):
///
///   minimise f(v) = 1/2 v'Dv - r'v + s |v_T|   subject to   v_1 <= g,
///
/// with D the symmetric positive definite diagonal block, r the local right-hand side, s >= 0 the
/// slip bound (s = 0: frictionless) and v_T = (v_2, ..., v_d). f is strictly convex, so the
/// minimiser is unique, and it is found exactly in two cases:
///   1. v_1 free: eliminating v_1 = (r_1 - D_1T v_T) / D_11 leaves the tangential problem
///      min 1/2 x'Sx - q'x + s|x| with the Schur complement S = D_TT - D_T1 D_1T / D_11 and
///      q = r_T - D_T1 r_1 / D_11. If the resulting v_1 <= g it is the minimiser (convexity).
///   2. otherwise the bound is active, v_1 = g, and min 1/2 x'Sx - q'x + s|x| with S = D_TT,
///      q = r_T - D_T1 g.
/// The tangential problem (shrink()): x = 0 if |q| <= s (stick); otherwise x != 0 solves
/// (S + s/rho I) x = q with rho = |x| (slip). In the eigenbasis S = U diag(lambda) U', c = U'q,
/// rho is the unique positive root of phi(rho) = sum_i c_i^2 / (lambda_i rho + s)^2 - 1, which is
/// convex and decreasing with phi(0) = |q|^2 / s^2 - 1 > 0; Newton's method from rho = 0 increases
/// monotonically to it. In one tangential dimension (d = 2) the root is explicit:
/// x = sign(q) (|q| - s) / S.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <cmath>

namespace obs {

/// argmin over x in R^m of 1/2 x'Sx - q'x + s|x| (S symmetric positive definite, s >= 0).
template <int m>
Eigen::Matrix<double, m, 1> shrink(const Eigen::Matrix<double, m, m>& S, const Eigen::Matrix<double, m, 1>& q,
                                   double s) {
  using Vec = Eigen::Matrix<double, m, 1>;
  const double qn = q.norm();
  if (qn <= s) return Vec::Zero();  // stick (also q = 0 with s = 0)
  if (s == 0) return S.ldlt().solve(q);  // frictionless: no shrinkage
  if constexpr (m == 1) {
    Vec x;
    x[0] = (q[0] > 0 ? qn - s : s - qn) / S(0, 0);
    return x;
  } else {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, m, m>> eig(S);
    const Vec lambda = eig.eigenvalues();
    const Vec c = eig.eigenvectors().transpose() * q;
    // Newton on phi(rho) = sum c_i^2 / (lambda_i rho + s)^2 - 1 from rho = 0 (monotone, quadratic)
    double rho = 0;
    for (int it = 0; it < 100; ++it) {
      double phi = -1, dphi = 0;
      for (int i = 0; i < m; ++i) {
        const double a = lambda[i] * rho + s;
        phi += c[i] * c[i] / (a * a);
        dphi -= 2 * lambda[i] * c[i] * c[i] / (a * a * a);
      }
      const double next = rho - phi / dphi;
      if (!(next > rho)) break;  // converged: the iterates increase until round-off stops them
      rho = next;
    }
    Vec y;
    for (int i = 0; i < m; ++i) y[i] = c[i] * rho / (lambda[i] * rho + s);
    return eig.eigenvectors() * y;
  }
}

/// argmin of 1/2 v'Dv - r'v + s|v_T| subject to v_1 <= g (see the file comment; g = +inf: no bound).
template <int d>
Eigen::Matrix<double, d, 1> solveFrictionBlock(const Eigen::Matrix<double, d, d>& D, const Eigen::Matrix<double, d, 1>& r,
                                               double g, double s) {
  constexpr int m = d - 1;
  using Vec = Eigen::Matrix<double, d, 1>;
  using TVec = Eigen::Matrix<double, m, 1>;
  using TMat = Eigen::Matrix<double, m, m>;
  const double d11 = D(0, 0);
  const TVec dt1 = D.template block<m, 1>(1, 0);
  const TMat dtt = D.template block<m, m>(1, 1);
  Vec v;
  // 1. the normal component free
  const TMat S = dtt - dt1 * dt1.transpose() / d11;
  const TVec q = r.template tail<m>() - dt1 * (r[0] / d11);
  const TVec x = shrink<m>(S, q, s);
  v[0] = (r[0] - dt1.dot(x)) / d11;
  if (v[0] <= g) {
    v.template tail<m>() = x;
    return v;
  }
  // 2. the bound active
  v[0] = g;
  v.template tail<m>() = shrink<m>(dtt, TVec(r.template tail<m>() - dt1 * g), s);
  return v;
}

}  // namespace obs
