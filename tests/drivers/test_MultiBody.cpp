// Multi-body scenes ([[body]], [[contact]] pairs with dual mortar) through runScene (`obs run`): the
// 3D patch scene transmits the constant pressure exactly with equal and opposite forces; the 2D
// cylinder scene agrees between TNNMG and PDAS and writes one .vtu per body plus a .pvd; a one-body
// contact scene gives the same results as before the contact model (it is the one-body case of the
// same path); every bad input of the multi-body format is a one-line error naming file and line.
// Bodies from one Gmsh file ([body.mesh] physical = volume group): data/scenes/twobody_gmsh.toml gives
// the results of the generator scene twobody_patch.toml bit for bit (also refined), and every bad
// group selection is a one-line error naming the scene line and key. Dynamic scenes: the momentum is
// conserved, every body gets its .vtu per output step, and the slave side's .vtu carries the contact
// fields of the normal jump (normal velocity = approach velocity before the impact, 0 in contact), its
// pressures times boundary masses sum to the time series' contact force, the master's forces balance.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>

#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"
#include "DriverTestSupport.hpp"

using obs::test::slurp;
using obs::test::summaryOf;
namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "multi_body";
const fs::path kScenes = fs::path(OBS_DATA_DIR) / "scenes";

RunResult run(const fs::path& scene, const std::string& out, std::vector<std::string> overrides = {}) {
  RunOptions o;
  o.outputDirectory = kTmp / out;
  o.overrides = std::move(overrides);
  return runScene(scene, o);
}

TEST(MultiBodyScene, PatchSceneTransmitsConstantPressureExactly) {
  const RunResult r = run(kScenes / "twobody_patch.toml", "patch");
  ASSERT_EQ(r.pairs.size(), 1u);
  const PairReport& p = r.pairs.front();
  EXPECT_EQ(p.potentialVertices, 36);
  EXPECT_EQ(p.actualVertices, 36);
  EXPECT_NEAR(p.pressureMin, 10.0, 1e-8);
  EXPECT_NEAR(p.pressureMax, 10.0, 1e-8);
  EXPECT_NEAR(p.load, 10.0, 1e-9);
  EXPECT_NEAR(p.area, 1.0, 1e-12);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(p.forceSlave[a] + p.forceMaster[a], 0.0, 1e-11);
  EXPECT_NEAR(p.forceSlave[2], 10.0, 1e-9);  // the lower block pushes the upper one up
  // the exact solution's largest displacement: the upper block's top corner (2.5e-5, 2.5e-5, -1.5e-4)
  EXPECT_NEAR(r.maxDisplacement, std::sqrt(2 * 2.5e-5 * 2.5e-5 + 1.5e-4 * 1.5e-4), 1e-14);
  ASSERT_EQ(r.bodies.size(), 2u);
  EXPECT_EQ(r.bodies[0].name, "lower");
  const nlohmann::json j = summaryOf(kTmp / "patch");
  ASSERT_TRUE(j.contains("pairs"));
  EXPECT_EQ(j["pairs"][0]["force_slave"].size(), 3u);
  EXPECT_EQ(j["pairs"][0]["force_master"].size(), 3u);
  for (const char* key : {"load_P", "actual_vertices", "pressure_min", "pressure_max"})
    EXPECT_TRUE(j["pairs"][0].contains(key)) << key;
  EXPECT_TRUE(fs::exists(kTmp / "patch" / "twobody_patch_lower.vtu"));
  EXPECT_TRUE(fs::exists(kTmp / "patch" / "twobody_patch_upper.vtu"));
  const std::string pvd = slurp(kTmp / "patch" / "twobody_patch.pvd");
  EXPECT_NE(pvd.find("part=\"1\" file=\"twobody_patch_upper.vtu\""), std::string::npos) << pvd;
}

TEST(MultiBodyScene, RollersOnTheSlaveSideMeetTheContactZone) {
  // step-42 with the rigid ball replaced by a meshed elastic ball as master: the cube's top face is
  // the slave surface and the search distance reaches its edges, whose vertices sit on the roller
  // sides (u_x, u_y prescribed, orthogonal to the contact normal e_z): allowed as for one body
  fs::create_directories(kTmp);
  const fs::path scene = kTmp / "step42_meshed_ball.toml";
  std::ofstream(scene) << R"(
[[body]]
name = "cube"
[body.mesh]
generator = "box"
type = "hexahedron"
cells = [4, 4, 4]
lower = [0, 0, 0]
upper = [1, 1, 1]
refine = 1
[body.material]
E = 2e5
nu = 0.3
[[body.dirichlet]]
boundary = "bottom"
[[body.dirichlet]]
boundary = "left"
components = ["x", "y"]
[[body.dirichlet]]
boundary = "right"
components = ["x", "y"]
[[body.dirichlet]]
boundary = "front"
components = ["x", "y"]
[[body.dirichlet]]
boundary = "back"
components = ["x", "y"]

[[body]]
name = "ball"
[body.mesh]
generator = "half_ball"
type = "hexahedron"
centre = [0.5, 0.5, 1.6]
radius = 0.6
cells = 2
refine = 1
[body.material]
E = 2e5
nu = 0.3
[[body.dirichlet]]
boundary = "top"
value = [0, 0, -0.01]

[[contact]]
slave = { body = "cube", boundary = "top" }
master = { body = "ball", boundary = "surface" }
search_distance = 2.0
)";
  const RunResult r = run(scene, "step42_meshed_ball");
  ASSERT_EQ(r.pairs.size(), 1u);
  const PairReport& p = r.pairs.front();
  // the top face has 9 x 9 vertices, 7 x 7 off its edges: more than 49 constrained means slave
  // vertices on the roller sides have constraints (69: all but the 12 next to the corners, which the
  // ball's shadow of radius 0.6 does not cover)
  EXPECT_GT(p.potentialVertices, 49);
  EXPECT_GT(p.actualVertices, 0);
  EXPECT_GT(p.load, 0);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(p.forceSlave[a] + p.forceMaster[a], 0.0, 1e-10 * p.load);
  EXPECT_LT(p.forceSlave[2], 0);  // the ball pushes the cube down
}

TEST(MultiBodyScene, CylinderSceneTnnmgAgreesWithPdas) {
  RunOptions o;  // --refine 2 for both bodies
  o.refine = 2;
  o.outputDirectory = kTmp / "cyl_tnnmg";
  const RunResult t = runScene(kScenes / "twobody_cylinders.toml", o);
  o.outputDirectory = kTmp / "cyl_pdas";
  o.overrides = {"solver.type=\"pdas\""};
  const RunResult p = runScene(kScenes / "twobody_cylinders.toml", o);
  ASSERT_EQ(t.pairs.size(), 1u);
  EXPECT_TRUE(t.solver.converged);
  EXPECT_LE(t.solver.iterations, 20);
  EXPECT_EQ(t.pairs[0].actualVertices, p.pairs[0].actualVertices);
  EXPECT_NEAR(t.pairs[0].load, p.pairs[0].load, 1e-7 * p.pairs[0].load);
  EXPECT_GT(t.pairs[0].actualVertices, 3);
  EXPECT_LT(t.pairs[0].forceMaster[1], 0);  // the block is pushed down
  EXPECT_NEAR(t.pairs[0].forceSlave[1] + t.pairs[0].forceMaster[1], 0.0, 1e-12);
  EXPECT_GT(t.pairs[0].uncovered, 0);  // the arc above the block is not covered: no constraint there
}

TEST(MultiBodyScene, RigidObstacleOfOneBodyIsTheOneBodyProblem) {
  // the punch as body 'punch' of a multi-body scene with a second, clamped body and no pair: the
  // punch's contact results equal those of data/scenes/punch.toml (the same model path)
  fs::create_directories(kTmp);
  const fs::path scene = kTmp / "punch_and_block.toml";
  std::ofstream(scene) << R"(
[[body]]
name = "punch"
[body.mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 4]
lower = [0, 0]
upper = [1, 1]
refine = 3
[body.material]
E = 3e5
nu = 0.25
[[body.dirichlet]]
boundary = "top"
value = [0, -0.01]

[[body]]
name = "block"
[body.mesh]
generator = "box"
type = "triangle"
cells = [2, 2]
lower = [3, 0]
upper = [4, 1]
[body.material]
E = 1.0
nu = 0.3
[[body.dirichlet]]
boundary = "left"

[[contact]]
body = "punch"
boundary = "bottom"
obstacle = "strip"
point = [0.5, 0]
half_width = 0.0625
direction = [0, -1]
)";
  const RunResult multi = run(scene, "punch_and_block");
  RunOptions o;
  o.refine = 3;
  o.outputDirectory = kTmp / "punch_alone";
  const RunResult single = runScene(kScenes / "punch.toml", o);
  ASSERT_EQ(multi.pairs.size(), 1u);
  ASSERT_TRUE(single.contact.has_value());
  const PairReport& p = multi.pairs.front();
  EXPECT_EQ(p.master, "obstacle strip");
  EXPECT_EQ(p.actualVertices, single.contact->actualVertices);
  EXPECT_EQ(p.potentialVertices, single.contact->potentialVertices);
  EXPECT_NEAR(p.load, single.contact->load, 1e-9 * single.contact->load);
  EXPECT_NEAR(p.forceMaster[1], single.contact->force[1], 1e-9 * single.contact->load);
  EXPECT_EQ(multi.solver.iterations, single.solver.iterations);
}

// --- bad input -----------------------------------------------------------------------------------

std::string errorOf(const std::string& text, bool run = false) {
  // a directory per test: ctest runs the tests of this file in parallel processes
  const fs::path dir = kTmp / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::create_directories(dir);
  const fs::path p = dir / "bad.toml";
  std::ofstream(p) << text;
  try {
    const Scene s = parseScene(p);
    if (run) {
      RunOptions o;
      o.outputDirectory = dir / "bad";
      runScene(s, o);
    } else {
      checkMultiBodyScene(s);
    }
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "no error";
}

const std::string kLower = R"(
[[body]]
name = "lower"
[body.mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 2]
lower = [0.0, 0.0]
upper = [1.0, 0.5]
[body.material]
E = 1.0
nu = 0.3
[[body.dirichlet]]
boundary = "bottom"
)";

std::string upper(const std::string& lower = "[0.0, 0.5]", const std::string& upper = "[1.0, 1.0]",
                  const std::string& dirichlet = "top") {
  return R"(
[[body]]
name = "upper"
[body.mesh]
generator = "box"
type = "triangle"
cells = [3, 2]
lower = )" + lower + R"(
upper = )" + upper + R"(
[body.material]
E = 1.0
nu = 0.3
[[body.dirichlet]]
boundary = ")" + dirichlet + R"("
value = [0.0, -0.01]
)";
}

const std::string kPair = R"(
[[contact]]
slave = { body = "upper", boundary = "bottom" }
master = { body = "lower", boundary = "top" }
)";

TEST(MultiBodyScene, DynamicImpactConservesMomentumAndWritesEveryBody) {
  // data/scenes/twobody_impact.toml: two free blocks collide and separate (docs/dynamics.md)
  const RunResult r = run(kScenes / "twobody_impact.toml", "impact");
  const fs::path dir = kTmp / "impact";
  const auto j = summaryOf(dir);
  const auto& dyn = j.at("dynamics");
  EXPECT_EQ(dyn.at("steps").get<int>(), 120);
  EXPECT_LT(dyn.at("max_penetration").get<double>(), 1e-10);
  EXPECT_GT(dyn.at("max_contact_force").get<double>(), 1.0);
  EXPECT_LE(dyn.at("energy_ratio").get<double>(), 1.0);  // the scheme is dissipative
  // the tracked slave node touched and left again
  const auto& t = dyn.at("tracked").at(0);
  EXPECT_TRUE(t.at("contact_node").get<bool>());
  EXPECT_FALSE(t.at("first_contact_time").is_null());
  EXPECT_FALSE(t.at("detachment_time").is_null());
  ASSERT_EQ(r.bodies.size(), 2u);
  EXPECT_EQ(j.at("bodies").size(), 2u);
  // momentum in the time series: constant to round-off
  std::ifstream csv(dir / "timeseries.csv");
  std::string line;
  std::getline(csv, line);
  double first = 0, worst = 0;
  int rows = 0;
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string cell;
    for (int k = 0; k <= 7; ++k) std::getline(ss, cell, ',');  // momentum_y is column 7
    const double py = std::stod(cell);
    if (rows++ == 0) first = py;
    worst = std::max(worst, std::abs(py - first));
  }
  EXPECT_EQ(rows, 121);
  EXPECT_GT(std::abs(first), 0.1);
  EXPECT_LT(worst, 1e-11 * std::abs(first));
  // one .vtu per body and output step, parts of one .pvd
  for (const char* body : {"lower", "upper"})
    for (const char* step : {"000000", "000060", "000120"})
      EXPECT_TRUE(fs::exists(dir / ("twobody_impact_" + std::string(body) + "_" + step + ".vtu"))) << body << step;
  const std::string pvd = slurp(dir / "twobody_impact.pvd");
  EXPECT_NE(pvd.find("part=\"1\" file=\"twobody_impact_upper_000120.vtu\""), std::string::npos);
  // a comparison keeps the energy ratio with M~ for the redistributed schemes
  run(kScenes / "twobody_impact.toml", "impact_klr",
      {"dynamics.compare=[\"khenous-laborde-renard\"]", "dynamics.output_stride=1000"});
  const auto cmp = summaryOf(kTmp / "impact_klr").at("dynamics_comparison");
  ASSERT_EQ(cmp.size(), 2u);
  EXPECT_FALSE(cmp[0].contains("energy_ratio_redistributed"));
  const auto& klr = cmp[1];
  EXPECT_EQ(klr.at("scheme").get<std::string>(), "khenous-laborde-renard");
  EXPECT_DOUBLE_EQ(klr.at("energy_ratio_redistributed").get<double>(),
                   klr.at("final_energy_redistributed").get<double>() / klr.at("initial_energy_redistributed").get<double>());
  EXPECT_LT(klr.at("max_penetration").get<double>(), 1e-10);
  // KLR conserves M~ v (thesis (5.46)), not M v; the time series has both, and the scheme without
  // M~ leaves the M~ v columns empty
  const obs::test::Table klrSeries = obs::test::readCsv(kTmp / "impact_klr" / "timeseries_khenous-laborde-renard.csv");
  const std::vector<double>& pr = klrSeries["momentum_redistributed_y"];
  ASSERT_EQ(pr.size(), 121u);
  EXPECT_GT(std::abs(pr[0]), 0.1);
  double driftTilde = 0, driftLumped = 0;
  for (std::size_t n = 0; n < pr.size(); ++n) {
    driftTilde = std::max(driftTilde, std::abs(pr[n] - pr[0]));
    driftLumped = std::max(driftLumped, std::abs(klrSeries["momentum_y"][n] - klrSeries["momentum_y"][0]));
  }
  EXPECT_LT(driftTilde, 1e-11 * std::abs(pr[0]));
  EXPECT_GT(driftLumped, 1e-6 * std::abs(pr[0]));  // M v is not conserved: the column is M~ v, not a copy
  const obs::test::Table other = obs::test::readCsv(kTmp / "impact_klr" / ("timeseries_" + cmp[0].at("scheme").get<std::string>() + ".csv"));
  EXPECT_TRUE(std::isnan(other["momentum_redistributed_y"][5]));
  // multi-body runs stop with a checkpoint (restarts: test_Checkpoint.cpp, CheckpointMultiBody)
  RunOptions o;
  o.outputDirectory = kTmp / "impact_stop";
  fs::remove_all(*o.outputDirectory);
  o.stopAfterStep = 10;
  EXPECT_THROW(runScene(kScenes / "twobody_impact.toml", o), RunInterrupted);
  EXPECT_TRUE(fs::exists(kTmp / "impact_stop" / "checkpoint.h5"));
}

TEST(MultiBodyScene, DynamicImpactVtkHasTheContactFieldsOfTheJump) {
  // data/scenes/twobody_impact.toml, a .vtu every 5 steps: the slave side (upper body, bottom y = 1.02,
  // all 15 nodes covered by the master, n_p = (0, -1)) carries the contact fields of the normal jump
  // [u]_nu = n_p.(u_p - sum_q C_pq u_q) and the dual-mortar pressure lambda_p; both sides carry the nodal
  // contact forces. Approach velocity [v]_nu = n.(v_upper - v_lower) = 2, gap 0.02: the jump reaches the
  // gap at step 10 (t = 0.01), the bodies separate near step 52.
  const fs::path dir = kTmp / "impact_fields";
  fs::remove_all(dir);
  run(kScenes / "twobody_impact.toml", "impact_fields", {"dynamics.output_stride=5"});
  const obs::test::Table ts = obs::test::readCsv(dir / "timeseries.csv");
  ASSERT_EQ(ts.rows, 121u);
  double maxForce = 0;  // the scale of the round-off bounds on forces
  for (double f : ts["contact_force_y"]) maxForce = std::max(maxForce, std::abs(f));
  ASSERT_GT(maxForce, 30.0);
  int flight = 0, pressed = 0, apart = 0;
  for (int n = 0; n <= 120; n += 5) {
    SCOPED_TRACE(n);
    std::ostringstream step;
    step << std::setw(6) << std::setfill('0') << n;
    const auto upper = obs::test::readVtu(dir / ("twobody_impact_upper_" + step.str() + ".vtu"));
    const auto lower = obs::test::readVtu(dir / ("twobody_impact_lower_" + step.str() + ".vtu"));
    const auto row = static_cast<std::size_t>(n);
    ASSERT_DOUBLE_EQ(ts["step"][row], n);
    const double t = n * 1e-3;
    // slave side: the 15 bottom nodes, their boundary masses m_p = D_pp = int phi_p (fully covered)
    const auto gap = upper.array("gap"), un = upper.array("normal_displacement"), vn = upper.array("normal_velocity"),
               s = upper.array("contact_pressure"), state = upper.array("contact_state"),
               fu = upper.array("contact_force");
    ASSERT_EQ(s.size(), upper.points.size());
    ASSERT_EQ(fu.size(), 3 * upper.points.size());
    std::vector<double> xs;
    for (const auto& x : upper.points)
      if (std::abs(x[1] - 1.02) <= 1e-12) xs.push_back(x[0]);
    ASSERT_EQ(xs.size(), 15u);
    std::sort(xs.begin(), xs.end());
    auto boundaryMass = [&](double x) {
      const std::size_t i = static_cast<std::size_t>(std::lower_bound(xs.begin(), xs.end(), x - 1e-12) - xs.begin());
      return ((i + 1 < xs.size() ? xs[i + 1] : x) - (i > 0 ? xs[i - 1] : x)) / 2;
    };
    double load = 0;  // sum_p s_p m_p over the slave nodes
    Eigen::Vector2d slaveForce = Eigen::Vector2d::Zero(), masterForce = Eigen::Vector2d::Zero();
    int active = 0;
    for (std::size_t p = 0; p < upper.points.size(); ++p) {
      slaveForce += Eigen::Vector2d(fu[3 * p], fu[3 * p + 1]);
      if (std::abs(upper.points[p][1] - 1.02) > 1e-12) {  // not a slave node: no contact fields, no force
        for (const auto* f : {&gap, &un, &vn, &s, &state}) EXPECT_EQ((*f)[p], 0);
        EXPECT_EQ(fu[3 * p + 1], 0);
        continue;
      }
      const double m = boundaryMass(upper.points[p][0]);
      EXPECT_GE(state[p], 1);
      EXPECT_NEAR(gap[p] + un[p], 0.02, 1e-12);  // gap = g~_p / D_pp - [u]_nu
      EXPECT_GE(s[p], -1e-12 * maxForce);         // lambda_p >= 0 up to round-off
      // the nodal force on the slave node is -D_pp lambda_p n_p, n_p = (0, -1)
      EXPECT_EQ(fu[3 * p], 0);
      EXPECT_NEAR(fu[3 * p + 1], s[p] * m, 1e-12 * maxForce);
      load += s[p] * m;
      if (state[p] == 2) {
        ++active;
        EXPECT_LE(gap[p], 1e-8 * 0.02);
      }
    }
    // master side: no constrained nodes (contact fields 0), the reaction forces on its top face only
    const auto fl = lower.array("contact_force");
    ASSERT_EQ(fl.size(), 3 * lower.points.size());
    for (const char* name : {"gap", "normal_displacement", "normal_velocity", "contact_pressure", "contact_state"}) {
      const auto f = lower.array(name);
      ASSERT_EQ(f.size(), lower.points.size()) << name;
      for (double x : f) EXPECT_EQ(x, 0) << name;
    }
    for (std::size_t p = 0; p < lower.points.size(); ++p) {
      masterForce += Eigen::Vector2d(fl[3 * p], fl[3 * p + 1]);
      if (std::abs(lower.points[p][1] - 1) > 1e-12) {
        EXPECT_EQ(fl[3 * p + 1], 0);
      }
    }
    // the time series' contact force is the force the slave side exerts on the master side:
    // -sum_p s_p m_p n_p = the master's nodal forces; action = reaction
    EXPECT_NEAR(load, -ts["contact_force_y"][row], 1e-12 * maxForce);
    EXPECT_NEAR(masterForce.y(), ts["contact_force_y"][row], 1e-12 * maxForce);
    EXPECT_NEAR(slaveForce.y(), -ts["contact_force_y"][row], 1e-12 * maxForce);
    EXPECT_NEAR((slaveForce + masterForce).norm(), 0, 1e-12 * maxForce);
    EXPECT_EQ(static_cast<double>(active), ts["active_solution"][row]);
    // mortar unknowns have no diagonal lower bound: no error bound (docs/theory.md#tnnmg-error-bound)
    EXPECT_TRUE(std::isnan(ts["solver_error_bound"][row]));
    // the tracked slave node (0.5, 1.02): the time series' jump values are the .vtu's
    for (std::size_t p = 0; p < upper.points.size(); ++p)
      if (std::abs(upper.points[p][0] - 0.5) <= 1e-12 && std::abs(upper.points[p][1] - 1.02) <= 1e-12) {
        EXPECT_DOUBLE_EQ(un[p], ts["tracked0_normal_displacement"][row]);
        EXPECT_DOUBLE_EQ(vn[p], ts["tracked0_normal_velocity"][row]);
        EXPECT_DOUBLE_EQ(gap[p], ts["tracked0_gap"][row]);
      }
    if (n < 10) {  // free flight: the jump moves with the relative velocity 2 of the initial velocities
      ++flight;
      EXPECT_EQ(active, 0);
      for (std::size_t p = 0; p < upper.points.size(); ++p) {
        if (std::abs(upper.points[p][1] - 1.02) > 1e-12) continue;
        EXPECT_NEAR(vn[p], 2, 1e-12);
        EXPECT_NEAR(un[p], 2 * t, 1e-14);
        EXPECT_LE(std::abs(s[p]), 1e-12 * maxForce);
      }
    } else if (n >= 15 && n <= 50) {  // pressed together: every slave node active, the jump at rest
      ++pressed;
      EXPECT_EQ(active, 15);
      EXPECT_GT(load, 1.0);
      for (std::size_t p = 0; p < upper.points.size(); ++p) {
        if (std::abs(upper.points[p][1] - 1.02) > 1e-12) continue;
        // improved contact-stabilized scheme: no normal (relative) velocity at the nodes in contact
        EXPECT_NEAR(vn[p], 0, 1e-10);
        EXPECT_GT(s[p], 0);
      }
    } else if (n >= 60) {  // apart again: separating, no contact force
      ++apart;
      EXPECT_EQ(active, 0);
      EXPECT_LE(std::abs(load), 1e-12 * maxForce);
      for (std::size_t p = 0; p < upper.points.size(); ++p) {
        if (std::abs(upper.points[p][1] - 1.02) <= 1e-12) {
          EXPECT_LT(vn[p], 0);
        }
      }
    }
  }
  EXPECT_EQ(flight, 2);
  EXPECT_EQ(pressed, 8);
  EXPECT_EQ(apart, 13);
}

TEST(MultiBodyScene, AdaptiveCylinderSceneRefinesBothBodies) {
  RunOptions o;
  o.outputDirectory = kTmp / "cyl_adaptive";
  o.overrides = {"adaptivity.steps=4", "adaptivity.vtk=\"every\""};
  const RunResult r = runScene(kScenes / "twobody_cylinders_adaptive.toml", o);
  EXPECT_TRUE(r.solver.converged);
  ASSERT_EQ(r.pairs.size(), 1u);
  const PairReport& p = r.pairs.front();
  EXPECT_EQ(p.slave, "cylinder:arc");
  EXPECT_EQ(p.master, "block:top");
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(p.forceSlave[a] + p.forceMaster[a], 0.0, 1e-10 * p.load);
  EXPECT_GT(p.actualVertices, 3);
  ASSERT_EQ(r.bodies.size(), 2u);
  EXPECT_EQ(r.vertices, r.bodies[0].vertices + r.bodies[1].vertices);
  const nlohmann::json j = summaryOf(kTmp / "cyl_adaptive");
  const auto& steps = j["adaptivity"]["steps"];
  ASSERT_EQ(steps.size(), 4u);
  // both bodies grow, eta decreases, per-body estimates add up in squares
  EXPECT_GT(steps[3]["bodies"][0]["vertices"].get<long long>(), steps[0]["bodies"][0]["vertices"].get<long long>());
  EXPECT_GT(steps[3]["bodies"][1]["vertices"].get<long long>(), steps[0]["bodies"][1]["vertices"].get<long long>());
  EXPECT_LT(steps[3]["eta"].get<double>(), steps[0]["eta"].get<double>());
  for (const auto& s : steps) {
    const double e0 = s["bodies"][0]["eta"], e1 = s["bodies"][1]["eta"], e = s["eta"];
    EXPECT_NEAR(e * e, e0 * e0 + e1 * e1, 1e-12 * e * e);
  }
  EXPECT_EQ(j["pairs"][0]["actual_vertices"].get<long long>(), p.actualVertices);
  // one .vtu per body and step, parts of one .pvd
  for (int k = 0; k < 4; ++k)
    for (const char* b : {"block", "cylinder"}) {
      char name[64];
      std::snprintf(name, sizeof name, "step_%03d_%s.vtu", k, b);
      EXPECT_TRUE(fs::exists(kTmp / "cyl_adaptive" / name)) << name;
    }
  const std::string pvd = slurp(kTmp / "cyl_adaptive" / "twobody_cylinders_adaptive.pvd");
  EXPECT_NE(pvd.find("timestep=\"3\" part=\"1\" file=\"step_003_cylinder.vtu\""), std::string::npos) << pvd;
  const std::string vtu = slurp(kTmp / "cyl_adaptive" / "step_003_cylinder.vtu");
  for (const char* field : {"contact_pressure", "node_class", "indicator", "eta_6", "marked"})
    EXPECT_NE(vtu.find(std::string("Name=\"") + field + "\""), std::string::npos) << field;
  EXPECT_TRUE(fs::exists(kTmp / "cyl_adaptive" / "steps.csv"));
}

TEST(MultiBodyScene, ValidSceneChecks) {
  EXPECT_EQ(errorOf(kLower + upper() + kPair), "no error");
}

TEST(MultiBodyScene, BodyPrescribedEverywhereIsARigidMaster) {
  // [[body.dirichlet]] everywhere = true: the lower block (master) is prescribed at every vertex;
  // with a zero value it is a rigid support, and the result equals that of the block clamped on all
  // its sides (its interior is then zero too)
  std::string rigid = kLower;
  rigid.replace(rigid.find("boundary = \"bottom\""), std::string("boundary = \"bottom\"").size(), "everywhere = true");
  EXPECT_EQ(errorOf(rigid + upper() + kPair), "no error");
  std::string clamped = kLower;
  for (const char* side : {"left", "right", "top"})
    clamped += std::string("[[body.dirichlet]]\nboundary = \"") + side + "\"\n";
  const auto load = [&](const std::string& text, const std::string& name) {
    const fs::path dir = kTmp / "everywhere";
    fs::create_directories(dir);
    std::ofstream(dir / (name + ".toml")) << text;
    RunOptions o;
    o.outputDirectory = dir / name;
    const RunResult r = runScene(dir / (name + ".toml"), o);
    EXPECT_EQ(r.pairs.size(), 1u);
    return r.pairs.front().load;
  };
  const double a = load(rigid + upper() + kPair, "rigid"), b = load(clamped + upper() + kPair, "clamped");
  EXPECT_GT(a, 0);
  EXPECT_NEAR(a, b, 1e-8 * b);
  // everywhere replaces the boundary: both at once is a one-line error with the line
  std::string both = kLower;
  both.replace(both.find("boundary = \"bottom\""), std::string("boundary = \"bottom\"").size(),
               "boundary = \"bottom\"\neverywhere = true");
  const std::string m = errorOf(both + upper() + kPair);
  EXPECT_NE(m.find("everywhere"), std::string::npos) << m;
  EXPECT_NE(m.find("remove the boundary"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

TEST(MultiBodyScene, InitialVelocityOfABodyPrescribedEverywhereIsAnError) {
  // dynamics: the body's motion is its prescribed displacement, an initial velocity of its own would
  // be dropped silently
  std::string rigid = kLower;
  rigid.replace(rigid.find("boundary = \"bottom\""), std::string("boundary = \"bottom\"").size(), "everywhere = true");
  rigid.replace(rigid.find("[body.mesh]"), std::string("[body.mesh]").size(), "initial_velocity = [0.0, 1.0]\n[body.mesh]");
  rigid.replace(rigid.find("nu = 0.3"), std::string("nu = 0.3").size(), "nu = 0.3\ndensity = 1.0");
  std::string up = upper();
  up.replace(up.find("nu = 0.3"), std::string("nu = 0.3").size(), "nu = 0.3\ndensity = 1.0");
  const std::string m =
      errorOf(rigid + up + kPair + "\n[dynamics]\nscheme = \"contact-stabilized\"\ntau = 1e-3\nsteps = 2\n", true);
  EXPECT_NE(m.find("initial_velocity: every vertex of the body is prescribed"), std::string::npos) << m;
  EXPECT_NE(m.find("bad.toml:"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
}

TEST(MultiBodyScene, BadInputIsOneLineErrorWithLine) {
  auto expect = [](const std::string& text, const std::string& part, bool run = false) {
    const std::string m = errorOf(text, run);
    EXPECT_NE(m.find(part), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    EXPECT_NE(m.find("bad.toml"), std::string::npos) << m;
  };
  expect(kLower + kPair, "needs at least two bodies");
  expect(kLower + upper(), "needs [[contact]] pairs");
  expect(kLower + upper() + kPair + R"(
[[contact]]
body = "lower"
boundary = "right"
obstacle = "plane"
point = [1.5, 0.0]
direction = [1.0, 0.0]

[[contact]]
body = "lower"
boundary = "left"
obstacle = "plane"
point = [-0.5, 0.0]
direction = [-1.0, 0.0]
)", "already has a rigid obstacle");
  expect(kLower + upper() + kPair + "\n[mesh]\ngenerator = \"box\"\n", "cannot be combined with [[body]]");
  expect(kLower + upper() + kPair + "\n[adaptivity]\nsteps = 2\nreference = \"punch\"\n",
         "[adaptivity] reference = \"punch\" is a one-body solution");
  expect(kLower + upper() + kPair + "\n[adaptivity]\nsteps = 2\n[dynamics]\ntau = 0.1\nsteps = 2\n",
         "[adaptivity] and [dynamics] cannot be combined");
  expect(kLower + upper() + kPair + "\n[adaptivity]\nsteps = 2\n[solver]\ntype = \"pgs\"\n",
         "is not available with [adaptivity]", true);
  expect(kLower + upper() + kPair + "\n[dynamics]\ntau = 0.1\nsteps = 2\n", "[[body]] 'lower': [material] density is missing");
  {
    std::string withVelocity = kLower + upper() + kPair;
    withVelocity.insert(withVelocity.find("[body.mesh]"), "initial_velocity = [0, 1]\n");
    expect(withVelocity, "initial_velocity / initial_displacement need a [dynamics] section");
  }
  std::string dup = kLower + kLower;
  expect(dup + kPair, "is used by the body of line");
  expect(kLower + upper() + R"(
[[contact]]
slave = { body = "upper", boundary = "bottom" }
master = { body = "nobody", boundary = "top" }
)", "\"nobody\" is not a body of this scene (bodies: lower, upper)");
  expect(kLower + upper() + R"(
[[contact]]
slave = { body = "upper", boundary = "bottom" }
master = { body = "upper", boundary = "top" }
)", "self-contact is not supported");
  expect(kLower + upper() + R"(
[[contact]]
slave = { body = "upper", boundary = "floor" }
master = { body = "lower", boundary = "top" }
)", "boundary = \"floor\" does not exist");
  expect(kLower + upper() + R"(
[[contact]]
slave = { body = "upper", boundary = "bottom" }
master = { body = "lower", boundary = "top" }
friction = 0.3
)", "friction");
  // surfaces far apart: the distance is reported
  expect(kLower + upper("[5.0, 0.5]", "[6.0, 1.0]") + kPair, "covers no slave node");
  // a free body (no Dirichlet data) in a static scene
  std::string free = upper();
  free = free.substr(0, free.find("[[body.dirichlet]]"));
  expect(kLower + free + kPair, "(in [[body]] 'upper')");
  // a Dirichlet condition on the slave side of the interface
  expect(kLower + upper("[0.0, 0.5]", "[1.0, 1.0]", "bottom") + kPair, "not orthogonal to its contact normal",
         true);
}

// --- bodies from one Gmsh file -------------------------------------------------------------------

/// Expects identical results of two runs of the same two-body problem, bit for bit.
void expectSameResults(const RunResult& a, const RunResult& b) {
  ASSERT_EQ(a.pairs.size(), 1u);
  ASSERT_EQ(b.pairs.size(), 1u);
  const PairReport &p = a.pairs[0], &q = b.pairs[0];
  EXPECT_EQ(p.potentialVertices, q.potentialVertices);
  EXPECT_EQ(p.actualVertices, q.actualVertices);
  EXPECT_EQ(p.load, q.load);
  EXPECT_EQ(p.pressureMin, q.pressureMin);
  EXPECT_EQ(p.pressureMax, q.pressureMax);
  EXPECT_EQ(p.area, q.area);
  EXPECT_EQ(p.forceSlave, q.forceSlave);
  EXPECT_EQ(p.forceMaster, q.forceMaster);
  EXPECT_EQ(a.solver.iterations, b.solver.iterations);
  EXPECT_EQ(a.maxDisplacement, b.maxDisplacement);
  EXPECT_EQ(a.maxVonMises, b.maxVonMises);
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  for (std::size_t i = 0; i < a.bodies.size(); ++i) {
    EXPECT_EQ(a.bodies[i].name, b.bodies[i].name);
    EXPECT_EQ(a.bodies[i].vertices, b.bodies[i].vertices);
    EXPECT_EQ(a.bodies[i].cells, b.bodies[i].cells);
    EXPECT_EQ(a.bodies[i].maxDisplacement, b.bodies[i].maxDisplacement);
    EXPECT_EQ(a.bodies[i].maxVonMises, b.bodies[i].maxVonMises);
  }
}

TEST(MultiBodyScene, BodiesFromOneGmshFileGiveTheGeneratorResult) {
  // data/meshes/two_blocks.msh holds the two blocks of twobody_patch.toml as physical volumes
  const RunResult g = run(kScenes / "twobody_gmsh.toml", "gmsh");
  const RunResult b = run(kScenes / "twobody_patch.toml", "gmsh_patch");
  expectSameResults(g, b);
  const PairReport& p = g.pairs.front();
  EXPECT_EQ(p.actualVertices, 36);  // the 6 x 6 nodes of the upper block's bottom
  EXPECT_NEAR(p.pressureMin, 10.0, 1e-8);
  EXPECT_NEAR(p.pressureMax, 10.0, 1e-8);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(p.forceSlave[a] + p.forceMaster[a], 0.0, 1e-11);  // action = reaction
  EXPECT_NEAR(p.forceSlave[2], 10.0, 1e-9);
  ASSERT_EQ(g.bodies.size(), 2u);
  EXPECT_EQ(g.bodies[0].cells, 162);
  EXPECT_EQ(g.bodies[1].cells, 50);
  // the fields written are the same too
  for (const char* body : {"lower", "upper"})
    EXPECT_EQ(slurp(kTmp / "gmsh" / ("twobody_gmsh_" + std::string(body) + ".vtu")),
              slurp(kTmp / "gmsh_patch" / ("twobody_patch_" + std::string(body) + ".vtu")))
        << body;
  // --refine refines the bodies read from the file as it refines generated ones
  RunOptions o;
  o.refine = 1;
  o.outputDirectory = kTmp / "gmsh_refined";
  const RunResult gr = runScene(kScenes / "twobody_gmsh.toml", o);
  o.outputDirectory = kTmp / "gmsh_patch_refined";
  const RunResult br = runScene(kScenes / "twobody_patch.toml", o);
  expectSameResults(gr, br);
  EXPECT_EQ(gr.bodies[0].cells, 8 * 162);
  EXPECT_EQ(gr.pairs[0].actualVertices, 11 * 11);
}

TEST(MultiBodyScene, OneBodySceneTakesOneGroupOfAGmshFile) {
  // the key works in a one-body [mesh] as well; refine applies to the group's cells
  const fs::path dir = kTmp / "one_group";
  fs::create_directories(dir);
  const fs::path scene = dir / "upper.toml";
  std::ofstream(scene) << "[mesh]\nfile = \"" << (fs::path(OBS_DATA_DIR) / "meshes" / "two_blocks.msh").string()
                       << "\"\nphysical = \"upper\"\nrefine = 1\n[material]\nE = 1\nnu = 0.3\n"
                          "[[dirichlet]]\nboundary = \"bottom\"\n";
  const Scene s = parseScene(scene);
  EXPECT_EQ(s.mesh.physicalName, "upper");
  EXPECT_EQ(s.mesh.physicalLine, 3);
  const obs::mesh::Mesh m = buildMesh(s);
  EXPECT_EQ(m.numCells(), 8 * 50);
  EXPECT_EQ(buildMesh(s, 0).numCells(), 50);
  for (obs::mesh::Index v = 0; v < m.numVertices(); ++v) EXPECT_GE(m.vertex(v).z(), 1.0);  // the upper block only
  EXPECT_EQ(buildMesh(s, 0).numVertices(), 108);
}

/// A scene of the two blocks read from `mesh` with the given selections (TOML values).
std::string gmshBodies(const std::string& mesh, const std::string& lower, const std::string& upper) {
  auto body = [&](const std::string& name, const std::string& physical, const std::string& fixed) {
    return "\n[[body]]\nname = \"" + name + "\"\n[body.mesh]\nfile = \"" + mesh + "\"\n" +
           (physical.empty() ? "" : "physical = " + physical + "\n") +
           "[body.material]\nE = 1.0\nnu = 0.3\n[[body.dirichlet]]\nboundary = \"" + fixed + "\"\n";
  };
  return body("lower", lower, "bottom") + body("upper", upper, "top") +
         "\n[[contact]]\nslave = { body = \"upper\", boundary = \"bottom\" }\n"
         "master = { body = \"lower\", boundary = \"top\" }\n";
}

TEST(MultiBodyScene, BadGmshGroupSelectionIsOneLineErrorWithLineAndKey) {
  const std::string msh = (fs::path(OBS_DATA_DIR) / "meshes" / "two_blocks.msh").string();
  // a copy with a volume group that holds no cells
  const fs::path dir = kTmp / "bad_groups";
  fs::create_directories(dir);
  std::string text = slurp(msh);
  text.replace(text.find("$PhysicalNames\n8\n"), 17, "$PhysicalNames\n9\n3 7 \"void\"\n");
  const fs::path withVoid = dir / "with_void.msh";
  std::ofstream(withVoid) << text;

  EXPECT_EQ(errorOf(gmshBodies(msh, "\"lower\"", "\"upper\"")), "no error");
  auto expect = [](const std::string& scene, const std::vector<std::string>& parts) {
    const std::string m = errorOf(scene);
    for (const std::string& part : parts) EXPECT_NE(m.find(part), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  };
  // the physical key of the lower body is on line 6 of the scene
  const std::string groups = "(cell groups of dimension 3 (volumes): 1 \"lower\" (162 cells), 2 \"upper\" (50 cells))";
  expect(gmshBodies(msh, "\"middle\"", "2"),
         {"bad.toml:6: [mesh] physical = \"middle\": ", "two_blocks.msh: no physical group named \"middle\"",
          groups, "(in [[body]] 'lower')"});
  expect(gmshBodies(msh, "7", "2"),
         {"bad.toml:6: [mesh] physical = 7: ", "no physical group of dimension 3 (volumes) with tag 7", "1 \"lower\""});
  // a boundary group, by name and by tag
  expect(gmshBodies(msh, "\"top\"", "2"),
         {"bad.toml:6: [mesh] physical = \"top\": ", "physical group \"top\" (tag 4) has dimension 2, not the mesh dimension 3",
          groups});
  expect(gmshBodies(msh, "\"lower\"", "4"),
         {"bad.toml:17: [mesh] physical = 4: ", "physical tag 4 is a group of dimension 2 only", "(in [[body]] 'upper')"});
  // a group without cells
  expect(gmshBodies(withVoid.string(), "\"void\"", "2"),
         {"bad.toml:6: [mesh] physical = \"void\": ", "with_void.msh: physical group 7 \"void\" (dimension 3) holds no cells"});
  // the key without a file, and values that are no group
  std::string generated = kLower + upper() + kPair;
  generated.insert(generated.find("[body.material]"), "physical = \"lower\"\n");
  expect(generated, {"bad.toml:10: [mesh] physical needs file = \"mesh.msh\""});
  expect(gmshBodies(msh, "1.5", "2"), {"bad.toml:6: [mesh] physical must be a physical group name (string) or tag (integer), got a float"});
  expect(gmshBodies(msh, "\"\"", "2"), {"bad.toml:6: [mesh] physical must not be empty"});
}

}  // namespace
