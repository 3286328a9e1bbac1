#pragma once
/// \file EstimatorTestSupport.hpp
/// Helpers shared by the estimator tests, independent of the library's own quadrature.
#include <functional>

namespace obs::test {

/// Composite 5-point Gauss-Legendre on [a, b] with n panels (independent of mesh::quadratureRule).
inline double integrate(const std::function<double(double)>& f, double a, double b, int n) {
  static const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                              0.9061798459386640};
  static const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                              0.4786286704993665, 0.2369268850561891};
  double s = 0, h = (b - a) / n;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 5; ++k) s += 0.5 * h * w[k] * f(a + h * (i + 0.5 + 0.5 * x[k]));
  return s;
}

}  // namespace obs::test
