// `obs sweep` (SweepCommand.hpp): --vary parsing, every combination in its own process, sweep.csv
// with accuracy against the finest run and the cost of each run, failed runs as rows, resuming an
// interrupted sweep, errors before anything runs, and the program's exit code.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "obs/drivers/SweepCommand.hpp"
#include "obs/mesh/Error.hpp"

#include "DriverTestSupport.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "sweep";

/// The punch of docs/theory.md#analytic-references, small.
fs::path punchScene() {
  // one file per test: ctest runs the tests of this file in parallel processes
  const fs::path dir = kTmp / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::create_directories(dir);
  const fs::path p = dir / "punch.toml";
  std::ofstream(p) << R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 4]
refine = 1

[material]
E = 3e5
nu = 0.25

[[dirichlet]]
boundary = "top"
value = [0, -0.01]

[contact]
boundary = "bottom"
obstacle = "strip"
point = [0.5, 0]
half_width = 0.0625
direction = [0, -1]
)";
  return p;
}

/// sweep.csv as rows of column -> value.
std::vector<std::map<std::string, std::string>> readCsv(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::string cur;
    bool quoted = false;
    for (char c : s) {
      if (c == '"') quoted = !quoted;
      else if (c == ',' && !quoted) out.push_back(cur), cur.clear();
      else cur += c;
    }
    out.push_back(cur);
    return out;
  };
  std::getline(in, line);
  header = split(line);
  while (std::getline(in, line)) {
    const auto fields = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < fields.size(); ++i) row[header[i]] = fields[i];
    rows.push_back(row);
  }
  return rows;
}

SweepOptions options(const fs::path& out) {
  SweepOptions o;
  o.scene = punchScene();
  o.output = out;
  o.obsBinary = OBS_BINARY;
  return o;
}

}  // namespace

TEST(Sweep, ParsesVaryArguments) {
  const SweepVariable a = parseSweepVariable("mesh.refine=1, 2,3");
  EXPECT_EQ(a.key, "mesh.refine");
  EXPECT_EQ(a.values, (std::vector<std::string>{"1", "2", "3"}));
  const SweepVariable b = parseSweepVariable("dirichlet.value=[0,0,-1],[0, 0, -2]");
  EXPECT_EQ(b.values, (std::vector<std::string>{"[0,0,-1]", "[0, 0, -2]"}));
  const SweepVariable c = parseSweepVariable("mesh.type=\"quadrilateral\",'a,b'");
  EXPECT_EQ(c.values, (std::vector<std::string>{"\"quadrilateral\"", "'a,b'"}));
  for (const char* bad : {"mesh.refine", "=1,2", "refine=1,2", "mesh.refine=1,,2", "mesh.value=[1,2"}) {
    try {
      parseSweepVariable(bad);
      ADD_FAILURE() << bad << ": no error";
    } catch (const obs::Error& e) {
      EXPECT_NE(std::string(e.what()).find("--vary"), std::string::npos) << e.what();
    }
  }
}

#ifdef OBS_MPIEXEC
// --mpi 2: every run through the MPI launcher on two ranks (the distributed runner); the loads are
// the runs' in one process, the ranks column and each summary say 2, peak_mb is the largest
// rank's, and a sweep in one process does not reuse the distributed runs.
TEST(Sweep, RunsEveryCombinationOnMpiRanks) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  // Open MPI under CI runs as root; the tests on 2 cores oversubscribe nothing at 2 ranks
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  setenv("OMP_WAIT_POLICY", "PASSIVE", 1);
  const fs::path out = kTmp / "mpi";
  fs::remove_all(out);
  SweepOptions o = options(out);
  o.vary = {parseSweepVariable("mesh.refine=1,2")};
  o.mpiRanks = 2;
  o.mpiLauncher = OBS_MPIEXEC;
  const SweepSummary s = runSweep(o);
  EXPECT_EQ(s.failed, 0);
  const auto rows = readCsv(out / "sweep.csv");
  ASSERT_EQ(rows.size(), 2u);
  SweepOptions serial = options(kTmp / "mpi_serial");
  fs::remove_all(serial.output);
  serial.vary = o.vary;
  runSweep(serial);
  const auto one = readCsv(serial.output / "sweep.csv");
  ASSERT_EQ(one.size(), 2u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].at("status"), "ok") << rows[i].at("error");
    EXPECT_EQ(rows[i].at("ranks"), "2");
    EXPECT_EQ(one[i].at("ranks"), "1");
    EXPECT_EQ(rows[i].at("unknowns"), one[i].at("unknowns"));
    const double p = std::stod(one[i].at("load_P"));
    EXPECT_NEAR(std::stod(rows[i].at("load_P")), p, 1e-9 * p);
    std::ifstream in(out / ("run_00" + std::to_string(i)) / "summary.json");
    const nlohmann::json summary = nlohmann::json::parse(in);
    EXPECT_EQ(summary.value("ranks", 0), 2);
    EXPECT_DOUBLE_EQ(std::stod(rows[i].at("peak_mb")), summary.value("peak_memory_mb_largest_rank", 0.0));
  }
  // the same sweep in one process reruns everything (the finished runs had 2 ranks)
  o.mpiRanks = 0;
  const SweepSummary again = runSweep(o);
  EXPECT_EQ(again.reused, 0);
  EXPECT_EQ(readCsv(out / "sweep.csv").front().at("ranks"), "1");
}
#endif

TEST(Sweep, RunsEveryCombinationAndMeasuresAccuracyAgainstTheFinestRun) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path out = kTmp / "refine";
  fs::remove_all(out);
  SweepOptions o = options(out);
  o.vary = {parseSweepVariable("mesh.refine=0,1,2"), parseSweepVariable("solver.tolerance=1e-6,1e-10")};
  std::vector<std::string> lines;
  o.progress = [&](const std::string& l) { lines.push_back(l); };
  const SweepSummary s = runSweep(o);
  EXPECT_EQ(s.runs, 6);
  EXPECT_EQ(s.failed, 0);
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_NE(lines[0].find("[1/6] mesh.refine=0 solver.tolerance=1e-6: "), std::string::npos) << lines[0];
  const auto rows = readCsv(out / "sweep.csv");
  ASSERT_EQ(rows.size(), 6u);
  // the last key varies fastest; the reference is the finest run with the smaller tolerance
  EXPECT_EQ(rows[5].at("mesh.refine"), "2");
  EXPECT_EQ(rows[5].at("solver.tolerance"), "1e-10");
  EXPECT_EQ(rows[5].at("reference"), "1");
  EXPECT_EQ(rows[5].at("load_error"), "");
  for (const auto& r : rows) {
    EXPECT_EQ(r.at("status"), "ok");
    EXPECT_GT(std::stod(r.at("wall_s")), 0);
    EXPECT_GT(std::stod(r.at("peak_mb")), 1);
    EXPECT_FALSE(r.at("load_P").empty());
  }
  // load_error = |P - P_ref| / P_ref with the reference's P
  const double reference = std::stod(rows[5].at("load_P"));
  for (int i : {0, 1, 2, 3, 4}) {
    const double p = std::stod(rows[i].at("load_P"));
    EXPECT_NEAR(std::stod(rows[i].at("load_error")), std::abs(p - reference) / reference, 1e-8);
  }
  EXPECT_GT(std::stod(rows[1].at("load_error")), 1e-3);  // another grid: another load
  EXPECT_EQ(std::stod(rows[0].at("unknowns")), std::stod(rows[1].at("unknowns")));
  EXPECT_LT(std::stod(rows[1].at("unknowns")), std::stod(rows[3].at("unknowns")));
  // each run kept its own outputs
  EXPECT_TRUE(fs::exists(out / "run_004" / "summary.json"));
  EXPECT_TRUE(fs::exists(out / "run_004" / "sweep_run.json"));
}

TEST(Sweep, ExplicitReferenceRun) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path out = kTmp / "reference";
  fs::remove_all(out);
  SweepOptions o = options(out);
  o.vary = {parseSweepVariable("mesh.refine=0,1")};
  o.referenceOverrides = {"mesh.refine=3"};
  const SweepSummary s = runSweep(o);
  EXPECT_EQ(s.runs, 2);
  const auto rows = readCsv(out / "sweep.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[2].at("run"), "ref");
  EXPECT_EQ(rows[2].at("mesh.refine"), "3");
  EXPECT_EQ(rows[2].at("reference"), "1");
  EXPECT_GT(std::stod(rows[2].at("unknowns")), std::stod(rows[1].at("unknowns")));
  const double reference = std::stod(rows[2].at("load_P"));
  for (int i : {0, 1})
    EXPECT_NEAR(std::stod(rows[i].at("load_error")), std::abs(std::stod(rows[i].at("load_P")) - reference) / reference,
                1e-8);
  EXPECT_TRUE(fs::exists(out / "run_ref" / "summary.json"));
  o.referenceOverrides = {"mesh.refin=3"};
  EXPECT_THROW(runSweep(o), obs::Error);
}

TEST(Sweep, DynamicRunsReportEnergyAndContactForce) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path out = kTmp / "dynamic";
  fs::remove_all(out);
  SweepOptions o = options(out);
  o.scene = fs::path(OBS_DATA_DIR) / "scenes" / "dynamics_bar.toml";
  o.vary = {parseSweepVariable("dynamics.scheme=\"contact-implicit\",\"contact-stabilized\"")};
  EXPECT_EQ(runSweep(o).failed, 0);
  const auto rows = readCsv(out / "sweep.csv");
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& r : rows) {
    const double ratio = std::stod(r.at("energy_ratio"));
    EXPECT_NEAR(std::stod(r.at("energy_error")), std::abs(ratio - 1), 1e-9);
    EXPECT_GE(std::stod(r.at("force_variation")), 0);
    EXPECT_FALSE(r.at("max_penetration").empty());
  }
  // the contact force of the contact-implicit scheme oscillates, the stabilized one's does not
  // (docs/dynamics.md): a much larger total variation
  EXPECT_GT(std::stod(rows[0].at("force_variation")), 2 * std::stod(rows[1].at("force_variation")));
}

TEST(Sweep, FailedRunsAreRowsAndASweepResumes) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path out = kTmp / "resume";
  fs::remove_all(out);
  SweepOptions o = options(out);
  o.overrides = {"solver.tolerance=1e-14"};
  o.vary = {parseSweepVariable("solver.max_iterations=1,200")};
  const SweepSummary first = runSweep(o);
  EXPECT_EQ(first.failed, 1);
  auto rows = readCsv(out / "sweep.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].at("status"), "failed");
  EXPECT_NE(rows[0].at("error").find("did not converge in 1 iterations"), std::string::npos) << rows[0].at("error");
  EXPECT_EQ(rows[1].at("status"), "ok");

  // again: nothing reruns; without its record, run 1 reruns
  std::vector<std::string> lines;
  o.progress = [&](const std::string& l) { lines.push_back(l); };
  const SweepSummary second = runSweep(o);
  EXPECT_EQ(second.reused, 2);
  fs::remove(out / "run_001" / "sweep_run.json");
  lines.clear();
  const SweepSummary third = runSweep(o);
  EXPECT_EQ(third.reused, 1);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find("reused"), std::string::npos);
  EXPECT_EQ(lines[1].find("reused"), std::string::npos);
  // other overrides do not reuse the records
  o.overrides = {"solver.tolerance=1e-12"};
  EXPECT_EQ(runSweep(o).reused, 0);
}

TEST(Sweep, BadKeysAreErrorsBeforeAnythingRuns) {
  const fs::path out = kTmp / "bad";
  fs::remove_all(out);
  SweepOptions o = options(out);
  o.vary = {parseSweepVariable("mesh.refine=1,2"), parseSweepVariable("solver.tolerance=1e-8,2")};
  try {
    runSweep(o);
    ADD_FAILURE() << "no error";
  } catch (const obs::Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("tolerance"), std::string::npos) << m;
    EXPECT_NE(m.find("in the sweep combination mesh.refine=1 solver.tolerance=2"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(out / "run_000"));
  o.vary = {parseSweepVariable("mesh.refine=1,2"), parseSweepVariable("mesh.refine=3")};
  EXPECT_THROW(runSweep(o), obs::Error);
}

TEST(Sweep, CommandLineExitCodes) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path scene = punchScene();
  const auto ok = obs::test::runObs(kTmp, "sweep '" + scene.string() + "' --vary mesh.refine=0,1 -o cli_ok", "cli_ok");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_NE(ok.out.find("sweep.csv"), std::string::npos);
  const auto failed = obs::test::runObs(
      kTmp, "sweep '" + scene.string() + "' --set solver.tolerance=1e-14 --vary solver.max_iterations=1,200 -o cli_fail",
      "cli_fail");
  EXPECT_EQ(failed.code, 1);
  EXPECT_NE(failed.err.find("obs: error: sweep: 1 of 2 runs failed"), std::string::npos) << failed.err;
  const auto usage = obs::test::runObs(kTmp, "sweep '" + scene.string() + "' -o x", "cli_usage");
  EXPECT_EQ(usage.code, 2);
}
