// Curved mesh generators (ball, disk, half disk, rounded block): counts, conformity, orientation,
// boundary ids/names, vertices on the exact surfaces, projections (idempotent, closest point),
// volume convergence under uniform refinement with projected boundary vertices, bad arguments.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/RedRefinement.hpp"

using namespace obs::mesh;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kT = static_cast<int>(CellType::Tetrahedron),
              kH = static_cast<int>(CellType::Hexahedron), kPr = static_cast<int>(CellType::Prism),
              kPy = static_cast<int>(CellType::Pyramid);

using LevelSet = std::function<double(const Point&)>;  // signed distance to a curved surface

struct Case {
  std::string name{};
  std::function<CurvedMesh()> make{};
  double volume = 0.0;  // exact volume (area) of the domain
  Index vertices = 0;   // expected counts
  std::array<Index, 7> cells{};
  std::map<int, Index> facesPerId{};
  std::map<int, std::string> names{};
  std::map<int, LevelSet> surfaces{};  // curved boundary ids and their exact surfaces
  double size = 1.0;                   // length scale for tolerances and random points
  Point centre = Point::Zero();        // a point of the domain for random points
  // Required volume error reduction of the first refinement step (the second must reach 3).
  double firstReduction = 3.0;
};

const Point kBallCentre(0.5, -1.0, 2.0);
constexpr double kBallRadius = 1.5;
const Point kDiskCentre(-0.5, 1.0, 0.0);
constexpr double kDiskRadius = 2.0;

LevelSet sphere(const Point& c, double r, int dim) {
  return [=](const Point& x) { return (x - c).head(dim).norm() - r; };
}

std::string caseName(const char* geometry, CellType t, int n) {
  return std::string(geometry) + "_" + std::string(name(t)) + "_" + std::to_string(n);
}

Case ballCase(CellType t, int n) {
  const Index m = (n + 1) / 2, hexes = n * n * n + 6 * n * n * m;
  const Index lattice = (n + 1) * (n + 1) * (n + 1),
              surface = lattice - (n - 1) * (n - 1) * (n - 1);
  const bool centres = t == CellType::Pyramid || t == CellType::Tetrahedron;
  Case c{.name = caseName("ball", t, n),
         .make = [=] { return ballMesh(kBallCentre, kBallRadius, t, n); },
         .volume = 4.0 / 3.0 * kPi * std::pow(kBallRadius, 3),
         .vertices = lattice + m * surface + (centres ? hexes : 0),
         .names = {{kCurvedSurface, "surface"}},
         .surfaces = {{kCurvedSurface, sphere(kBallCentre, kBallRadius, 3)}},
         .size = kBallRadius,
         .centre = kBallCentre};
  const Index quads = 6 * n * n;  // outer block faces
  switch (t) {
    case CellType::Hexahedron:
      c.cells[kH] = hexes;
      c.facesPerId[1] = quads;
      break;
    case CellType::Pyramid:
      c.cells[kPy] = 6 * hexes;
      c.facesPerId[1] = quads;
      break;
    case CellType::Tetrahedron:
      c.cells[kT] = 12 * hexes;
      c.facesPerId[1] = 2 * quads;
      break;
    default:  // prisms: the +-z blocks run radially (triangulated outer faces), the others not
      c.cells[kPr] = 2 * hexes;
      c.facesPerId[1] = 2 * (2 * n * n) + 4 * n * n;
  }
  // With one cell the outer vertices are the corners of the inscribed cube, whose flat faces the
  // first refinement only starts to bend (error 8.94 -> 3.30 for r = 1.5, then ~4x per step).
  if (n == 1) c.firstReduction = 2.5;
  return c;
}

Case diskCase(CellType t, int n) {
  const Index m = (n + 1) / 2, split = t == CellType::Triangle ? 2 : 1;
  Case c{.name = caseName("disk", t, n),
         .make = [=] { return diskMesh(kDiskCentre, kDiskRadius, t, n); },
         .volume = kPi * kDiskRadius * kDiskRadius,
         .vertices = (n + 1) * (n + 1) + m * 4 * n,
         .facesPerId = {{kCurvedSurface, 4 * n}},
         .names = {{kCurvedSurface, "circle"}},
         .surfaces = {{kCurvedSurface, sphere(kDiskCentre, kDiskRadius, 2)}},
         .size = kDiskRadius,
         .centre = kDiskCentre};
  c.cells[static_cast<int>(t)] = split * (n * n + 4 * n * m);
  return c;
}

Case halfDiskCase(CellType t, int n) {
  const Index split = t == CellType::Triangle ? 2 : 1;
  Case c{.name = caseName("halfdisk", t, n),
         .make = [=] { return halfDiskMesh(kDiskCentre, kDiskRadius, t, n); },
         .volume = 0.5 * kPi * kDiskRadius * kDiskRadius,
         // inner 2n x n rectangle, then n layers of 4n + 1 vertices
         .vertices = (2 * n + 1) * (n + 1) + n * (4 * n + 1),
         .facesPerId = {{kCurvedSurface, 4 * n}, {kHalfDiskTop, 4 * n}},
         .names = {{kCurvedSurface, "arc"}, {kHalfDiskTop, "top"}},
         .surfaces = {{kCurvedSurface, sphere(kDiskCentre, kDiskRadius, 2)}},
         .size = kDiskRadius,
         .centre = kDiskCentre - Point(0, 0.5 * kDiskRadius, 0)};
  c.cells[static_cast<int>(t)] = split * 6 * n * n;
  return c;
}

// Rounded block: width 2, depth 1.5 and cells as below; R = 2.5 (shallow) or R = 1 (semicircle).
constexpr double kW = 2.0, kD = 1.5;
constexpr std::array<int, 3> kBlockCells = {4, 2, 3};

double roundedBlockArea(double W, double H, double R) {
  const double h = 0.5 * W;  // area of [0,W] x [z_b, H]
  return W * H - W * R + h * std::sqrt(R * R - h * h) + R * R * std::asin(h / R);
}

Case blockCase(CellType t, double R, double H) {
  const int dim = dimension(t), up = dim - 1;
  const Mesh box = boxMesh(t, kBlockCells, Point::Zero(), Point(kW, kD, 1.0));
  Case c{.name = "block_" + std::string(name(t)) + (R < kW ? "_semicircle" : ""),
         .make = [=] { return roundedBlockMesh(kW, H, kD, R, t, kBlockCells); },
         .volume = roundedBlockArea(kW, H, R) * (dim == 3 ? kD : 1.0),
         .vertices = box.numVertices(),
         .cells = box.cellCounts(),
         .names = box.boundaryNames(),
         .surfaces = {{kBottom,
                       [=](const Point& x) { return std::hypot(x[0] - 0.5 * kW, x[up] - R) - R; }}},
         .size = kW,
         .centre = dim == 3 ? Point(0.5 * kW, 0.5 * kD, 0.5 * H) : Point(0.5 * kW, 0.5 * H, 0)};
  for (Index f = 0; f < box.numBoundaryFaces(); ++f) ++c.facesPerId[box.boundaryFaceId(f)];
  return c;
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

std::vector<Case> cases() {
  std::vector<Case> out;
  for (CellType t :
       {CellType::Hexahedron, CellType::Tetrahedron, CellType::Prism, CellType::Pyramid})
    for (int n : {1, 2, 3}) out.push_back(ballCase(t, n));
  for (CellType t : {CellType::Quadrilateral, CellType::Triangle}) {
    for (int n : {1, 2, 3}) out.push_back(diskCase(t, n));
    for (int n : {1, 2}) out.push_back(halfDiskCase(t, n));
  }
  for (CellType t : kVolumeCellTypes) {
    out.push_back(blockCase(t, 2.5, 1.2));
    out.push_back(blockCase(t, 1.0, 1.5));
  }
  return out;
}

/// Moves every vertex of a boundary face with a projection onto its surface.
void projectBoundaryVertices(Mesh& mesh, const std::map<int, BoundaryProjection>& projections) {
  std::vector<char> done(mesh.numVertices(), 0);
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    const auto it = projections.find(mesh.boundaryFaceId(f));
    if (it == projections.end()) continue;
    for (Index v : mesh.boundaryFaceVertices(f))
      if (!done[v]) mesh.vertex(v) = it->second(mesh.vertex(v)), done[v] = 1;
  }
}

/// Largest distance of a vertex of a curved boundary face from its exact surface.
double maxSurfaceDistance(const Mesh& mesh, const std::map<int, LevelSet>& surfaces) {
  double worst = 0.0;
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    const auto it = surfaces.find(mesh.boundaryFaceId(f));
    if (it == surfaces.end()) continue;
    for (Index v : mesh.boundaryFaceVertices(f))
      worst = std::max(worst, std::abs(it->second(mesh.vertex(v))));
  }
  return worst;
}

Index countNotPositive(const Mesh& mesh) {
  Index bad = 0;
  for (Index c = 0; c < mesh.numCells(); ++c)
    bad += !isPositivelyOriented(mesh, c) || !(cellVolume(mesh, c) > 0.0);
  return bad;
}

class CurvedMeshTest : public ::testing::TestWithParam<Case> {
 protected:
  void SetUp() override { curved_ = GetParam().make(); }
  CurvedMesh curved_;
};

TEST_P(CurvedMeshTest, Counts) {
  const Case& c = GetParam();
  const Mesh& m = curved_.mesh;
  EXPECT_EQ(m.numVertices(), c.vertices);
  EXPECT_EQ(m.cellCounts(), c.cells);
  std::map<int, Index> faces;
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) ++faces[m.boundaryFaceId(f)];
  EXPECT_EQ(faces, c.facesPerId);
  EXPECT_EQ(m.boundaryNames(), c.names);
  // Exactly the curved ids have projections.
  std::vector<int> projected, curved;
  for (const auto& p : curved_.projections) projected.push_back(p.first);
  for (const auto& s : c.surfaces) curved.push_back(s.first);
  EXPECT_EQ(projected, curved);
}

TEST_P(CurvedMeshTest, ConformingAndPositivelyOriented) {
  const Mesh& m = curved_.mesh;
  const ConformityReport r = checkConformity(m);
  EXPECT_TRUE(r.conforming());
  EXPECT_EQ(r.nonManifoldFaces, 0);
  EXPECT_EQ(r.misorientedFaces, 0);
  EXPECT_EQ(r.hangingFaces, 0);
  EXPECT_EQ(r.unmatchedBoundaryFaces, 0);
  EXPECT_EQ(r.boundaryFaces, m.numBoundaryFaces());
  EXPECT_EQ(countNotPositive(m), 0);
}

TEST_P(CurvedMeshTest, BoundaryFacesPointOutwardAndCurvedVerticesLieOnTheSurface) {
  const Mesh& m = curved_.mesh;
  const FaceTable faces(m);
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
    const auto fv = m.boundaryFaceVertices(f);
    const Index cell = faces.side(faces.find(fv), 0).cell;
    Point centroid = Point::Zero(), faceCentre = Point::Zero(), n = Point::Zero();
    for (const Point& x : cellCorners(m, cell)) centroid += x;
    centroid /= static_cast<double>(m.cellVertices(cell).size());
    for (Index v : fv) faceCentre += m.vertex(v) / static_cast<double>(fv.size());
    if (m.dimension() == 2) {
      const Point t = m.vertex(fv[1]) - m.vertex(fv[0]);
      n = Point(t[1], -t[0], 0);
    } else {
      for (std::size_t i = 0; i < fv.size(); ++i)
        n += m.vertex(fv[i]).cross(m.vertex(fv[(i + 1) % fv.size()]));
    }
    EXPECT_GT(n.dot(faceCentre - centroid), 0.0) << "face " << f;
  }
  EXPECT_LE(maxSurfaceDistance(m, GetParam().surfaces), 1e-12 * GetParam().size);
}

TEST_P(CurvedMeshTest, ProjectionsAreIdempotentClosestPoints) {
  const Case& c = GetParam();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (const auto& [id, project] : curved_.projections) {
    const LevelSet& surface = c.surfaces.at(id);
    for (int k = 0; k < 200; ++k) {
      Point x = c.centre + c.size * Point(u(rng), u(rng), u(rng));
      if (curved_.mesh.dimension() == 2) x[2] = 0.0;
      const Point p = project(x);
      EXPECT_LE(std::abs(surface(p)), 1e-12 * c.size);
      EXPECT_NEAR((p - x).norm(), std::abs(surface(x)), 1e-12 * c.size);  // closest point
      EXPECT_LE((project(p) - p).norm(), 1e-12 * c.size);
    }
  }
}

TEST_P(CurvedMeshTest, VolumeConvergesUnderRefinementWithProjection) {
  const Case& c = GetParam();
  const double e0 = std::abs(totalVolume(curved_.mesh) - c.volume);
  Mesh fine = refineUniformly(curved_.mesh);
  EXPECT_NEAR(totalVolume(fine), totalVolume(curved_.mesh), 1e-12 * c.volume);  // nested
  projectBoundaryVertices(fine, curved_.projections);
  const double e1 = std::abs(totalVolume(fine) - c.volume);
  EXPECT_LT(e1, e0 / c.firstReduction) << "coarse error " << e0;
  EXPECT_EQ(countNotPositive(fine), 0);
  EXPECT_TRUE(checkConformity(fine).conforming());
  EXPECT_LE(maxSurfaceDistance(fine, c.surfaces), 1e-12 * c.size);
  // A second step keeps converging.
  Mesh finer = refineUniformly(fine);
  projectBoundaryVertices(finer, curved_.projections);
  const double e2 = std::abs(totalVolume(finer) - c.volume);
  EXPECT_LT(e2, e1 / 3.0) << "error " << e1;
  EXPECT_LT(e2, 0.1 * c.volume);
  EXPECT_EQ(countNotPositive(finer), 0);
}

INSTANTIATE_TEST_SUITE_P(All, CurvedMeshTest, ::testing::ValuesIn(cases()),
                         [](const auto& info) { return info.param.name; });

/// Smallest scaled Jacobian (det of the unit edge vectors at a corner) over the corners of hexes.
double minScaledJacobian(const Mesh& m) {
  double worst = 1.0;
  for (Index c = 0; c < m.numCells(); ++c) {
    const auto x = cellCorners(m, c);
    for (int i = 0; i < 8; ++i) {
      const int j = i % 4, top = i / 4 * 4;
      const Point e1 = x[top + (top ? (j + 3) % 4 : (j + 1) % 4)] - x[i];
      const Point e2 = x[top + (top ? (j + 1) % 4 : (j + 3) % 4)] - x[i];
      const Point e3 = x[top ? j : j + 4] - x[i];
      worst = std::min(worst, e1.normalized().cross(e2.normalized()).dot(e3.normalized()));
    }
  }
  return worst;
}

TEST(BallMesh, HexahedraAreWellShaped) {
  // The worst corners are where three shell blocks meet the inner cube corner (1/sqrt(3)).
  for (int n = 1; n <= 6; ++n)
    EXPECT_GT(minScaledJacobian(ballMesh(kBallCentre, kBallRadius, CellType::Hexahedron, n).mesh),
              0.57)
        << "n = " << n;
}

TEST(BallMesh, IsSymmetricAndReachesThePoles) {
  const Mesh m = ballMesh(Point::Zero(), 1.0, CellType::Hexahedron, 2).mesh;
  Point sum = Point::Zero();
  int poles = 0;
  for (const Point& x : m.vertices()) {
    sum += x;
    poles += std::abs(x.norm() - 1.0) < 1e-14 && std::abs(x.cwiseAbs().maxCoeff() - 1.0) < 1e-14;
  }
  EXPECT_LE(sum.norm(), 1e-12);
  EXPECT_EQ(poles, 6);  // the south pole is a vertex (contact with a plane starts there)
}

TEST(HalfDiskMesh, DiameterIsFlatAndExact) {
  const CurvedMesh hd = halfDiskMesh(kDiskCentre, kDiskRadius, CellType::Triangle, 2);
  for (Index f = 0; f < hd.mesh.numBoundaryFaces(); ++f)
    if (hd.mesh.boundaryFaceId(f) == kHalfDiskTop) {
      for (Index v : hd.mesh.boundaryFaceVertices(f))
        EXPECT_EQ(hd.mesh.vertex(v)[1], kDiskCentre[1]);
    }
  EXPECT_NEAR(boundaryMeasureById(hd.mesh).at(kHalfDiskTop), 2.0 * kDiskRadius, 1e-13);
  for (const Point& x : hd.mesh.vertices()) EXPECT_LE(x[1], kDiskCentre[1]);
}

TEST(HalfBallMesh, EquatorIsFlatAndEveryTypeConforms) {
  // the flat top is the exact disc z = centre.z of area pi r^2; the mesh is a conforming half of the
  // ball (volume close to 2/3 pi r^3 for the flat-faced cells), for every 3D type
  const Point c(0.5, -0.25, 1.0);
  for (CellType type : {CellType::Hexahedron, CellType::Tetrahedron, CellType::Prism, CellType::Pyramid}) {
    const CurvedMesh hb = halfBallMesh(c, 1.0, type, 2);
    for (Index f = 0; f < hb.mesh.numBoundaryFaces(); ++f)
      if (hb.mesh.boundaryFaceId(f) == kHalfDiskTop) {
        for (Index v : hb.mesh.boundaryFaceVertices(f)) EXPECT_EQ(hb.mesh.vertex(v)[2], c[2]) << name(type);
      }
    for (const Point& x : hb.mesh.vertices()) EXPECT_LE(x[2], c[2]) << name(type);
    const auto measures = boundaryMeasureById(hb.mesh);
    EXPECT_NEAR(measures.at(kHalfDiskTop), std::numbers::pi, 0.1) << name(type);  // polygonal disc
    EXPECT_EQ(hb.mesh.boundaryNames().at(kHalfDiskTop), "top");
    EXPECT_TRUE(hb.projections.count(kCurvedSurface));
    // half of the full ball's boundary faces on the sphere
    const CurvedMesh ball = ballMesh(c, 1.0, type, 4);
    EXPECT_NEAR(measures.at(kCurvedSurface), 0.5 * boundaryMeasureById(ball.mesh).at(kCurvedSurface), 1e-12)
        << name(type);
  }
}

TEST(RoundedBlockMesh, FlatSidesAndLowestPoint) {
  const double H = 1.2, R = 2.5;
  const CurvedMesh b = roundedBlockMesh(kW, H, kD, R, CellType::Hexahedron, kBlockCells);
  const std::map<int, std::pair<int, double>> plane = {
      {kLeft, {0, 0.0}}, {kRight, {0, kW}}, {kTop, {2, H}}, {kFront, {1, 0.0}}, {kBack, {1, kD}}};
  for (Index f = 0; f < b.mesh.numBoundaryFaces(); ++f) {
    const auto it = plane.find(b.mesh.boundaryFaceId(f));
    if (it == plane.end()) continue;
    for (Index v : b.mesh.boundaryFaceVertices(f))
      EXPECT_NEAR(b.mesh.vertex(v)[it->second.first], it->second.second, 1e-14);
  }
  EXPECT_NEAR(boundaryMeasureById(b.mesh).at(kTop), kW * kD, 1e-13);
  double lowest = 1.0;
  for (const Point& x : b.mesh.vertices()) lowest = std::min(lowest, x[2]);
  EXPECT_EQ(lowest, 0.0);  // the middle bottom line (x = width/2) touches z = 0
}

TEST(CurvedMeshes, BadArgumentsThrow) {
  const Point c = Point::Zero();
  EXPECT_THROW(ballMesh(c, 1.0, CellType::Quadrilateral, 2), obs::Error);
  EXPECT_THROW(ballMesh(c, 1.0, CellType::Segment, 2), obs::Error);
  EXPECT_THROW(ballMesh(c, 0.0, CellType::Hexahedron, 2), obs::Error);
  EXPECT_THROW(ballMesh(c, -1.0, CellType::Hexahedron, 2), obs::Error);
  EXPECT_THROW(ballMesh(c, NAN, CellType::Hexahedron, 2), obs::Error);
  EXPECT_THROW(ballMesh(c, 1.0, CellType::Hexahedron, 0), obs::Error);
  EXPECT_THROW(ballMesh(c, 1.0, CellType::Tetrahedron, 100000), obs::Error);
  EXPECT_THROW(ballMesh(Point(INFINITY, 0, 0), 1.0, CellType::Hexahedron, 1), obs::Error);
  EXPECT_THROW(diskMesh(c, 1.0, CellType::Hexahedron, 2), obs::Error);
  EXPECT_THROW(diskMesh(c, 1.0, CellType::Triangle, 0), obs::Error);
  EXPECT_THROW(diskMesh(c, -2.0, CellType::Triangle, 1), obs::Error);
  EXPECT_THROW(halfDiskMesh(c, 1.0, CellType::Prism, 1), obs::Error);
  EXPECT_THROW(halfDiskMesh(c, 1.0, CellType::Quadrilateral, -1), obs::Error);
  EXPECT_THROW(halfDiskMesh(c, 0.0, CellType::Quadrilateral, 1), obs::Error);

  const auto hex = CellType::Hexahedron;
  EXPECT_THROW(roundedBlockMesh(2.0, 1.0, 1.0, 0.99, hex, {2, 2, 2}), obs::Error);  // R < w/2
  EXPECT_THROW(roundedBlockMesh(2.0, 1.0, 1.0, 1.0, hex, {2, 2, 2}), obs::Error);   // h <= rise
  EXPECT_THROW(roundedBlockMesh(0.0, 1.0, 1.0, 1.0, hex, {2, 2, 2}), obs::Error);
  EXPECT_THROW(roundedBlockMesh(2.0, -1.0, 1.0, 3.0, hex, {2, 2, 2}), obs::Error);
  EXPECT_THROW(roundedBlockMesh(2.0, 1.0, 0.0, 3.0, hex, {2, 2, 2}), obs::Error);
  EXPECT_THROW(roundedBlockMesh(2.0, 1.0, 1.0, -3.0, hex, {2, 2, 2}), obs::Error);
  EXPECT_THROW(roundedBlockMesh(2.0, 1.0, 1.0, 3.0, hex, {2, 0, 2}), obs::Error);
  EXPECT_THROW(roundedBlockMesh(2.0, 1.0, 1.0, 3.0, CellType::Segment, {2, 2, 2}), obs::Error);
  // 2D blocks ignore the depth and cells[2].
  EXPECT_NO_THROW(roundedBlockMesh(2.0, 1.0, 0.0, 3.0, CellType::Triangle, {2, 2, 0}));
  EXPECT_NO_THROW(roundedBlockMesh(2.0, 1.5, 1.0, 1.0, hex, {2, 2, 2}));  // semicircle
}

}  // namespace
