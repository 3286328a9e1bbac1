// Imported meshes without refinement levels (docs/reliability.md): on a one-level grid TNNMG's
// multigrid correction degenerates to a direct solve, refactorised at every active-set change. obs
// solves such scenes correctly but says so, once, on stderr, with what it costs and how to avoid it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "DriverTestSupport.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"

namespace {

namespace fs = std::filesystem;

std::string sceneText(const std::string& solver) {
  return "[mesh]\nfile = \"" OBS_DATA_DIR "/meshes/square_triangles.msh\"\n"
         "[material]\nE = 100\nnu = 0.3\n"
         "[[dirichlet]]\nboundary = \"top\"\nvalue = [0, -0.01]\n"
         "[contact]\nboundary = \"bottom\"\nobstacle = \"plane\"\npoint = [0, 0]\ndirection = [0, -1]\n" +
         solver;
}

TEST(SingleLevelWarning, OnlyForMultigridSolversOnOneLevel) {
  using obs::drivers::singleLevelWarning;
  const auto scene = obs::drivers::parseSceneString(sceneText(""), "s.toml", ".");
  const std::string w = singleLevelWarning(scene, obs::drivers::buildGrid(scene));
  EXPECT_EQ(w.rfind("warning: the grid has a single level (a mesh file without refine), so TNNMG", 0), 0u) << w;
  EXPECT_NE(w.find("refactorised whenever the active set changes"), std::string::npos) << w;
  EXPECT_NE(w.find("[mesh] refine = 1"), std::string::npos) << w;
  EXPECT_EQ(singleLevelWarning(scene, obs::drivers::buildGrid(scene, 1)), "");  // a hierarchy: no warning
  // solvers without a hierarchy: nothing to warn about
  for (const char* type : {"pdas", "pgs"}) {
    const auto other = obs::drivers::parseSceneString(sceneText("[solver]\ntype = \"" + std::string(type) + "\"\n"),
                                                      "s.toml", ".");
    EXPECT_EQ(singleLevelWarning(other, obs::drivers::buildGrid(other)), "") << type;
  }
}

#ifdef OBS_BINARY
TEST(SingleLevelWarning, ObsRunWarnsOnStderrAndStillSolves) {
  const fs::path work = fs::path(OBS_TEST_TMP_DIR) / "single_level";
  fs::create_directories(work);
  std::ofstream(work / "imported.toml") << sceneText("");
  const auto one = obs::test::runObs(work, "run imported.toml -o one", "one");
  ASSERT_EQ(one.code, 0) << one.err;
  EXPECT_NE(one.err.find("warning: the grid has a single level"), std::string::npos) << one.err;
  EXPECT_TRUE(obs::test::summaryOf(work / "one")["solver"]["converged"].get<bool>());
  const auto two = obs::test::runObs(work, "run imported.toml --refine 1 -o two", "two");
  ASSERT_EQ(two.code, 0) << two.err;
  EXPECT_EQ(two.err.find("warning"), std::string::npos) << two.err;
}
#endif

}  // namespace
