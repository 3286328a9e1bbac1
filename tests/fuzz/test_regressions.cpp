// Regression tests for the parser defects found by fuzz_parsers (docs/reliability.md), and the
// determinism of the mutator (an input is a function of seed and number, so that a saved failure
// can be regenerated with `fuzz_parsers --print`).
#include <gtest/gtest.h>

#include <string>

#include "FuzzTargets.hpp"
#include "Mutator.hpp"
#include "obs/drivers/Expression.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"

namespace {

using obs::fuzz::Dialect;
using obs::fuzz::Mutator;

const std::string kScenes = OBS_DATA_DIR "/scenes";

std::string repeated(const std::string& unit, int n) {
  std::string s;
  for (int i = 0; i < n; ++i) s += unit;
  return s;
}

/// The message of the obs::Error that `f` throws ("" and a test failure if it throws none).
template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const obs::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no obs::Error thrown";
  return "";
}

const std::string kValidScene = R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [2, 2]
[material]
E = 1
nu = 0.3
[[dirichlet]]
boundary = "left"
)";

TEST(Mutator, InputIsAFunctionOfSeedAndNumber) {
  const Mutator a({"x + 1", "sin(y)"}, Dialect::Expression), b({"x + 1", "sin(y)"}, Dialect::Expression);
  int differ = 0;
  for (std::uint64_t i = 0; i < 200; ++i) {
    EXPECT_EQ(a.input(7, i), b.input(7, i));
    differ += a.input(7, i) != a.input(8, i);
  }
  EXPECT_GT(differ, 150);  // another seed gives other inputs
}

TEST(FuzzTargets, ValidSceneIsAccepted) {
  EXPECT_EQ(obs::fuzz::runScene(kValidScene, kScenes), obs::fuzz::Accepted::Fully);
}

// Found by fuzz_parsers (seed 1): toml11's recursive descent overflowed the stack on ~7000
// nested arrays (SIGSEGV) and took minutes on nested inline tables; now the nesting is checked
// before parsing.
TEST(FuzzRegression, DeeplyNestedTomlArraysAreAnError) {
  for (const auto& [open, close] : {std::pair{"[", "]"}, std::pair{"{a=", "}"}}) {
    const std::string text =
        kValidScene + "nested = " + repeated(open, 100000) + "1" + repeated(close, 100000) + "\n";
    const std::string msg = errorOf([&] { obs::drivers::parseSceneString(text, "deep.toml", kScenes); });
    EXPECT_EQ(msg, "deep.toml:10: TOML arrays and inline tables nested deeper than 32 levels");
  }
  // 32 levels are still read (and then reported as what they are: an unknown key)
  const std::string ok = kValidScene + "x = " + repeated("[", 32) + repeated("]", 32) + "\n";
  const std::string msg = errorOf([&] { obs::drivers::parseSceneString(ok, "ok.toml", kScenes); });
  EXPECT_NE(msg.find("unknown key 'x'"), std::string::npos) << msg;
}

// Found by fuzz_parsers (seed 1000, input 51863 of 100,000): a table header with 21,000 dotted
// parts ([a.b.b.b...]) kept toml11 busy for more than a minute.
TEST(FuzzRegression, DeeplyDottedKeysAreAnError) {
  for (const std::string& line : {"[adaptivity" + repeated(".b", 20000) + "]\n", "a" + repeated(".b", 20000) + " = 1\n"}) {
    const std::string msg =
        errorOf([&] { obs::drivers::parseSceneString(kValidScene + line, "dots.toml", kScenes); });
    EXPECT_EQ(msg, "dots.toml:10: TOML key with more than 32 dotted parts");
  }
  // values with points (numbers, dates, multi-line arrays) are no keys
  const std::string ok = kValidScene + "[output]\ndirectory = \"a.b.c\"\n";
  EXPECT_EQ(obs::fuzz::runScene(ok, kScenes), obs::fuzz::Accepted::Fully);
  EXPECT_EQ(obs::fuzz::runScene(kValidScene + "[body_force]\nvalue = [\n" + repeated("1.5 +", 0) + "0.5,\n" +
                                    repeated("0.", 1) + "25,\n]\n",
                                kScenes),
            obs::fuzz::Accepted::Fully);
}

TEST(FuzzRegression, NestedValueOfSetOverrideIsAnError) {
  const std::string msg = errorOf([&] {
    obs::drivers::parseSceneString(kValidScene, "s.toml", kScenes,
                                   {"material.E=" + repeated("[", 50000) + repeated("]", 50000)});
  });
  EXPECT_NE(msg.find("nested deeper than 32 levels"), std::string::npos) << msg;
}

// Found by fuzz_parsers (seed 1): an expression error quoted the text verbatim, so a line break in
// it (a TOML multi-line string) gave a message of several lines, and a long text a message of
// any length. Now the quote is printable and at most ~80 characters around the position.
TEST(FuzzRegression, ExpressionErrorsAreOneBoundedLine) {
  const std::string msg = errorOf([] { obs::drivers::Expression::parse("1 +\n sin(x) $"); });
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  EXPECT_EQ(msg, "expression \"1 +? sin(x) $\": unexpected '$' (missing operator?) at position 13");
  const std::string longText = repeated("x + ", 5000) + "?";
  const std::string longMsg = errorOf([&] { obs::drivers::Expression::parse(longText); });
  EXPECT_LT(longMsg.size(), 400u) << longMsg;
  EXPECT_NE(longMsg.find("at position 20001"), std::string::npos) << longMsg;
  // in a scene, too
  const std::string scene = kValidScene + "value = \"\"\"0.1 *\nsinn(x)\"\"\"\n";
  const std::string sceneMsg = errorOf([&] { obs::drivers::parseSceneString(scene, "m.toml", kScenes); });
  EXPECT_EQ(sceneMsg.find('\n'), std::string::npos) << sceneMsg;
  EXPECT_NE(sceneMsg.find("\"0.1 *?sinn(x)\": unknown function 'sinn'"), std::string::npos) << sceneMsg;
}

// Found by fuzz_parsers (seeds 1 and 3): string values with line breaks (TOML multi-line strings)
// were quoted verbatim in messages ("[mesh] generator = \"multi\nline\" is unknown"), giving
// messages of several lines. Names and keywords must now be one line, and quoted values are.
TEST(FuzzRegression, MultiLineStringsGiveOneLineMessages) {
  auto scene = [](const std::string& key, const std::string& value) {
    std::string text = kValidScene;
    const auto at = text.find(key + " = ");
    const auto end = text.find('\n', at);
    return text.substr(0, at) + key + " = " + value + text.substr(end);
  };
  for (const std::string& text :
       {scene("generator", "'''\nbox\n'''"), scene("boundary", "\"\"\"le\nft\"\"\""),
        kValidScene + "[contact]\nboundary = \"right\"\nobstacle = \"plane\"\npoint = [2, 0]\n"
                      "direction = '''\nnormal'''\n"}) {
    const std::string msg = errorOf([&] { obs::fuzz::runScene(text, kScenes); });
    EXPECT_FALSE(msg.empty());
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
  const std::string msg = errorOf([&] { obs::fuzz::runScene(scene("generator", "'''\nbox\n'''"), kScenes); });
  EXPECT_NE(msg.find("[mesh] generator must be one line of text"), std::string::npos) << msg;
}

// Found by fuzz_parsers (seeds 6 and 10): a ball of radius 1 centred at 9.2e18 has coordinates
// that cannot resolve its cells; the generator threw std::logic_error ("a cell is not positively
// oriented"), which is no input error. Now it is an obs::Error.
TEST(FuzzRegression, BallFarFromTheOriginIsAnError) {
  const std::string scene = R"([mesh]
generator = "ball"
type = "pyramid"
cells = 2
centre = [0, 9223372036854775807, 0]
radius = 1
[material]
E = 500
nu = 0.3
density = 1
[contact]
boundary = "surface"
obstacle = "plane"
point = [0, 0, -1.01]
direction = [0, 0, -1]
[dynamics]
tau = 5e-3
steps = 1
)";
  const std::string msg = errorOf([&] { obs::fuzz::runScene(scene, kScenes); });
  EXPECT_NE(msg.find("degenerate in floating point"), std::string::npos) << msg;
}

// Found in review and confirmed with a 10^6-term input (SIGSEGV): "x+x+...+x" built a syntax tree
// as deep as the chain is long, and emitting and freeing it recursed once per term.
TEST(FuzzRegression, LongOperatorChainsAreBounded) {
  const std::string msg =
      errorOf([] { obs::drivers::Expression::parse("x" + repeated("+x", 1000000)); });
  EXPECT_NE(msg.find("more than 10000 chained operations"), std::string::npos) << msg.substr(0, 300);
  // 9,999 operations are fine, and a chain of constants folds to one constant
  const auto e = obs::drivers::Expression::parse("x" + repeated("*1", 9999));
  EXPECT_EQ(e(3, 0, 0), 3.0);
  EXPECT_TRUE(obs::drivers::Expression::parse("1" + repeated("+1", 100000)).isConstant());
}

// Found in review of the fuzz budget: a generated mesh was built before its size was checked, so
// cells = [9000, 9000] (below the parser's box limit of 1e8 boxes) made `obs check` allocate
// 1.6 GB for 31 s before the 5e7-cell limit rejected it (a ball with cells = 1000 was stopped only
// by ballMesh's 32-bit index check). Now the size is computed from the parameters first.
TEST(FuzzRegression, OversizedGeneratedMeshesFailBeforeAllocating) {
  std::string box = kValidScene;
  box.replace(box.find("[2, 2]"), 6, "[9000, 9000]");
  const auto boxScene = obs::drivers::parseSceneString(box, "big.toml", kScenes);
  EXPECT_EQ(errorOf([&] { obs::drivers::buildMesh(boxScene); }),
            "big.toml:1: [mesh] asks for 8.1e+07 cells (the limit is 5e+07)");
  std::string ball = R"([mesh]
generator = "ball"
type = "pyramid"
cells = 1000
[material]
E = 500
nu = 0.3
density = 1
[contact]
boundary = "surface"
obstacle = "plane"
point = [0, 0, -1.01]
direction = [0, 0, -1]
[dynamics]
tau = 5e-3
steps = 1
)";
  const std::string msg = errorOf([&] {
    const auto scene = obs::drivers::parseSceneString(ball, "ball.toml", kScenes);
    obs::drivers::buildMesh(scene);
  });
  EXPECT_EQ(msg, "ball.toml:1: [mesh] asks for 2.4e+10 cells (the limit is 5e+07)");
}

}  // namespace
