// Reproducibility (docs/reliability.md): two runs of the same scene give bitwise identical
// results. Every number of summary.json except the wall times and memory figures, and every VTK
// file, must agree byte for byte between two runs of a static contact scene (the punch, TNNMG) and
// a small dynamic contact scene (the bar dropped on a plane).
#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>

#include "DriverTestSupport.hpp"

namespace {

namespace fs = std::filesystem;

#ifdef OBS_BINARY

/// Keys whose values measure the machine rather than the computation.
bool isMachineFigure(const std::string& key) {
  for (const char* part : {"time", "seconds", "memory", "peak", "_s", "date", "host"})
    if (key.find(part) != std::string::npos) return true;
  return false;
}

/// Compares two JSON documents, skipping machine figures; `path` names the position in messages.
void expectSameResults(const nlohmann::json& a, const nlohmann::json& b, const std::string& path, int& compared) {
  ASSERT_EQ(a.type(), b.type()) << path;
  if (a.is_object()) {
    ASSERT_EQ(a.size(), b.size()) << path;
    for (auto it = a.begin(); it != a.end(); ++it) {
      if (isMachineFigure(it.key())) continue;
      ASSERT_TRUE(b.contains(it.key())) << path << "." << it.key();
      expectSameResults(it.value(), b.at(it.key()), path + "." + it.key(), compared);
    }
  } else if (a.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << path;
    for (std::size_t i = 0; i < a.size(); ++i) expectSameResults(a[i], b[i], path + "[" + std::to_string(i) + "]", compared);
  } else if (a.is_number_float()) {
    // bitwise: the same double (JSON writes the shortest round-trip form)
    EXPECT_EQ(a.get<double>(), b.get<double>()) << path;
    ++compared;
  } else {
    EXPECT_EQ(a, b) << path;
    ++compared;
  }
}

void expectReproducible(const std::string& scene, const std::string& extra, const std::string& tag) {
  const fs::path work = fs::path(OBS_TEST_TMP_DIR) / ("reproducibility_" + tag);
  fs::remove_all(work);
  // the same relative output directory in two working directories, so that paths agree too
  for (const char* run : {"a", "b"}) {
    const auto o = obs::test::runObs(work / run, "run '" + std::string(OBS_DATA_DIR) + "/scenes/" + scene +
                                                     "' -q -o out " + extra,
                                     "run");
    ASSERT_EQ(o.code, 0) << o.err;
  }
  const fs::path a = work / "a" / "out", b = work / "b" / "out";
  int compared = 0;
  expectSameResults(obs::test::summaryOf(a), obs::test::summaryOf(b), "summary", compared);
  EXPECT_GT(compared, 10);
  std::set<std::string> vtk;
  for (const auto& e : fs::directory_iterator(a))
    if (e.path().extension() == ".vtu" || e.path().extension() == ".pvd") vtk.insert(e.path().filename().string());
  EXPECT_FALSE(vtk.empty());
  for (const std::string& f : vtk) {
    ASSERT_TRUE(fs::exists(b / f)) << f;
    const std::string fa = obs::test::slurp(a / f), fb = obs::test::slurp(b / f);
    EXPECT_FALSE(fa.empty()) << f;
    EXPECT_TRUE(fa == fb) << f << " differs between two runs";
  }
}

TEST(Reproducibility, ContactSceneGivesBitwiseIdenticalResults) {
  expectReproducible("punch.toml", "", "punch");
}

TEST(Reproducibility, DynamicSceneGivesBitwiseIdenticalResults) {
  expectReproducible("dynamics_bar.toml", "--set dynamics.steps=120", "dynamics");
}

#endif

}  // namespace

// Two threads (docs/performance.md#threads): step-42 at 16^3 cells (4,913 vertices, above the size
// below which loops stay sequential), so the sweeps run in their METIS order on both threads.
TEST(Reproducibility, TwoThreadsGiveBitwiseIdenticalResults) {
  expectReproducible("step42.toml", "--threads 2", "threads2");
}
