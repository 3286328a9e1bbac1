// Dynamic contact scenes ([dynamics], drivers DynamicScene.hpp): the three data scenes (ball =
// Geometry A, rounded block = Geometry 1, the 1D bar as a column) run a few steps and write
// timeseries.csv, the .pvd collection and summary.json "dynamics"; the bar's contact end follows
// the exact free flight h0 - v0 t to 1e-8 before impact and lifts off near the exact time
// h0/v0 + 2L/c0; a comparison writes one series per scheme (scene option and --compare-schemes on
// the command line); bad input (tau <= 0, missing density, unknown scheme, end_time and steps,
// an initial state violating the constraint, ...) is a one-line error with file:line and key
// before the first step; static scenes assemble no mass matrix; [dynamics] inexact records the
// tolerance of every step, saves iterations, and off (the default) changes nothing.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "obs/drivers/DynamicScene.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"

#include "DriverTestSupport.hpp"

using obs::test::readCsv;
using obs::test::slurp;
using obs::test::Table;
using obs::test::summaryOf;
namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "dynamics";
const fs::path kScenes = fs::path(OBS_DATA_DIR) / "scenes";

/// Runs a scene into a fresh kTmp/<out>.
RunResult runInto(const Scene& scene, const std::string& out, bool compare = false) {
  fs::remove_all(kTmp / out);
  RunOptions o;
  o.outputDirectory = kTmp / out;
  o.compareSchemes = compare;
  return runScene(scene, o);
}

/// Runs a data scene with `steps` time steps into kTmp/<out>.
RunResult runData(const std::string& name, int steps, const std::string& out, bool compare = false) {
  Scene scene = parseScene(kScenes / (name + ".toml"));
  scene.dynamics->steps = steps;
  scene.dynamics->endTime.reset();
  return runInto(scene, out, compare);
}

std::string errorOf(const std::string& text, const std::string& file = "bad.toml") {
  try {
    const Scene scene = parseSceneString(text, file, kTmp);
    validateScene(scene, buildMesh(scene));
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "";
}

/// The bar scene with a replaceable [dynamics] body (lines: [mesh] 1, [material] 8, [contact] 13,
/// [dynamics] 19, its first key 20).
std::string barScene(const std::string& dynamics, const std::string& material = "density = 1\n") {
  return "[mesh]\ngenerator = \"box\"\ntype = \"quadrilateral\"\ncells = [1, 20]\nlower = [0, 5]\n"
         "upper = [1, 15]\n\n"
         "[material]\nE = 900\nnu = 0\n" +
         material +
         "\n[contact]\nboundary = \"bottom\"\nobstacle = \"plane\"\npoint = [0, 0]\ndirection = [0, -1]\n\n"
         "[dynamics]\n" +
         dynamics;
}

void expectContains(const std::string& message, const std::vector<std::string>& parts) {
  for (const std::string& p : parts) EXPECT_NE(message.find(p), std::string::npos) << p << "\n  in: " << message;
}

}  // namespace

TEST(DynamicScenes, EachDataSceneRunsAFewSteps) {
  for (const char* name : {"dynamics_ball", "dynamics_block", "dynamics_bar"}) {
    SCOPED_TRACE(name);
    const RunResult r = runData(name, 3, name);
    const fs::path dir = kTmp / name;
    const Table ts = readCsv(dir / "timeseries.csv");
    ASSERT_EQ(ts.rows, 4u);  // t^0 .. t^3
    for (const char* col :
         {"t", "step", "energy", "energy_redistributed", "momentum_x", "momentum_z", "contact_force_x",
          "contact_force_z", "active_solution", "active_predictor", "predictor_only", "solution_only",
          "max_penetration", "solver_iterations", "solver_seconds", "tracked0_normal_displacement",
          "tracked0_normal_velocity", "tracked0_gap", "solver_kkt", "solver_error_bound"})
      EXPECT_TRUE(ts.columns.count(col)) << col;
    EXPECT_EQ(ts["step"][3], 3);
    // the lumped mass bounds every step's error (docs/theory.md#tnnmg-error-bound): empty at t^0, a
    // bound of the solution's relative error afterwards, below the tolerance it stopped at
    EXPECT_TRUE(std::isnan(ts["solver_error_bound"][0]));
    for (std::size_t i = 1; i < ts.rows; ++i) {
      EXPECT_GE(ts["solver_error_bound"][i], 0) << "row " << i;
      EXPECT_LT(ts["solver_error_bound"][i], ts["solver_tolerance"][i]) << "row " << i;
    }
    const nlohmann::json s = summaryOf(dir);
    const auto& d = s.at("dynamics");
    EXPECT_EQ(d.at("scheme"), "improved-contact-stabilized");
    EXPECT_EQ(d.at("steps"), 3);
    EXPECT_NEAR(d.at("end_time").get<double>(), 3 * d.at("tau").get<double>(), 1e-14);
    EXPECT_DOUBLE_EQ(d.at("initial_energy").get<double>(), ts["energy"][0]);
    EXPECT_DOUBLE_EQ(d.at("final_energy").get<double>(), ts["energy"][3]);
    EXPECT_GT(d.at("initial_energy").get<double>(), 0);
    // the energy-dissipative scheme never gains energy
    EXPECT_LE(d.at("energy_ratio").get<double>(), 1 + 1e-10);
    EXPECT_GE(d.at("max_penetration").get<double>(), 0);
    EXPECT_GT(d.at("mean_iterations_per_step").get<double>(), 0);
    ASSERT_EQ(d.at("tracked").size(), 1u);
    EXPECT_TRUE(d.at("tracked")[0].at("contact_node").get<bool>());
    EXPECT_EQ(s.at("mass_assemblies"), 1);
    EXPECT_FALSE(s.contains("dynamics_comparison"));
    EXPECT_EQ(s.at("solver").at("type"), "tnnmg");
    // .pvd over time: steps 0 and 3 (last) at least
    const std::string pvd = slurp(dir / (std::string(name) + ".pvd"));
    EXPECT_NE(pvd.find("type=\"Collection\""), std::string::npos);
    EXPECT_NE(pvd.find(std::string(name) + "_000000.vtu"), std::string::npos);
    EXPECT_NE(pvd.find(std::string(name) + "_000003.vtu"), std::string::npos);
    EXPECT_TRUE(fs::exists(dir / (std::string(name) + "_000003.vtu")));
    // runs.csv row as for static scenes
    EXPECT_TRUE(fs::exists(dir / "runs.csv"));
    EXPECT_EQ(r.massAssemblies, 1);
  }
}

TEST(DynamicScenes, VtkHasTheContactPressureAndNormalVelocity) {
  // The bar (width 1, bottom y = 5 with two vertices, m_p^C = 1/2 each) falls with v0 = 10 onto
  // y = 0: impact at t = h0/v0 = 0.5 (step 167 of tau = 3e-3), contact for 2L/c0 = 2/3 after it
  // with the contact stress rho c0 v0 = 300 of the exact solution (the scale of the round-off bounds).
  Scene scene = parseScene(kScenes / "dynamics_bar.toml");
  scene.dynamics->steps = 200;
  scene.dynamics->endTime.reset();
  scene.dynamics->outputStride = 10;
  const fs::path dir = kTmp / "bar_vtk_fields";
  fs::remove_all(dir);
  RunOptions o;
  o.outputDirectory = dir;
  runScene(scene, o);
  const Table ts = readCsv(dir / "timeseries.csv");
  int flight = 0, contact = 0;
  for (int n = 0; n <= 200; n += 10) {
    SCOPED_TRACE(n);
    std::ostringstream name;
    name << "dynamics_bar_" << std::setw(6) << std::setfill('0') << n << ".vtu";
    const auto vtu = obs::test::readVtu(dir / name.str());
    const auto s = vtu.array("contact_pressure"), vn = vtu.array("normal_velocity"), v = vtu.array("velocity"),
               state = vtu.array("contact_state");
    ASSERT_EQ(s.size(), vtu.points.size());
    ASSERT_EQ(vn.size(), vtu.points.size());
    double force = 0;  // sum_p s_p m_p^C over the contact boundary
    int bottom = 0, touching = 0;
    for (std::size_t p = 0; p < vtu.points.size(); ++p) {
      if (std::abs(vtu.points[p][1] - 5) > 1e-12) {  // off Gamma_C: both fields are 0
        EXPECT_EQ(s[p], 0);
        EXPECT_EQ(vn[p], 0);
        continue;
      }
      ++bottom;
      EXPECT_DOUBLE_EQ(vn[p], -v[3 * p + 1]);  // nu = (0, -1)
      EXPECT_GE(s[p], -1e-12 * 300);  // the multipliers are >= 0 up to round-off
      force += 0.5 * s[p];
      if (state[p] == 2) {
        ++touching;
        // improved contact-stabilized scheme: no normal velocity at the nodes in contact
        EXPECT_NEAR(vn[p], 0, 1e-9);
      }
    }
    ASSERT_EQ(bottom, 2);
    const auto row = static_cast<std::size_t>(n);
    ASSERT_DOUBLE_EQ(ts["step"][row], n);
    EXPECT_NEAR(force, std::abs(ts["contact_force_y"][row]), 1e-9 * std::max(1.0, force));
    if (n * 3e-3 < 0.5) {  // free flight: v = -v0 exactly, no pressure
      ++flight;
      EXPECT_EQ(touching, 0);
      EXPECT_LE(std::abs(force), 1e-12 * 300);
      for (std::size_t p = 0; p < vtu.points.size(); ++p) {
        if (std::abs(vtu.points[p][1] - 5) <= 1e-12) {
          EXPECT_NEAR(vn[p], 10, 1e-9);
        }
      }
    } else if (n >= 170) {
      ++contact;
      EXPECT_EQ(touching, 2);
      EXPECT_GT(force, 0);
    }
  }
  EXPECT_EQ(flight, 17);
  EXPECT_EQ(contact, 4);
}

TEST(DynamicScenes, GeneratedMeshesLieOnTheCurvedSurfaces) {
  // ball: every vertex of the contact boundary on the sphere of radius 1 after refinement
  const Scene ball = parseScene(kScenes / "dynamics_ball.toml");
  const obs::mesh::Mesh m = buildMesh(ball);
  const int id = *m.boundaryId("surface");
  double worst = 0;
  for (obs::mesh::Index f = 0; f < m.numBoundaryFaces(); ++f)
    if (m.boundaryFaceId(f) == id)
      for (obs::mesh::Index v : m.boundaryFaceVertices(f)) worst = std::max(worst, std::abs(m.vertex(v).norm() - 1));
  EXPECT_LT(worst, 1e-12);
  // rounded block: lowest point z = 0 at x = 0.75, bottom on the cylinder (x - 0.75)^2 + (z - 1.5)^2 = 1.5^2
  const Scene block = parseScene(kScenes / "dynamics_block.toml");
  const obs::mesh::Mesh b = buildMesh(block);
  const int bottom = *b.boundaryId("bottom");
  worst = 0;
  for (obs::mesh::Index f = 0; f < b.numBoundaryFaces(); ++f)
    if (b.boundaryFaceId(f) == bottom)
      for (obs::mesh::Index v : b.boundaryFaceVertices(f)) {
        const auto& x = b.vertex(v);
        worst = std::max(worst, std::abs(std::hypot(x[0] - 0.75, x[2] - 1.5) - 1.5));
      }
  EXPECT_LT(worst, 1e-12);
}

TEST(DynamicScenes, BarFollowsTheExactFlightAndLiftsOffNearTheExactTime) {
  // the full default run: tau = 3e-3, 450 steps (t = 1.35)
  const RunResult r = runData("dynamics_bar", 450, "bar_full");
  const fs::path dir = kTmp / "bar_full";
  const Table ts = readCsv(dir / "timeseries.csv");
  const double h0 = 5, v0 = 10, L = 10, c0 = 30;
  int checked = 0;
  for (std::size_t i = 0; i < ts.rows; ++i) {
    const double t = ts["t"][i];
    if (t >= h0 / v0) break;
    // height of the contact end = h0 + u_y = h0 - nu'u (nu = -e_y)
    EXPECT_NEAR(h0 - ts["tracked0_normal_displacement"][i], h0 - v0 * t, 1e-8) << "t = " << t;
    EXPECT_NEAR(ts["tracked0_normal_velocity"][i], v0, 1e-8) << "t = " << t;
    EXPECT_EQ(ts["active_solution"][i], 0) << "t = " << t;
    ++checked;
  }
  EXPECT_EQ(checked, 167);  // t = 0 .. 0.498
  // in contact after the impact, at rest on the plane (no penetration for this scheme)
  const std::size_t mid = 250;  // t = 0.75
  EXPECT_NEAR(ts["tracked0_gap"][mid], 0, 1e-9);
  EXPECT_EQ(ts["active_solution"][mid], 2);
  const nlohmann::json summary = summaryOf(dir);
  const nlohmann::json& tr = summary.at("dynamics").at("tracked")[0];
  const double exact = h0 / v0 + 2 * L / c0;
  EXPECT_NEAR(tr.at("first_contact_time").get<double>(), 0.501, 1e-9);  // first step after t = 0.5
  // the discrete bar (20 cells, lumped mass) detaches within a few steps of the exact time
  EXPECT_NEAR(tr.at("detachment_time").get<double>(), exact, 0.05);
  EXPECT_NEAR(tr.at("release_time").get<double>(), exact, 0.05);
  EXPECT_LT(tr.at("final_normal_velocity").get<double>(), 0);  // moving away from the plane
  // after the rebound the momentum points up; |p|^2 / 2m <= E <= E_0 = m v0^2 / 2 (the scheme
  // dissipates), so |p| <= m v0 with m = rho L = 10, and little is lost (exact: p = m v0)
  const double p = ts["momentum_y"][ts.rows - 1], m = 10;
  EXPECT_LE(p, m * v0 * (1 + 1e-10));
  EXPECT_GT(p, 0.9 * m * v0);
  EXPECT_EQ(r.contact->actualVertices, 0);  // flying again at t = 1.35
}

TEST(DynamicScenes, ComparisonWritesOneSeriesPerScheme) {
  // scene option: two schemes besides the scene's
  Scene scene = parseSceneString(barScene("scheme = \"contact-implicit\"\ntau = 3e-3\nsteps = 4\n"
                                          "initial_velocity = [0, -10]\ntracked = [[0, 5]]\n"
                                          "compare = [\"contact-stabilized\", \"contact-implicit\", \"classical\"]\n"),
                                 "cmp.toml", kTmp);
  const fs::path dir = kTmp / "cmp_scene";
  fs::remove_all(dir);
  RunOptions o;
  o.outputDirectory = dir;
  const RunResult r = runScene(scene, o);
  EXPECT_EQ(r.massAssemblies, 3);
  EXPECT_FALSE(fs::exists(dir / "timeseries.csv"));
  for (const char* s : {"contact-implicit", "contact-stabilized", "classical"})
    EXPECT_EQ(readCsv(dir / ("timeseries_" + std::string(s) + ".csv")).rows, 5u) << s;
  const nlohmann::json j = summaryOf(dir);
  EXPECT_EQ(j.at("dynamics").at("scheme"), "contact-implicit");
  ASSERT_EQ(j.at("dynamics_comparison").size(), 3u);
  EXPECT_EQ(j.at("dynamics_comparison")[1].at("scheme"), "contact-stabilized");
  // before impact all schemes agree exactly (free flight)
  const Table a = readCsv(dir / "timeseries_contact-implicit.csv");
  const Table b = readCsv(dir / "timeseries_classical.csv");
  EXPECT_DOUBLE_EQ(a["tracked0_normal_displacement"][4], b["tracked0_normal_displacement"][4]);

  // --compare-schemes (RunOptions::compareSchemes): every scheme
  EXPECT_EQ(dynamicSchemes(scene, true).size(), 10u);
  EXPECT_EQ(dynamicSchemes(scene, true)[0], "contact-implicit");
}

TEST(DynamicScenes, BallRunsTheRedistributedSchemesAndTheSummaryKeepsBothEnergyRatios) {
  // Geometry A at refine 2 (whole sphere massless): KLR and HHW were refused before the lower bound of
  // the mass redistribution ("non-positive diagonal entry -5.12392e-06 at vertex 13"); now M~ has
  // entries at the bound, is positive definite, and the comparison's summary keeps per scheme the
  // energy ratio with the standard mass and, for the schemes with M~, the one with M~
  Scene scene = parseScene(kScenes / "dynamics_ball.toml");
  scene.mesh.refine = 2;
  scene.dynamics->steps = 3;
  scene.dynamics->endTime.reset();
  scene.dynamics->compare = {"khenous-laborde-renard", "hager-huebner-wohlmuth"};
  const fs::path dir = kTmp / "ball_klr";
  fs::remove_all(dir);
  RunOptions o;
  o.outputDirectory = dir;
  runScene(scene, o);
  const nlohmann::json j = summaryOf(dir);
  EXPECT_EQ(j.at("vertices").get<int>(), 4321);
  const auto& cmp = j.at("dynamics_comparison");
  ASSERT_EQ(cmp.size(), 3u);
  EXPECT_FALSE(cmp[0].contains("error"));
  EXPECT_FALSE(cmp[0].contains("energy_ratio_redistributed"));
  EXPECT_FALSE(cmp[0].contains("redistribution"));
  for (int k : {1, 2}) {
    const auto& d = cmp[k];
    ASSERT_FALSE(d.contains("error")) << d.at("error");
    EXPECT_GT(d.at("energy_ratio").get<double>(), 0);
    EXPECT_DOUBLE_EQ(d.at("energy_ratio_redistributed").get<double>(),
                     d.at("final_energy_redistributed").get<double>() / d.at("initial_energy_redistributed").get<double>());
    EXPECT_GT(d.at("redistribution").at("bounded_entries").get<long long>(), 0);
    EXPECT_NEAR(d.at("redistribution").at("min_factor").get<double>(), 0.1, 1e-12);
    EXPECT_TRUE(d.at("redistribution").at("positive_definite").get<bool>());
    EXPECT_EQ(d.at("redistribution").at("moments").get<int>(), 2);
  }
  // KLR and HHW conserve E~ (+ tau^2/8 a'M~a for KLR) while the ball flies (contact starts after step 1)
  EXPECT_NEAR(cmp[2].at("energy_ratio_redistributed").get<double>(), 1.0, 1e-3);
}

TEST(DynamicScenes, RedistributionMomentsReachTheMassMatrix) {
  // [dynamics] redistribution_moments = 1 (mass and centre of gravity only, the thesis' M~ of
  // Sec. 5.2.6) builds another M~ than the default 2: the summary says which, and KLR's states differ
  auto run = [](int moments) {
    Scene scene = parseScene(kScenes / "twobody_impact.toml");
    scene.dynamics->scheme = "khenous-laborde-renard";
    scene.dynamics->steps = 12;
    scene.dynamics->endTime.reset();
    scene.dynamics->redistributionMoments = moments;
    const std::string out = "klr_moments_" + std::to_string(moments);
    runInto(scene, out);
    return summaryOf(kTmp / out).at("dynamics");
  };
  const nlohmann::json a = run(1), b = run(2);
  EXPECT_EQ(a.at("redistribution").at("moments").get<int>(), 1);
  EXPECT_EQ(b.at("redistribution").at("moments").get<int>(), 2);
  EXPECT_NE(a.at("final_energy_redistributed").get<double>(), b.at("final_energy_redistributed").get<double>());
  // the initial E~ is the same: the bodies translate rigidly, and both M~ keep each body's mass
  EXPECT_NEAR(a.at("initial_energy_redistributed").get<double>(), b.at("initial_energy_redistributed").get<double>(),
              1e-12 * b.at("initial_energy_redistributed").get<double>());
}

TEST(DynamicScenes, ComparedSchemeThatCannotRunIsReportedNotFatal) {
  // consistent mass: fine for contact-implicit, refused by the predictor scheme contact-stabilized
  // (Newmark.hpp); the comparison records the refusal and goes on
  Scene scene = parseSceneString(barScene("scheme = \"contact-implicit\"\nmass = \"consistent\"\ntau = 3e-3\n"
                                          "steps = 2\ninitial_velocity = [0, -10]\n"
                                          "compare = [\"contact-stabilized\", \"classical\"]\n"),
                                 "cmp_failed.toml", kTmp);
  const fs::path dir = kTmp / "cmp_failed";
  fs::remove_all(dir);
  RunOptions o;
  o.outputDirectory = dir;
  std::vector<std::string> warnings;
  o.stepProgress = [&](const std::string& line) { warnings.push_back(line); };
  runScene(scene, o);
  const nlohmann::json j = summaryOf(dir);
  ASSERT_EQ(j.at("dynamics_comparison").size(), 3u);
  EXPECT_EQ(j.at("dynamics_comparison")[0].at("scheme"), "contact-implicit");
  EXPECT_EQ(j.at("dynamics_comparison")[1].at("scheme"), "classical");
  EXPECT_EQ(j.at("dynamics_comparison")[2].at("scheme"), "contact-stabilized");
  expectContains(j.at("dynamics_comparison")[2].at("error").get<std::string>(),
                 {"cmp_failed.toml:25:", "[dynamics] scheme = \"contact-stabilized\"", "lumped"});
  EXPECT_TRUE(fs::exists(dir / "timeseries_classical.csv"));
  EXPECT_FALSE(fs::exists(dir / "timeseries_contact-stabilized.csv"));
  EXPECT_TRUE(std::any_of(warnings.begin(), warnings.end(), [](const std::string& w) {
    return w.rfind("warning: contact-stabilized skipped", 0) == 0;
  }));
}

TEST(DynamicScenes, CompareSchemesOnTheCommandLine) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path dir = kTmp / "cli_cmp";
  fs::remove_all(dir);
  fs::create_directories(kTmp);
  const std::string scene = barScene("tau = 3e-3\nsteps = 2\ninitial_velocity = [0, -10]\n");
  std::ofstream(kTmp / "cli_bar.toml") << scene;
  const std::string cmd = "'" + std::string(OBS_BINARY) + "' run '" + (kTmp / "cli_bar.toml").string() +
                          "' --compare-schemes -o '" + dir.string() + "' >'" + (kTmp / "cli.out").string() +
                          "' 2>'" + (kTmp / "cli.err").string() + "'";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 0) << slurp(kTmp / "cli.err");
  int series = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind("timeseries_", 0) == 0) {
      ++series;
      EXPECT_EQ(readCsv(e.path()).rows, 3u) << e.path();
    }
  EXPECT_EQ(series, 10);
  EXPECT_EQ(summaryOf(dir).at("dynamics_comparison").size(), 10u);
  EXPECT_EQ(summaryOf(dir).at("mass_assemblies"), 10);
  // progress lines on stderr, one per scheme at its last step
  EXPECT_NE(slurp(kTmp / "cli.err").find("khenous-laborde-renard: step 2/2"), std::string::npos);
}

TEST(DynamicScenes, BadInputIsAnErrorWithFileLineAndKey) {
  const std::string v = "initial_velocity = [0, -10]\n";
  expectContains(errorOf(barScene("tau = 0\nsteps = 3\n" + v)), {"bad.toml:20:", "[dynamics] tau", "must be positive"});
  expectContains(errorOf(barScene("tau = -1e-3\nsteps = 3\n" + v)), {"bad.toml:20:", "[dynamics] tau"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\n" + v, "")),
                 {"bad.toml:8:", "[material] density is missing", "[dynamics] (line 18)"});
  const std::string unknown = errorOf(barScene("scheme = \"newmark\"\ntau = 1e-3\nsteps = 3\n"));
  expectContains(unknown, {"bad.toml:20:", "[dynamics] scheme", "\"newmark\" is unknown", "contact-implicit",
                           "improved-contact-stabilized", "khenous-laborde-renard", "hager-huebner-wohlmuth"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\nend_time = 1\n")),
                 {"bad.toml:22:", "[dynamics] end_time", "cannot be combined with steps"});
  expectContains(errorOf(barScene("tau = 1e-3\n")), {"bad.toml:19:", "[dynamics] needs end_time"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 0\n")), {"bad.toml:21:", "[dynamics] steps"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\nfoo = 1\n")), {"bad.toml:22:", "unknown key 'foo'"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\nmass = \"consistent\"\n")),
                 {"bad.toml:22:", "[dynamics] mass", "not available for scheme = \"improved-contact-stabilized\""});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\ncompare = [\"all-of-them\"]\n")),
                 {"bad.toml:22:", "[dynamics] compare[0]", "is unknown"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\noutput_stride = 0\n")), {"bad.toml:22:", "output_stride"});
  EXPECT_EQ(errorOf(barScene("tau = 1e-3\nsteps = 3\ninexact = 1\n")),
            "bad.toml:22: [dynamics] inexact = 1 must lie in [0, 1) (the fraction of the time-error estimate; 0: off)");
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\ninexact = -0.1\n")),
                 {"bad.toml:22:", "[dynamics] inexact = -0.1 must lie in [0, 1)"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\ninexact = \"yes\"\n")),
                 {"bad.toml:22:", "[dynamics] inexact", "must be a number"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\ninexact = nan\n")),
                 {"bad.toml:22:", "[dynamics] inexact", "must be finite"});
  EXPECT_EQ(errorOf(barScene("tau = 1e-3\nsteps = 3\nredistribution_moments = 3\n")),
            "bad.toml:22: [dynamics] redistribution_moments = 3 must be 0 (none: the contact rows zeroed, nothing "
            "moved), 1 (mass and centre of gravity) or 2 (also the second moments)");
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\nredistribution_moments = \"first\"\n")),
                 {"bad.toml:22:", "[dynamics] redistribution_moments", "must be an integer"});
  expectContains(errorOf(barScene("tau = 1e-3\nsteps = 3\n") + "\n[solver]\ntype = \"pdas\"\n"),
                 {"bad.toml:23:", "[solver] type = \"pdas\" is not available with [dynamics]"});
  // [mesh] generators
  expectContains(errorOf("[mesh]\ngenerator = \"ball\"\ntype = \"quadrilateral\"\ncells = 2\n[material]\nE = 1\nnu = 0\n"),
                 {"bad.toml:3:", "[mesh] type", "needs a 3D cell type"});
  expectContains(errorOf("[mesh]\ngenerator = \"ball\"\ntype = \"pyramid\"\ncells = 2\nwidth = 1\n[material]\nE = 1\nnu = 0\n"),
                 {"bad.toml:5:", "[mesh] width", "does not apply to generator = \"ball\""});
  expectContains(errorOf("[mesh]\ngenerator = \"rounded_block\"\ntype = \"hexahedron\"\ncells = [1, 1, 1]\n"
                         "width = 2\nheight = 1\ndepth = 1\narc_radius = 0.5\n[material]\nE = 1\nnu = 0\n"),
                 {"bad.toml:8:", "[mesh] arc_radius", "at least width / 2"});
}

TEST(DynamicScenes, InexactSolvesRecordTheirToleranceAndOffIsTheDefault) {
  // [dynamics] inexact (docs/theory.md#dynamic-inexact-solves) on Geometry A (the ball; impact from
  // step 2), 100 steps: absent, = 0 and = 0.1. (On Geometry 1 every step takes 2 TNNMG iterations,
  // the least the relative stopping test allows, so inexact solves change nothing there.)
  auto run = [](const std::string& out, std::optional<double> inexact) {
    Scene scene = parseScene(kScenes / "dynamics_ball.toml");
    scene.dynamics->steps = 100;
    if (inexact) scene.dynamics->inexact = *inexact;
    const fs::path dir = kTmp / out;
    fs::remove_all(dir);
    RunOptions o;
    o.outputDirectory = dir;
    runScene(scene, o);
    return dir;
  };
  const fs::path absent = run("inexact_absent", std::nullopt), zero = run("inexact_zero", 0.0),
                 on = run("inexact_on", 0.1);
  const Table a = readCsv(absent / "timeseries.csv"), z = readCsv(zero / "timeseries.csv"),
              i = readCsv(on / "timeseries.csv");
  ASSERT_EQ(a.rows, 101u);
  ASSERT_EQ(z.rows, 101u);
  ASSERT_EQ(i.rows, 101u);
  const nlohmann::json sa = summaryOf(absent), si = summaryOf(on);
  const double base = sa.at("solver").at("tolerance").get<double>();
  // off (absent or 0): every column but the timings bitwise equal, the tolerance of every step the
  // solver tolerance, no time-error estimate
  for (const std::string& col : a.header) {
    if (col == "solver_seconds" || col == "step_seconds") continue;
    for (std::size_t k = 0; k < a.rows; ++k) {
      if (std::isnan(a[col][k])) {
        EXPECT_TRUE(std::isnan(z[col][k])) << col << " row " << k;
      } else {
        EXPECT_EQ(a[col][k], z[col][k]) << col << " row " << k;
      }
    }
  }
  EXPECT_TRUE(std::isnan(a["solver_tolerance"][0]));  // the initial state was not solved
  for (std::size_t k = 1; k < a.rows; ++k) {
    EXPECT_EQ(a["solver_tolerance"][k], base) << k;
    EXPECT_TRUE(std::isnan(a["time_error"][k])) << k;
  }
  const nlohmann::json& da = sa.at("dynamics");
  EXPECT_EQ(da.at("inexact").get<double>(), 0.0);
  EXPECT_EQ(da.at("min_solver_tolerance").get<double>(), base);
  EXPECT_EQ(da.at("max_solver_tolerance").get<double>(), base);
  // on: steps 1 and 2 at the solver tolerance, later ones looser but at most 1e-2; the estimate from
  // step 2 on; fewer iterations; energy, penetration and contact force close to the exact solves
  int loose = 0;
  double iterationsOff = 0, iterationsOn = 0;
  for (std::size_t k = 1; k < i.rows; ++k) {
    if (k <= 2) {
      EXPECT_EQ(i["solver_tolerance"][k], base) << k;
    }
    EXPECT_GE(i["solver_tolerance"][k], base) << k;
    EXPECT_LE(i["solver_tolerance"][k], 1e-2) << k;
    EXPECT_EQ(std::isnan(i["time_error"][k]), k == 1) << k;
    loose += i["solver_tolerance"][k] > base;
    iterationsOff += a["solver_iterations"][k];
    iterationsOn += i["solver_iterations"][k];
  }
  EXPECT_GT(loose, 50);
  EXPECT_LT(iterationsOn, iterationsOff);
  const nlohmann::json& di = si.at("dynamics");
  EXPECT_EQ(di.at("inexact").get<double>(), 0.1);
  EXPECT_EQ(di.at("min_solver_tolerance").get<double>(), base);
  EXPECT_GT(di.at("max_solver_tolerance").get<double>(), base);
  EXPECT_NEAR(di.at("energy_ratio").get<double>(), da.at("energy_ratio").get<double>(), 1e-3);
  EXPECT_LE(di.at("max_penetration").get<double>(), 1e-12);
  EXPECT_NEAR(di.at("max_contact_force").get<double>(), da.at("max_contact_force").get<double>(),
              0.02 * da.at("max_contact_force").get<double>());
}

TEST(DynamicScenes, InadmissibleInitialStateFailsBeforeTheFirstStep) {
  // the bar's lower end moved 6 down: 1 below the plane y = 0
  const Scene scene = parseSceneString(
      barScene("tau = 1e-3\nsteps = 3\ninitial_velocity = [0, -10]\ninitial_displacement = [0, -6]\n"), "bad.toml",
      kTmp);
  const fs::path dir = kTmp / "bad_initial";
  fs::remove_all(dir);
  RunOptions o;
  o.outputDirectory = dir;
  std::string message;
  try {
    runScene(scene, o);
  } catch (const obs::Error& e) {
    message = e.what();
  }
  expectContains(message, {"bad.toml:23:", "[dynamics]", "initial state", "not admissible"});
  EXPECT_FALSE(fs::exists(dir / "timeseries.csv"));
  EXPECT_FALSE(fs::exists(dir / "summary.json"));
  // tracked point with the wrong number of coordinates
  const Scene t = parseSceneString(barScene("tau = 1e-3\nsteps = 3\ntracked = [[0, 5, 0]]\n"), "bad.toml", kTmp);
  message.clear();
  try {
    runScene(t, o);
  } catch (const obs::Error& e) {
    message = e.what();
  }
  expectContains(message, {"bad.toml:22:", "[dynamics] tracked[0] has 3 coordinates, expected 2"});
}

TEST(DynamicScenes, StaticScenesAssembleNoMassMatrix) {
  const fs::path dir = kTmp / "static";
  fs::remove_all(dir);
  RunOptions o;
  o.outputDirectory = dir;
  const RunResult r = runScene(kScenes / "cantilever.toml", o);
  EXPECT_EQ(r.massAssemblies, 0);
  const nlohmann::json j = summaryOf(dir);
  EXPECT_EQ(j.at("mass_assemblies"), 0);
  EXPECT_FALSE(j.contains("dynamics"));
  // density is accepted (and ignored) by static scenes
  EXPECT_EQ(errorOf("[mesh]\ngenerator = \"box\"\ntype = \"quadrilateral\"\ncells = [2, 2]\n[material]\nE = 1\nnu = 0\n"
                    "density = 2\n[[dirichlet]]\nboundary = \"left\"\n"),
            "");
}

TEST(DynamicScenes, WCycleKeyReachesTheNewmarkSolver) {
  // [solver] cycle = "W" reaches the Newmark driver's TNNMG: another cycle, other round-off, the same
  // time series to the solver tolerance (refine 2: three levels; on two levels the W-cycle is the
  // V-cycle, the coarsest level being solved exactly)
  auto run = [](const std::string& out, std::optional<int> cycle) {
    Scene scene = parseScene(kScenes / "dynamics_ball.toml");
    scene.mesh.refine = 2;
    scene.dynamics->steps = 10;
    scene.solver.cycleIndex = cycle;
    runInto(scene, out);
    return readCsv(kTmp / out / "timeseries.csv");
  };
  const Table v = run("cycle_v_dyn", std::nullopt), w = run("cycle_w_dyn", 2);
  ASSERT_EQ(v.rows, 11u);
  ASSERT_EQ(w.rows, 11u);
  bool differs = false;
  for (std::size_t k = 0; k < v.rows; ++k) {
    EXPECT_NEAR(w["energy"][k], v["energy"][k], 1e-8 * v["energy"][0]) << k;
    EXPECT_EQ(w["active_solution"][k], v["active_solution"][k]) << k;
    differs = differs || w["energy"][k] != v["energy"][k];
  }
  EXPECT_TRUE(differs) << "cycle = \"W\" did not reach the solver";
}

TEST(DynamicScenes, LocalSmoothingKeyIsAppliedAndChangesNothingOnUniformGrids) {
  // [solver] local_smoothing (docs/theory.md#local-multigrid) reaches the Newmark driver's TNNMG; the
  // dynamic scenes refine uniformly, where every basis function is new on its level, so switching it
  // off gives the same time series bit for bit
  auto run = [](const std::string& out, std::optional<bool> local) {
    Scene scene = parseScene(kScenes / "dynamics_ball.toml");
    scene.dynamics->steps = 20;
    scene.solver.localSmoothing = local;
    runInto(scene, out);
    return readCsv(kTmp / out / "timeseries.csv");
  };
  const Table on = run("local_default", std::nullopt), off = run("local_off", false);
  ASSERT_EQ(on.rows, 21u);
  ASSERT_EQ(off.rows, 21u);
  for (const char* col : {"energy", "contact_force_z", "solver_iterations", "active_solution"})
    for (std::size_t k = 0; k < on.rows; ++k) EXPECT_EQ(on[col][k], off[col][k]) << col << " row " << k;
}
