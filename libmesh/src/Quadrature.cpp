// Quadrature rules on the reference elements (see Quadrature.hpp for the exactness statement).
//
// All rules are products of Gauss-Legendre rules on [0,1]: tensor products on quadrilaterals,
// hexahedra and prisms, and conical (collapsed, Stroud) products on simplices and pyramids, where the
// Jacobian of the collapse is absorbed by using more points in the collapsed directions:
//   triangle     x = u (1-v), y = v                           J = (1-v)
//   tetrahedron  x = u (1-v)(1-w), y = v (1-w), z = w         J = (1-v)(1-w)^2
//   pyramid      x = u (1-w), y = v (1-w), z = w               J = (1-w)^2
// A polynomial of total degree k becomes degree k in u, k + 1 in v (triangle) etc.; an n-point
// Gauss rule is exact to degree 2n - 1.
#include "obs/mesh/Quadrature.hpp"

#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <numbers>

#include "obs/mesh/Error.hpp"

namespace obs::mesh {
namespace {

struct Rule1D {
  std::vector<double> x, w;  // on [0,1]
};

/// n-point Gauss-Legendre rule on [0,1] (Newton iteration on the Legendre recurrence).
Rule1D gaussLegendre(int n) {
  Rule1D r;
  r.x.resize(n);
  r.w.resize(n);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double t = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = t;  // P_0, P_1
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1;
      // p1 = P_n(t), p0 = P_{n-1}(t)
      dp = n * (t * p1 - p0) / (t * t - 1);
      const double dt = p1 / dp;
      t -= dt;
      if (std::abs(dt) < 1e-16) break;
    }
    // recompute derivative at the converged root
    double p0 = 1, p1 = t;
    for (int k = 2; k <= n; ++k) {
      const double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k;
      p0 = p1;
      p1 = p2;
    }
    dp = n == 1 ? 1.0 : n * (t * p1 - p0) / (t * t - 1);
    const double w = 2 / ((1 - t * t) * dp * dp);
    // map [-1,1] -> [0,1]
    r.x[i] = 0.5 * (1 - t);
    r.x[n - 1 - i] = 0.5 * (1 + t);
    r.w[i] = r.w[n - 1 - i] = 0.5 * w;
  }
  return r;
}

/// Points needed for exactness `degree` in one direction.
int pointsFor(int degree) { return std::max(1, (degree + 2) / 2); }

QuadratureRule build(CellType type, int degree) {
  QuadratureRule q;
  q.type = type;
  q.degree = degree;
  auto add = [&](double x, double y, double z, double w) {
    q.points.emplace_back(x, y, z);
    q.weights.push_back(w);
  };
  // Simplices to degree 1: the centroid rule (exact for linear functions; the collapsed product
  // rules below would take 2 points on a triangle's edge direction and 4 on a tetrahedron)
  if (degree <= 1 && type == CellType::Triangle) {
    add(1.0 / 3, 1.0 / 3, 0, 0.5);
    return q;
  }
  if (degree <= 1 && type == CellType::Tetrahedron) {
    add(0.25, 0.25, 0.25, 1.0 / 6);
    return q;
  }
  const Rule1D a = gaussLegendre(pointsFor(degree));      // plain direction
  const Rule1D b = gaussLegendre(pointsFor(degree + 1));  // one collapse factor
  const Rule1D c = gaussLegendre(pointsFor(degree + 2));  // two collapse factors
  switch (type) {
    case CellType::Segment:
      for (std::size_t i = 0; i < a.x.size(); ++i) add(a.x[i], 0, 0, a.w[i]);
      break;
    case CellType::Quadrilateral:
      for (std::size_t j = 0; j < a.x.size(); ++j)
        for (std::size_t i = 0; i < a.x.size(); ++i) add(a.x[i], a.x[j], 0, a.w[i] * a.w[j]);
      break;
    case CellType::Hexahedron:
      for (std::size_t k = 0; k < a.x.size(); ++k)
        for (std::size_t j = 0; j < a.x.size(); ++j)
          for (std::size_t i = 0; i < a.x.size(); ++i)
            add(a.x[i], a.x[j], a.x[k], a.w[i] * a.w[j] * a.w[k]);
      break;
    case CellType::Triangle:
      for (std::size_t j = 0; j < b.x.size(); ++j)
        for (std::size_t i = 0; i < a.x.size(); ++i) {
          const double v = b.x[j];
          add(a.x[i] * (1 - v), v, 0, a.w[i] * b.w[j] * (1 - v));
        }
      break;
    case CellType::Tetrahedron:
      for (std::size_t k = 0; k < c.x.size(); ++k)
        for (std::size_t j = 0; j < b.x.size(); ++j)
          for (std::size_t i = 0; i < a.x.size(); ++i) {
            const double v = b.x[j], w = c.x[k];
            add(a.x[i] * (1 - v) * (1 - w), v * (1 - w), w,
                a.w[i] * b.w[j] * c.w[k] * (1 - v) * (1 - w) * (1 - w));
          }
      break;
    case CellType::Prism:
      for (std::size_t k = 0; k < a.x.size(); ++k)
        for (std::size_t j = 0; j < b.x.size(); ++j)
          for (std::size_t i = 0; i < a.x.size(); ++i) {
            const double v = b.x[j];
            add(a.x[i] * (1 - v), v, a.x[k], a.w[i] * b.w[j] * (1 - v) * a.w[k]);
          }
      break;
    case CellType::Pyramid:
      for (std::size_t k = 0; k < c.x.size(); ++k)
        for (std::size_t j = 0; j < a.x.size(); ++j)
          for (std::size_t i = 0; i < a.x.size(); ++i) {
            const double w = c.x[k];
            add(a.x[i] * (1 - w), a.x[j] * (1 - w), w,
                a.w[i] * a.w[j] * c.w[k] * (1 - w) * (1 - w));
          }
      break;
  }
  return q;
}

}  // namespace

const QuadratureRule& quadratureRule(CellType type, int degree) {
  if (degree < 0 || degree > 30)
    throw Error("quadratureRule: degree " + std::to_string(degree) + " outside [0, 30]");
  // Built once per (type, degree) under a lock; afterwards a lock-free read, since the residual
  // estimators ask for a rule per cell and per face on several threads.
  constexpr int kTypes = static_cast<int>(CellType::Pyramid) + 1;
  static std::array<std::array<std::atomic<const QuadratureRule*>, 31>, kTypes> ready{};
  static std::array<std::array<std::unique_ptr<const QuadratureRule>, 31>, kTypes> owned;
  static std::mutex mutex;
  const int t = static_cast<int>(type);
  if (t < 0 || t >= kTypes) throw Error("quadratureRule: unknown cell type " + std::to_string(t));
  std::atomic<const QuadratureRule*>& fast = ready[t][degree];
  if (const QuadratureRule* q = fast.load(std::memory_order_acquire)) return *q;
  std::lock_guard lock(mutex);
  std::unique_ptr<const QuadratureRule>& slot = owned[t][degree];
  if (!slot) {
    slot = std::make_unique<const QuadratureRule>(build(type, degree));
    fast.store(slot.get(), std::memory_order_release);
  }
  return *slot;
}

}  // namespace obs::mesh
