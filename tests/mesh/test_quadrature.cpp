// Quadrature exactness: every rule integrates the monomials of its stated exactness class exactly
// (Quadrature.hpp), for all degrees 0..12; weights are positive and points interior.
#include <gtest/gtest.h>

#include <cmath>
#include <thread>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Quadrature.hpp"

using namespace obs::mesh;

namespace {

double fact(int n) { return std::tgamma(n + 1.0); }

/// Exact integral of x^a y^b z^c over the reference element.
double exactMonomial(CellType t, int a, int b, int c) {
  switch (t) {
    case CellType::Segment: return 1.0 / (a + 1);
    case CellType::Quadrilateral: return 1.0 / ((a + 1) * (b + 1));
    case CellType::Hexahedron: return 1.0 / ((a + 1) * (b + 1) * (c + 1));
    case CellType::Triangle: return fact(a) * fact(b) / fact(a + b + 2);
    case CellType::Tetrahedron: return fact(a) * fact(b) * fact(c) / fact(a + b + c + 3);
    case CellType::Prism: return fact(a) * fact(b) / fact(a + b + 2) / (c + 1);
    case CellType::Pyramid:
      return fact(c) * fact(a + b + 2) / (fact(a + b + c + 3) * (a + 1) * (b + 1));
  }
  return 0;
}

/// Is x^a y^b z^c in the exactness class of degree k for this type (Quadrature.hpp)?
bool inClass(CellType t, int a, int b, int c, int k) {
  switch (t) {
    case CellType::Segment: return a <= k && b == 0 && c == 0;
    case CellType::Quadrilateral: return a <= k && b <= k && c == 0;
    case CellType::Hexahedron: return a <= k && b <= k && c <= k;
    case CellType::Triangle: return a + b <= k && c == 0;
    case CellType::Prism: return a + b <= k && c <= k;
    case CellType::Tetrahedron:
    case CellType::Pyramid: return a + b + c <= k;
  }
  return false;
}

double integrate(const QuadratureRule& q, int a, int b, int c) {
  double s = 0;
  for (std::size_t i = 0; i < q.size(); ++i)
    s += q.weights[i] * std::pow(q.points[i][0], a) * std::pow(q.points[i][1], b) *
         std::pow(q.points[i][2], c);
  return s;
}

class QuadratureTest : public ::testing::TestWithParam<CellType> {};

TEST_P(QuadratureTest, ExactForStatedClass) {
  const CellType t = GetParam();
  const int dim = dimension(t);
  for (int k = 0; k <= 12; ++k) {
    const auto& q = quadratureRule(t, k);
    EXPECT_EQ(q.degree, k);
    for (int a = 0; a <= k + 1; ++a)
      for (int b = 0; b <= (dim > 1 ? k + 1 : 0); ++b)
        for (int c = 0; c <= (dim > 2 ? k + 1 : 0); ++c) {
          const double exact = exactMonomial(t, a, b, c);
          const double err = std::abs(integrate(q, a, b, c) - exact) / exact;
          if (inClass(t, a, b, c, k)) {
            EXPECT_LT(err, 1e-13) << name(t) << " degree " << k << " monomial " << a << b << c;
          }
        }
  }
}

TEST_P(QuadratureTest, PositiveWeightsInteriorPoints) {
  const CellType t = GetParam();
  for (int k = 0; k <= 12; ++k) {
    const auto& q = quadratureRule(t, k);
    for (std::size_t i = 0; i < q.size(); ++i) {
      EXPECT_GT(q.weights[i], 0);
      const Point& p = q.points[i];
      for (int d = 0; d < dimension(t); ++d) {
        EXPECT_GT(p[d], 0);
        EXPECT_LT(p[d], 1);
      }
    }
  }
}

TEST(Quadrature, RejectsBadDegree) {
  EXPECT_THROW(quadratureRule(CellType::Triangle, -1), obs::Error);
  EXPECT_THROW(quadratureRule(CellType::Triangle, 31), obs::Error);
}

// The rules are built on first use and then read without a lock: threads asking at once for the
// same, not yet built rules all get the one rule object.
TEST(Quadrature, ConcurrentFirstUseGivesOneRulePerTypeAndDegree) {
  constexpr int kThreads = 4;
  std::vector<std::vector<const QuadratureRule*>> seen(kThreads);
  std::vector<std::thread> pool;
  for (int t = 0; t < kThreads; ++t)
    pool.emplace_back([&seen, t] {
      for (int degree = 30; degree >= 0; --degree)  // high degrees: not used by the other tests
        for (CellType type : kAllCellTypes) seen[t].push_back(&quadratureRule(type, degree));
    });
  for (std::thread& th : pool) th.join();
  for (int t = 1; t < kThreads; ++t) EXPECT_EQ(seen[t], seen[0]);
  std::size_t k = 0;
  for (int degree = 30; degree >= 0; --degree)
    for (CellType type : kAllCellTypes) {
      EXPECT_EQ(&quadratureRule(type, degree), seen[0][k]);
      EXPECT_FALSE(seen[0][k++]->points.empty());
    }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, QuadratureTest,
                         ::testing::ValuesIn(kAllCellTypes),
                         [](const auto& info) { return std::string(name(info.param)); });

}  // namespace
