// The local Tresca problem of a contact vertex (FrictionBlock.hpp): its exact optimality conditions
// on random data, the stick / slip / frictionless limits, and its scale invariance.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <random>

#include "obs/obs/FrictionBlock.hpp"

namespace {

template <int d>
struct Case {
  Eigen::Matrix<double, d, d> D;
  Eigen::Matrix<double, d, 1> r;
  double g = 0, s = 0;
};

template <int d>
Case<d> randomCase(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Case<d> c;
  Eigen::Matrix<double, d, d> B;
  for (int i = 0; i < d; ++i)
    for (int j = 0; j < d; ++j) B(i, j) = u(rng);
  c.D = B * B.transpose() + 0.1 * Eigen::Matrix<double, d, d>::Identity();  // SPD, condition up to ~1e2
  for (int i = 0; i < d; ++i) c.r[i] = u(rng);
  c.g = 0.5 * u(rng);
  c.s = std::abs(u(rng));
  return c;
}

/// The KKT conditions of min 1/2 v'Dv - r'v + s|v_T| s.t. v_1 <= g at v, to the tolerance tol of the
/// data's scale: lambda = (r - Dv)_1 >= 0 with lambda (g - v_1) = 0, and t = (r - Dv)_T in s d|v_T|.
template <int d>
void expectOptimal(const Case<d>& c, const Eigen::Matrix<double, d, 1>& v, const std::string& what) {
  const double scale = c.r.norm() + c.D.norm() * v.norm() + c.s;
  const double tol = 1e-12 * scale;
  const Eigen::Matrix<double, d, 1> res = c.r - c.D * v;
  EXPECT_LE(v[0], c.g + 1e-13 * (std::abs(c.g) + v.norm())) << what;
  EXPECT_GE(res[0], -tol) << what << ": the normal multiplier is negative";
  EXPECT_LE(std::abs(res[0] * (c.g - v[0])), tol * (std::abs(c.g) + v.norm() + 1)) << what;
  const Eigen::Matrix<double, d - 1, 1> t = res.template tail<d - 1>(), vt = v.template tail<d - 1>();
  if (vt.norm() == 0) {
    EXPECT_LE(t.norm(), c.s + tol) << what << ": stick needs |t| <= s";
  } else {
    EXPECT_LE((t - c.s * vt / vt.norm()).norm(), tol) << what << ": slip needs t = s v_T / |v_T|";
  }
}

template <int d>
void randomCases() {
  std::mt19937 rng(20261128 + d);
  int stick = 0, slip = 0, active = 0;
  for (int k = 0; k < 2000; ++k) {
    Case<d> c = randomCase<d>(rng);
    if (k % 4 == 1) c.s *= 1e-3;  // nearly frictionless
    if (k % 4 == 2) c.s *= 10;    // mostly stick
    const auto v = obs::solveFrictionBlock<d>(c.D, c.r, c.g, c.s);
    expectOptimal<d>(c, v, "case " + std::to_string(k));
    (v.template tail<d - 1>().norm() == 0 ? stick : slip) += 1;
    active += v[0] == c.g;
  }
  // the cases cover both branches of both alternatives
  EXPECT_GT(stick, 100);
  EXPECT_GT(slip, 100);
  EXPECT_GT(active, 100);
  EXPECT_LT(active, 1900);
}

}  // namespace

TEST(FrictionBlock, OptimalOnRandomData2D) { randomCases<2>(); }
TEST(FrictionBlock, OptimalOnRandomData3D) { randomCases<3>(); }

TEST(FrictionBlock, FrictionlessIsTheBoundConstrainedSolve) {
  // s = 0: the projected block solve of the frictionless smoother (free solve, else clamp and solve
  // the tail), to round-off
  std::mt19937 rng(7);
  for (int k = 0; k < 200; ++k) {
    Case<3> c = randomCase<3>(rng);
    const auto v = obs::solveFrictionBlock<3>(c.D, c.r, c.g, 0.0);
    Eigen::Vector3d w = c.D.ldlt().solve(c.r);
    if (w[0] > c.g) {
      w[0] = c.g;
      w.tail<2>() = c.D.block<2, 2>(1, 1).ldlt().solve(Eigen::Vector2d(c.r.tail<2>() - c.D.block<2, 1>(1, 0) * c.g));
    }
    EXPECT_LE((v - w).norm(), 1e-13 * (1 + w.norm())) << k;
  }
}

TEST(FrictionBlock, LargeBoundSticksExactly) {
  // s above |(r - D v)_T| of the stick solution: the tangential components are exactly zero
  std::mt19937 rng(11);
  for (int k = 0; k < 200; ++k) {
    Case<3> c = randomCase<3>(rng);
    c.s = 1e3 * (c.r.norm() + c.D.norm());
    const auto v = obs::solveFrictionBlock<3>(c.D, c.r, c.g, c.s);
    EXPECT_EQ(v[1], 0.0);
    EXPECT_EQ(v[2], 0.0);
    EXPECT_LE(v[0], c.g);
  }
}

TEST(FrictionBlock, IsotropicSlipIsAlongTheLoad) {
  // D = I, no bound: v_T = (1 - s / |r_T|) r_T (the shrinkage of the load), v_1 = r_1
  const Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d r(0.3, 3.0, 4.0);
  const auto v = obs::solveFrictionBlock<3>(D, r, 1e300, 2.0);
  EXPECT_NEAR(v[0], 0.3, 1e-15);
  EXPECT_NEAR(v[1], 3.0 * 3.0 / 5.0, 1e-14);
  EXPECT_NEAR(v[2], 4.0 * 3.0 / 5.0, 1e-14);
}

TEST(FrictionBlock, ScaleInvariant) {
  // D -> a D, r -> a b r, s -> a b s, g -> b g scales v by b (units of stiffness and length)
  std::mt19937 rng(3);
  for (int k = 0; k < 200; ++k) {
    const Case<3> c = randomCase<3>(rng);
    const double a = 1e7, b = 1e-4;
    const auto v = obs::solveFrictionBlock<3>(c.D, c.r, c.g, c.s);
    const auto w = obs::solveFrictionBlock<3>(Eigen::Matrix3d(a * c.D), Eigen::Vector3d(a * b * c.r), b * c.g, a * b * c.s);
    EXPECT_LE((w - b * v).norm(), 1e-12 * b * (1 + v.norm())) << k;
  }
}
