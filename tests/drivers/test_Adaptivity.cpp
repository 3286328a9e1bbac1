// `obs run` with [adaptivity] (AdaptiveScene.hpp, docs/scenes.md): the example scenes 1A-3B run
// on a coarse setting, steps.csv / summary.json / pressure.csv / VTK per step, --set overrides and
// their errors, estimator / marking names, --plugin. The program tests are skipped when obs is
// not built; the parser tests always run.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "obs/drivers/SceneParser.hpp"
#include "obs/estimators/PluginPaths.hpp"
#include "obs/mesh/Error.hpp"

#include "DriverTestSupport.hpp"

using obs::test::slurp;
namespace fs = std::filesystem;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "adaptivity";
const fs::path kScenes = fs::path(OBS_DATA_DIR) / "scenes";

using Output = obs::test::ObsOutput;

/// Runs `obs <args>` in kTmp, capturing stdout and stderr.
Output runObs(const std::string& args, const std::string& tag) { return obs::test::runObs(kTmp, args, tag); }

using Table = std::vector<std::vector<std::string>>;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream is(line);
  while (std::getline(is, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

/// Header + rows of a CSV file without quoting.
Table readCsv(const fs::path& p) {
  Table t;
  std::ifstream in(p);
  for (std::string line; std::getline(in, line);) t.push_back(split(line));
  return t;
}

int col(const Table& t, const std::string& name) {
  for (std::size_t i = 0; i < t.at(0).size(); ++i)
    if (t[0][i] == name) return static_cast<int>(i);
  ADD_FAILURE() << "no column " << name;
  return 0;
}

double number(const Table& t, int row, const std::string& name) {
  const std::string& s = t.at(row).at(col(t, name));
  return s.empty() ? std::nan("") : std::stod(s);
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

constexpr double kPiTest = 3.14159265358979323846;

class AdaptiveRun : public ::testing::Test {
protected:
  void SetUp() override {
    if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  }
  /// Runs a scene with extra arguments into kTmp/<tag>.
  Output run(const std::string& scene, const std::string& args, const std::string& tag) {
    fs::remove_all(kTmp / tag);
    return runObs("run '" + scene + "' -o '" + (kTmp / tag).string() + "' " + args, tag);
  }
};

std::string scenePath(const std::string& name) { return (kScenes / (name + ".toml")).string(); }

}  // namespace

// Every example scene runs two steps; steps.csv, summary.json and pressure.csv hold the records.
TEST_F(AdaptiveRun, ExampleScenesRunTwoSteps) {
  for (const std::string name : {"example1a", "example1b", "example2a", "example2b", "example3a", "example3b"}) {
    SCOPED_TRACE(name);
    const Output o = run(scenePath(name), "--set adaptivity.steps=2", name);
    ASSERT_EQ(o.code, 0) << o.err;
    // one progress line per step on stderr
    EXPECT_TRUE(contains(o.err, "step 0/1: ")) << o.err;
    EXPECT_TRUE(contains(o.err, "step 1/1: ")) << o.err;
    const fs::path dir = kTmp / name;
    const Table steps = readCsv(dir / "steps.csv");
    ASSERT_EQ(steps.size(), 3u);
    for (std::size_t r = 1; r < steps.size(); ++r) ASSERT_EQ(steps[r].size(), steps[0].size()) << r;
    EXPECT_EQ(steps[1][0], "0");
    EXPECT_EQ(steps[2][0], "1");
    EXPECT_GT(number(steps, 2, "vertices"), number(steps, 1, "vertices"));  // refined
    EXPECT_GT(number(steps, 1, "marked"), 0);
    EXPECT_EQ(number(steps, 2, "marked"), 0);  // the last step marks nothing
    EXPECT_EQ(number(steps, 1, "unknowns"), number(steps, 1, "vertices") * (name[7] == '3' ? 3 : 2));
    for (int r : {1, 2}) {
      EXPECT_GT(number(steps, r, "eta"), 0);
      EXPECT_GT(number(steps, r, "actual_contact"), 0);
      EXPECT_LE(number(steps, r, "actual_contact"), number(steps, r, "potential_contact"));
      EXPECT_EQ(number(steps, r, "actual_contact"),
                number(steps, r, "semi_contact") + number(steps, r, "full_contact"));
      EXPECT_EQ(steps[r][col(steps, "converged")], "1");
      EXPECT_GT(number(steps, r, "load"), 0);
      EXPECT_TRUE(std::isfinite(number(steps, r, "pressure_error")));
      EXPECT_GT(number(steps, r, "exact_radius"), 0);
      // the eta_k columns add up to eta
      double sum = 0;
      for (int k = 1; k <= 8; ++k) {
        const double e = number(steps, r, "eta_" + std::to_string(k));
        if (std::isfinite(e)) sum += e * e;
      }
      EXPECT_NEAR(std::sqrt(sum), number(steps, r, "eta"), 1e-6 * number(steps, r, "eta"));
    }
    EXPECT_TRUE(std::isnan(number(steps, 1, "eoc")));
    EXPECT_TRUE(std::isfinite(number(steps, 2, "eoc")));

    const auto summary = nlohmann::json::parse(slurp(dir / "summary.json"));
    ASSERT_TRUE(summary.contains("adaptivity"));
    const auto& a = summary["adaptivity"];
    EXPECT_EQ(a["estimator"], "contact-residual");
    ASSERT_EQ(a["steps"].size(), 2u);
    EXPECT_EQ(a["steps"][1]["vertices"].get<double>(), number(steps, 2, "vertices"));
    EXPECT_EQ(summary["vertices"].get<double>(), number(steps, 2, "vertices"));  // final step
    EXPECT_EQ(summary["contact"]["actual_vertices"].get<double>(), number(steps, 2, "actual_contact"));

    const Table pressure = readCsv(dir / "pressure.csv");
    // one row per constrained vertex (finite gap; for the punch only the strip's), s sorted
    EXPECT_EQ(static_cast<double>(pressure.size() - 1), summary["contact"]["potential_vertices"].get<double>());
    EXPECT_LE(static_cast<double>(pressure.size() - 1), number(steps, 2, "potential_contact"));
    for (std::size_t r = 2; r < pressure.size(); ++r) EXPECT_LE(number(pressure, r - 1, "s"), number(pressure, r, "s"));
    // vtk = "last": one .vtu (the last step) and the collection
    EXPECT_TRUE(fs::exists(dir / "step_001.vtu"));
    EXPECT_FALSE(fs::exists(dir / "step_000.vtu"));
    EXPECT_TRUE(fs::exists(dir / (name + ".pvd")));
    // runs.csv: one row describing the final step
    const Table runs = readCsv(dir / "runs.csv");
    ASSERT_EQ(runs.size(), 2u);
    EXPECT_EQ(number(runs, 1, "vertices"), number(steps, 2, "vertices"));
  }
}

// vtk = "every": one .vtu per step with the estimator fields, and a .pvd listing them.
TEST_F(AdaptiveRun, VtkEveryWritesOneFilePerStep) {
  const Output o = run(scenePath("example1a"), "--set adaptivity.steps=3 --set 'adaptivity.vtk=\"every\"'", "every");
  ASSERT_EQ(o.code, 0) << o.err;
  const fs::path dir = kTmp / "every";
  for (const char* f : {"step_000.vtu", "step_001.vtu", "step_002.vtu"}) {
    ASSERT_TRUE(fs::exists(dir / f)) << f;
    const std::string vtu = slurp(dir / f);
    for (const char* field : {"\"displacement\"", "\"stress\"", "\"contact_pressure\"", "\"node_class\"",
                              "\"eta_1\"", "\"eta_6\"", "\"indicator\"", "\"marked\""})
      EXPECT_TRUE(contains(vtu, field)) << f << " lacks " << field;
  }
  EXPECT_FALSE(fs::exists(dir / "step_003.vtu"));
  const std::string pvd = slurp(dir / "example1a.pvd");
  EXPECT_TRUE(contains(pvd, "file=\"step_000.vtu\""));
  EXPECT_TRUE(contains(pvd, "file=\"step_002.vtu\""));
}

// reference_load: nodal_pressure_error_fixed_load is the nodal error of docs/theory.md#pressure-error
// with the fixed P*, recomputed here from pressure_NNN.csv (pressure = "every": one file per step,
// the last equal to pressure.csv); without reference_load the column is empty.
TEST_F(AdaptiveRun, FixedLoadNodalErrorAndPressurePerStep) {
  const double Pstar = 1549.10, b = 0.0625;
  const Output o = run(scenePath("example1b"),
                       "--set adaptivity.steps=3 --set adaptivity.reference_load=1549.10 "
                       "--set 'adaptivity.pressure=\"every\"'",
                       "fixedload");
  ASSERT_EQ(o.code, 0) << o.err;
  const fs::path dir = kTmp / "fixedload";
  const Table steps = readCsv(dir / "steps.csv");
  ASSERT_EQ(steps.size(), 4u);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(k);
    char name[32];
    std::snprintf(name, sizeof name, "pressure_%03d.csv", k);
    ASSERT_TRUE(fs::exists(dir / name));
    const Table p = readCsv(dir / name);
    double num = 0, den = 0, numP = 0, denP = 0;
    int inside = 0;
    const double P = number(steps, k + 1, "load");
    for (std::size_t r = 1; r < p.size(); ++r) {
      const double s = number(p, static_cast<int>(r), "x") - 0.5, sp = number(p, static_cast<int>(r), "s_p"),
                   m = number(p, static_cast<int>(r), "m_p");
      EXPECT_GT(m, 0);
      if (!(std::abs(s) < b)) continue;  // the two edge vertices (and nothing else) are left out
      ++inside;
      const double e = Pstar / (kPiTest * std::sqrt(b * b - s * s)), eP = P / (kPiTest * std::sqrt(b * b - s * s));
      num += m * (sp - e) * (sp - e);
      den += m * e * e;
      numP += m * (sp - eP) * (sp - eP);
      denP += m * eP * eP;
    }
    EXPECT_EQ(inside, static_cast<int>(p.size()) - 3);  // rows minus header minus the two edges
    EXPECT_NEAR(number(steps, k + 1, "nodal_pressure_error_fixed_load"), std::sqrt(num / den), 1e-7);
    EXPECT_NEAR(number(steps, k + 1, "nodal_pressure_error"), std::sqrt(numP / denP), 1e-7);
    // P differs from P* on these coarse grids, so the two columns differ
    EXPECT_NE(number(steps, k + 1, "nodal_pressure_error_fixed_load"), number(steps, k + 1, "nodal_pressure_error"));
  }
  EXPECT_FALSE(fs::exists(dir / "pressure_003.csv"));
  EXPECT_EQ(slurp(dir / "pressure_002.csv"), slurp(dir / "pressure.csv"));
  const auto summary = nlohmann::json::parse(slurp(dir / "summary.json"));
  EXPECT_EQ(summary["adaptivity"]["reference_load"].get<double>(), Pstar);
  EXPECT_NEAR(summary["adaptivity"]["steps"][2]["reference"]["nodal_pressure_error_fixed_load"].get<double>(),
              number(steps, 3, "nodal_pressure_error_fixed_load"), 1e-9);

  // without reference_load (example2a has none): the column is there and empty, one pressure.csv
  const Output w = run(scenePath("example2a"), "--set adaptivity.steps=2", "nofixedload");
  ASSERT_EQ(w.code, 0) << w.err;
  const Table s2 = readCsv(kTmp / "nofixedload" / "steps.csv");
  ASSERT_EQ(s2.size(), 3u);
  for (int r : {1, 2}) {
    ASSERT_EQ(s2[r].size(), s2[0].size());
    EXPECT_EQ(s2[r][col(s2, "nodal_pressure_error_fixed_load")], "");
  }
  EXPECT_FALSE(fs::exists(kTmp / "nofixedload" / "pressure_000.csv"));
}

// --set replaces scene keys: uniform refinement from 16 x 16 quadrilaterals gives the exact vertex
// counts 17^2, 33^2, 65^2; the eoc column agrees with the eta and vertex columns (docs/theory.md#eoc).
TEST_F(AdaptiveRun, SetOverridesRefinementAndEstimator) {
  const Output o = run(scenePath("example1a"),
                       "--set adaptivity.steps=3 --set 'adaptivity.refinement=\"uniform\"' "
                       "--set 'adaptivity.estimator=\"residual\"' --set 'adaptivity.vtk=\"none\"'",
                       "uniform");
  ASSERT_EQ(o.code, 0) << o.err;
  const fs::path dir = kTmp / "uniform";
  const Table steps = readCsv(dir / "steps.csv");
  ASSERT_EQ(steps.size(), 4u);
  EXPECT_EQ(number(steps, 1, "vertices"), 17 * 17);
  EXPECT_EQ(number(steps, 2, "vertices"), 33 * 33);
  EXPECT_EQ(number(steps, 3, "vertices"), 65 * 65);
  EXPECT_EQ(number(steps, 1, "marked"), 256);  // uniform: every cell
  for (int r : {2, 3}) {
    const double eoc = (std::log(number(steps, r - 1, "eta")) - std::log(number(steps, r, "eta"))) /
                       (std::log(number(steps, r, "vertices")) - std::log(number(steps, r - 1, "vertices")));
    EXPECT_NEAR(number(steps, r, "eoc"), eoc, 1e-6);
    EXPECT_GT(eoc, 0.1);  // the estimator decreases
  }
  const auto summary = nlohmann::json::parse(slurp(dir / "summary.json"));
  EXPECT_EQ(summary["adaptivity"]["estimator"], "residual");
  EXPECT_EQ(summary["adaptivity"]["refinement"], "uniform");
  EXPECT_FALSE(fs::exists(dir / "step_002.vtu"));  // vtk = "none"
  EXPECT_FALSE(contains(steps[0].back() + "," + slurp(dir / "steps.csv").substr(0, 200), "eta_6"));
}

TEST_F(AdaptiveRun, WCycleKeyReachesTheAdaptiveSolver) {
  // [solver] cycle = "W" reaches AdaptiveLoop's TNNMG: the adaptive Hertz run on tetrahedra takes
  // fewer iterations on the last (finest) step and ends with the same load
  const std::string args = "--set adaptivity.steps=4 --set 'adaptivity.vtk=\"none\"'";
  const Output v = run(scenePath("example3b"), args, "cycle_v_adaptive");
  const Output w = run(scenePath("example3b"), args + " --set 'solver.cycle=\"W\"'", "cycle_w_adaptive");
  ASSERT_EQ(v.code, 0) << v.err;
  ASSERT_EQ(w.code, 0) << w.err;
  const Table sv = readCsv(kTmp / "cycle_v_adaptive" / "steps.csv");
  const Table sw = readCsv(kTmp / "cycle_w_adaptive" / "steps.csv");
  ASSERT_EQ(sv.size(), 5u);
  ASSERT_EQ(sw.size(), 5u);
  EXPECT_EQ(number(sv, 4, "vertices"), number(sw, 4, "vertices"));
  EXPECT_LT(number(sw, 4, "iterations"), number(sv, 4, "iterations"));
  EXPECT_NEAR(number(sw, 4, "load"), number(sv, 4, "load"), 1e-7 * number(sv, 4, "load"));
}

TEST_F(AdaptiveRun, UnconvergedStepStopsTheLoopAndInexactIsRecorded) {
  // TNNMG capped at 8 iterations: the first step that needs more is the last one, not estimated
  const Output o = run(scenePath("example1a"), "--set adaptivity.steps=6 --set solver.max_iterations=8", "capped");
  EXPECT_EQ(o.code, 1);
  EXPECT_TRUE(contains(o.err, "did not converge in step ")) << o.err;
  EXPECT_TRUE(contains(o.err, "the adaptive loop stopped there without estimating on it")) << o.err;
  const auto summary = nlohmann::json::parse(slurp(kTmp / "capped" / "summary.json"));
  const auto& steps = summary["adaptivity"]["steps"];
  ASSERT_GE(steps.size(), 2u);
  ASSERT_LT(steps.size(), 6u);
  EXPECT_FALSE(steps.back()["converged"].get<bool>());
  EXPECT_TRUE(steps.back()["eta"].is_null());
  EXPECT_TRUE(steps[0]["converged"].get<bool>());

  // inexact = 0.1: intermediate steps record their looser tolerance, the first and last 1e-10
  const Output i = run(scenePath("example1a"), "--set adaptivity.steps=4 --set adaptivity.inexact=0.1", "inexact");
  ASSERT_EQ(i.code, 0) << i.err;
  const auto s = nlohmann::json::parse(slurp(kTmp / "inexact" / "summary.json"))["adaptivity"]["steps"];
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0]["solver_tolerance"].get<double>(), 1e-10);
  EXPECT_GT(s[1]["solver_tolerance"].get<double>(), 1e-8);
  EXPECT_EQ(s[3]["solver_tolerance"].get<double>(), 1e-10);
}

TEST_F(AdaptiveRun, BadSetGivesOneLineErrors) {
  struct Case {
    std::string set, message;
  };
  const std::vector<Case> cases = {
      {"adaptivity.steps=0", "example1a.toml (from --set): [adaptivity] steps = 0 must lie in [1, 100]"},
      {"adaptivity.nope=1", "example1a.toml (from --set): [adaptivity] unknown key 'nope'"},
      {"adaptivity.steps='\"many\"'", "(from --set): [adaptivity] steps must be an integer, got a string"},
      {"adaptivity.estimator=residual", "--set 'adaptivity.estimator=residual': the value residual is not a TOML value"},
      {"foo.bar=1", "unknown section [foo] (allowed sections: mesh, material"},
      {"adaptivity.steps", "expected section.key=value"},
      {"dirichlet.value=1", "[[dirichlet]] is an array of tables"},
      {"material.E=-1", "example1a.toml (from --set): [material] E = -1 must be positive"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.set);
    const Output o = run(scenePath("example1a"), "--set " + c.set, "badset");
    EXPECT_EQ(o.code, 1);
    EXPECT_TRUE(contains(o.err, c.message)) << o.err;
    EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
    EXPECT_FALSE(fs::exists(kTmp / "badset" / "steps.csv"));
  }
}

TEST_F(AdaptiveRun, PluginEstimatorCanBeNamedInTheScene) {
  if (!fs::exists(OBS_EXAMPLE_ESTIMATOR_PLUGIN))
    GTEST_SKIP() << "example plugin not built: " << OBS_EXAMPLE_ESTIMATOR_PLUGIN;
  // example-uniform gives every cell the same indicator: theta = 1 marks them all
  const std::string set =
      "--set adaptivity.steps=2 --set adaptivity.theta=1.0 --set 'adaptivity.estimator=\"example-uniform\"'";
  // without the plugin the name is unknown, and the message lists the known names
  const Output without = run(scenePath("example1a"), set, "noplugin");
  EXPECT_EQ(without.code, 1);
  EXPECT_TRUE(contains(without.err, "[adaptivity] estimator = \"example-uniform\" is unknown (known estimators: "
                                    "contact-residual, residual"))
      << without.err;
  const Output with =
      run(scenePath("example1a"), "--plugin '" + std::string(OBS_EXAMPLE_ESTIMATOR_PLUGIN) + "' " + set, "plugin");
  ASSERT_EQ(with.code, 0) << with.err;
  const auto summary = nlohmann::json::parse(slurp(kTmp / "plugin" / "summary.json"));
  EXPECT_EQ(summary["adaptivity"]["estimator"], "example-uniform");
  EXPECT_EQ(summary["adaptivity"]["steps"].size(), 2u);
}

TEST_F(AdaptiveRun, BadPluginPathIsAClearError) {
  const Output o = run(scenePath("example1a"), "--plugin /nonexistent/libno_such.so", "badplugin");
  EXPECT_EQ(o.code, 1);
  EXPECT_TRUE(contains(o.err, "obs: error: estimator plugin '/nonexistent/libno_such.so': cannot load")) << o.err;
  EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
}

TEST_F(AdaptiveRun, HelpDocumentsSetAndPlugin) {
  const Output o = runObs("run --help", "runhelp");
  EXPECT_EQ(o.code, 0);
  for (const char* s : {"--set", "--plugin", "--plots", "[adaptivity]", "steps.csv"})
    EXPECT_TRUE(contains(o.out, s)) << s;
}

// ---- parser (no program needed) -------------------------------------------------------------

namespace {

const std::string kBase = R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 4]
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
)";

std::string parseError(const std::string& text, const std::vector<std::string>& overrides = {}) {
  try {
    obs::drivers::parseSceneString(text, "s.toml", ".", overrides);
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(AdaptivityParser, DefaultsAndValues) {
  using obs::drivers::AdaptivitySpec;
  const auto plain = obs::drivers::parseSceneString(kBase, "s.toml", ".");
  EXPECT_FALSE(plain.adaptivity.has_value());  // without [adaptivity]: a static run
  const auto d = obs::drivers::parseSceneString(kBase + "[adaptivity]\n", "s.toml", ".");
  ASSERT_TRUE(d.adaptivity);
  EXPECT_FALSE(d.adaptivity->uniform);
  EXPECT_EQ(d.adaptivity->estimator, "contact-residual");
  EXPECT_EQ(d.adaptivity->marking, "mean");
  EXPECT_FALSE(d.adaptivity->theta);
  EXPECT_EQ(d.adaptivity->steps, 8);
  EXPECT_EQ(d.adaptivity->vtk, AdaptivitySpec::Vtk::Last);
  const auto s = obs::drivers::parseSceneString(
      kBase + "[adaptivity]\nrefinement = \"uniform\"\nestimator = \"residual\"\nmarking = \"doerfler\"\n"
              "theta = 0.3\nsteps = 4\nmax_vertices = 1000\neta_tolerance = 0.5\nreference = \"punch\"\n"
              "vtk = \"every\"\n",
      "s.toml", ".");
  EXPECT_TRUE(s.adaptivity->uniform);
  EXPECT_EQ(s.adaptivity->estimator, "residual");
  EXPECT_EQ(s.adaptivity->marking, "doerfler");
  EXPECT_EQ(*s.adaptivity->theta, 0.3);
  EXPECT_EQ(s.adaptivity->steps, 4);
  EXPECT_EQ(s.adaptivity->maxVertices, 1000);
  EXPECT_EQ(s.adaptivity->etaTolerance, 0.5);
  EXPECT_EQ(s.adaptivity->reference, "punch");
  EXPECT_EQ(s.adaptivity->vtk, AdaptivitySpec::Vtk::Every);
  EXPECT_FALSE(s.adaptivity->referenceLoad);
  EXPECT_FALSE(s.adaptivity->pressureEvery);
  const auto fixed = obs::drivers::parseSceneString(
      kBase + "[adaptivity]\nreference = \"punch\"\nreference_load = 1549.10\npressure = \"every\"\n", "s.toml", ".");
  EXPECT_EQ(*fixed.adaptivity->referenceLoad, 1549.10);
  EXPECT_TRUE(fixed.adaptivity->pressureEvery);
  EXPECT_FALSE(s.adaptivity->closureAllEdges);  // default "half-edges"
  EXPECT_TRUE(obs::drivers::parseSceneString(kBase + "[adaptivity]\nclosure = \"all-edges\"\n", "s.toml", ".")
                  .adaptivity->closureAllEdges);
  // an override replaces a file value and may create the section
  const auto o = obs::drivers::parseSceneString(kBase, "s.toml", ".", {"adaptivity.steps=3", "output.plots=true"});
  ASSERT_TRUE(o.adaptivity);
  EXPECT_EQ(o.adaptivity->steps, 3);
  EXPECT_TRUE(o.output.plots);
}

TEST(AdaptivityParser, ErrorsNameLineAndKnownNames) {
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nmarking = \"best\"\n"),
            "s.toml:17: [adaptivity] marking = \"best\" is unknown (known strategies: doerfler, fraction, "
            "maximum, mean)");
  EXPECT_TRUE(contains(parseError(kBase + "[adaptivity]\nestimator = \"zz\"\n"),
                       "s.toml:17: [adaptivity] estimator = \"zz\" is unknown (known estimators: contact-residual, "
                       "residual"));
  EXPECT_TRUE(contains(parseError(kBase + "[adaptivity]\nmarking = \"doerfler\"\ntheta = 2\n"),
                       "s.toml:18: [adaptivity] theta = 2 is not valid for marking = \"doerfler\""));
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nrefinement = \"random\"\n"),
            "s.toml:17: [adaptivity] refinement = \"random\" is unknown (known: adaptive, uniform)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nreference = \"sphere\"\n"),
            "s.toml:17: [adaptivity] reference = \"sphere\" is unknown (known references: punch, wedge, hertz)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nvtk = \"all\"\n"),
            "s.toml:17: [adaptivity] vtk = \"all\" is unknown (known: every, last, none)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nmax_vertices = -1\n"),
            "s.toml:17: [adaptivity] max_vertices = -1 must not be negative (0: off)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nclosure = \"green\"\n"),
            "s.toml:17: [adaptivity] closure = \"green\" is unknown (known: half-edges, all-edges)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nreference_load = 1549.1\n"),
            "s.toml:17: [adaptivity] reference_load needs reference = \"punch\", \"wedge\" or \"hertz\" (it is the "
            "load of the reference)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nreference = \"punch\"\nreference_load = -2\n"),
            "s.toml:18: [adaptivity] reference_load = -2 must be positive and finite");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\npressure = \"all\"\n"),
            "s.toml:17: [adaptivity] pressure = \"all\" is unknown (known: every, last)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\ninexact = 1.5\n"),
            "s.toml:17: [adaptivity] inexact = 1.5 must lie in [0, 1) (the fraction of the estimator; 0: off)");
  // the same problems from --set name the override instead of a line
  EXPECT_EQ(parseError(kBase, {"adaptivity.marking=\"best\""}),
            "s.toml (from --set): [adaptivity] marking = \"best\" is unknown (known strategies: doerfler, "
            "fraction, maximum, mean)");
  EXPECT_EQ(parseError(kBase + "[adaptivity]\nsteps = 2\n", {"adaptivity.steps=-2"}),
            "s.toml (from --set): [adaptivity] steps = -2 must lie in [1, 100]");
}
