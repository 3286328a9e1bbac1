// Obstacles from surface meshes (SurfaceObstacle.hpp): the gap of a planar surface equals the plane
// obstacle's to round-off (also inclined and with a direction oblique to the plane), the bounding-
// volume hierarchy finds the same crossings as testing every face (also for lines through shared
// edges and vertices), closed surfaces give negative gaps inside, a polygon converges to the disk at
// O(h^2), `reverse` equals reordering the faces, and every defect of a surface is one obs::Error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/SurfaceMesh.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/SurfaceObstacle.hpp"

using namespace obs;
using mesh::CellType;
using mesh::SurfaceMesh;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

template <class F>
void expectErrorMentioning(F f, const std::string& word) {
  try {
    f();
    ADD_FAILURE() << "no obs::Error thrown (expected one mentioning '" << word << "')";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
}

/// A grid of n x n quadrilaterals (or 2 n^2 triangles) over [-L, L]^2 in the frame (origin, e1, e2),
/// lifted by height(s1, s2) along e1 x e2; counterclockwise seen from the side e1 x e2 points to.
template <class Height>
SurfaceMesh gridSurface(int n, double L, const Point& origin, const Point& e1, const Point& e2,
                        Height height, bool triangles) {
  SurfaceMesh s;
  s.dimension = 3;
  s.source = "grid";
  const Point normal = e1.cross(e2);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double s1 = -L + 2 * L * i / n, s2 = -L + 2 * L * j / n;
      s.vertices.push_back(origin + s1 * e1 + s2 * e2 + height(s1, s2) * normal);
    }
  auto v = [n](int i, int j) { return static_cast<mesh::Index>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (triangles) {
        s.types.push_back(CellType::Triangle);
        s.faces.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1), -1});
        s.types.push_back(CellType::Triangle);
        s.faces.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1), -1});
      } else {
        s.types.push_back(CellType::Quadrilateral);
        s.faces.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)});
      }
    }
  return s;
}

SurfaceMesh flatSquare(int n, double L, double z, bool triangles) {
  return gridSurface(n, L, Point(0, 0, z), Point::UnitX(), Point::UnitY(),
                     [](double, double) { return 0.0; }, triangles);
}

/// The unit cube [0,1]^3 as 6 outward quadrilaterals.
SurfaceMesh unitCube() {
  SurfaceMesh s;
  s.dimension = 3;
  s.source = "cube";
  for (int k = 0; k < 8; ++k) s.vertices.push_back(Point(k & 1, (k >> 1) & 1, (k >> 2) & 1));
  const std::array<std::array<mesh::Index, 4>, 6> quads{{{0, 2, 3, 1},   // z = 0, normal -z
                                                          {4, 5, 7, 6},   // z = 1, normal +z
                                                          {0, 1, 5, 4},   // y = 0, normal -y
                                                          {2, 6, 7, 3},   // y = 1, normal +y
                                                          {0, 4, 6, 2},   // x = 0, normal -x
                                                          {1, 3, 7, 5}}}; // x = 1, normal +x
  for (const auto& q : quads) {
    s.types.push_back(CellType::Quadrilateral);
    s.faces.push_back(q);
  }
  return s;
}

/// A closed polygon with n counterclockwise segments inscribed in the circle (centre, radius).
SurfaceMesh polygon(int n, const Point& centre, double radius) {
  SurfaceMesh s;
  s.dimension = 2;
  s.source = "polygon";
  for (int k = 0; k < n; ++k) {
    const double phi = 2 * std::numbers::pi * k / n;
    s.vertices.push_back(centre + radius * Point(std::cos(phi), std::sin(phi), 0));
    s.types.push_back(CellType::Segment);
    s.faces.push_back({k, (k + 1) % n, -1, -1});
  }
  return s;
}

}  // namespace

TEST(SurfaceObstacle, FlatSurfaceEqualsPlaneObstacle) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (bool triangles : {false, true}) {
    const SurfaceObstacle surface(flatSquare(8, 2, 0.3, triangles), Point(0, 0, -2));
    const PlaneObstacle plane(Point(0, 0, 0.3), Point(0, 0, -1));
    EXPECT_EQ(surface.numTriangles(), triangles ? 128 : 128);
    EXPECT_EQ(surface.dimension(), 3);
    EXPECT_TRUE(surface.direction(Point(1, 2, 3)).isApprox(Point(0, 0, -1)));
    for (int k = 0; k < 200; ++k) {
      const Point x(u(rng), u(rng), u(rng));  // above and below (penetrating) the surface
      EXPECT_NEAR(surface.gap(x), plane.gap(x), 1e-14) << x.transpose();
    }
    // on grid lines and vertices, where the line meets several faces
    for (const Point& x : {Point(0, 0, 1), Point(0.5, 0.5, 0.7), Point(0.5, 0.1, 0.2), Point(-2, -2, 1)})
      EXPECT_NEAR(surface.gap(x), plane.gap(x), 1e-14) << x.transpose();
    // beside the surface the line misses it
    EXPECT_EQ(surface.gap(Point(2.5, 0, 1)), kInf);
  }
}

TEST(SurfaceObstacle, InclinedSurfaceAndObliqueDirection) {
  const Point n = Point(1, -2, 3).normalized();
  const Point e1 = n.cross(Point::UnitX()).normalized(), e2 = n.cross(e1);  // e1 x e2 = n
  const Point origin(0.2, -0.1, 0.4);
  const SurfaceMesh s = gridSurface(6, 3, origin, e1, e2, [](double, double) { return 0.0; }, true);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  // along the normal: the plane obstacle
  const SurfaceObstacle normal(s, -n);
  const PlaneObstacle plane(origin, -n);
  // oblique: t with (x + t nu - origin) . n = 0
  const Point nu = (-n + 0.4 * e1 - 0.3 * e2).normalized();
  const SurfaceObstacle oblique(s, nu);
  for (int k = 0; k < 200; ++k) {
    const Point x = origin + Point(u(rng), u(rng), u(rng));
    EXPECT_NEAR(normal.gap(x), plane.gap(x), 1e-14);
    EXPECT_NEAR(oblique.gap(x), (origin - x).dot(n) / nu.dot(n), 1e-13);
  }
}

TEST(SurfaceObstacle, HierarchyFindsWhatTestingEveryFaceFinds) {
  // a bumpy surface of 3200 triangles and a closed cube below it
  const SurfaceMesh bumps = gridSurface(40, 1, Point::Zero(), Point::UnitX(), Point::UnitY(),
                                        [](double a, double b) { return 0.2 * std::sin(5 * a) * std::cos(3 * b); }, true);
  const Point nu = Point(0.3, -0.2, -1).normalized();
  const SurfaceObstacle surface(bumps, nu);
  EXPECT_EQ(surface.numTriangles(), 3200);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  std::uniform_int_distribution<int> grid(-20, 20);
  int hits = 0;
  for (int k = 0; k < 2000; ++k) {
    // every other point on a grid vertex of the surface's parameter plane (lines through vertices)
    const Point x = k % 2 ? Point(u(rng), u(rng), u(rng)) : Point(grid(rng) / 20.0, grid(rng) / 20.0, 0.5);
    const auto fast = surface.crossings(x);
    const auto slow = surface.crossingsBruteForce(x);
    ASSERT_EQ(fast.size(), slow.size()) << x.transpose();
    for (std::size_t i = 0; i < fast.size(); ++i) {
      EXPECT_EQ(fast[i].t, slow[i].t);
      EXPECT_EQ(fast[i].entry, slow[i].entry);
    }
    EXPECT_LE(fast.size(), 2u);  // an open height field: at most one crossing (two at a fold)
    hits += !fast.empty();
  }
  EXPECT_GT(hits, 1000);
}

TEST(SurfaceObstacle, ClosedSurfaceGivesNegativeGapInside) {
  const SurfaceObstacle cube(unitCube(), Point(0, 0, -1));
  EXPECT_EQ(cube.numTriangles(), 12);
  EXPECT_NEAR(cube.gap(Point(0.3, 0.6, 1.5)), 0.5, 1e-15);   // above: distance to the top
  EXPECT_NEAR(cube.gap(Point(0.3, 0.6, 0.75)), -0.25, 1e-15);  // inside: pushed out through the top
  EXPECT_EQ(cube.gap(Point(0.3, 0.6, -0.5)), kInf);          // below, pressing away from the cube
  EXPECT_EQ(cube.gap(Point(1.3, 0.6, 2)), kInf);             // beside it
  // through the diagonal of the split top face and through a top vertex: one entry, one exit
  EXPECT_EQ(cube.crossings(Point(0.4, 0.4, 2)).size(), 2u);
  EXPECT_EQ(cube.crossings(Point(1, 1, 2)).size(), 2u);
  EXPECT_NEAR(cube.gap(Point(0.4, 0.4, 2)), 1, 1e-15);
  // sideways: the faces x = 0 and x = 1
  const SurfaceObstacle side(unitCube(), Point(1, 0, 0));
  EXPECT_NEAR(side.gap(Point(-0.5, 0.5, 0.5)), 0.5, 1e-15);
  EXPECT_NEAR(side.gap(Point(0.9, 0.5, 0.5)), -0.9, 1e-15);
}

TEST(SurfaceObstacle, PolygonConvergesToTheDiskQuadratically) {
  // body above the disk of radius 1 at the origin, nu = -e_y, points over the middle half
  const DiskObstacle disk(Point::Zero(), 1.0);
  std::vector<double> errors;
  for (int n : {32, 64, 128, 256}) {
    const SurfaceObstacle poly(polygon(n, Point::Zero(), 1.0), Point(0, -1, 0));
    EXPECT_EQ(poly.dimension(), 2);
    double error = 0;
    for (int k = 0; k <= 100; ++k) {
      const Point x(-0.5 + k / 100.0, 1.2, 0);
      const double g = poly.gap(x);
      EXPECT_GE(g, disk.gap(x) - 1e-14);  // an inscribed polygon lies inside the disk
      error = std::max(error, g - disk.gap(x));
    }
    errors.push_back(error);
  }
  for (std::size_t i = 1; i < errors.size(); ++i) {
    const double rate = std::log2(errors[i - 1] / errors[i]);
    if (std::getenv("OBS_TEST_VERBOSE"))
      std::printf("polygon of %d segments: max gap error %.3e, rate %.3f\n", 32 << i, errors[i], rate);
    EXPECT_NEAR(rate, 2.0, 0.15) << "n = " << (32 << i);
  }
  // inside the polygon: the entry through the top (vertex 16 of 64 at (0, 1)), negative
  const SurfaceObstacle poly(polygon(64, Point::Zero(), 1.0), Point(0, -1, 0));
  EXPECT_NEAR(poly.gap(Point(0, 0.5, 0)), -0.5, 1e-14);
  EXPECT_EQ(poly.crossings(Point(0, 0.5, 0)).size(), 2u);  // the two segments at the vertex count once
}

TEST(SurfaceObstacle, ReverseEqualsReorderedFaces) {
  SurfaceMesh down = flatSquare(4, 1, 0, true);
  for (auto& f : down.faces) std::swap(f[1], f[2]);  // now clockwise seen from above
  const Point x(0.3, 0.2, 0.5);
  const SurfaceObstacle wrong(down, Point(0, 0, -1));
  EXPECT_TRUE(wrong.seesOnlyBackFaces(x));
  EXPECT_EQ(wrong.gap(x), kInf);
  const SurfaceObstacle fixed(down, Point(0, 0, -1), true);
  EXPECT_FALSE(fixed.seesOnlyBackFaces(x));
  EXPECT_NEAR(fixed.gap(x), 0.5, 1e-15);
}

TEST(SurfaceObstacle, DefectsAreErrors) {
  const Point down(0, 0, -1);
  {
    SurfaceMesh s = flatSquare(2, 1, 0, false);
    std::swap(s.faces[1][1], s.faces[1][3]);  // one face flipped
    expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "oriented oppositely");
  }
  {
    SurfaceMesh s = flatSquare(1, 1, 0, true);
    s.vertices.push_back(Point(0, 0, 1));  // a fin on the diagonal (0, 3): three faces at an edge
    s.types.push_back(CellType::Triangle);
    s.faces.push_back({0, 3, 4, -1});
    expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "shared by 3 faces");
  }
  {
    SurfaceMesh s = flatSquare(1, 1, 0, true);
    s.faces[0] = {0, 1, 1, -1};
    expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "degenerate");
  }
  {
    SurfaceMesh s = flatSquare(3, 1, 0, false);
    s.faces.erase(s.faces.begin() + 4);  // the middle quadrilateral: a hole
    s.types.erase(s.types.begin() + 4);
    expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "has a hole");
  }
  {
    SurfaceMesh s = flatSquare(1, 1, 0, true);
    s.vertices[2][2] = std::nan("");
    expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "non-finite");
  }
  {
    SurfaceMesh s = flatSquare(1, 1, 0, true);
    s.faces[0][2] = 17;
    expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "does not exist");
  }
  {
    SurfaceMesh s = polygon(8, Point::Zero(), 1);
    s.vertices[3][2] = 0.5;
    expectErrorMentioning([&] { SurfaceObstacle(s, Point(0, -1, 0)); }, "z != 0");
  }
  expectErrorMentioning([&] { SurfaceObstacle(flatSquare(1, 1, 0, true), Point::Zero()); }, "non-zero");
  expectErrorMentioning([&] { SurfaceObstacle(SurfaceMesh{}, down); }, "no faces");
  // a face of the wrong kind for the dimension
  SurfaceMesh s = polygon(8, Point::Zero(), 1);
  s.dimension = 3;
  expectErrorMentioning([&] { SurfaceObstacle(s, down); }, "expected triangles or quadrilaterals");
}

// --- closest-point mode (signed distance) ---------------------------------------------------------

TEST(SurfaceObstacle, ClosestPointModeIsTheSignedDistance) {
  const SurfaceObstacle cube(unitCube(), SurfaceObstacle::ClosestPoint{});
  EXPECT_TRUE(cube.closestPointMode());
  // above the top face, and inside below it: the same direction -e_z (into the obstacle)
  EXPECT_NEAR(cube.gap(Point(0.4, 0.5, 1.3)), 0.3, 1e-15);
  EXPECT_TRUE(cube.direction(Point(0.4, 0.5, 1.3)).isApprox(Point(0, 0, -1)));
  EXPECT_NEAR(cube.gap(Point(0.4, 0.5, 0.9)), -0.1, 1e-15);
  EXPECT_TRUE(cube.direction(Point(0.4, 0.5, 0.9)).isApprox(Point(0, 0, -1)));
  // beside the cube, and at a corner: towards the nearest point
  EXPECT_NEAR(cube.gap(Point(1.25, 0.5, 0.5)), 0.25, 1e-15);
  EXPECT_TRUE(cube.direction(Point(1.25, 0.5, 0.5)).isApprox(Point(-1, 0, 0)));
  EXPECT_NEAR(cube.gap(Point(1.2, 1.2, 1.2)), 0.2 * std::sqrt(3.0), 1e-14);
  EXPECT_TRUE(cube.direction(Point(1.2, 1.2, 1.2)).isApprox(Point(-1, -1, -1).normalized()));
  // on the surface: gap 0, the inward normal; below the cube it is finite (unlike a fixed direction)
  EXPECT_NEAR(cube.gap(Point(0.3, 0.7, 1)), 0, 1e-15);
  EXPECT_TRUE(cube.direction(Point(0.3, 0.7, 1)).isApprox(Point(0, 0, -1)));
  EXPECT_NEAR(cube.gap(Point(0.5, 0.5, -0.5)), 0.5, 1e-15);
  EXPECT_TRUE(cube.direction(Point(0.5, 0.5, -0.5)).isApprox(Point(0, 0, 1)));
  // deep inside: the nearest face decides (x = 0.1 is nearest to the face x = 0)
  EXPECT_NEAR(cube.gap(Point(0.1, 0.5, 0.4)), -0.1, 1e-15);
  EXPECT_TRUE(cube.direction(Point(0.1, 0.5, 0.4)).isApprox(Point(1, 0, 0)));
}

TEST(SurfaceObstacle, ClosestPointModeConvergesToTheDiskWithNormalDirections) {
  // DiskObstacle in "normal" mode is the exact signed distance with nu = (c - x)/|c - x|
  const DiskObstacle disk(Point::Zero(), 1.0, Point(0, -1, 0), BallObstacle::Direction::Normal);
  std::vector<double> gapErrors, directionErrors;
  for (int n : {32, 64, 128, 256}) {
    const SurfaceObstacle poly(polygon(n, Point::Zero(), 1.0), SurfaceObstacle::ClosestPoint{});
    double eg = 0, ed = 0;
    for (int k = 0; k < 200; ++k) {
      const double phi = 0.1 + 2 * std::numbers::pi * k / 200, r = 1.3 + 0.2 * std::sin(3.0 * k);
      const Point x(r * std::cos(phi), r * std::sin(phi), 0);
      eg = std::max(eg, std::abs(poly.gap(x) - disk.gap(x)));
      ed = std::max(ed, (poly.direction(x) - disk.direction(x)).norm());
    }
    gapErrors.push_back(eg);
    directionErrors.push_back(ed);
  }
  for (std::size_t i = 1; i < gapErrors.size(); ++i) {
    EXPECT_NEAR(std::log2(gapErrors[i - 1] / gapErrors[i]), 2.0, 0.2);  // O(h^2): the chord sag
    EXPECT_GT(std::log2(directionErrors[i - 1] / directionErrors[i]), 0.8);  // O(h): at least
  }
}

TEST(SurfaceObstacle, ClosedSurfaceTurnedInsideOutIsAnError) {
  SurfaceMesh inverted = unitCube();
  for (auto& q : inverted.faces) std::swap(q[1], q[3]);
  expectErrorMentioning([&] { SurfaceObstacle(inverted, Point(0, 0, -1)); }, "negative volume");
  expectErrorMentioning([&] { SurfaceObstacle(inverted, SurfaceObstacle::ClosestPoint{}); }, "set reverse = true");
  EXPECT_NO_THROW(SurfaceObstacle(inverted, SurfaceObstacle::ClosestPoint{}, true));
  SurfaceMesh clockwise = polygon(16, Point::Zero(), 1.0);
  for (auto& f : clockwise.faces) std::swap(f[0], f[1]);
  expectErrorMentioning([&] { SurfaceObstacle(clockwise, Point(0, -1, 0)); }, "negative area");
}
