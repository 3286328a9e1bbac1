// The thesis' 3D examples 4-9 (Sec. 4.2.3) as scenes data/scenes/example4.toml ... example9.toml:
//  - each scene's obstacle has the documented gap and constraint direction at hand-picked points
//    (strip, pyramid, ball, hat, sine wave, smiley through the scene's [contact] section);
//  - each scene runs the adaptive loop on a coarse setting (2 steps): every solve converges, the
//    final step has actual contact and a positive finite estimate;
//  - one check per example from the thesis' discussion: Example 4 touches only inside the strip;
//    Example 5 touches around the tip, where the pressure is largest; Example 6 (convex ball) has
//    eta_8 > 0 but eta_7 = 0; Example 7 (hat) has eta_7 > 0 and eta_8 > 0; Example 8: on the starting
//    grid only the crest on a grid line is found, eta_{8,p} > 0 next to the three others, and two
//    adaptive refinements find all four crests; Example 9 touches only along the smiley, on the outline, both eyes and the mouth.
#include <gtest/gtest.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/obs/Obstacle.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;
using obs::Point;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "examples3d";
const fs::path kScenes = fs::path(OBS_DATA_DIR) / "scenes";

fs::path sceneFile(int example) { return kScenes / ("example" + std::to_string(example) + ".toml"); }

/// A CSV file with a header row, values by column name.
struct Table {
  std::vector<std::map<std::string, std::string>> rows;
  double number(std::size_t row, const std::string& column) const {
    const auto& r = rows.at(row);
    const auto it = r.find(column);
    if (it == r.end()) throw std::runtime_error("no column " + column);
    return it->second.empty() ? std::nan("") : std::stod(it->second);
  }
  double last(const std::string& column) const { return number(rows.size() - 1, column); }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

Table readCsv(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error("cannot read " + p.string());
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = split(line);
  Table t;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const std::vector<std::string> cells = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size(); ++i) row[header[i]] = i < cells.size() ? cells[i] : "";
    t.rows.push_back(std::move(row));
  }
  return t;
}

struct ExampleRun {
  RunResult result;
  Table steps;     ///< steps.csv
  Table pressure;  ///< pressure.csv: potential contact vertices of the last step
  /// Vertices of the last step in actual contact (s_p above 1e-6 of the largest s_p).
  std::vector<Point> contactVertices() const {
    double maxS = 0;
    for (std::size_t i = 0; i < pressure.rows.size(); ++i) maxS = std::max(maxS, pressure.number(i, "s_p"));
    std::vector<Point> out;
    for (std::size_t i = 0; i < pressure.rows.size(); ++i)
      if (pressure.number(i, "s_p") > 1e-6 * maxS)
        out.emplace_back(pressure.number(i, "x"), pressure.number(i, "y"), pressure.number(i, "z"));
    return out;
  }
};

/// Runs example `example` with `steps` adaptive solves.
/// With `vtk`, the last step's .vtu is written (to <tmp>/example<N>_<steps>_vtk/step_<k>.vtu).
ExampleRun runExample(int example, int steps, bool vtk = false) {
  RunOptions o;
  const fs::path dir =
      kTmp / ("example" + std::to_string(example) + "_" + std::to_string(steps) + (vtk ? "_vtk" : ""));
  o.outputDirectory = dir;
  o.overrides = {"adaptivity.steps=" + std::to_string(steps), vtk ? "adaptivity.vtk=\"last\"" : "adaptivity.vtk=\"none\""};
  ExampleRun r{runScene(sceneFile(example), o), readCsv(dir / "steps.csv"), readCsv(dir / "pressure.csv")};
  return r;
}

/// Every step converged; the last has actual contact and a positive finite estimate; the grid was refined.
void expectConvergedWithContact(const ExampleRun& r, int steps) {
  ASSERT_EQ(static_cast<int>(r.steps.rows.size()), steps);
  for (std::size_t k = 0; k < r.steps.rows.size(); ++k) EXPECT_EQ(r.steps.number(k, "converged"), 1.0) << k;
  EXPECT_GT(r.steps.last("actual_contact"), 0);
  EXPECT_LE(r.steps.last("actual_contact"), r.steps.last("potential_contact"));
  EXPECT_TRUE(std::isfinite(r.steps.last("eta")) && r.steps.last("eta") > 0);
  if (steps > 1) {
    EXPECT_GT(r.steps.last("vertices"), r.steps.number(0, "vertices"));  // it refined
  }
  ASSERT_TRUE(r.result.contact.has_value());
  EXPECT_TRUE(r.result.solver.converged);
  EXPECT_FALSE(r.contactVertices().empty());
}

}  // namespace

// --- the scenes' obstacles ----------------------------------------------------------------------

TEST(Examples3D, ObstaclesHaveTheDocumentedGapsAndDirection) {
  struct Probe {
    Point x;
    double gap;
  };
  const double hat = 0.07 - 0.07 * std::pow(1 - 0.16 / 0.25, 2);  // r = 0.4 on the crown
  const std::map<int, std::vector<Probe>> probes{
      {4, {{Point(0.5, 0.5, 0), 0}, {Point(0.21, 0.9, 0), 0}, {Point(0.19, 0.5, 0), 0.5}, {Point(0.5, 0.5, 0.2), 0.2}}},
      {5, {{Point(0.5, 0.5, 0), 0}, {Point(0.7, 0.6, 0), 0.2}, {Point(0.5, 0.1, 0.1), 0.5}}},
      {6, {{Point(0.5, 0.5, 0), 0}, {Point(0.8, 0.5, 0), 0.5 - std::sqrt(0.25 - 0.09)}}},
      {7, {{Point(0.5, 0.5, 0), 0}, {Point(0.9, 0.5, 0), hat}, {Point(0.05, 0.05, 0), 0.07}}},
      {8, {{Point(0.1, 0.3, 0), 0}, {Point(0.6, 0.9, 0), 0}, {Point(0.225, 0.5, 0), 0.1}, {Point(0.0, 0.5, 0), 0.05 * (1 - std::cos(0.8 * std::numbers::pi))}}},
      {9, {{Point(0.9, 0.5, 0), 0}, {Point(0.64, 0.62, 0), 0}, {Point(0.5, 0.26, 0), 0}, {Point(0.5, 0.2, 0), 0.03}}},
  };
  for (const auto& [example, list] : probes) {
    const Scene scene = parseScene(sceneFile(example));
    const auto obstacle = makeObstacle(scene, 3);
    for (const Probe& p : list) {
      EXPECT_NEAR(obstacle->gap(p.x), p.gap, 1e-12) << "example " << example << " at " << p.x.transpose();
      EXPECT_TRUE(obstacle->direction(p.x).isApprox(Point(0, 0, -1))) << "example " << example;
    }
  }
}

// --- smoke runs with one check each -----------------------------------------------------------

TEST(Examples3D, Example4TouchesOnlyInsideTheStrip) {
  const ExampleRun r = runExample(4, 2);
  expectConvergedWithContact(r, 2);
  int left = 0, right = 0;
  for (const Point& x : r.contactVertices()) {
    EXPECT_LE(std::abs(x[0] - 0.5), 0.3 + 1e-12) << x.transpose();
    (x[0] < 0.5 ? left : right) += 1;
  }
  EXPECT_GT(left, 0);
  EXPECT_GT(right, 0);
  // g = 0.5 outside the strip is out of reach: some potential contact vertices stay free
  EXPECT_LT(r.steps.last("actual_contact"), r.steps.last("potential_contact"));
}

TEST(Examples3D, Example5TouchesAroundTheTipWithTheLargestPressureThere) {
  const ExampleRun r = runExample(5, 2);
  expectConvergedWithContact(r, 2);
  for (const Point& x : r.contactVertices())
    EXPECT_LT(std::max(std::abs(x[0] - 0.5), std::abs(x[1] - 0.5)), 0.25) << x.transpose();
  std::size_t argmax = 0;
  for (std::size_t i = 0; i < r.pressure.rows.size(); ++i)
    if (r.pressure.number(i, "s_p") > r.pressure.number(argmax, "s_p")) argmax = i;
  EXPECT_NEAR(r.pressure.number(argmax, "x"), 0.5, 1e-12);
  EXPECT_NEAR(r.pressure.number(argmax, "y"), 0.5, 1e-12);
}

TEST(Examples3D, Example6ConvexBallGivesEta8ButNoEta7) {
  const ExampleRun r = runExample(6, 2);
  expectConvergedWithContact(r, 2);
  for (std::size_t k = 0; k < r.steps.rows.size(); ++k) {
    EXPECT_EQ(r.steps.number(k, "eta_7"), 0.0) << k;  // g <= g_m everywhere: (g - g_m)^+ = 0
    EXPECT_GT(r.steps.number(k, "eta_8"), 0.0) << k;  // the interpolated gap penetrates the ball
  }
  for (const Point& x : r.contactVertices()) EXPECT_LT(std::hypot(x[0] - 0.5, x[1] - 0.5), 0.5);
}

TEST(Examples3D, Example7HatHasEta7AndEta8) {
  const ExampleRun r = runExample(7, 2);
  expectConvergedWithContact(r, 2);
  for (std::size_t k = 0; k < r.steps.rows.size(); ++k) {
    EXPECT_GT(r.steps.number(k, "eta_7"), 0.0) << k;  // contact reaches the concave part of the crown
    EXPECT_GT(r.steps.number(k, "eta_8"), 0.0) << k;  // and covers its convex top
  }
}

TEST(Examples3D, Example8FindsTheCrestsOffTheStartingGridThroughRefinement) {
  const double crests[4] = {0.1, 0.35, 0.6, 0.85};
  auto touchedCrests = [&](const ExampleRun& r) {
    std::vector<int> count(4, 0);
    for (const Point& x : r.contactVertices())
      for (int c = 0; c < 4; ++c)
        if (std::abs(x[0] - crests[c]) < 0.125) ++count[c];
    return count;
  };
  // step 0 alone: only the crest x = 0.6 on a grid line is in contact; the solution penetrates the
  // exact obstacle at the other crests, which eta_8 (exact g) sees
  const ExampleRun first = runExample(8, 1, true);
  expectConvergedWithContact(first, 1);
  const std::vector<int> c0 = touchedCrests(first);
  EXPECT_EQ(c0[0], 0);
  EXPECT_EQ(c0[1], 0);
  EXPECT_GT(c0[2], 0);
  EXPECT_EQ(c0[3], 0);
  EXPECT_GT(first.steps.last("eta_8"), 0.0);
  // ... and locates it at the crests not yet in contact: eta_{8,p} > 0 at a bottom vertex within
  // 0.125 of each of x = 0.1, 0.35 and 0.85 (step_000.vtu, vertex field eta_8)
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  const fs::path vtu = kTmp / "example8_1_vtk" / "step_000.vtu";
  reader->SetFileName(vtu.string().c_str());
  reader->Update();
  vtkUnstructuredGrid* grid = reader->GetOutput();
  vtkDataArray* eta8 = grid->GetPointData()->GetArray("eta_8");
  ASSERT_NE(eta8, nullptr) << vtu;
  double nearCrest[4] = {0, 0, 0, 0};
  for (vtkIdType i = 0; i < grid->GetNumberOfPoints(); ++i) {
    double x[3];
    grid->GetPoint(i, x);
    if (std::abs(x[2]) > 1e-12) continue;
    for (int c = 0; c < 4; ++c)
      if (std::abs(x[0] - crests[c]) < 0.125) nearCrest[c] = std::max(nearCrest[c], eta8->GetTuple1(i));
  }
  for (int c : {0, 1, 3}) EXPECT_GT(nearCrest[c], 0.0) << "crest x = " << crests[c];
  // after two adaptive refinements every crest is in contact
  const ExampleRun third = runExample(8, 3);
  expectConvergedWithContact(third, 3);
  for (int c = 0; c < 4; ++c) EXPECT_GT(touchedCrests(third)[c], 0) << "crest x = " << crests[c];
}

TEST(Examples3D, Example9TouchesAlongTheSmileyOnly) {
  const ExampleRun r = runExample(9, 3);
  expectConvergedWithContact(r, 3);
  const obs::SmileyObstacle smiley(Point(0.5, 0.5, 0), 0.4, 0.5);
  int outline = 0, leftEye = 0, rightEye = 0, mouth = 0;
  for (const Point& x : r.contactVertices()) {
    const double s1 = x[0] - 0.5, s2 = x[1] - 0.5;
    EXPECT_LT(smiley.distance(s1, s2), 0.05) << x.transpose();  // a narrow band around the curves
    if (std::abs(std::hypot(s1, s2) - 0.4) < 0.05) ++outline;
    if (std::hypot(s1 + 0.14, s2 - 0.12) < 0.09) ++leftEye;
    if (std::hypot(s1 - 0.14, s2 - 0.12) < 0.09) ++rightEye;
    if (s2 < -0.1 && std::abs(std::hypot(s1, s2) - 0.24) < 0.05) ++mouth;
  }
  EXPECT_GT(outline, 0);
  EXPECT_GT(leftEye, 0);
  EXPECT_GT(rightEye, 0);
  EXPECT_GT(mouth, 0);
}
