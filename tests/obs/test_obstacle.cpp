// Obstacles (gap and direction formulas, parameter validation) and the ContactSet built from them.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/Obstacle.hpp"

using namespace obs;
using mesh::CellType;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Runs f, expects an obs::Error whose message contains `word`.
template <class F>
void expectErrorMentioning(F f, const std::string& word) {
  try {
    f();
    ADD_FAILURE() << "no obs::Error thrown (expected one mentioning '" << word << "')";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
}

Point P(double x, double y, double z = 0) { return Point(x, y, z); }

}  // namespace

TEST(Obstacle, PlaneGapIsSignedDistanceAlongDirection) {
  const PlaneObstacle plane(P(0, -0.1), P(0, -2));  // y = -0.1 below a body, nu = -e_y (normalised)
  EXPECT_NEAR(plane.gap(P(0.3, 0)), 0.1, 1e-15);
  EXPECT_NEAR(plane.gap(P(0.3, 0.5)), 0.6, 1e-15);
  EXPECT_NEAR(plane.gap(P(0.3, -0.3)), -0.2, 1e-15);  // penetration: negative gap
  EXPECT_TRUE(plane.direction(P(7, 7)).isApprox(P(0, -1)));
  EXPECT_EQ(plane.name(), "plane");
  // oblique plane through the origin with nu = (1, -1)/sqrt 2
  const PlaneObstacle oblique(P(0, 0), P(1, -1));
  EXPECT_NEAR(oblique.gap(P(-1, 1)), std::sqrt(2.0), 1e-14);
}

TEST(Obstacle, StripIsAPunchWithInfiniteGapOutside) {
  // docs/theory.md#punch: g = 0 on x in [0.4375, 0.5625] of y = 0, constraint direction -e_y
  const StripObstacle punch(P(0.5, 0), 0.0625, P(0, -1));
  EXPECT_EQ(punch.gap(P(0.5, 0)), 0.0);
  EXPECT_EQ(punch.gap(P(0.4375, 0)), 0.0);  // band edge is included
  EXPECT_EQ(punch.gap(P(0.5625, 0)), 0.0);
  EXPECT_NEAR(punch.gap(P(0.45, 0.2)), 0.2, 1e-15);
  EXPECT_EQ(punch.gap(P(0.4, 0)), kInf);
  EXPECT_EQ(punch.gap(P(0.7, 0)), kInf);
  EXPECT_TRUE(punch.direction(P(0, 0)).isApprox(P(0, -1)));
  // thesis Example 4: finite gap outside, and a 3D strip along y
  const StripObstacle strip3(P(0.5, 0.5, 0), 0.3, P(0, 0, -1), Point::UnitX(), 0.5);
  EXPECT_EQ(strip3.gap(P(0.3, 0.9, 0)), 0.0);
  EXPECT_EQ(strip3.gap(P(0.9, 0.1, 0)), 0.5);
}

TEST(Obstacle, WedgeGivesSlopeTimesDistanceFromApex) {
  const WedgeObstacle wedge(P(0.5, 0), 0.2);  // docs/theory.md#wedge: g = 0.2 |x - 0.5| on y = 0
  for (double x : {0.0, 0.3, 0.5, 0.61, 1.0}) EXPECT_NEAR(wedge.gap(P(x, 0)), 0.2 * std::abs(x - 0.5), 1e-15);
  EXPECT_NEAR(wedge.gap(P(0.2, 0.1)), 0.1 + 0.06, 1e-15);
  EXPECT_TRUE(wedge.direction(P(0, 0)).isApprox(P(0, -1)));
}

TEST(Obstacle, BallReproducesTheHertzGap) {
  // docs/theory.md#hertz: ball of radius 0.75 touching (0.5, 0.5, 0) from below, g = R - sqrt(R^2 - r^2)
  const double R = 0.75;
  const BallObstacle ball(P(0.5, 0.5, -R), R);
  for (const Point& x : {P(0.5, 0.5, 0), P(0.6, 0.5, 0), P(0.3, 0.8, 0), P(1, 1, 0), P(0.5, 1.2, 0)}) {
    const double r2 = std::pow(x[0] - 0.5, 2) + std::pow(x[1] - 0.5, 2);
    EXPECT_NEAR(ball.gap(x), R - std::sqrt(R * R - r2), 1e-14) << x.transpose();
  }
  // above the surface: g = x_z - (c_z + sqrt(R^2 - r^2))
  EXPECT_NEAR(ball.gap(P(0.7, 0.5, 0.3)), 0.3 + R - std::sqrt(R * R - 0.04), 1e-14);
  // the vertical line misses the ball: unconstrained
  EXPECT_EQ(ball.gap(P(0.5 + 0.76, 0.5, 0)), kInf);
  EXPECT_EQ(ball.gap(P(1.1, 1.1, 0)), kInf);  // r = 0.8485 > R
  EXPECT_TRUE(ball.direction(P(0, 0, 0)).isApprox(P(0, 0, -1)));
  EXPECT_EQ(ball.dimension(), 3);
  // normal mode: distance to the sphere along the line to the centre
  const BallObstacle radial(P(0, 0, 0), 1.0, -Point::UnitZ(), BallObstacle::Direction::Normal);
  EXPECT_NEAR(radial.gap(P(0, 3, 4)), 4.0, 1e-14);
  EXPECT_TRUE(radial.direction(P(0, 3, 4)).isApprox(P(0, -0.6, -0.8)));
}

TEST(Obstacle, DiskIsTheTwoDimensionalBall) {
  const DiskObstacle disk(P(0.5, -1), 1.0);
  EXPECT_EQ(disk.name(), "disk");
  EXPECT_EQ(disk.dimension(), 2);
  EXPECT_NEAR(disk.gap(P(0.5, 0)), 0.0, 1e-15);
  EXPECT_NEAR(disk.gap(P(1.1, 0)), 1 - std::sqrt(1 - 0.36), 1e-14);
  EXPECT_EQ(disk.gap(P(1.6, 0)), kInf);
}

TEST(Obstacle, PyramidHatAndSineWaveHeights) {
  const PyramidObstacle pyramid(P(0.5, 0.5, 0), 1.0);  // 45 degrees (thesis Example 5)
  EXPECT_NEAR(pyramid.gap(P(0.5, 0.5, 0)), 0.0, 1e-15);
  EXPECT_NEAR(pyramid.gap(P(0.7, 0.6, 0)), 0.2, 1e-15);
  EXPECT_NEAR(pyramid.gap(P(0.4, 0.2, 0.1)), 0.1 + 0.3, 1e-15);

  const HatObstacle hat(P(0.5, 0.5, -0.1), 0.1, 0.4, P(0, 0, -1));  // crown top touches z = 0
  EXPECT_NEAR(hat.gap(P(0.5, 0.5, 0)), 0.0, 1e-15);
  EXPECT_NEAR(hat.gap(P(0.7, 0.5, 0)), 0.1 - 0.1 * 0.75 * 0.75, 1e-15);  // r/R = 1/2
  EXPECT_NEAR(hat.gap(P(0.95, 0.5, 0)), 0.1, 1e-15);                     // on the brim

  const SineWaveObstacle wave(P(0, -0.05), 0.05, 0.5, P(0, -1));  // crests touch y = 0
  EXPECT_NEAR(wave.gap(P(0, 0)), 0.0, 1e-15);
  EXPECT_NEAR(wave.gap(P(0.25, 0)), 0.1, 1e-15);  // trough
  EXPECT_NEAR(wave.gap(P(0.125, 0)), 0.05, 1e-15);
  EXPECT_NEAR(wave.gap(P(0.5, 0)), 0.0, 1e-15);
}

TEST(Obstacle, SmileyTouchesAlongOutlineEyesAndMouth) {
  // face of radius R = 0.4 centred under the bottom of the unit cube, ridges of slope 1/2, nu = -e_z
  // (t1 = e_x, t2 = e_y): eyes at (0.5 -+ 0.14, 0.62) of radius 0.04, mouth |s| = 0.24 at 210..330 deg
  const SmileyObstacle smiley(P(0.5, 0.5, 0), 0.4, 0.5);
  EXPECT_EQ(smiley.name(), "smiley");
  EXPECT_EQ(smiley.dimension(), 3);
  EXPECT_TRUE(smiley.direction(P(0.1, 0.2, 0)).isApprox(P(0, 0, -1)));
  // on the curves the gap is the height above the face plane
  EXPECT_NEAR(smiley.gap(P(0.9, 0.5, 0)), 0.0, 1e-15);                // outline, east
  EXPECT_NEAR(smiley.gap(P(0.5, 0.1, 0)), 0.0, 1e-15);                // outline, south
  EXPECT_NEAR(smiley.gap(P(0.64, 0.62, 0)), 0.0, 1e-15);              // right eye centre
  EXPECT_NEAR(smiley.gap(P(0.36 + 0.03, 0.62, 0)), 0.0, 1e-15);       // inside the left eye
  EXPECT_NEAR(smiley.gap(P(0.5, 0.26, 0)), 0.0, 1e-15);               // bottom of the mouth
  EXPECT_NEAR(smiley.gap(P(0.5, 0.26, 0.1)), 0.1, 1e-15);             // 0.1 above it
  // off the curves: slope times the distance to the nearest one
  EXPECT_NEAR(smiley.gap(P(0.5, 0.2, 0)), 0.5 * 0.06, 1e-15);         // mouth 0.06 away, outline 0.1
  EXPECT_NEAR(smiley.gap(P(0.5, 0.5, 0)), 0.5 * (std::hypot(0.14, 0.12) - 0.04), 1e-15);  // centre: eyes
  EXPECT_NEAR(smiley.gap(P(1.0, 1.0, 0)), 0.5 * (std::sqrt(0.5) - 0.4), 1e-15);  // corner: outline
  // beyond the mouth's right end (330 deg, at (0.5 + 0.24 cos 30, 0.5 - 0.12)): distance to the end
  const Point end(0.5 + 0.24 * std::cos(std::numbers::pi / 6), 0.38, 0);
  EXPECT_NEAR(smiley.gap(end + P(0.02, 0.02, 0)), 0.5 * std::hypot(0.02, 0.02), 1e-14);
  EXPECT_NEAR(smiley.distance(0.0, 0.0), std::hypot(0.14, 0.12) - 0.04, 1e-15);

  // another direction: contact on the right face x = 1, nu = +e_x; the frame is t1 = e_y (e_x is
  // parallel to nu), t2 = t1 x nu = -e_z, so "up" on the face (the eyes) is -z
  const SmileyObstacle side(P(1, 0.5, 0.5), 0.4, 2.0, P(2, 0, 0));
  EXPECT_TRUE(side.direction(P(1, 0, 0)).isApprox(P(1, 0, 0)));
  EXPECT_NEAR(side.gap(P(1, 0.64, 0.38)), 0.0, 1e-15);                // right eye (s = (0.14, 0.12))
  EXPECT_NEAR(side.gap(P(0.9, 0.5, 0.74)), 0.1, 1e-15);               // mouth bottom, 0.1 inside the body
}

TEST(Obstacle, FunctionObstacleCallsTheUserFunctions) {
  const FunctionObstacle f([](const Point& x) { return x[1] - x[0] * x[0]; },
                           [](const Point&) { return Point(0, -1, 0); }, "parabola", 2);
  EXPECT_NEAR(f.gap(P(0.5, 1)), 0.75, 1e-15);
  EXPECT_EQ(f.name(), "parabola");
  EXPECT_EQ(f.dimension(), 2);
}

TEST(Obstacle, InvalidParametersNameTheParameter) {
  expectErrorMentioning([] { BallObstacle(P(0, 0, 0), -1.0); }, "radius");
  expectErrorMentioning([] { DiskObstacle(P(0, 0), 0.0); }, "radius");
  expectErrorMentioning([] { BallObstacle(P(0, 0, 0), 1.0, P(0, 0, 0)); }, "direction");
  expectErrorMentioning([] { BallObstacle(P(0, kInf, 0), 1.0); }, "centre");
  expectErrorMentioning([] { PlaneObstacle(P(0, 0), P(0, 0)); }, "direction");
  expectErrorMentioning([] { PlaneObstacle(P(std::nan(""), 0), P(0, -1)); }, "point");
  expectErrorMentioning([] { StripObstacle(P(0.5, 0), 0.0, P(0, -1)); }, "halfWidth");
  expectErrorMentioning([] { StripObstacle(P(0.5, 0), 0.1, P(0, -1), P(1, 0), std::nan("")); }, "outsideGap");
  expectErrorMentioning([] { WedgeObstacle(P(0.5, 0), -0.2); }, "slope");
  expectErrorMentioning([] { PyramidObstacle(P(0.5, 0.5, 0), std::nan("")); }, "slope");
  expectErrorMentioning([] { HatObstacle(P(0, 0, 0), 0.1, -1.0, P(0, 0, -1)); }, "radius");
  expectErrorMentioning([] { SineWaveObstacle(P(0, 0), 0.1, 0.0, P(0, -1)); }, "wavelength");
  expectErrorMentioning([] { SmileyObstacle(P(0.5, 0.5, 0), 0.0, 1.0); }, "radius");
  expectErrorMentioning([] { SmileyObstacle(P(0.5, 0.5, 0), 0.4, -1.0); }, "slope");
  expectErrorMentioning([] { FunctionObstacle({}, [](const Point&) { return Point(0, -1, 0); }); }, "gap");
}

// --- ContactSet --------------------------------------------------------------------------------

TEST(ContactSet, BottomOfABoxWithMassesRotationsAndFaces) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, {4, 3, 1}, P(0, 0), P(2, 1));
  const DiskObstacle disk(P(1, -1), 1.0);
  const ContactSet cs(m, mesh::kBottom, disk);
  ASSERT_EQ(cs.size(), 5);
  EXPECT_EQ(cs.faces().size(), 4u);
  EXPECT_NEAR(cs.measure(), 2.0, 1e-14);
  double total = 0;
  for (Index k = 0; k < cs.size(); ++k) {
    total += cs.boundaryMass(k);
    const Point& x = cs.position(k);
    EXPECT_EQ(x[1], 0.0);
    EXPECT_EQ(cs.nodeOf(cs.vertex(k)), k);
    EXPECT_NEAR(cs.gap(k), disk.gap(x), 0);
    const Eigen::Matrix3d& Q = cs.rotation(k);
    EXPECT_TRUE((Q.transpose() * Q).isApprox(Eigen::Matrix3d::Identity(), 1e-14));
    EXPECT_TRUE((Q.col(0)).isApprox(cs.direction(k), 1e-14));
    EXPECT_NEAR(Q(2, 2), 1.0, 1e-15);  // 2D: Q e_3 = e_3
  }
  EXPECT_NEAR(total, 2.0, 1e-14);
  EXPECT_NEAR(cs.boundaryMass(0), 0.25, 1e-14);  // end node: half an edge of length 0.5
  EXPECT_NEAR(cs.boundaryMass(2), 0.5, 1e-14);
  EXPECT_EQ(cs.nodeOf(m.numVertices() - 1), -1);  // a top vertex
  // by name
  const ContactSet byName(m, "bottom", disk);
  EXPECT_EQ(byName.size(), 5);
}

TEST(ContactSet, LumpedMassesOnTriangularAndQuadrilateralFaces) {
  for (CellType t : {CellType::Hexahedron, CellType::Tetrahedron}) {
    const auto m = mesh::boxMesh(t, {2, 2, 1}, P(0, 0, 0), P(1, 2, 1));
    const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0, 0), P(0, 0, -1)));
    EXPECT_EQ(cs.size(), 9);
    double total = 0;
    for (Index k = 0; k < cs.size(); ++k) total += cs.boundaryMass(k);
    EXPECT_NEAR(total, 2.0, 1e-13) << mesh::name(t);
    EXPECT_NEAR(cs.measure(), 2.0, 1e-13);
    if (t == CellType::Hexahedron) {
      EXPECT_NEAR(cs.boundaryMass(4), 0.5, 1e-14);  // centre node: 4 quarters of 0.5
    }
  }
}

TEST(ContactSet, HouseholderRotationForEveryDirection) {
  for (const Point& nu : {P(1, 0, 0), P(-1, 0, 0), P(0, 0, -1), P(0.6, -0.8, 0), P(1, 1e-9, 0).normalized(),
                          P(1, 2, -3).normalized(), P(-1, 2, 3).normalized()}) {
    const Eigen::Matrix3d Q = householderRotation(nu);
    EXPECT_TRUE((Q.transpose() * Q).isApprox(Eigen::Matrix3d::Identity(), 1e-14)) << nu.transpose();
    EXPECT_LT((Q.col(0) - nu).norm(), 1e-15) << nu.transpose();
  }
}

TEST(ContactSet, BadInputIsAnError) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 2);
  const DiskObstacle disk(P(0.5, -1), 1.0);
  expectErrorMentioning([&] { ContactSet(m, 17, disk); }, "empty");
  expectErrorMentioning([&] { ContactSet(m, "floor", disk); }, "floor");
  expectErrorMentioning([&] { ContactSet(m, mesh::kBottom, BallObstacle(P(0.5, 0.5, -1), 1.0)); }, "dimension");
  const FunctionObstacle nanGap([](const Point&) { return std::nan(""); }, [](const Point&) { return P(0, -1); });
  expectErrorMentioning([&] { ContactSet(m, mesh::kBottom, nanGap); }, "gap");
  const FunctionObstacle zeroDir([](const Point&) { return 0.0; }, [](const Point&) { return P(0, 0); });
  expectErrorMentioning([&] { ContactSet(m, mesh::kBottom, zeroDir); }, "direction");
}
