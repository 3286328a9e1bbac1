// Friction through runScene (`obs run`, docs/scenes.md#friction): the uniform-slip scene gives the
// exact ratio mu of tangential to normal force; the cylinder scene and the two-body (mortar) scene
// stick in the middle and slip at the ends; mu = 0 is the frictionless run; the outputs (summary.json, .vtu); bad input.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"

#include "DriverTestSupport.hpp"

using obs::test::readCsv;

using obs::test::readVtu;
using obs::test::summaryOf;
namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "friction_scene";
const fs::path kScenes = fs::path(OBS_DATA_DIR) / "scenes";

fs::path writeScene(const std::string& name, const std::string& text) {
  fs::create_directories(kTmp);
  const fs::path p = kTmp / (name + ".toml");
  std::ofstream(p) << text;
  return p;
}

RunResult runIn(const fs::path& scene, const fs::path& out, std::optional<int> refine = {}) {
  fs::remove_all(out);
  RunOptions o;
  o.outputDirectory = out;
  o.refine = refine;
  return runScene(scene, o);
}

std::string errorOf(const std::string& name, const std::string& text) {
  try {
    const Scene scene = parseScene(writeScene(name, text));
    validateScene(scene, buildMesh(scene));
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "";
}

/// The punch of docs/theory.md#analytic-references with `friction` (a TOML value, or empty: none) and
/// an optional extra section.
std::string punch(const std::string& friction, const std::string& extra = "") {
  return R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 4]
refine = 2

[material]
E = 3e5
nu = 0.25

[[dirichlet]]
boundary = "top"
value = [0.002, -0.01]

[contact]
boundary = "bottom"
obstacle = "strip"
point = [0.5, 0]
half_width = 0.0625
direction = [0, -1]
)" + (friction.empty() ? std::string() : "friction = " + friction + "\n") + extra;
}

void expectErrorWith(const std::string& message, std::initializer_list<const char*> parts) {
  ASSERT_FALSE(message.empty()) << "no error";
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  for (const char* p : parts) EXPECT_NE(message.find(p), std::string::npos) << message;
}

}  // namespace

TEST(FrictionScene, UniformSlipGivesTheRatioMu) {
  const fs::path out = kTmp / "slip";
  const RunResult r = runIn(kScenes / "friction_slip.toml", out);
  ASSERT_TRUE(r.contact && r.contact->friction);
  const FrictionReport& f = *r.contact->friction;
  EXPECT_EQ(f.law, "coulomb");
  // the exact state: tangential force = mu x normal force, every contact vertex slipping (to the
  // Coulomb fixed point's stopping rule, a relative change of the slip bounds of 1e-6)
  EXPECT_NEAR(f.tangentialForce[0] / r.contact->load, 0.3, 0.3 * 1e-6);
  EXPECT_GT(f.tangentialForce[0], 0);  // the body slides in +x and drags the plane along
  EXPECT_EQ(f.slipVertices, r.contact->actualVertices);
  EXPECT_EQ(f.stickVertices, 0);
  ASSERT_TRUE(r.solver.friction);
  EXPECT_TRUE(r.solver.friction->converged);
  EXPECT_TRUE(r.solver.friction->contracting);
  EXPECT_GT(r.solver.friction->iterations, 1);
  const nlohmann::json j = summaryOf(out);
  EXPECT_EQ(j["contact"]["friction"]["law"], "coulomb");
  EXPECT_EQ(j["contact"]["friction"]["slip_vertices"], r.contact->actualVertices);
  EXPECT_TRUE(j["solver"]["friction"]["converged"].get<bool>());
  const auto vtu = readVtu(out / "friction_slip.vtu");
  for (const char* name : {"friction_force", "slip", "stick_slip"})
    EXPECT_FALSE(vtu.array(name).empty()) << name;
}

TEST(FrictionScene, CylinderSticksInTheMiddleAndSlipsAtTheEnds) {
  const RunResult r = runIn(kScenes / "friction_cylinder.toml", kTmp / "cylinder");
  ASSERT_TRUE(r.contact && r.contact->friction);
  const FrictionReport& f = *r.contact->friction;
  EXPECT_GT(f.stickVertices, 0);
  EXPECT_GT(f.slipVertices, 0);
  EXPECT_EQ(f.stickVertices + f.slipVertices, r.contact->actualVertices);
  // partial slip: the tangential force stays below mu times the normal force
  EXPECT_LT(std::abs(f.tangentialForce[0]), 0.3 * r.contact->load);
  EXPECT_GT(std::abs(f.tangentialForce[0]), 0.01 * r.contact->load);
  EXPECT_TRUE(r.solver.converged);
}

TEST(FrictionScene, MortarPairSticksAndSlips) {
  const RunResult r = runIn(kScenes / "twobody_friction.toml", kTmp / "twobody");
  ASSERT_EQ(r.pairs.size(), 1u);
  const PairReport& p = r.pairs[0];
  ASSERT_TRUE(p.friction);
  EXPECT_GT(p.friction->stickVertices, 0);
  EXPECT_GT(p.friction->slipVertices, 0);
  EXPECT_EQ(p.friction->stickVertices + p.friction->slipVertices, p.actualVertices);
  // the cylinder is moved in +x: the friction on it points to -x, below mu times the normal force
  EXPECT_LT(p.friction->tangentialForce[0], 0);
  EXPECT_LT(std::abs(p.friction->tangentialForce[0]), 0.3 * p.load);
  EXPECT_TRUE(r.solver.converged);
}

TEST(FrictionScene, ZeroCoefficientIsTheFrictionlessRun) {
  const RunResult a = runIn(writeScene("frictionless", punch("")), kTmp / "frictionless");
  const RunResult b = runIn(writeScene("mu0", punch("{ law = \"coulomb\", mu = 0 }")), kTmp / "mu0");
  const RunResult c = runIn(writeScene("bound0", punch("{ law = \"tresca\", bound = 0 }")), kTmp / "bound0");
  for (const RunResult* r : {&b, &c}) {
    EXPECT_EQ(r->solver.iterations, a.solver.iterations);
    EXPECT_EQ(r->maxDisplacement, a.maxDisplacement);
    EXPECT_EQ(r->contact->load, a.contact->load);
  }
  EXPECT_FALSE(a.contact->friction);
  // Tresca with a positive bound changes the solution
  const RunResult d = runIn(writeScene("tresca", punch("{ law = \"tresca\", bound = 20 }")), kTmp / "tresca");
  ASSERT_TRUE(d.contact->friction);
  EXPECT_GT(std::abs(d.contact->friction->tangentialForce[0]), 1e-3 * d.contact->load);
  EXPECT_NE(d.contact->load, a.contact->load);  // against a rigid obstacle friction changes the normal forces too
  EXPECT_EQ(d.solver.friction->iterations, 1);  // Tresca: one solve
}

TEST(FrictionScene, BadInputIsAOneLineError) {
  expectErrorWith(errorOf("law", punch("{ law = \"stiction\", mu = 0.3 }")), {"friction law", "stiction", "coulomb, tresca"});
  expectErrorWith(errorOf("negative", punch("{ law = \"coulomb\", mu = -0.1 }")), {"friction mu", ">= 0"});
  expectErrorWith(errorOf("other", punch("{ law = \"coulomb\", bound = 3 }")), {"friction bound", "does not apply"});
  expectErrorWith(errorOf("missing", punch("{ law = \"tresca\" }")), {"friction", "bound"});
  expectErrorWith(errorOf("table", punch("0.3")), {"friction", "must be a table"});
}

TEST(FrictionScene, PdasSolvesTheSameCoulombProblemIn2D) {
  const RunResult a = runIn(writeScene("tnnmg_mu", punch("{ law = \"coulomb\", mu = 0.3 }")), kTmp / "tnnmg_mu");
  const RunResult b = runIn(writeScene("pdas_mu", punch("{ law = \"coulomb\", mu = 0.3 }", "[solver]\ntype = \"pdas\"\n")),
                            kTmp / "pdas_mu");
  EXPECT_TRUE(b.solver.converged);
  EXPECT_NEAR(b.contact->load, a.contact->load, 1e-6 * a.contact->load);
  EXPECT_NEAR(b.contact->friction->tangentialForce[0], a.contact->friction->tangentialForce[0],
              1e-6 * a.contact->load);
  EXPECT_EQ(b.contact->friction->stickVertices, a.contact->friction->stickVertices);
}

TEST(FrictionScene, CattaneoMindlinPathInIncrements) {
  const fs::path out = kTmp / "cattaneo";
  const RunResult r = runIn(kScenes / "cattaneo_mindlin.toml", out, 4);
  ASSERT_EQ(r.increments.size(), 4u);
  const auto csv = readCsv(out / "increments.csv");
  EXPECT_EQ(csv.rows, 4u);
  // normal loading (t <= 0.5), then shear at the full normal load: Q grows, the stick zone shrinks, and
  // P stays to within the coupling of these finite, curved bodies (exactly only for half-planes)
  const IncrementReport &a = r.increments[1], &b = r.increments[2], &c = r.increments[3];
  EXPECT_NEAR(b.force[1], a.force[1], 1e-2 * std::abs(a.force[1]));
  EXPECT_NEAR(c.force[1], a.force[1], 1e-2 * std::abs(a.force[1]));
  EXPECT_LT(std::abs(a.tangentialForce[0]), 0.01 * 0.3 * std::abs(a.force[1]));  // equal materials: little shear
  EXPECT_GT(std::abs(c.tangentialForce[0]), std::abs(b.tangentialForce[0]));
  EXPECT_GT(b.stickVertices, c.stickVertices);
  EXPECT_GT(c.slipVertices, 0);
  // Cattaneo-Mindlin: c = b sqrt(1 - Q/(mu P)); c and b are both measured over whole faces, so the
  // bound is one face h (docs/verification.md#friction-verification: -0.6 h measured at this refine)
  ASSERT_EQ(r.pairs.size(), 1u);
  const PairReport& p = r.pairs[0];
  const double q = std::abs(p.friction->tangentialForce[0]) / (0.3 * p.load);
  EXPECT_GT(q, 0.5);
  EXPECT_LT(q, 0.9);
  const double h = 2 * p.radius / static_cast<double>(p.actualVertices - 1);
  EXPECT_NEAR(p.friction->stickRadius, p.radius * std::sqrt(1 - q), h);
}

/// The same path in 3D (data/scenes/cattaneo_mindlin_3d.toml on its Gmsh mesh without refinement,
/// 7,000 unknowns): the stick disc's radius c = a (1 - Q/(mu P))^(1/3) to one face (-0.26 h measured).
TEST(FrictionScene, CattaneoMindlin3D) {
  const RunResult r = runIn(kScenes / "cattaneo_mindlin_3d.toml", kTmp / "cattaneo3d", 0);
  ASSERT_EQ(r.increments.size(), 4u);
  const IncrementReport &a = r.increments[1], &c = r.increments[3];
  EXPECT_NEAR(c.force[2], a.force[2], 1e-2 * std::abs(a.force[2]));
  EXPECT_GT(c.slipVertices, a.slipVertices);
  ASSERT_EQ(r.pairs.size(), 1u);
  const PairReport& p = r.pairs[0];
  const double q = std::abs(p.friction->tangentialForce[0]) / (0.3 * p.load);
  EXPECT_GT(q, 0.4);
  EXPECT_LT(q, 0.8);
  // the edge of an equilateral triangle of the contact area per contact vertex
  const double h = std::sqrt(2 * 3.141592653589793 * p.radius * p.radius / (std::sqrt(3.0) * p.actualVertices));
  EXPECT_NEAR(p.friction->stickRadius, p.radius * std::cbrt(1 - q), h);
}

std::string fileText(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The adaptive loop with friction (docs/theory.md#friction-estimators). On the uniform-slip scene the
/// discrete solution is the exact affine field, whose stress is constant and whose shear on the
/// contact boundary is the friction traction: the contact estimator, which measures the tangential
/// stress against the friction traction, is round-off there, while the standard residual estimator
/// counts the shear as error.
TEST(FrictionScene, AdaptiveLoopMeasuresTheStressAgainstTheFrictionTraction) {
  const std::string slip = fileText(kScenes / "friction_slip.toml");
  const auto adaptive = [](const std::string& estimator) {
    return "\n[adaptivity]\nrefinement = \"adaptive\"\nestimator = \"" + estimator +
           "\"\nmarking = \"maximum\"\ntheta = 0.5\nsteps = 2\n";
  };
  const fs::path outC = kTmp / "adaptive_contact", outR = kTmp / "adaptive_residual";
  const RunResult c = runIn(writeScene("adaptive_contact", slip + adaptive("contact-residual")), outC, 2);
  const RunResult r = runIn(writeScene("adaptive_residual", slip + adaptive("residual")), outR, 2);
  EXPECT_TRUE(c.solver.converged);
  const nlohmann::json jc = summaryOf(outC)["adaptivity"]["steps"], jr = summaryOf(outR)["adaptivity"]["steps"];
  ASSERT_EQ(jc.size(), 2u);
  ASSERT_EQ(jr.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const double etaC = jc[k]["eta"].get<double>(), etaR = jr[k]["eta"].get<double>();
    EXPECT_GT(etaR, 0);
    // round-off of the affine field and the fixed point's tolerance (1e-6 of the slip bounds)
    EXPECT_LT(etaC, 1e-5 * etaR) << "step " << k;
    // every contact vertex slips, and the friction force is mu times the normal force; the two
    // bottom corners are in contact (node classes) but prescribed, so without a friction unknown
    const nlohmann::json& f = jc[k]["friction"];
    EXPECT_EQ(f["stick_vertices"].get<long long>(), 0);
    EXPECT_EQ(f["slip_vertices"].get<long long>() + 2, jc[k]["actual_contact"].get<long long>());
    EXPECT_NEAR(f["tangential_force"][0].get<double>(), -0.3 * jc[k]["load"].get<double>(),
                1e-5 * jc[k]["load"].get<double>());
  }
  // partial slip: the contact estimator refines, and the last step's .vtu has the friction fields
  const std::string cylinder = fileText(kScenes / "friction_cylinder.toml");
  const fs::path outY = kTmp / "adaptive_cylinder";
  const RunResult y = runIn(writeScene("adaptive_cylinder", cylinder + adaptive("contact-residual")), outY, 2);
  EXPECT_TRUE(y.solver.converged);
  const nlohmann::json jy = summaryOf(outY)["adaptivity"]["steps"];
  ASSERT_EQ(jy.size(), 2u);
  EXPECT_GT(jy[1]["vertices"].get<long long>(), jy[0]["vertices"].get<long long>());
  EXPECT_GT(jy[1]["friction"]["stick_vertices"].get<long long>(), 0);
  EXPECT_GT(jy[1]["friction"]["slip_vertices"].get<long long>(), 0);
  bool found = false;
  for (const auto& e : fs::directory_iterator(outY))
    if (e.path().extension() == ".vtu") {
      const auto vtu = readVtu(e.path());
      EXPECT_FALSE(vtu.array("friction_force").empty()) << e.path();
      EXPECT_FALSE(vtu.array("stick_slip").empty()) << e.path();
      found = true;
    }
  EXPECT_TRUE(found);
}

TEST(FrictionScene, LoadingErrors) {
  expectErrorWith(errorOf("steps0", punch("", "[loading]\nsteps = 0\n")), {"[loading] steps", "[1, 10000]"});
  expectErrorWith(errorOf("stepskey", punch("", "[loading]\nincrements = 3\n")), {"[loading]", "increments"});
  const std::string linear = R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [2, 2]

[material]
E = 1
nu = 0.3

[[dirichlet]]
boundary = "bottom"

[loading]
steps = 2
)";
  expectErrorWith(errorOf("linear", linear), {"[loading] needs contact"});
}

TEST(FrictionScene, SlidingBlockStopsWhereFrictionSaysSo) {
  const fs::path out = kTmp / "sliding";
  runIn(kScenes / "dynamics_sliding_block.toml", out);
  const auto ts = readCsv(out / "timeseries.csv");
  ASSERT_GT(ts.rows, 100u);
  const auto& t = ts.columns.at("t");
  const auto& px = ts.columns.at("momentum_x");
  const auto& dissipated = ts.columns.at("friction_dissipation");
  EXPECT_TRUE(ts.columns.count("stick_nodes") && ts.columns.count("slip_nodes"));
  const double mass = 0.25, muG = 0.2 * 10;
  for (std::size_t k = 0; k < ts.rows; ++k) {
    // v = v0 - mu g t until the stop at 0.5 (the block settling onto the floor disturbs it by < 1 %)
    if (t[k] < 0.45) {
      EXPECT_NEAR(px[k] / mass, 1 - muG * t[k], 0.01) << "t = " << t[k];
    }
    if (t[k] > 0.6) {
      EXPECT_LT(std::abs(px[k] / mass), 0.02) << "t = " << t[k];
    }
  }
  // the kinetic energy of the slide, 1/2 m v0^2 = 0.125, went into friction (and a little into the
  // settling)
  EXPECT_NEAR(dissipated[ts.rows - 1], 0.125, 0.005);
  const nlohmann::json j = summaryOf(out);
  EXPECT_NEAR(j["dynamics"]["friction"]["dissipated_energy"].get<double>(), dissipated[ts.rows - 1], 1e-12);
}
