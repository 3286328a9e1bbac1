// End-to-end runs through runScene, the function behind `obs run`: outputs (.vtu, summary.json,
// CSV rows), progress lines, options, the numbers of a problem with a known exact solution, and
// every scene in data/scenes.
#include <gtest/gtest.h>

#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/Summary.hpp"
#include "obs/mesh/Error.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "run_scene";

fs::path writeScene(const std::string& name, const std::string& text) {
  fs::create_directories(kTmp);
  const fs::path p = kTmp / (name + ".toml");
  std::ofstream(p) << text;
  return p;
}

std::vector<std::string> lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

/// Uniaxial tension of a 2D strip: u_x = 0 on the left, u_y = 0 at the bottom, traction p on
/// the right. Exact: sigma_xx = p, plane strain eps_xx = p (1 - nu^2) / E, eps_yy = -p nu (1 + nu)
/// / E.
const std::string kTension = R"([mesh]
generator = "box"
type = "triangle"
cells = [4, 2]
lower = [0, 0]
upper = [2, 1]

[material]
E = 100
nu = 0.25

[[dirichlet]]
boundary = "left"
components = ["x"]

[[dirichlet]]
boundary = "bottom"
components = ["y"]

[[neumann]]
boundary = "right"
traction = ["2 + 0*y", 0]

[output]
csv = "runs.csv"
)";

}  // namespace

TEST(RunScene, WritesVtuSummaryAndCsv) {
  const fs::path scene = writeScene("tension", kTension);
  const fs::path out = kTmp / "out_tension";
  fs::remove_all(out);
  std::vector<std::string> progress;
  RunOptions options;
  options.outputDirectory = out;
  options.progress = [&](const std::string& l) { progress.push_back(l); };
  const RunResult r = runScene(scene, options);

  // the result
  EXPECT_EQ(r.scene, scene.string());
  EXPECT_EQ(r.dimension, 2);
  EXPECT_EQ(r.cells, 16);
  EXPECT_EQ(r.vertices, 15);
  EXPECT_EQ(r.cellsPerType[static_cast<int>(obs::mesh::CellType::Triangle)], 16);
  EXPECT_EQ(r.dofs, 30);
  EXPECT_EQ(r.freeDofs, 30 - 3 - 5);
  EXPECT_GT(r.totalSeconds, 0);
  EXPECT_GE(r.totalSeconds, r.assemblySeconds + r.solveSeconds);
  EXPECT_GT(r.peakMemoryMB, 1);
  // exact solution (P1 reproduces it): u(2, 1) = (2 eps_xx, eps_yy)
  const double E = 100, nu = 0.25, p = 2;
  const double exx = p * (1 - nu * nu) / E, eyy = -p * nu * (1 + nu) / E;
  EXPECT_NEAR(r.maxDisplacement, std::hypot(2 * exx, eyy), 1e-12);
  // von Mises of sigma = diag(p, 0, nu p) (plane strain)
  const double szz = nu * p;
  EXPECT_NEAR(r.maxVonMises, std::sqrt(0.5 * (p * p + szz * szz + (p - szz) * (p - szz))), 1e-10);

  // progress lines
  ASSERT_EQ(progress.size(), 4u);
  EXPECT_EQ(progress[0].rfind("mesh built: 16 triangle cells / 15 vertices", 0), 0u) << progress[0];
  EXPECT_EQ(progress[1].rfind("assembled: 30 dofs (22 free)", 0), 0u) << progress[1];
  EXPECT_EQ(progress[2].rfind("solved in", 0), 0u) << progress[2];
  EXPECT_EQ(progress[3].rfind("written: ", 0), 0u) << progress[3];

  // files
  ASSERT_EQ(r.outputFiles.size(), 3u);
  EXPECT_EQ(r.outputFiles[0], out / "tension.vtu");
  EXPECT_EQ(r.outputFiles[1], out / "runs.csv");
  EXPECT_EQ(r.outputFiles[2], out / "summary.json");
  for (const auto& f : r.outputFiles) EXPECT_TRUE(fs::exists(f)) << f;

  // summary.json
  std::ifstream in(out / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const char* key : {"obs_version", "scene", "dimension", "vertices", "cells",
                          "cells_per_type", "refine", "dofs", "free_dofs", "times",
                          "peak_memory_mb", "max_displacement", "max_von_mises", "output_files"})
    EXPECT_TRUE(j.contains(key)) << key;
  for (const char* key : {"mesh_s", "assembly_s", "solve_s", "output_s", "total_s"})
    EXPECT_TRUE(j["times"].contains(key)) << key;
  EXPECT_EQ(j["scene"], scene.string());
  EXPECT_EQ(j["dimension"], 2);
  EXPECT_EQ(j["cells"], 16);
  EXPECT_EQ(j["cells_per_type"]["triangle"], 16);
  EXPECT_EQ(j["cells_per_type"].size(), 1u);
  EXPECT_EQ(j["dofs"], 30);
  EXPECT_EQ(j["free_dofs"], 22);
  EXPECT_DOUBLE_EQ(j["max_displacement"].get<double>(), r.maxDisplacement);
  EXPECT_EQ(j["output_files"].size(), 3u);
  EXPECT_EQ(j["solver"]["type"], "direct");
  EXPECT_EQ(j["solver"]["iterations"], 1);
  EXPECT_EQ(j["solver"]["converged"], true);
  EXPECT_FALSE(j.contains("contact"));
  EXPECT_EQ(j["output_files"][2], (out / "summary.json").string());

  // CSV: header once, one row per run
  auto csv = lines(out / "runs.csv");
  ASSERT_EQ(csv.size(), 2u);
  EXPECT_EQ(csv[0],
            "scene,cells,vertices,dofs,assembly_s,solve_s,total_s,peak_mb,max_displacement,max_von_"
            "mises,solver,iterations,converged,potential_contact,actual_contact,contact_force_x,"
            "contact_force_y,contact_force_z,load_P,contact_area,contact_radius,max_violation,"
            "kkt_feasibility,kkt_multiplier_sign,kkt_complementarity,kkt_stationarity");
  // a linear run: direct solver, one "iteration", empty contact and KKT columns
  EXPECT_NE(csv[1].find(",direct,1,1,,,,,,,,,,,,,"), std::string::npos) << csv[1];
  EXPECT_EQ(std::count(csv[1].begin(), csv[1].end(), ','), 25) << csv[1];
  EXPECT_EQ(csv[1].rfind(scene.string() + ",16,15,30,", 0), 0u) << csv[1];
  runScene(scene, RunOptions{out, 1, {}});
  csv = lines(out / "runs.csv");
  ASSERT_EQ(csv.size(), 3u);
  EXPECT_EQ(csv[2].rfind(scene.string() + ",64,45,90,", 0), 0u) << csv[2];

  // the .vtu holds the solution fields
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName((out / "tension.vtu").string().c_str());
  reader->Update();
  vtkUnstructuredGrid* grid = reader->GetOutput();
  EXPECT_EQ(grid->GetNumberOfCells(), 64);  // the refined run overwrote it
  for (const char* name : {"displacement", "stress", "von_mises", "boundary_id"})
    EXPECT_NE(grid->GetPointData()->GetArray(name), nullptr) << name;
  for (const char* name : {"stress", "von_mises", "element_type"})
    EXPECT_NE(grid->GetCellData()->GetArray(name), nullptr) << name;
}

TEST(RunScene, OutputDirectoryFromSceneAndVtkSwitch) {
  const fs::path out = kTmp / "from_scene";
  fs::remove_all(out);
  const fs::path scene = writeScene("novtk", R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [2, 2]
[material]
E = 1
nu = 0.3
[[dirichlet]]
boundary = "left"
[body_force]
value = [0, -1]
[output]
directory = ")" + out.string() + R"("
vtk = false
)");
  const RunResult r = runScene(scene);
  // summary.json and the default runs.csv, no .vtu
  ASSERT_EQ(r.outputFiles.size(), 2u);
  for (const auto& f : r.outputFiles) EXPECT_NE(f.extension(), ".vtu");
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_TRUE(fs::exists(out / "runs.csv"));
  EXPECT_FALSE(fs::exists(out / "novtk.vtu"));
  EXPECT_GT(r.maxDisplacement, 0);
}

TEST(RunScene, InvalidSceneThrowsBeforeWriting) {
  const fs::path out = kTmp / "invalid";
  fs::remove_all(out);
  const fs::path scene =
      writeScene("invalid",
                 "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = [2, 2]\n"
                 "[material]\nE = 1\nnu = 0.3\n");
  EXPECT_THROW(runScene(scene, RunOptions{out, {}, {}}), obs::Error);
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST(RunScene, CsvRowQuotesAndHeader) {
  RunResult r;
  r.scene = "a,b.toml";
  r.cells = 2;
  EXPECT_EQ(csvRow(r).rfind("\"a,b.toml\",2,", 0), 0u) << csvRow(r);
  const std::string header = csvHeader();
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), 25);
  // the first ten columns keep their names and order
  EXPECT_EQ(header.rfind("scene,cells,vertices,dofs,assembly_s,solve_s,total_s,peak_mb,"
                         "max_displacement,max_von_mises,",
                         0),
            0u);
  const std::string row = csvRow(r);
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), 25 + 1) << row;  // + the quoted one
}

TEST(RunScene, EveryDataSceneRuns) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(OBS_DATA_DIR) / "scenes")) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    const fs::path out = kTmp / "scenes" / entry.path().stem();
    fs::remove_all(out);
    RunResult r;
    RunOptions options{out, {}, {}};
    // adaptive scenes ([adaptivity]) run two steps here; tests/drivers/test_Adaptivity.cpp has more
    if (parseScene(entry.path()).adaptivity) options.overrides = {"adaptivity.steps=2"};
    ASSERT_NO_THROW(r = runScene(entry.path(), options));
    EXPECT_TRUE(fs::exists(out / "summary.json"));
    EXPECT_GT(r.maxDisplacement, 0);
    EXPECT_TRUE(std::isfinite(r.maxVonMises));
    EXPECT_GT(r.totalSeconds, 0);  // run times belong to bench/ and scripts, not to a unit test
    ++count;
  }
  EXPECT_GE(count, 3);
}
