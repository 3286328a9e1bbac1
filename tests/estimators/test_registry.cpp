// EstimatorRegistry: built-ins, errors that list the registered names, duplicates, plugins loaded
// with dlopen (the example plugin of libestimators/examples and a library without the entry
// point), and the `obs estimators` command of the program when it is built.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/PluginPaths.hpp"
#include "obs/estimators/ResidualEstimator.hpp"
#include "obs/mesh/BoxMesh.hpp"

using namespace obs;
using namespace obs::estimators;
namespace fs = std::filesystem;

namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "(no obs::Error thrown)";
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

TEST(EstimatorRegistry, GlobalHoldsTheBuiltins) {
  auto& registry = EstimatorRegistry::global();
  EXPECT_EQ(&registry, &EstimatorRegistry::global());
  ASSERT_TRUE(registry.contains("residual"));
  const auto estimator = registry.create("residual");
  EXPECT_EQ(estimator->name(), "residual");
  EXPECT_EQ(registry.description("residual"), estimator->description());
  EXPECT_NE(dynamic_cast<ResidualEstimator*>(estimator.get()), nullptr);
  ASSERT_TRUE(registry.contains("contact-residual"));
  EXPECT_NE(dynamic_cast<ContactResidualEstimator*>(registry.create("contact-residual").get()), nullptr);
  for (const auto& e : registry.entries())
    if (e.name == "residual" || e.name == "contact-residual") {
      EXPECT_EQ(e.origin, EstimatorRegistry::kBuiltin);
    }
}

TEST(EstimatorRegistry, UnknownNameListsTheRegisteredOnes) {
  const std::string e = errorOf([] { EstimatorRegistry::global().create("resdual"); });
  EXPECT_TRUE(contains(e, "unknown estimator 'resdual'")) << e;
  EXPECT_TRUE(contains(e, "registered: ")) << e;
  EXPECT_TRUE(contains(e, "residual")) << e;
  EstimatorRegistry empty;
  EXPECT_TRUE(contains(errorOf([&] { empty.create("residual"); }), "(registered: none)"));
  EXPECT_TRUE(contains(errorOf([&] { empty.description("x"); }), "unknown estimator 'x'"));
}

TEST(EstimatorRegistry, AddChecksNamesAndFactories) {
  EstimatorRegistry r;
  registerBuiltinEstimators(r);
  EXPECT_EQ(r.names(), (std::vector<std::string>{"contact-residual", "residual"}));
  const auto factory = [] { return std::make_unique<ResidualEstimator>(); };
  EXPECT_TRUE(contains(errorOf([&] { r.add("residual", "again", factory); }),
                       "estimator 'residual' is already registered (built-in)"));
  EXPECT_TRUE(contains(errorOf([&] { r.add("", "x", factory); }), "empty name"));
  EXPECT_TRUE(contains(errorOf([&] { r.add("two words", "x", factory); }), "whitespace"));
  EXPECT_TRUE(contains(errorOf([&] { r.add("none", "x", nullptr); }), "no factory"));
  r.add("null", "returns nothing", [] { return std::unique_ptr<Estimator>(); });
  EXPECT_TRUE(contains(errorOf([&] { r.create("null"); }), "returned no estimator"));
  r.add("another", "embedding code may add its own", factory);
  EXPECT_EQ(r.names(), (std::vector<std::string>{"another", "contact-residual", "null", "residual"}));
}

TEST(EstimatorRegistry, LoadsThePluginOnce) {
  ASSERT_TRUE(fs::exists(OBS_EXAMPLE_ESTIMATOR_PLUGIN)) << OBS_EXAMPLE_ESTIMATOR_PLUGIN;
  EstimatorRegistry r;
  registerBuiltinEstimators(r);
  r.loadPlugin(OBS_EXAMPLE_ESTIMATOR_PLUGIN);
  ASSERT_TRUE(r.contains("example-uniform"));
  EXPECT_NO_THROW(r.loadPlugin(OBS_EXAMPLE_ESTIMATOR_PLUGIN));  // already loaded: nothing happens
  for (const auto& e : r.entries())
    if (e.name == "example-uniform") {
      EXPECT_EQ(e.origin, "plugin " + std::string(OBS_EXAMPLE_ESTIMATOR_PLUGIN));
    }

  const auto estimator = r.create("example-uniform");
  const auto m = mesh::boxMesh(mesh::CellType::Quadrilateral, 3);
  const Material mat{1.0, 0.3};
  const BoundaryConditions bc;
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(m.numVertices() * 2);
  const auto result = estimator->estimate(EstimatorInput(m, mat, bc, u));
  ASSERT_EQ(result.indicators.size(), 9u);
  for (double e : result.indicators) EXPECT_DOUBLE_EQ(e, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(result.total, 1.0);
  EXPECT_TRUE(result.validFor(m));

  // a second registry loads the same library again (its own registrations)
  EstimatorRegistry other;
  other.loadPlugin(OBS_EXAMPLE_ESTIMATOR_PLUGIN);
  EXPECT_EQ(other.names(), std::vector<std::string>{"example-uniform"});
  // a plugin registering a name twice fails with the plugin's path
  const std::string dup = errorOf([&] {
    EstimatorRegistry third;
    third.add("example-uniform", "first", [] { return std::make_unique<ResidualEstimator>(); });
    third.loadPlugin(OBS_EXAMPLE_ESTIMATOR_PLUGIN);
  });
  EXPECT_TRUE(contains(dup, OBS_EXAMPLE_ESTIMATOR_PLUGIN)) << dup;
  EXPECT_TRUE(contains(dup, "already registered")) << dup;
}

TEST(EstimatorRegistry, PluginErrorsNameThePathAndTheCause) {
  EstimatorRegistry r;
  const std::string missing = "/nonexistent/libno_such_plugin.so";
  const std::string e1 = errorOf([&] { r.loadPlugin(missing); });
  EXPECT_TRUE(contains(e1, "estimator plugin '" + missing + "': cannot load: ")) << e1;
  EXPECT_TRUE(contains(e1, "No such file")) << e1;  // dlerror()

  fs::create_directories(OBS_TEST_TMP_DIR);
  const fs::path notElf = fs::path(OBS_TEST_TMP_DIR) / "not_a_library.so";
  std::ofstream(notElf) << "not a shared library\n";
  const std::string e2 = errorOf([&] { r.loadPlugin(notElf); });
  EXPECT_TRUE(contains(e2, notElf.string())) << e2;
  EXPECT_TRUE(contains(e2, "cannot load")) << e2;

  ASSERT_TRUE(fs::exists(OBS_NO_ENTRY_ESTIMATOR_PLUGIN));
  const std::string e3 = errorOf([&] { r.loadPlugin(OBS_NO_ENTRY_ESTIMATOR_PLUGIN); });
  EXPECT_TRUE(contains(e3, OBS_NO_ENTRY_ESTIMATOR_PLUGIN)) << e3;
  EXPECT_TRUE(contains(e3, "no entry point 'obs_register_estimators'")) << e3;
  EXPECT_TRUE(contains(e3, "undefined symbol")) << e3;  // dlerror()
  EXPECT_TRUE(r.names().empty());
  EXPECT_TRUE(contains(errorOf([&] { r.loadPlugin(""); }), "empty path"));
}

// --- the `obs estimators` command -------------------------------------------------------------

struct Output {
  int code = -1;
  std::string out, err;
};

/// Runs `obs <args>` in `cwd` (default: the test's temporary directory).
Output runObs(const std::string& args, const std::string& tag, fs::path cwd = {}) {
  const fs::path dir = fs::path(OBS_TEST_TMP_DIR) / "estimators_cli";
  fs::create_directories(dir);
  if (cwd.empty()) cwd = dir;
  const fs::path out = dir / (tag + ".out"), err = dir / (tag + ".err");
  const std::string cmd = "cd '" + cwd.string() + "' && '" + std::string(OBS_CLI_PROGRAM) + "' " +
                          args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  Output o;
  o.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::stringstream so, se;
  so << std::ifstream(out).rdbuf();
  se << std::ifstream(err).rdbuf();
  o.out = so.str();
  o.err = se.str();
  return o;
}

class EstimatorsCommand : public ::testing::Test {
protected:
  void SetUp() override {
    if (std::string(OBS_CLI_PROGRAM).empty() || !fs::exists(OBS_CLI_PROGRAM))
      GTEST_SKIP() << "the obs program is not built";
  }
};

TEST_F(EstimatorsCommand, ListsTheBuiltinsWithDescriptions) {
  const Output o = runObs("estimators", "list");
  EXPECT_EQ(o.code, 0) << o.err;
  EXPECT_TRUE(o.err.empty()) << o.err;
  EXPECT_EQ(o.out.rfind("contact-residual  residual-type estimator for contact", 0), 0u) << o.out;
  EXPECT_TRUE(contains(o.out, "\nresidual          standard residual estimator")) << o.out;
  const Output h = runObs("--help", "help");
  EXPECT_TRUE(contains(h.out, "estimators")) << h.out;
}

TEST_F(EstimatorsCommand, LoadsPlugins) {
  const Output o = runObs("estimators --plugin '" + std::string(OBS_EXAMPLE_ESTIMATOR_PLUGIN) + "'",
                          "plugin");
  EXPECT_EQ(o.code, 0) << o.err;
  EXPECT_TRUE(contains(o.out, "example-uniform   equal indicators on every cell")) << o.out;
  EXPECT_TRUE(contains(o.out, "\nresidual          standard residual")) << o.out;

  // a file name in the current directory is found without "./"
  const fs::path plugin(OBS_EXAMPLE_ESTIMATOR_PLUGIN);
  const Output local = runObs("estimators --plugin " + plugin.filename().string(), "local_plugin",
                              plugin.parent_path());
  EXPECT_EQ(local.code, 0) << local.err;
  EXPECT_TRUE(contains(local.out, "example-uniform")) << local.out;

  const Output bad = runObs("estimators --plugin /nonexistent/lib.so", "bad_plugin");
  EXPECT_EQ(bad.code, 1);
  EXPECT_EQ(bad.err.rfind("obs: error: estimator plugin '/nonexistent/lib.so': cannot load: ", 0), 0u)
      << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
  EXPECT_TRUE(bad.out.empty()) << bad.out;

  const Output missing = runObs("estimators --plugin", "missing_argument");
  EXPECT_EQ(missing.code, 2) << missing.err;
}

}  // namespace
