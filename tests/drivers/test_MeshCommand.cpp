// `obs mesh` through runMeshCommand: the report of a randomly refined grid is consistent (leaf
// counts, conformity, volume) and reproducible from the seed, files are written, bad options fail.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "obs/drivers/MeshCommand.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/Parallel.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "mesh_command";

/// The scene file kTmp/<name or type>.toml (tests running at once need different names).
fs::path writeScene(const std::string& type, const std::string& cells, const std::string& upper,
                    const std::string& name = "") {
  fs::create_directories(kTmp);
  const fs::path p = kTmp / ((name.empty() ? type : name) + ".toml");
  std::ofstream(p) << "[mesh]\ngenerator = \"box\"\ntype = \"" << type << "\"\ncells = " << cells
                   << "\nupper = " << upper << "\n[material]\nE = 1\nnu = 0.3\n[[dirichlet]]\n"
                      "boundary = \"left\"\n";
  return p;
}

class MeshCommandTest : public ::testing::TestWithParam<std::string> {};

TEST_P(MeshCommandTest, RandomRefinementReportIsConsistent) {
  const bool is2D = GetParam() == "triangle" || GetParam() == "quadrilateral";
  MeshCommandOptions o;
  o.scene = is2D ? writeScene(GetParam(), "[3, 2]", "[2.0, 1.0]")
                 : writeScene(GetParam(), "[2, 2, 1]", "[2.0, 1.0, 0.5]");
  o.uniform = 1;
  o.randomCycles = is2D ? 6 : 3;
  o.seed = 11;
  o.output = kTmp / ("out_" + GetParam());
  o.levels = true;
  const auto r = runMeshCommand(o);
  EXPECT_TRUE(r["conformity"]["conforming"].get<bool>());
  EXPECT_EQ(r["conformity"]["inverted_elements"].get<int>(), 0);
  EXPECT_NEAR(r["volume"].get<double>(), is2D ? 2.0 : 1.0, 1e-11);  // round-off of ~1e4 terms
  long long sumTypes = 0, sumLevels = 0;
  for (const auto& [k, v] : r["leaf_elements_per_type"].items()) sumTypes += v.get<long long>();
  for (const auto& [k, v] : r["leaf_elements_per_level"].items()) sumLevels += v.get<long long>();
  EXPECT_EQ(sumTypes, r["leaf_elements"].get<long long>());
  EXPECT_EQ(sumLevels, r["leaf_elements"].get<long long>());
  EXPECT_GT(r["levels"].get<int>(), 2);
  EXPECT_GT(r["quality"]["min"].get<double>(), 0.0);
  EXPECT_LE(r["quality"]["max"].get<double>(), 1.0 + 1e-12);
  ASSERT_EQ(r["output_files"].size(), 1u + r["levels"].get<std::size_t>());
  for (const auto& f : r["output_files"]) EXPECT_TRUE(fs::exists(f.get<std::string>()));
  // the same seed gives the same grid
  o.output.reset();
  const auto again = runMeshCommand(o);
  EXPECT_EQ(again["leaf_elements"], r["leaf_elements"]);
  EXPECT_EQ(again["vertices"], r["vertices"]);
}

INSTANTIATE_TEST_SUITE_P(AllTypes, MeshCommandTest,
                         ::testing::Values("triangle", "quadrilateral", "tetrahedron", "hexahedron",
                                           "prism", "pyramid"));

// On two threads (obs mesh --threads 2: the red refinement and the uniform propagation on threads,
// Grid::adapt) the report is that of one thread but for the times and the thread count: the same
// grid. 16^3 hexahedra refined uniformly (4,096 red elements), then a random local cycle of a
// quarter of the leaves (some 8,000 red elements, green closures): both on threads (from 2,048).
TEST(MeshCommand, TwoThreadsReportTheGridOfOne) {
  MeshCommandOptions o;
  o.scene = writeScene("hexahedron", "[16, 16, 16]", "[1.0, 1.0, 1.0]", "two_threads");
  o.uniform = 1;
  o.randomCycles = 1;
  o.fraction = 0.25;
  o.seed = 5;
  obs::setThreads(1);
  auto one = runMeshCommand(o);
  obs::setThreads(2);
  auto two = runMeshCommand(o);
  obs::setThreads(1);
  EXPECT_EQ(one["threads"].get<int>(), 1);
  EXPECT_EQ(two["threads"].get<int>(), 2);
  EXPECT_GT(one["leaf_elements"].get<long long>(), 32768);
  for (auto* r : {&one, &two}) {
    r->erase("times_s");
    r->erase("threads");
  }
  EXPECT_EQ(one, two);
}

TEST(MeshCommand, RejectsBadOptions) {
  MeshCommandOptions o;
  o.scene = writeScene("quadrilateral", "[2, 2]", "[2.0, 1.0]");
  o.fraction = 0;
  EXPECT_THROW(runMeshCommand(o), obs::Error);
  o.fraction = 0.1;
  o.randomCycles = -1;
  EXPECT_THROW(runMeshCommand(o), obs::Error);
  o.randomCycles = 0;
  o.scene = kTmp / "missing.toml";
  EXPECT_THROW(runMeshCommand(o), obs::Error);
}

}  // namespace
