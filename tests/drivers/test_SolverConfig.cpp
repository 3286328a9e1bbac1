// One solver configuration (obs/obs/SolverConfig.hpp): the same [solver] section gives the same
// options to a static, an adaptive and a dynamic run, with one set of defaults, and the multigrid
// options of the section reach the adaptive loop's and the time stepper's TNNMG.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "obs/drivers/AdaptiveScene.hpp"
#include "obs/drivers/DynamicScene.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"

#include "DriverTestSupport.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;
using obs::ContactSolverKind;
using obs::LinearSmoother;
using obs::SolverConfig;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "solver_config";

/// A block pressed onto a plane: a contact scene every kind can run.
const std::string kBlock = R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 4]
lower = [0, 0]
upper = [1, 1]
refine = 1

[material]
E = 1000
nu = 0.3
density = 1

[[dirichlet]]
boundary = "top"
value = [0, -0.02]

[contact]
boundary = "bottom"
obstacle = "plane"
point = [0, -0.01]
direction = [0, -1]
)";

const std::string kAdaptivity = "\n[adaptivity]\nsteps = 2\n";
const std::string kDynamics = "\n[dynamics]\ntau = 1e-3\nsteps = 3\noutput_stride = 3\n";

Scene sceneOf(const std::string& text, const std::string& name) {
  return parseSceneString(text, name + ".toml", kTmp);
}

struct Kinds {
  SolverConfig staticRun, adaptiveRun, dynamicRun;
};

/// The configuration each kind of run takes from the same [solver] section.
Kinds configsOf(const std::string& solver) {
  Kinds k;
  k.staticRun = solverConfig(sceneOf(kBlock + solver, "static"));
  k.adaptiveRun = adaptiveLoopOptions(sceneOf(kBlock + kAdaptivity + solver, "adaptive"), true).solver;
  const Scene dynamic = sceneOf(kBlock + kDynamics + solver, "dynamic");
  k.dynamicRun = newmarkOptions(dynamic, dynamic.dynamics->scheme).solver;
  return k;
}

}  // namespace

TEST(SolverConfig, TheSameSectionGivesTheSameOptionsInEveryKind) {
  const Kinds k = configsOf(R"(
[solver]
type = "tnnmg"
tolerance = 1e-9
max_iterations = 77
pre_smoothing = 2
post_smoothing = 1
smoother = "vertex-patch"
krylov_steps = 2
linear_smoothing = 1
local_smoothing = false
cycle = "W"
)");
  EXPECT_EQ(k.staticRun, k.adaptiveRun);
  EXPECT_EQ(k.staticRun, k.dynamicRun);
  const SolverConfig& c = k.staticRun;
  EXPECT_EQ(c.kind, ContactSolverKind::TNNMG);
  EXPECT_EQ(c.tolerance, 1e-9);
  EXPECT_EQ(c.iterationCap(), 77);
  EXPECT_EQ(c.preSmoothing, 2);
  EXPECT_EQ(c.postSmoothing, 1);
  EXPECT_EQ(c.multigrid.smoother, LinearSmoother::VertexPatch);
  EXPECT_EQ(c.multigrid.krylovSteps, 2);
  EXPECT_EQ(c.multigrid.preSmoothing, 1);
  EXPECT_EQ(c.multigrid.postSmoothing, 1);
  EXPECT_FALSE(c.multigrid.localSmoothing);
  EXPECT_EQ(c.multigrid.cycleIndex, 2);
}

TEST(SolverConfig, OneSetOfDefaults) {
  const Kinds k = configsOf("");
  EXPECT_EQ(k.staticRun, SolverConfig{});
  EXPECT_EQ(k.adaptiveRun, SolverConfig{});
  EXPECT_EQ(k.dynamicRun, SolverConfig{});
  // the documented defaults (docs/scenes.md [solver])
  EXPECT_EQ(SolverConfig{}.tolerance, 1e-10);
  EXPECT_EQ(SolverConfig{}.iterationCap(), 200);
  EXPECT_EQ(obs::defaultMaxIterations(ContactSolverKind::PrimalDualActiveSet), 100);
  EXPECT_EQ(obs::defaultMaxIterations(ContactSolverKind::ProjectedGaussSeidel), 10000);
  EXPECT_EQ(obs::NewmarkOptions{}.solver, SolverConfig{});
  EXPECT_EQ(obs::estimators::AdaptiveLoopOptions{}.solver, SolverConfig{});
}

TEST(SolverConfig, TheLinearCorrectionOptionsReachAdaptiveAndDynamicRuns) {
  // Gauss-Seidel V(3,3) cycles against vertex-patch V(1,1) cycles with CG: the same solutions to
  // the solver tolerance (the patch options were refused outside static runs before)
  const std::string tight = "\n[solver]\ntolerance = 1e-12\n";
  const std::string patch = tight + "smoother = \"vertex-patch\"\nkrylov_steps = 2\nlinear_smoothing = 1\n";
  for (const std::string& kind : {kAdaptivity, kDynamics}) {
    const std::string name = kind == kAdaptivity ? "adaptive" : "dynamic";
    const std::string last = kind == kAdaptivity ? "step_001.vtu" : "_000003.vtu";  // the final state
    SCOPED_TRACE(name);
    RunOptions o;
    o.outputDirectory = kTmp / (name + "_gs");
    const RunResult a = runScene(sceneOf(kBlock + kind + tight, name + "_gs"), o);
    o.outputDirectory = kTmp / (name + "_patch");
    const RunResult b = runScene(sceneOf(kBlock + kind + patch, name + "_patch"), o);
    EXPECT_TRUE(a.solver.converged);
    EXPECT_TRUE(b.solver.converged);
    auto displacement = [&](const std::string& run) {
      const fs::path dir = kTmp / run;
      const fs::path file = dir / (kind == kAdaptivity ? last : run + last);
      const obs::test::Vtu v = obs::test::readVtu(file);
      const auto it = std::find(v.names.begin(), v.names.end(), "displacement");
      EXPECT_NE(it, v.names.end()) << file;
      return it == v.names.end() ? std::vector<double>{} : v.arrays[static_cast<std::size_t>(it - v.names.begin())];
    };
    const std::vector<double> ua = displacement(name + "_gs"), ub = displacement(name + "_patch");
    ASSERT_EQ(ua.size(), ub.size());
    ASSERT_FALSE(ua.empty());
    double difference = 0;  // the prescribed 0.02 at the top is the scale
    for (std::size_t i = 0; i < ua.size(); ++i) difference = std::max(difference, std::abs(ua[i] - ub[i]));
    EXPECT_LT(difference, 1e-8 * 0.02);
    EXPECT_GT(difference, 0.0);  // not bitwise equal: the patch smoother did run
    EXPECT_NE(a.maxVonMises, 0.0);
    EXPECT_NEAR(b.maxVonMises, a.maxVonMises, 1e-7 * a.maxVonMises);
  }
}
