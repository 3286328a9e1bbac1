// [mesh] projection: the curved boundaries of imported meshes refined onto their exact shapes
// (circle, sphere, cylinder, plane), and one-line errors for projections that do not fit the mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Gmsh.hpp"
#include "obs/mesh/Grid.hpp"
#include "DriverTestSupport.hpp"

using namespace obs;
using namespace obs::drivers;
namespace fs = std::filesystem;

namespace {

const fs::path kScenes = fs::path(OBS_DATA_DIR) / "scenes";

/// The plate with a hole (centre (1, 0.5), radius 0.25, boundary "hole") of data/meshes, refined twice.
Scene plate(const std::string& projection) {
  return parseSceneString(R"(
[mesh]
file = "../meshes/plate_with_hole.msh"
refine = 2
)" + projection + R"(
[material]
E = 1
nu = 0.3
[[dirichlet]]
boundary = "left"
)",
                          "plate.toml", kScenes);
}

/// Largest | |x - c| - r | over the leaf vertices on the hole.
double holeDeviation(const mesh::Grid& grid) {
  const mesh::Mesh m = grid.leafMesh();
  double worst = 0;
  for (mesh::Index f = 0; f < m.numBoundaryFaces(); ++f) {
    if (m.boundaryFaceId(f) != 4) continue;
    for (mesh::Index v : m.boundaryFaceVertices(f))
      worst = std::max(worst, std::abs((m.vertex(v) - mesh::Point(1, 0.5, 0)).norm() - 0.25));
  }
  return worst;
}

std::string errorOf(const std::string& projection) {
  try {
    buildGrid(plate(projection));
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(MeshProjection, ImportedHoleRefinesOntoTheCircle) {
  // without a projection the new vertices lie on the chords of the coarse 12-gon: off the circle by
  // up to r (1 - cos(pi / 12)) = 8.5e-3; with it, on the circle to round-off
  const double chords = holeDeviation(buildGrid(plate("")));
  EXPECT_GT(chords, 1e-3);
  EXPECT_LT(chords, 0.25 * (1 - std::cos(M_PI / 12)) * 1.01);
  const Scene s = plate(R"(projection = { boundary = "hole", shape = "circle", centre = [1, 0.5], radius = 0.25 })");
  ASSERT_EQ(s.mesh.projections.size(), 1u);
  // the file's hole vertices are Gmsh's, on the circle to its output precision
  EXPECT_LT(holeDeviation(buildGrid(s)), 1e-9);
  // an array of projections, a plane that keeps the flat bottom flat
  const Scene two = plate(R"(projection = [{ boundary = "hole", shape = "sphere", centre = [1, 0.5], radius = 0.25 },
                                          { boundary = "bottom", shape = "plane", centre = [0, 0], normal = [0, -1] }])");
  ASSERT_EQ(two.mesh.projections.size(), 2u);
  EXPECT_LT(holeDeviation(buildGrid(two)), 1e-9);
}

TEST(MeshProjection, ProjectionsThatDoNotFitAreOneLineErrors) {
  const auto expectError = [](const std::string& projection, const std::string& part) {
    const std::string m = errorOf(projection);
    EXPECT_NE(m.find(part), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  };
  // a radius that does not fit the hole: the vertex and its distance are named
  expectError(R"(projection = { boundary = "hole", shape = "circle", centre = [1, 0.5], radius = 0.3 })",
              "away from the circle");
  expectError(R"(projection = { boundary = "hole", shape = "cylinder", centre = [1, 0.5], radius = 0.25, axis = [0, 0, 1] })",
              "needs a 3D mesh");
  expectError(R"(projection = { boundary = "hole", shape = "torus", centre = [1, 0.5], radius = 0.25 })",
              "is unknown");
  expectError(R"(projection = { boundary = "rim", shape = "circle", centre = [1, 0.5], radius = 0.25 })", "rim");
  expectError(R"(projection = { boundary = "hole", shape = "circle", centre = [1, 0.5], radius = -1 })",
              "must be positive");
  expectError(R"(projection = { boundary = "hole", shape = "circle", centre = [1, 0.5] })", "radius");
  expectError(R"(projection = { boundary = "bottom", shape = "plane", centre = [0, 0], normal = [0, 0] })",
              "zero vector");
  expectError(R"(projection = { boundary = "hole", shape = "circle", centre = [1, 0.5], radius = 0.25, axis = [0, 1] })",
              "does not apply");
  expectError(R"(projection = "hole")", "must be a table");
}

TEST(MeshProjection, ImportedCylinderGivesTheGeneratorsContact) {
  // data/scenes/twobody_cylinders.toml at refine 3 with the half-cylinder's coarse mesh read from a
  // Gmsh file (written from the generator's level 0): with the projection of its arc onto the
  // circle the run is the generator's (the same grids up to the rounding of the projection); without
  // it the arc stays the coarse polygon and the pressure differs by percents
  const fs::path dir = fs::path(OBS_TEST_TMP_DIR) / "mesh_projection";
  fs::create_directories(dir);
  mesh::writeGmsh(mesh::halfDiskMesh(mesh::Point(0, 1, 0), 1.0, mesh::CellType::Triangle, 2).mesh,
                  dir / "half_disk.msh");
  const std::string block = R"(
[[body]]
name = "block"
[body.mesh]
generator = "box"
type = "quadrilateral"
cells = [8, 4]
lower = [-2.0, -2.0]
upper = [2.0, 0.0]
refine = 3
[body.material]
E = 1.0
nu = 0.3
[[body.dirichlet]]
boundary = "bottom"
[[body]]
name = "cylinder"
[body.material]
E = 1.0
nu = 0.3
[[body.dirichlet]]
boundary = "top"
value = [0.0, -0.05]
[[contact]]
slave = { body = "cylinder", boundary = "arc" }
master = { body = "block", boundary = "top" }
[solver]
type = "tnnmg"
tolerance = 1e-12
[body.mesh]
refine = 3
)";
  const auto runWith = [&](const std::string& name, const std::string& meshKeys) {
    std::ofstream(dir / (name + ".toml")) << block << meshKeys;
    RunOptions o;
    o.outputDirectory = dir / name;
    const RunResult r = runScene(dir / (name + ".toml"), o);
    EXPECT_EQ(r.pairs.size(), 1u);
    return r.pairs.front();
  };
  const PairReport generated = runWith("generated", R"(generator = "half_disk"
type = "triangle"
centre = [0.0, 1.0]
radius = 1.0
cells = [2]
)");
  const PairReport projected = runWith("projected", R"(file = "half_disk.msh"
projection = { boundary = "arc", shape = "circle", centre = [0, 1], radius = 1 }
)");
  const PairReport polygon = runWith("polygon", R"(file = "half_disk.msh"
)");
  EXPECT_EQ(projected.actualVertices, generated.actualVertices);
  EXPECT_NEAR(projected.load, generated.load, 1e-10 * generated.load);
  EXPECT_NEAR(projected.pressureMax, generated.pressureMax, 1e-9 * generated.pressureMax);
  EXPECT_GT(std::abs(polygon.pressureMax - generated.pressureMax), 0.01 * generated.pressureMax);
}

namespace {

/// The largest |p - p_Hertz| / p0 over the slave vertices of data/scenes/twobody_gmsh_cylinders.toml
/// in contact with |x| <= 0.8 a (away from the edge of the zone, where the square root is steepest),
/// and their number; p_Hertz for the computed load, two cylinders of radius 1 and one material.
struct HertzDeviation {
  double worst = 0;
  int vertices = 0;
  double halfWidth = 0;
};
HertzDeviation hertzDeviation(const std::string& name, const std::string& sceneText) {
  const fs::path dir = fs::path(OBS_TEST_TMP_DIR) / "gmsh_cylinders";
  fs::create_directories(dir);
  // the scene's mesh files, relative to data/scenes, from the test's own directory
  const std::string relative = "\"../meshes/";
  const std::string absolute = std::string(1, '"').append((kScenes.parent_path() / "meshes").string()).append("/");
  std::string text;
  for (std::size_t from = 0;;) {
    const std::size_t at = sceneText.find(relative, from);
    text += sceneText.substr(from, at == std::string::npos ? std::string::npos : at - from);
    if (at == std::string::npos) break;
    text += absolute;
    from = at + relative.size();
  }
  const fs::path file = dir / (name + ".toml");
  std::ofstream(file) << text;
  RunOptions o;
  o.outputDirectory = dir / name;
  const RunResult r = runScene(file, o);
  EXPECT_EQ(r.pairs.size(), 1u);
  const double P = r.pairs.front().load;
  const double E = 1, nu = 0.3, Rstar = 0.5, Estar = E / (2 * (1 - nu * nu));
  HertzDeviation h;
  h.halfWidth = std::sqrt(4 * P * Rstar / (M_PI * Estar));
  const double a = h.halfWidth, p0 = 2 * P / (M_PI * a);
  const obs::test::Vtu upper = obs::test::readVtu(dir / name / (name + "_upper.vtu"));
  const auto p = upper.array("contact_pressure");
  EXPECT_EQ(p.size(), upper.points.size());
  for (std::size_t v = 0; v < p.size(); ++v) {
    const double x = upper.points[v][0];
    if (!(p[v] > 0) || std::abs(x) > 0.8 * a) continue;
    const double exact = p0 * std::sqrt(1 - x * x / (a * a));
    h.worst = std::max(h.worst, std::abs(p[v] - exact) / p0);
    ++h.vertices;
  }
  return h;
}

std::string slurpFile(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

TEST(MeshProjection, TwoCylindersFromGmshFilesMatchHertz) {
  // data/scenes/twobody_gmsh_cylinders.toml: two graded half-cylinders from Gmsh files, refined twice
  // with the arcs projected onto the circles. The dual-mortar pressure at every contact vertex away
  // from the edge of the zone is Hertz's within 3 % of p0 (for the computed load); without the
  // projections the refined arcs are the coarse polygons and their corners break that bound.
  const std::string text = slurpFile(kScenes / "twobody_gmsh_cylinders.toml");
  const HertzDeviation projected = hertzDeviation("projected", text);
  EXPECT_GT(projected.vertices, 50);
  EXPECT_GT(projected.halfWidth, 0.02);
  EXPECT_LT(projected.worst, 0.03) << projected.vertices << " vertices, a = " << projected.halfWidth;
  std::string polygon;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("projection", 0) != 0) polygon += line + "\n";
  const HertzDeviation chords = hertzDeviation("polygon", polygon);
  EXPECT_GT(chords.worst, 0.03) << chords.vertices << " vertices";
  std::cout << "largest |p - p_Hertz| / p0 within 0.8 a: " << projected.worst << " projected (" << projected.vertices
            << " vertices, a = " << projected.halfWidth << "), " << chords.worst << " without projections\n";
}
