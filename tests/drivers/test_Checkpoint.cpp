// Checkpoint and restart (libobs Checkpoint.hpp, drivers DynamicScene, docs/checkpoint.md):
//  - the record API round-trips every entry type bitwise (NaN, empty vectors and texts included);
//  - a Newmark stepper set to a stored state continues bitwise like the original (library level);
//  - a dynamic run stopped at step k (--stop-after-step, SIGTERM) and restarted gives the same
//    summary (timings aside), time series (timing columns aside) and .vtu/.pvd files, byte for byte,
//    as the uninterrupted run, for schemes with and without carried scheme state;
//  - [output] checkpoint = { every = N } writes after every N-th step;
//  - writing is atomic: a failed write leaves the previous checkpoint intact, and a process killed
//    by SIGKILL at arbitrary times (checkpoints every step) never leaves an unreadable checkpoint.h5;
//  - restarting with another scene, --set, --refine, a truncated, damaged or non-HDF5 file, a file of
//    another format version or without the interrupted run's outputs is a one-line error naming
//    what differs; bad [output] checkpoint values are file:line errors;
//  - multi-body runs (twobody_impact.toml, mortar schemes with and without M~) stopped and restarted
//    equal the uninterrupted ones bitwise; their checkpoints hold per-body groups with the offsets
//    into the stacked vectors; a one-body checkpoint for a multi-body scene (and vice versa), other
//    bodies or a body's other grid are one-line errors naming the difference; SIGINT/SIGTERM stop a
//    multi-body run with exit code 3 and a restartable checkpoint, SIGKILL during checkpoint
//    writing never leaves an unreadable checkpoint.h5 (the one-body tests' scheme, two bodies);
//  - adaptive runs ([adaptivity], docs/checkpoint.md#adaptive-runs; one body: the punch, two
//    bodies: the cylinders) stopped after step k (--stop-after-step, SIGINT) and restarted give the
//    same .vtu/.pvd, steps.csv (timings aside), pressure.csv and summary.json as the uninterrupted
//    run; the loop state round-trips through the record; every = N; another scene, --set, --refine,
//    kind of run, a truncated or damaged file are one-line errors.
#include <gtest/gtest.h>

#include <hdf5.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/Newmark.hpp"
#include "obs/obs/Parallel.hpp"

#include "DriverTestSupport.hpp"

using obs::test::slurp;
using obs::test::summaryOf;
namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "checkpoint";

/// The bar of data/scenes/dynamics_bar.toml (a column dropped onto a plane: contact from t = 0.5,
/// lift-off at t = 1.17), `steps` steps of tau = 3e-3, a .vtu every 50 steps; `output` is appended to
/// [output] (lines: [mesh] 1, [output] 19, its first key 20; with no output entries tau is line 23).
std::string barScene(int steps, const std::string& output = "", const std::string& scheme = "improved-contact-stabilized") {
  return "[mesh]\ngenerator = \"box\"\ntype = \"quadrilateral\"\ncells = [1, 20]\nlower = [0, 5]\n"
         "upper = [1, 15]\n\n"
         "[material]\nE = 900\nnu = 0\ndensity = 1\n\n"
         "[contact]\nboundary = \"bottom\"\nobstacle = \"plane\"\npoint = [0, 0]\ndirection = [0, -1]\n\n"
         "[output]\n" +
         output +
         "\n[dynamics]\nscheme = \"" + scheme + "\"\ntau = 3e-3\nsteps = " + std::to_string(steps) +
         "\ninitial_velocity = [0, -10]\ntracked = [[0, 5]]\noutput_stride = 50\n";
}

fs::path writeScene(const std::string& name, const std::string& text) {
  fs::create_directories(kTmp);
  const fs::path p = kTmp / (name + ".toml");
  std::ofstream(p) << text;
  return p;
}

/// summary.json without wall times, memory and output paths (which name the directory).
nlohmann::json comparable(nlohmann::json j) {
  if (j.is_object()) {
    nlohmann::json out = nlohmann::json::object();
    for (auto& [k, v] : j.items()) {
      const bool timing = k.ends_with("_s") || k.find("seconds") != std::string::npos ||
                          k.find("memory") != std::string::npos || k == "output_files" || k == "timeseries";
      if (!timing) out[k] = comparable(v);
    }
    return out;
  }
  if (j.is_array())
    for (auto& v : j) v = comparable(v);
  return j;
}

/// The time series without its two timing columns (solver_seconds, step_seconds).
std::string withoutTimings(const fs::path& csv) {
  std::istringstream in(slurp(csv));
  std::string out;
  int timing[2] = {-1, -1};
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
    if (timing[0] < 0)
      for (std::size_t k = 0; k < f.size(); ++k) {
        if (f[k] == "solver_seconds") timing[0] = static_cast<int>(k);
        if (f[k] == "step_seconds") timing[1] = static_cast<int>(k);
      }
    for (std::size_t k = 0; k < f.size(); ++k)
      if (static_cast<int>(k) != timing[0] && static_cast<int>(k) != timing[1]) out += f[k] + ",";
    out += "\n";
  }
  return out;
}

/// Every .vtu/.pvd of `a` exists in `b` with the same bytes; the same time series and summary.
void expectSameRun(const fs::path& a, const fs::path& b) {
  int files = 0;
  for (const auto& e : fs::directory_iterator(a)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".vtu" && ext != ".pvd") continue;
    ++files;
    const fs::path other = b / e.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_TRUE(slurp(e.path()) == slurp(other)) << e.path().filename() << " differs";
  }
  EXPECT_GE(files, 3);
  EXPECT_EQ(withoutTimings(a / "timeseries.csv"), withoutTimings(b / "timeseries.csv"));
  EXPECT_EQ(comparable(summaryOf(a)).dump(1), comparable(summaryOf(b)).dump(1));
}

RunOptions quiet(const fs::path& dir) {
  RunOptions o;
  o.outputDirectory = dir;
  return o;
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "";
}

void expectContains(std::string message, const std::vector<std::string>& parts) {
  while (!message.empty() && message.back() == '\n') message.pop_back();  // stderr's line end
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  for (const std::string& p : parts) EXPECT_NE(message.find(p), std::string::npos) << p << "\n  in: " << message;
}

/// Runs the scene file into dir, stopped after step k; returns the checkpoint path.
fs::path stopAt(const fs::path& scene, const fs::path& dir, int k, std::vector<std::string> overrides = {}) {
  fs::remove_all(dir);
  RunOptions o = quiet(dir);
  o.stopAfterStep = k;
  o.overrides = std::move(overrides);
  EXPECT_THROW(runScene(scene, o), RunInterrupted);
  return dir / "checkpoint.h5";
}

}  // namespace

// --- the record ----------------------------------------------------------------------------------

TEST(CheckpointRecord, RoundTripsEveryEntryTypeBitwise) {
  fs::create_directories(kTmp);
  obs::CheckpointRecord r;
  r.kind = "test";
  Eigen::VectorXd x(5);
  x << 1.0 / 3.0, -0.0, std::numeric_limits<double>::quiet_NaN(), 1e-310, -std::numeric_limits<double>::infinity();
  r.set("a/b/vector", x, "a vector with NaN, -0, a denormal and -inf");
  r.set("a/empty_vector", Eigen::VectorXd(), "empty");
  r.set("a/integers", std::vector<long long>{-1, 0, 1LL << 62}, "integers");
  r.set("a/no_integers", std::vector<long long>{}, "empty");
  r.set("text", std::string("line 1\nline \"2\" = 'x'\n"), "text with newlines and quotes");
  r.set("empty_text", std::string(), "");
  r.set("real", 0.1, "0.1");
  r.set("integer", -7LL, "-7");
  const fs::path file = kTmp / "roundtrip.h5";
  obs::writeCheckpoint(file, r);
  EXPECT_FALSE(fs::exists(kTmp / "roundtrip.h5.tmp"));
  const obs::CheckpointRecord s = obs::readCheckpoint(file);
  EXPECT_EQ(s.kind, "test");
  ASSERT_EQ(s.entries().size(), r.entries().size());
  EXPECT_EQ(s.contentHash(), r.contentHash());
  const Eigen::VectorXd& y = s.vector("a/b/vector");
  ASSERT_EQ(y.size(), 5);
  EXPECT_EQ(std::memcmp(x.data(), y.data(), sizeof(double) * 5), 0);
  EXPECT_EQ(s.vector("a/empty_vector").size(), 0);
  EXPECT_EQ(s.integers("a/integers"), (std::vector<long long>{-1, 0, 1LL << 62}));
  EXPECT_TRUE(s.integers("a/no_integers").empty());
  EXPECT_EQ(s.text("text"), "line 1\nline \"2\" = 'x'\n");
  EXPECT_EQ(s.text("empty_text"), "");
  EXPECT_EQ(s.real("real"), 0.1);
  EXPECT_EQ(s.integer("integer"), -7);
  EXPECT_EQ(s.entries().at("a/b/vector").description, "a vector with NaN, -0, a denormal and -inf");
  // typed access names the entry
  expectContains(errorOf([&] { (void)s.real("text"); }), {"'text'", "is a text", "expected a real number"});
  expectContains(errorOf([&] { (void)s.vector("nothing"); }), {"'nothing'", "missing"});
  // names are HDF5 paths of plain components; an entry cannot be a group of others
  obs::CheckpointRecord bad;
  expectContains(errorOf([&] { bad.set("/x", 1.0, ""); }), {"invalid entry name '/x'"});
  expectContains(errorOf([&] { bad.set("x//y", 1.0, ""); }), {"invalid entry name"});
  expectContains(errorOf([&] { bad.set("x y", 1.0, ""); }), {"invalid entry name"});
  bad.set("x/y", 1.0, "");
  expectContains(errorOf([&] { bad.set("x", 1.0, ""); }), {"'x'", "'x/y'", "group"});
}

TEST(CheckpointRecord, FailedWriteLeavesThePreviousCheckpointIntact) {
  fs::create_directories(kTmp);
  const fs::path file = kTmp / "atomic.h5";
  obs::CheckpointRecord r;
  r.kind = "test";
  r.set("value", 1.0, "first");
  obs::writeCheckpoint(file, r);
  // the temporary cannot be created (a non-empty directory has its name): the write fails ...
  const fs::path tmp = kTmp / "atomic.h5.tmp";
  fs::remove_all(tmp);
  fs::create_directories(tmp / "blocker");
  r.set("value", 2.0, "second");
  expectContains(errorOf([&] { obs::writeCheckpoint(file, r); }), {file.string(), "cannot write the checkpoint"});
  // ... and the latest checkpoint is still the first, complete one
  EXPECT_EQ(obs::readCheckpoint(file).real("value"), 1.0);
  fs::remove_all(tmp);
  obs::writeCheckpoint(file, r);
  EXPECT_EQ(obs::readCheckpoint(file).real("value"), 2.0);
}

TEST(CheckpointRecord, DamagedTruncatedForeignAndOtherVersionFilesAreOneLineErrors) {
  fs::create_directories(kTmp);
  const fs::path good = kTmp / "good.h5";
  obs::CheckpointRecord r;
  r.kind = "test";
  r.set("state/values", Eigen::VectorXd::Constant(512, 1.25), "1.25 everywhere");
  obs::writeCheckpoint(good, r);
  const std::string bytes = slurp(good);

  // one flipped bit in the data: HDF5 reads it, the content hash does not match
  {
    std::string damaged = bytes;
    const double v = 1.25;
    const std::string pattern(reinterpret_cast<const char*>(&v), sizeof v);
    const std::size_t at = damaged.find(pattern + pattern);
    ASSERT_NE(at, std::string::npos);
    damaged[at + 8 * 100 + 3] ^= 0x10;
    const fs::path f = kTmp / "damaged.h5";
    std::ofstream(f, std::ios::binary) << damaged;
    expectContains(errorOf([&] { (void)obs::readCheckpoint(f); }),
                   {f.string(), "content hash", "differs", "damaged"});
  }
  // truncated at several lengths (as by a full disk or a copy cut short)
  for (double fraction : {0.1, 0.5, 0.9, 0.99}) {
    SCOPED_TRACE(fraction);
    const fs::path f = kTmp / "truncated.h5";
    std::ofstream(f, std::ios::binary) << bytes.substr(0, static_cast<std::size_t>(fraction * bytes.size()));
    const std::string e = errorOf([&] { (void)obs::readCheckpoint(f); });
    expectContains(e, {f.string() + ": "});
    EXPECT_TRUE(e.find("truncated") != std::string::npos || e.find("damaged") != std::string::npos) << e;
  }
  // not HDF5 at all, missing
  {
    const fs::path f = kTmp / "text.h5";
    std::ofstream(f) << "[mesh]\n";
    expectContains(errorOf([&] { (void)obs::readCheckpoint(f); }), {f.string(), "not an HDF5 file"});
    expectContains(errorOf([&] { (void)obs::readCheckpoint(kTmp / "missing.h5"); }), {"missing.h5", "no such"});
  }
  // another format version and a foreign HDF5 file (attributes changed with the HDF5 C API)
  {
    const fs::path f = kTmp / "version.h5";
    fs::copy_file(good, f, fs::copy_options::overwrite_existing);
    const hid_t h = H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(h, 0);
    const hid_t a = H5Aopen(h, "format_version", H5P_DEFAULT);
    const long long two = 2;
    H5Awrite(a, H5T_NATIVE_LLONG, &two);
    H5Aclose(a);
    H5Fclose(h);
    expectContains(errorOf([&] { (void)obs::readCheckpoint(f); }),
                   {f.string(), "format version 2", "reads version 1"});
  }
  {
    const fs::path f = kTmp / "foreign.h5";
    const hid_t h = H5Fcreate(f.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(h, 0);
    H5Fclose(h);
    expectContains(errorOf([&] { (void)obs::readCheckpoint(f); }), {f.string(), "attribute format is missing"});
  }
}

// --- library level: a Newmark stepper continues bitwise from a stored state ----------------------

TEST(CheckpointNewmark, StepperSetToAStoredStateContinuesBitwise) {
  const Scene scene = parseSceneString(barScene(1), "bar.toml", kTmp);
  const obs::mesh::Grid grid = buildGrid(scene);
  const obs::mesh::Mesh mesh = grid.leafView().mesh;
  const obs::BoundaryConditions bc = makeBoundaryConditions(scene, mesh);
  const auto obstacle = makeObstacle(scene, 2);
  const obs::ContactSet contact = makeContactSet(scene, mesh, *obstacle);
  for (obs::NewmarkScheme scheme : obs::allNewmarkSchemes()) {
    SCOPED_TRACE(std::string(obs::name(scheme)));
    obs::NewmarkOptions o;
    o.scheme = scheme;
    o.timeStep = 3e-3;
    o.solver.tolerance = 1e-11;
    Eigen::VectorXd u0 = Eigen::VectorXd::Zero(mesh.numVertices() * 2), v0 = u0;
    for (obs::mesh::Index p = 0; p < mesh.numVertices(); ++p) v0[2 * p + 1] = -10;
    obs::NewmarkFamily<2> a(grid, scene.material, bc, contact, o);
    a.initialize(u0, v0);
    for (int k = 0; k < 200; ++k) a.step();  // in contact from step 167
    obs::CheckpointRecord r;
    obs::storeNewmarkState(r, a.schemeState());
    const fs::path file = kTmp / "newmark.h5";
    obs::writeCheckpoint(file, r);
    obs::NewmarkFamily<2> b(grid, scene.material, bc, contact, o);
    b.initialize(u0, v0);  // the operators; the state is replaced
    b.setSchemeState(obs::loadNewmarkState(obs::readCheckpoint(file)));
    EXPECT_EQ(b.record().contactForce, a.record().contactForce);
    for (int k = 0; k < 60; ++k) {
      const obs::StepRecord ra = a.step(), rb = b.step();
      ASSERT_EQ(ra.solverIterations, rb.solverIterations) << "step " << ra.step;
      ASSERT_EQ(ra.activePredictor, rb.activePredictor);
    }
    EXPECT_TRUE(a.state().u == b.state().u);
    EXPECT_TRUE(a.state().v == b.state().v);
    EXPECT_EQ(a.state().time, b.state().time);
    EXPECT_EQ(a.record().contactForce, b.record().contactForce);
    // a state of another scheme is refused
    obs::NewmarkSchemeState other = a.schemeState();
    other.scheme = scheme == obs::NewmarkScheme::Classical ? "contact-implicit" : "classical";
    expectContains(errorOf([&] { b.setSchemeState(other); }), {"state of scheme '" + other.scheme + "'"});
    other = a.schemeState();
    other.state.v.resize(3);
    expectContains(errorOf([&] { b.setSchemeState(other); }), {"state vector v has 3 entries"});
  }
}

// --- obs run: interrupted and restarted runs equal the uninterrupted one -------------------------

TEST(CheckpointRestart, StoppedAndRestartedRunEqualsTheUninterruptedOneBitwise) {
  // the stop steps: before contact, in contact (with a .vtu step), after lift-off; the schemes:
  // predictor data, the classical multiplier carried into the next step, M~ with the acceleration
  const std::vector<std::pair<std::string, int>> cases = {
      {"improved-contact-stabilized", 100}, {"improved-contact-stabilized", 250}, {"classical", 213},
      {"khenous-laborde-renard", 190},      {"hager-huebner-wohlmuth", 420}};
  for (const auto& [scheme, k] : cases) {
    SCOPED_TRACE(scheme + " stopped after step " + std::to_string(k));
    const fs::path scene = writeScene("bar_" + scheme, barScene(450, "", scheme));
    const fs::path a = kTmp / ("full_" + scheme), b = kTmp / ("restarted_" + scheme + std::to_string(k));
    fs::remove_all(a);
    runScene(scene, quiet(a));
    const fs::path cp = stopAt(scene, b, k);
    ASSERT_TRUE(fs::exists(cp));
    EXPECT_FALSE(fs::exists(b / "summary.json"));
    const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
    EXPECT_EQ(rec.kind, "dynamic");
    EXPECT_EQ(rec.integer("scheme/step"), k);
    EXPECT_EQ(rec.text("scheme/name"), scheme);
    EXPECT_EQ(rec.text("scene/text"), slurp(scene));
    EXPECT_EQ(rec.integer("grid/leaf_vertices"), 42);
    RunOptions o = quiet(b);
    o.restart = cp;
    const RunResult r = runScene(scene, o);
    EXPECT_EQ(summaryOf(b).at("dynamics").at("steps"), 450);
    expectSameRun(a, b);
  }
}

TEST(CheckpointRestart, InexactSolvesContinueBitwise) {
  // [dynamics] inexact: the checkpoint carries v^{n-1} and the next step's tolerance
  // (docs/checkpoint.md), so the restarted run solves every step to the same tolerance
  const fs::path scene = writeScene("bar_inexact", barScene(450));
  const std::vector<std::string> inexact = {"dynamics.inexact=0.1"};
  const fs::path a = kTmp / "full_inexact", b = kTmp / "restarted_inexact";
  fs::remove_all(a);
  RunOptions full = quiet(a);
  full.overrides = inexact;
  runScene(scene, full);
  EXPECT_GT(summaryOf(a).at("dynamics").at("max_solver_tolerance").get<double>(),
            summaryOf(a).at("dynamics").at("min_solver_tolerance").get<double>());
  const fs::path cp = stopAt(scene, b, 250, inexact);
  const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
  EXPECT_EQ(rec.vector("scheme/previous_velocity").size(), 42 * 2);
  EXPECT_GT(rec.real("scheme/next_solver_tolerance"), 0);
  RunOptions o = quiet(b);
  o.restart = cp;
  o.overrides = inexact;
  runScene(scene, o);
  expectSameRun(a, b);
  // without inexact solves the entries are not written
  const fs::path c = kTmp / "stopped_exact";
  EXPECT_FALSE(obs::readCheckpoint(stopAt(scene, c, 250)).has("scheme/previous_velocity"));
}

TEST(CheckpointRestart, WarmStartFromThePreviousIncrementContinuesBitwise) {
  // [dynamics] warm_start = "previous-increment": the checkpoint carries the last step's increment
  // (scheme/previous_increment), so the restarted run starts every solve where the full run did
  const fs::path scene = writeScene("bar_warm", barScene(450));
  const std::vector<std::string> warm = {"dynamics.warm_start=\"previous-increment\""};
  const fs::path a = kTmp / "full_warm", b = kTmp / "restarted_warm";
  fs::remove_all(a);
  RunOptions full = quiet(a);
  full.overrides = warm;
  runScene(scene, full);
  EXPECT_EQ(summaryOf(a).at("dynamics").at("warm_start"), "previous-increment");
  const fs::path cp = stopAt(scene, b, 250, warm);
  const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
  EXPECT_EQ(rec.vector("scheme/previous_increment").size(), 42 * 2);
  EXPECT_GT(rec.vector("scheme/previous_increment").norm(), 0);
  RunOptions o = quiet(b);
  o.restart = cp;
  o.overrides = warm;
  runScene(scene, o);
  expectSameRun(a, b);
  // with the default start the entry is not written
  const fs::path c = kTmp / "stopped_predictor";
  EXPECT_FALSE(obs::readCheckpoint(stopAt(scene, c, 250)).has("scheme/previous_increment"));
}

TEST(CheckpointRestart, EveryNStepsAndARestartFromTheLastOne) {
  const fs::path scene = writeScene("bar_every", barScene(300, "checkpoint = { every = 40 }\n"));
  const fs::path a = kTmp / "every_full", b = kTmp / "every_stopped";
  fs::remove_all(a);
  std::vector<std::string> lines;
  RunOptions o = quiet(a);
  o.stepProgress = [&](const std::string& l) {
    if (l.starts_with("checkpoint:")) lines.push_back(l);
  };
  runScene(scene, o);
  ASSERT_EQ(lines.size(), 7u);  // steps 40, 80, ..., 280
  EXPECT_NE(lines[0].find("step 40 "), std::string::npos) << lines[0];
  EXPECT_EQ(obs::readCheckpoint(a / "checkpoint.h5").integer("scheme/step"), 280);
  // by wall time: a step takes more than a microsecond, so every step writes one
  {
    const fs::path timed = writeScene("bar_seconds", barScene(12, "checkpoint = { seconds = 1e-6 }\n"));
    int written = 0;
    RunOptions t = quiet(kTmp / "seconds");
    t.stepProgress = [&](const std::string& l) { written += l.starts_with("checkpoint:"); };
    runScene(timed, t);
    EXPECT_EQ(written, 12);
  }
  // a run killed between checkpoints: its outputs run ahead of the checkpoint and are cut back on
  // restart (here: outputs up to step 250, the checkpoint of step 240)
  const fs::path at240 = kTmp / "every_240.h5";
  fs::remove_all(b);
  fs::remove(at240);
  RunOptions s = quiet(b);
  s.stopAfterStep = 250;
  s.stepProgress = [&](const std::string& l) {
    if (l.starts_with("checkpoint: step 240 ")) fs::copy_file(b / "checkpoint.h5", at240);
  };
  EXPECT_THROW(runScene(scene, s), RunInterrupted);
  EXPECT_EQ(obs::readCheckpoint(b / "checkpoint.h5").integer("scheme/step"), 250);
  ASSERT_EQ(obs::readCheckpoint(at240).integer("scheme/step"), 240);
  RunOptions r = quiet(b);  // b holds outputs up to step 250, the checkpoint is at 240
  r.restart = at240;
  runScene(scene, r);
  expectSameRun(a, b);
}

TEST(CheckpointRestart, SigtermFinishesTheStepWritesACheckpointAndExitsWith3) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  const fs::path scene = writeScene("bar_signal", barScene(3000));
  const fs::path a = kTmp / "signal_full", b = kTmp / "signal_stopped";
  fs::remove_all(a);
  fs::remove_all(b);
  fs::create_directories(b);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string err = (b / "run.err").string();
    (void)!freopen(err.c_str(), "w", stderr);
    (void)!freopen("/dev/null", "w", stdout);
    unsetenv("OBS_THREADS");  // one thread, as the in-process runs compared with
    execl(OBS_BINARY, "obs", "run", scene.c_str(), "--output", b.c_str(), nullptr);
    _exit(127);
  }
  // signal once the time stepping has begun (the time series has rows)
  for (int i = 0; i < 20000; ++i) {
    std::ifstream in(b / "timeseries.csv");
    std::string line;
    int rows = 0;
    while (rows < 5 && std::getline(in, line)) ++rows;
    if (rows >= 5) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 3) << slurp(b / "run.err");
  const std::string err = slurp(b / "run.err");
  expectContains(err.substr(err.find("obs: error:")), {"interrupted by SIGTERM after step", "checkpoint written to",
                                                       "--restart"});
  const long long k = obs::readCheckpoint(b / "checkpoint.h5").integer("scheme/step");
  EXPECT_GT(k, 0);
  EXPECT_LT(k, 3000);
  const auto restarted = obs::test::runObs(
      kTmp, "run '" + scene.string() + "' --output '" + b.string() + "' --restart '" + (b / "checkpoint.h5").string() + "' -q",
      "signal_restart");
  ASSERT_EQ(restarted.code, 0) << restarted.err;
  runScene(scene, quiet(a));
  expectSameRun(a, b);
}

TEST(CheckpointRestart, KillDuringCheckpointWritingNeverLeavesACorruptLatestFile) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  // a checkpoint after every step; SIGKILL 0, 2, 4, ... ms after the first checkpoint appeared lands
  // during writes, between them and during renames
  const fs::path scene = writeScene("bar_kill", barScene(80, "checkpoint = { every = 1 }\nvtk = false\n"));
  int checked = 0, withTemporary = 0;
  for (int delayMs = 0; delayMs <= 14; delayMs += 2) {
    SCOPED_TRACE(delayMs);
    const fs::path dir = kTmp / "kill";
    fs::remove_all(dir);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      (void)!freopen("/dev/null", "w", stderr);
      (void)!freopen("/dev/null", "w", stdout);
      unsetenv("OBS_THREADS");  // one thread, as the in-process runs compared with
      execl(OBS_BINARY, "obs", "run", scene.c_str(), "--output", dir.c_str(), nullptr);
      _exit(127);
    }
    for (int i = 0; i < 20000 && !fs::exists(dir / "checkpoint.h5"); ++i)
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(fs::exists(dir / "checkpoint.h5"));
    withTemporary += fs::exists(dir / "checkpoint.h5.tmp");
    const obs::CheckpointRecord r = obs::readCheckpoint(dir / "checkpoint.h5");  // throws if damaged
    EXPECT_GE(r.integer("scheme/step"), 1);
    ++checked;
    if (delayMs == 6) {  // a restart after SIGKILL completes the run
      RunOptions o = quiet(dir);
      o.restart = dir / "checkpoint.h5";
      runScene(scene, o);
      EXPECT_EQ(summaryOf(dir).at("dynamics").at("steps"), 80);
    }
  }
  std::cout << "[ info ] " << checked << " runs killed, " << withTemporary
            << " of them while checkpoint.h5.tmp existed; every checkpoint.h5 was readable\n";
}

// --- errors --------------------------------------------------------------------------------------

TEST(CheckpointRestart, RestartWithAnotherSceneGridOrOutputIsAnErrorNamingTheDifference) {
  const fs::path scene = writeScene("bar_err", barScene(200));
  const fs::path dir = kTmp / "err";
  const fs::path cp = stopAt(scene, dir, 50);
  auto restart = [&](const fs::path& s, RunOptions o) {
    o.restart = cp;
    return errorOf([&] { runScene(s, o); });
  };
  // the scene text differs: the first differing line, both versions
  std::string text = barScene(200);
  text.replace(text.find("tau = 3e-3"), 10, "tau = 2e-3");
  const fs::path other = writeScene("bar_err_other", text);
  expectContains(restart(other, quiet(dir)), {cp.string() + ": ", "another scene", "line 23",
                                              "'tau = 2e-3' in " + other.string(), "'tau = 3e-3' in the checkpoint"});
  // the same text, other --set overrides
  RunOptions o = quiet(dir);
  o.overrides = {"dynamics.output_stride=10"};
  expectContains(restart(scene, o), {"another scene", "--set overrides differ", "dynamics.output_stride=10"});
  // another thread count (the sweep order depends on it)
  obs::setThreads(2);
  const std::string threadsError = restart(scene, quiet(dir));
  obs::setThreads(1);
  expectContains(threadsError, {cp.string() + ": ", "1 thread(s), this run has 2", "--threads 1"});
  // another grid
  o = quiet(dir);
  o.refine = 1;
  expectContains(restart(scene, o), {cp.string() + ": ", "grid of 42 vertices / 20 cells", "another --refine"});
  // a dynamic checkpoint without rows (as obs wrote before rows, docs/checkpoint.md#rows): the
  // same entries with the vectors as plain entries and no rows/keys
  {
    const fs::path old = kTmp / "err_no_rows.h5";
    const obs::CheckpointRecord withRows = obs::readCheckpoint(cp);
    obs::CheckpointRecord plain;
    plain.kind = withRows.kind;
    for (const auto& [name, e] : withRows.entries())
      if (name != "rows/keys") plain.set(name, e.value, e.description);
    obs::writeCheckpoint(old, plain);
    RunOptions r = quiet(dir);
    r.restart = old;
    expectContains(errorOf([&] { runScene(scene, r); }),
                   {old.string() + ": ", "no rows/keys", "before checkpoints with rows", "start the run again"});
  }
  // the outputs of the interrupted run are not in the output directory
  expectContains(restart(scene, quiet(kTmp / "err_elsewhere")),
                 {cp.string() + ": ", "is missing", "output directory of the interrupted run"});
  fs::remove_all(kTmp / "err_copy");
  fs::create_directories(kTmp / "err_copy");
  for (const auto& e : fs::directory_iterator(dir)) fs::copy_file(e.path(), kTmp / "err_copy" / e.path().filename());
  {
    std::string ts = slurp(kTmp / "err_copy" / "timeseries.csv");
    ts[ts.size() / 2] = ts[ts.size() / 2] == '1' ? '2' : '1';
    std::ofstream(kTmp / "err_copy" / "timeseries.csv", std::ios::binary) << ts;
  }
  expectContains(restart(scene, quiet(kTmp / "err_copy")), {"timeseries.csv does not begin with the", "step 50"});
  // a time series of another version (other columns; its checkpoint consistent with it): the
  // appended rows would not match the header, so the restart is refused
  {
    fs::remove_all(kTmp / "err_columns");
    fs::create_directories(kTmp / "err_columns");
    for (const auto& e : fs::directory_iterator(dir))
      fs::copy_file(e.path(), kTmp / "err_columns" / e.path().filename());
    obs::CheckpointRecord old = obs::readCheckpoint(cp);
    std::string ts = slurp(dir / "timeseries.csv").substr(0, static_cast<std::size_t>(old.integer("run/timeseries_bytes")));
    const std::string added = "momentum_redistributed_x,momentum_redistributed_y,momentum_redistributed_z,";
    ASSERT_NE(ts.find(added), std::string::npos);
    ts.erase(ts.find(added), added.size());
    std::ofstream(kTmp / "err_columns" / "timeseries.csv", std::ios::binary) << ts;
    old.set("run/timeseries_bytes", static_cast<long long>(ts.size()), "bytes");
    old.set("run/timeseries_hash", obs::hexHash(obs::fnv1a(ts.data(), ts.size())), "hash");
    const fs::path oldCp = kTmp / "err_columns" / "old_checkpoint.h5";
    obs::writeCheckpoint(oldCp, old);
    RunOptions h = quiet(kTmp / "err_columns");
    h.restart = oldCp;
    expectContains(errorOf([&] { runScene(scene, h); }),
                   {oldCp.string() + ": ", "timeseries.csv has other columns", "without --restart"});
  }
  // a checkpoint of a static scene cannot exist; a static scene with --restart is refused
  const fs::path plain = writeScene("plain", "[mesh]\ngenerator = \"box\"\ntype = \"quadrilateral\"\ncells = [2, 2]\n[material]\nE = 1\nnu = 0.3\n"
                                             "[[dirichlet]]\nboundary = \"left\"\n");
  expectContains(restart(plain, quiet(kTmp / "plain")), {"--restart applies to [dynamics] and [adaptivity] scenes only"});
  // --stop-after-step beyond the run
  o = quiet(kTmp / "err_stop");
  o.stopAfterStep = 200;
  expectContains(errorOf([&] { runScene(scene, o); }), {"--stop-after-step 200 must lie in [1, 199]"});
  // a damaged checkpoint through obs run: one line naming the file
  {
    std::string bytes = slurp(cp);
    bytes.resize(bytes.size() / 2);
    std::ofstream(kTmp / "half.h5", std::ios::binary) << bytes;
    RunOptions h = quiet(dir);
    h.restart = kTmp / "half.h5";
    expectContains(errorOf([&] { runScene(scene, h); }), {(kTmp / "half.h5").string() + ": "});
  }
  // and through the program: exit code 1, one line
  if (fs::exists(OBS_BINARY)) {
    const auto out = obs::test::runObs(kTmp, "run '" + other.string() + "' -o '" + dir.string() + "' --restart '" +
                                                 cp.string() + "'", "restart_other");
    EXPECT_EQ(out.code, 1);
    // the error is the last line of stderr, one line (warnings, e.g. of the single-level grid, come before it)
    const std::size_t at = out.err.find("obs: error: ");
    ASSERT_NE(at, std::string::npos) << out.err;
    EXPECT_EQ(std::count(out.err.begin() + static_cast<std::ptrdiff_t>(at), out.err.end(), '\n'), 1) << out.err;
    expectContains(out.err.substr(at), {"obs: error: ", "another scene"});
  }
}

// --- several bodies ([[body]] + [[contact]], dual mortar) ----------------------------------------

namespace {

/// data/scenes/twobody_impact.toml (impact after step 10, separation near step 50), shortened.
const fs::path kTwoBody = fs::path(OBS_DATA_DIR) / "scenes" / "twobody_impact.toml";

std::vector<std::string> twoBodyOverrides(const std::string& scheme, std::vector<std::string> more = {}) {
  std::vector<std::string> o = {"dynamics.steps=60", "dynamics.output_stride=10", "dynamics.scheme=\"" + scheme + "\""};
  o.insert(o.end(), more.begin(), more.end());
  return o;
}

}  // namespace

TEST(CheckpointMultiBody, StoppedAndRestartedTwoBodyRunEqualsTheUninterruptedOneBitwise) {
  // mortar schemes without (contact-implicit, improved-contact-stabilized with inexact solves) and
  // with redistributed masses (khenous-laborde-renard: a^n; hager-huebner-wohlmuth), stopped in
  // contact (after the impact at step 10) or at an output step
  struct Case {
    std::string scheme;
    int k;
    std::vector<std::string> more;
  };
  const std::vector<Case> cases = {{"contact-implicit", 17, {}},
                                   {"khenous-laborde-renard", 20, {}},
                                   {"hager-huebner-wohlmuth", 13, {}},
                                   {"improved-contact-stabilized", 23, {"dynamics.inexact=0.1"}}};
  for (const Case& t : cases) {
    SCOPED_TRACE(t.scheme + " stopped after step " + std::to_string(t.k));
    const std::vector<std::string> overrides = twoBodyOverrides(t.scheme, t.more);
    const fs::path a = kTmp / ("twobody_full_" + t.scheme), b = kTmp / ("twobody_restarted_" + t.scheme);
    fs::remove_all(a);
    RunOptions full = quiet(a);
    full.overrides = overrides;
    runScene(kTwoBody, full);
    const fs::path cp = stopAt(kTwoBody, b, t.k, overrides);
    ASSERT_TRUE(fs::exists(cp));
    EXPECT_FALSE(fs::exists(b / "summary.json"));
    // the layout: stacked vectors, per-body groups with the offsets into them
    const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
    EXPECT_EQ(rec.integer("scheme/step"), t.k);
    EXPECT_EQ(rec.text("scheme/name"), t.scheme);
    ASSERT_EQ(rec.integer("bodies/count"), 2);
    EXPECT_EQ(rec.text("bodies/0/name"), "lower");
    EXPECT_EQ(rec.text("bodies/1/name"), "upper");
    EXPECT_EQ(rec.integer("bodies/0/vertex_offset"), 0);
    EXPECT_EQ(rec.integer("bodies/0/leaf_vertices"), 11 * 11);  // 5 x 5 quadrilaterals, refined once
    EXPECT_EQ(rec.integer("bodies/1/vertex_offset"), 11 * 11);
    EXPECT_EQ(rec.integer("bodies/1/leaf_vertices"), 15 * 9);   // 7 x 4 triangles, refined once
    EXPECT_EQ(rec.integer("grid/leaf_vertices"), 11 * 11 + 15 * 9);
    EXPECT_EQ(rec.vector("scheme/displacement").size(), 2 * rec.integer("grid/leaf_vertices"));
    EXPECT_EQ(rec.vector("scheme/acceleration").size(),
              t.scheme == "khenous-laborde-renard" ? 2 * rec.integer("grid/leaf_vertices") : 0);
    EXPECT_GT(rec.vector("scheme/multiplier").norm(), 0);  // in contact
    EXPECT_EQ(rec.has("scheme/previous_velocity"), !t.more.empty());
    // .vtu of both bodies up to the stop step are in the file list
    EXPECT_NE(rec.text("run/vtu_files").find("twobody_impact_upper_000010.vtu"), std::string::npos);
    RunOptions o = quiet(b);
    o.restart = cp;
    o.overrides = overrides;
    runScene(kTwoBody, o);
    EXPECT_EQ(summaryOf(b).at("dynamics").at("steps"), 60);
    EXPECT_EQ(summaryOf(b).at("bodies").size(), 2u);
    expectSameRun(a, b);
    EXPECT_TRUE(fs::exists(b / "twobody_impact_lower_000060.vtu"));
    EXPECT_EQ(slurp(a / "twobody_impact.pvd"), slurp(b / "twobody_impact.pvd"));
  }
}

TEST(CheckpointMultiBody, EveryNStepsWritesMultiBodyCheckpoints) {
  const fs::path scene = writeScene("twobody_every", slurp(kTwoBody) + "\n[output]\ncheckpoint = { every = 25 }\n");
  int written = 0;
  RunOptions o = quiet(kTmp / "twobody_every");
  o.overrides = twoBodyOverrides("contact-implicit");
  o.stepProgress = [&](const std::string& l) { written += l.starts_with("checkpoint:"); };
  runScene(scene, o);
  EXPECT_EQ(written, 2);  // steps 25 and 50
  const obs::CheckpointRecord rec = obs::readCheckpoint(kTmp / "twobody_every" / "checkpoint.h5");
  EXPECT_EQ(rec.integer("scheme/step"), 50);
  EXPECT_EQ(rec.integer("bodies/count"), 2);
}

TEST(CheckpointMultiBody, OneBodyAgainstSeveralOrOtherBodiesAreOneLineErrors) {
  const std::vector<std::string> overrides = twoBodyOverrides("contact-implicit");
  const fs::path dir = kTmp / "twobody_err";
  const fs::path cp = stopAt(kTwoBody, dir, 15, overrides);
  ASSERT_TRUE(fs::exists(cp));
  auto restart = [&](const fs::path& scene, const fs::path& file, RunOptions o) {
    o.restart = file;
    return errorOf([&] { runScene(scene, o); });
  };
  // a multi-body checkpoint, a one-body scene
  const fs::path bar = writeScene("bar_vs_twobody", barScene(200));
  expectContains(restart(bar, cp, quiet(dir)),
                 {cp.string() + ": ", "a checkpoint of a multi-body run with 2 bodies ('lower', 'upper')",
                  bar.string() + " is a one-body scene"});
  // a one-body checkpoint, a multi-body scene
  const fs::path one = stopAt(bar, kTmp / "bar_for_twobody", 50);
  RunOptions o = quiet(kTmp / "bar_for_twobody");
  o.overrides = overrides;
  expectContains(restart(kTwoBody, one, o),
                 {one.string() + ": ", "a checkpoint of a one-body run",
                  kTwoBody.string() + " is a multi-body scene with 2 bodies ('lower', 'upper')"});
  // a body renamed
  std::string text = slurp(kTwoBody);
  for (std::size_t at; (at = text.find("\"upper\"")) != std::string::npos;) text.replace(at, 7, "\"top\"");
  const fs::path renamed = writeScene("twobody_renamed", text);
  o = quiet(dir);
  o.overrides = overrides;
  expectContains(restart(renamed, cp, o), {cp.string() + ": ", "body 2 is 'upper' in the checkpoint, 'top' in " +
                                                                   renamed.string()});
  // a third body
  const fs::path three = writeScene(
      "twobody_three", slurp(kTwoBody) +
                           "\n[[body]]\nname = \"third\"\n[body.mesh]\ngenerator = \"box\"\ntype = \"quadrilateral\"\n"
                           "cells = [2, 2]\nlower = [3, 0]\nupper = [4, 1]\nrefine = 1\n[body.material]\nE = 1e3\nnu = 0.3\n"
                           "density = 1\n");
  expectContains(restart(three, cp, o), {cp.string() + ": ", "a checkpoint of 2 bodies ('lower', 'upper')",
                                         "has 3 bodies ('lower', 'upper', 'third')"});
  // the same scene, a body's grid differs (another --refine): names the body
  o = quiet(dir);
  o.overrides = overrides;
  o.refine = 2;
  expectContains(restart(kTwoBody, cp, o), {cp.string() + ": ", "body 'lower' written for a grid of 121 vertices",
                                            "another --refine"});
  // a static multi-body scene writes none: [output] checkpoint is refused as for one body
  expectContains(errorOf([&] {
                   parseSceneString(slurp(fs::path(OBS_DATA_DIR) / "scenes" / "twobody_patch.toml") +
                                        "\n[output]\ncheckpoint = { every = 5 }\n",
                                    "static2.toml", fs::path(OBS_DATA_DIR) / "scenes");
                 }),
                 {"static2.toml:", "[output] checkpoint applies to [dynamics] and [adaptivity] scenes only"});
  // the same bodies, another scene text or other overrides: as for one body
  o = quiet(dir);
  o.overrides = twoBodyOverrides("contact-implicit", {"dynamics.output_stride=5"});
  expectContains(restart(kTwoBody, cp, o), {cp.string() + ": ", "another scene", "--set overrides differ",
                                            "'--set dynamics.output_stride=5' now, none in the checkpoint (override 4)"});
}

TEST(CheckpointScene, BadCheckpointKeysAreErrorsWithFileAndLine) {
  auto error = [](const std::string& output, const std::string& extra = "") {
    return errorOf([&] { parseSceneString(barScene(10, output) + extra, "bad.toml", kTmp); });
  };
  expectContains(error("checkpoint = { every = 0 }\n"), {"bad.toml:20: [output] checkpoint every = 0", ">= 1"});
  expectContains(error("checkpoint = { seconds = -1 }\n"), {"bad.toml:20: [output] checkpoint seconds = -1", "positive"});
  expectContains(error("checkpoint = { every = 1.5 }\n"), {"bad.toml:20: [output] checkpoint every must be an integer"});
  expectContains(error("checkpoint = { steps = 10 }\n"), {"bad.toml:20:", "steps"});
  expectContains(error("checkpoint = {}\n"), {"bad.toml:20: [output] checkpoint needs every = N"});
  expectContains(error("checkpoint = 10\n"), {"bad.toml:20: [output] checkpoint must be a table", "got an integer"});
  expectContains(error("checkpoint = { every = 5 }\n", "compare = [\"classical\"]\n"), {});  // parses; refused at run
  expectContains(errorOf([&] {
                   parseSceneString("[mesh]\ngenerator = \"box\"\ntype = \"quadrilateral\"\ncells = [2, 2]\n[material]\nE = 1\nnu = 0.3\n[output]\n"
                                    "checkpoint = { every = 5 }\n",
                                    "static.toml", kTmp);
                 }),
                 {"static.toml:9: [output] checkpoint applies to [dynamics] and [adaptivity] scenes only"});
  const fs::path scene =
      writeScene("bar_compare", barScene(10, "checkpoint = { every = 5 }\n") + "compare = [\"classical\"]\n");
  expectContains(errorOf([&] { runScene(scene, quiet(kTmp / "compare")); }),
                 {"bar_compare.toml:20: [output] checkpoint: scheme comparisons"});
  // valid: both keys
  const Scene s = parseSceneString(barScene(10, "checkpoint = { every = 5, seconds = 600 }\n"), "ok.toml", kTmp);
  ASSERT_TRUE(s.output.checkpoint);
  EXPECT_EQ(*s.output.checkpoint->every, 5);
  EXPECT_EQ(*s.output.checkpoint->seconds, 600);
}

// --- several bodies: signals and SIGKILL during writing ---------------------------------------------

namespace {

/// Runs `obs run <scene> --output <dir> <args>` in a child process (stderr to dir/run.err, stdout
/// discarded); returns its pid.
pid_t startObs(const fs::path& scene, const fs::path& dir, const std::vector<std::string>& args) {
  fs::create_directories(dir);
  std::vector<std::string> argv = {"obs", "run", scene.string(), "--output", dir.string()};
  argv.insert(argv.end(), args.begin(), args.end());
  const std::string err = (dir / "run.err").string();
  const pid_t pid = fork();
  if (pid == 0) {
    (void)!freopen(err.c_str(), "w", stderr);
    (void)!freopen("/dev/null", "w", stdout);
    std::vector<char*> c;
    for (std::string& a : argv) c.push_back(a.data());
    c.push_back(nullptr);
    unsetenv("OBS_THREADS");  // one thread, as the in-process runs compared with
    execv(OBS_BINARY, c.data());
    _exit(127);
  }
  return pid;
}

/// `--set` arguments of a list of overrides.
std::vector<std::string> setArgs(const std::vector<std::string>& overrides) {
  std::vector<std::string> a;
  for (const std::string& o : overrides) a.insert(a.end(), {"--set", o});
  return a;
}

/// Waits until `file` exists (at most ~20 s).
void waitFor(const fs::path& file) {
  for (int i = 0; i < 40000 && !fs::exists(file); ++i) std::this_thread::sleep_for(std::chrono::microseconds(500));
}

/// The exit code of a child (-1 if it did not exit normally).
int exitCodeOf(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST(CheckpointMultiBody, SigintAndSigtermFinishTheStepWriteACheckpointAndExitWith3) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  // the two-body impact, long enough that the signal arrives during the time stepping; one
  // uninterrupted run to compare both restarted runs with
  const std::vector<std::string> overrides = twoBodyOverrides("contact-implicit", {"dynamics.steps=400",
                                                                                    "dynamics.output_stride=100"});
  const fs::path a = kTmp / "twobody_signal_full";
  fs::remove_all(a);
  RunOptions full = quiet(a);
  full.overrides = overrides;
  runScene(kTwoBody, full);
  for (const int signal : {SIGINT, SIGTERM}) {
    const std::string name = signal == SIGINT ? "SIGINT" : "SIGTERM";
    SCOPED_TRACE(name);
    const fs::path b = kTmp / ("twobody_signal_" + name);
    fs::remove_all(b);
    const pid_t pid = startObs(kTwoBody, b, setArgs(overrides));
    ASSERT_GT(pid, 0);
    // signal once the time stepping has begun (the time series has rows)
    for (int i = 0; i < 20000; ++i) {
      std::ifstream in(b / "timeseries.csv");
      std::string line;
      int rows = 0;
      while (rows < 5 && std::getline(in, line)) ++rows;
      if (rows >= 5) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    kill(pid, signal);
    ASSERT_EQ(exitCodeOf(pid), 3) << slurp(b / "run.err");
    const std::string err = slurp(b / "run.err");
    ASSERT_NE(err.find("obs: error:"), std::string::npos) << err;
    expectContains(err.substr(err.find("obs: error:")),
                   {"interrupted by " + name + " after step", "checkpoint written to", "--restart"});
    const obs::CheckpointRecord rec = obs::readCheckpoint(b / "checkpoint.h5");
    EXPECT_EQ(rec.integer("bodies/count"), 2);
    const long long k = rec.integer("scheme/step");
    EXPECT_GT(k, 0);
    EXPECT_LT(k, 400);
    std::vector<std::string> args = setArgs(overrides);
    std::string restartArgs = "run '" + kTwoBody.string() + "' --output '" + b.string() + "' --restart '" +
                              (b / "checkpoint.h5").string() + "' -q";
    for (const std::string& o : overrides) restartArgs += " --set '" + o + "'";
    const auto restarted = obs::test::runObs(kTmp, restartArgs, "twobody_signal_restart_" + name);
    ASSERT_EQ(restarted.code, 0) << restarted.err;
    expectSameRun(a, b);
    EXPECT_EQ(slurp(a / "twobody_impact.pvd"), slurp(b / "twobody_impact.pvd"));
  }
}

TEST(CheckpointMultiBody, KillDuringCheckpointWritingNeverLeavesACorruptLatestFile) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  // a checkpoint after every step of the two-body impact; SIGKILL 0, 3, 6, ... ms after the first
  // checkpoint appeared lands during writes, between them and during renames
  const fs::path scene = writeScene("twobody_kill", slurp(kTwoBody) + "\n[output]\ncheckpoint = { every = 1 }\nvtk = false\n");
  const std::vector<std::string> overrides = twoBodyOverrides("contact-implicit");
  int checked = 0, withTemporary = 0;
  for (int delayMs = 0; delayMs <= 21; delayMs += 3) {
    SCOPED_TRACE(delayMs);
    const fs::path dir = kTmp / "twobody_kill";
    fs::remove_all(dir);
    const pid_t pid = startObs(scene, dir, setArgs(overrides));
    ASSERT_GT(pid, 0);
    waitFor(dir / "checkpoint.h5");
    std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
    kill(pid, SIGKILL);
    exitCodeOf(pid);
    ASSERT_TRUE(fs::exists(dir / "checkpoint.h5"));
    withTemporary += fs::exists(dir / "checkpoint.h5.tmp");
    const obs::CheckpointRecord r = obs::readCheckpoint(dir / "checkpoint.h5");  // throws if damaged
    EXPECT_GE(r.integer("scheme/step"), 1);
    EXPECT_EQ(r.integer("bodies/count"), 2);
    ++checked;
    if (delayMs == 9) {  // a restart after SIGKILL completes the run
      RunOptions o = quiet(dir);
      o.restart = dir / "checkpoint.h5";
      o.overrides = overrides;
      runScene(scene, o);
      EXPECT_EQ(summaryOf(dir).at("dynamics").at("steps"), 60);
    }
  }
  std::cout << "[ info ] " << checked << " two-body runs killed, " << withTemporary
            << " of them while checkpoint.h5.tmp existed; every checkpoint.h5 was readable\n";
}

// --- adaptive runs ([adaptivity], one body and several) ------------------------------------------

namespace {

/// The flat punch (example 1A, 256 quadrilaterals to start) and the two cylinders (two bodies,
/// dual mortar), shortened, with a .vtu of every step.
const fs::path kPunch = fs::path(OBS_DATA_DIR) / "scenes" / "example1a.toml";
const fs::path kCylinders = fs::path(OBS_DATA_DIR) / "scenes" / "twobody_cylinders_adaptive.toml";

std::vector<std::string> adaptiveOverrides(int steps, std::vector<std::string> more = {}) {
  std::vector<std::string> o = {"adaptivity.steps=" + std::to_string(steps), "adaptivity.vtk=\"every\""};
  o.insert(o.end(), more.begin(), more.end());
  return o;
}

/// steps.csv without its four wall-time columns.
std::string stepsWithoutTimings(const fs::path& csv) {
  std::istringstream in(slurp(csv));
  std::string out;
  std::vector<bool> timing;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
    if (timing.empty())
      for (const std::string& h : f)
        timing.push_back(h == "solver_s" || h == "estimator_s" || h == "refinement_s" || h == "transfer_s");
    for (std::size_t k = 0; k < f.size(); ++k)
      if (k >= timing.size() || !timing[k]) out += f[k] + ",";
    out += "\n";
  }
  return out;
}

/// Every .vtu/.pvd of `a` exists in `b` with the same bytes (at least `files` of them); the same
/// steps.csv (timings aside), pressure.csv and summary.json (timings and paths aside).
void expectSameAdaptiveRun(const fs::path& a, const fs::path& b, int files) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(a)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".vtu" && ext != ".pvd") continue;
    ++n;
    const fs::path other = b / e.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_TRUE(slurp(e.path()) == slurp(other)) << e.path().filename() << " differs";
  }
  EXPECT_GE(n, files);
  const std::string steps = stepsWithoutTimings(a / "steps.csv");
  EXPECT_GT(steps.size(), 100u);
  EXPECT_EQ(steps, stepsWithoutTimings(b / "steps.csv"));
  EXPECT_EQ(fs::exists(a / "pressure.csv"), fs::exists(b / "pressure.csv"));
  if (fs::exists(a / "pressure.csv")) {
    EXPECT_TRUE(slurp(a / "pressure.csv") == slurp(b / "pressure.csv"));
  }
  EXPECT_EQ(comparable(summaryOf(a)).dump(1), comparable(summaryOf(b)).dump(1));
}

/// The uninterrupted run of `scene` with `overrides` into dir.
void fullRun(const fs::path& scene, const fs::path& dir, const std::vector<std::string>& overrides) {
  fs::remove_all(dir);
  RunOptions o = quiet(dir);
  o.overrides = overrides;
  runScene(scene, o);
}

/// Restarts `scene` from `checkpoint` into dir.
void restartRun(const fs::path& scene, const fs::path& dir, const fs::path& checkpoint,
                const std::vector<std::string>& overrides) {
  RunOptions o = quiet(dir);
  o.overrides = overrides;
  o.restart = checkpoint;
  runScene(scene, o);
}

}  // namespace

TEST(CheckpointAdaptive, StoppedAndRestartedOneBodyRunEqualsTheUninterruptedOneBitwise) {
  // the punch, 4 solves; stopped after step 0 (one refinement), 1 and 2 (the last refinement)
  const std::vector<std::string> overrides = adaptiveOverrides(4);
  const fs::path a = kTmp / "punch_full";
  fullRun(kPunch, a, overrides);
  const nlohmann::json full = summaryOf(a).at("adaptivity").at("steps");
  ASSERT_EQ(full.size(), 4u);
  for (int k : {0, 1, 2}) {
    SCOPED_TRACE("stopped after step " + std::to_string(k));
    const fs::path b = kTmp / ("punch_restarted_" + std::to_string(k));
    const fs::path cp = stopAt(kPunch, b, k, overrides);
    ASSERT_TRUE(fs::exists(cp));
    EXPECT_FALSE(fs::exists(b / "summary.json"));
    EXPECT_FALSE(fs::exists(b / "steps.csv"));
    // the layout (docs/checkpoint.md#adaptive-runs)
    const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
    EXPECT_EQ(rec.kind, "adaptive");
    EXPECT_EQ(rec.text("scene/text"), slurp(kPunch));
    EXPECT_FALSE(rec.has("bodies/count"));
    EXPECT_EQ(rec.integer("adaptivity/next_step"), k + 1);
    EXPECT_EQ(rec.integer("adaptivity/body_count"), 1);
    EXPECT_EQ(rec.integer("initial_grid/leaf_vertices"), 17 * 17);
    // the grid is the one step k + 1 of the full run computed on
    EXPECT_EQ(rec.integer("grid/leaf_vertices"), full[k + 1].at("vertices").get<long long>());
    EXPECT_EQ(rec.integer("grid/leaf_cells"), full[k + 1].at("cells").get<long long>());
    const std::vector<long long>& counts = rec.integers("adaptivity/refinement/marked_counts");
    ASSERT_EQ(counts.size(), static_cast<std::size_t>(k + 1));
    long long marked = 0;
    for (int j = 0; j <= k; ++j) {
      EXPECT_EQ(counts[j], full[j].at("marked").get<long long>());
      EXPECT_EQ(rec.vector("adaptivity/steps/eta")[j], full[j].at("eta").get<double>());
      marked += counts[j];
    }
    EXPECT_EQ(rec.integers("adaptivity/refinement/marked_cells").size(), static_cast<std::size_t>(marked));
    EXPECT_EQ(rec.vector("adaptivity/start").size(), 2 * rec.integer("grid/leaf_vertices"));
    EXPECT_EQ(rec.integers("adaptivity/steps/has_reference").size(), static_cast<std::size_t>(k + 1));
    EXPECT_EQ(rec.text("run/vtu_files"), [&] {
      std::string s;
      for (int j = 0; j <= k; ++j) s += "step_00" + std::to_string(j) + ".vtu\n";
      return s;
    }());
    EXPECT_EQ(rec.vector("run/nodal_pressure_errors").size(), k + 1);
    restartRun(kPunch, b, cp, overrides);
    expectSameAdaptiveRun(a, b, 5);
  }
}

TEST(CheckpointAdaptive, InexactSolvesContinueBitwise) {
  // [adaptivity] inexact: step 2's TNNMG tolerance comes from step 1's eta, eoc, convergence rate
  // and energy norm, which the checkpoint after step 1 carries (the fraction is small enough that
  // the tolerance lies strictly between its bounds 1e-10 and 1e-2, so every input changes it)
  const std::vector<std::string> overrides = adaptiveOverrides(4, {"adaptivity.inexact=1e-7"});
  const fs::path a = kTmp / "punch_inexact_full", b = kTmp / "punch_inexact_restarted";
  fullRun(kPunch, a, overrides);
  const nlohmann::json steps = summaryOf(a).at("adaptivity").at("steps");
  EXPECT_GT(steps[2].at("solver_tolerance").get<double>(), 1e-10);  // an inexact step after the restart
  EXPECT_LT(steps[2].at("solver_tolerance").get<double>(), 1e-2);
  const fs::path cp = stopAt(kPunch, b, 1, overrides);
  const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
  EXPECT_GT(rec.real("adaptivity/inexact/last_rate"), 0);
  EXPECT_GT(rec.real("adaptivity/inexact/last_energy_norm"), 0);
  restartRun(kPunch, b, cp, overrides);
  expectSameAdaptiveRun(a, b, 5);
}

TEST(CheckpointAdaptive, UniformRefinementRestartsBitwise) {
  // refinement = "uniform": no marks are stored, the restart refines every cell as often again
  const std::vector<std::string> overrides = adaptiveOverrides(4, {"adaptivity.refinement=\"uniform\""});
  const fs::path a = kTmp / "punch_uniform_full", b = kTmp / "punch_uniform_restarted";
  fullRun(kPunch, a, overrides);
  const fs::path cp = stopAt(kPunch, b, 1, overrides);
  const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
  EXPECT_EQ(rec.integers("adaptivity/refinement/marked_counts"), (std::vector<long long>{0, 0}));
  EXPECT_EQ(rec.integer("grid/leaf_cells"), 256 * 16);  // refined twice
  restartRun(kPunch, b, cp, overrides);
  expectSameAdaptiveRun(a, b, 5);
}

TEST(CheckpointAdaptive, TheClosureRuleIsReplayed) {
  // closure = "all-edges" changes the grids (docs/estimators.md#closure-overhead); the replay of the
  // marks must use it too, else the refined grid's checksum differs from the stored one
  const std::vector<std::string> overrides = adaptiveOverrides(4, {"adaptivity.closure=\"all-edges\""});
  const fs::path a = kTmp / "punch_all_edges_full", b = kTmp / "punch_all_edges_restarted";
  fullRun(kPunch, a, overrides);
  const fs::path cp = stopAt(kPunch, b, 2, overrides);
  restartRun(kPunch, b, cp, overrides);
  expectSameAdaptiveRun(a, b, 4);
}

TEST(CheckpointAdaptive, StoppedAndRestartedTwoBodyRunEqualsTheUninterruptedOneBitwise) {
  // two bodies refined together (dual mortar between them); stopped after step 0 and 1
  const std::vector<std::string> overrides = adaptiveOverrides(3);
  const fs::path a = kTmp / "cylinders_full";
  fullRun(kCylinders, a, overrides);
  const nlohmann::json full = summaryOf(a).at("adaptivity").at("steps");
  ASSERT_EQ(full.size(), 3u);
  for (int k : {0, 1}) {
    SCOPED_TRACE("stopped after step " + std::to_string(k));
    const fs::path b = kTmp / ("cylinders_restarted_" + std::to_string(k));
    const fs::path cp = stopAt(kCylinders, b, k, overrides);
    ASSERT_TRUE(fs::exists(cp));
    EXPECT_FALSE(fs::exists(b / "summary.json"));
    const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
    EXPECT_EQ(rec.kind, "adaptive");
    ASSERT_EQ(rec.integer("bodies/count"), 2);
    EXPECT_EQ(rec.text("bodies/0/name"), "block");
    EXPECT_EQ(rec.text("bodies/1/name"), "cylinder");
    EXPECT_EQ(rec.integer("adaptivity/body_count"), 2);
    EXPECT_EQ(rec.integer("grid/leaf_vertices"), full[k + 1].at("vertices").get<long long>());
    for (int body : {0, 1})
      EXPECT_EQ(rec.integer("bodies/" + std::to_string(body) + "/leaf_vertices"),
                full[k + 1].at("bodies")[body].at("vertices").get<long long>());
    const std::vector<long long>& counts = rec.integers("adaptivity/refinement/marked_counts");
    ASSERT_EQ(counts.size(), static_cast<std::size_t>(2 * (k + 1)));
    for (int j = 0; j <= k; ++j)
      for (int body : {0, 1}) EXPECT_EQ(counts[2 * j + body], full[j].at("bodies")[body].at("marked").get<long long>());
    EXPECT_EQ(rec.integers("adaptivity/steps/bodies/cells").size(), static_cast<std::size_t>(2 * (k + 1)));
    EXPECT_EQ(rec.integers("adaptivity/steps/coupling_counts")[0], 1);
    EXPECT_EQ(rec.text("adaptivity/steps/couplings/label").find('\n') != std::string::npos, k > 0);
    restartRun(kCylinders, b, cp, overrides);
    expectSameAdaptiveRun(a, b, 7);
  }
}

TEST(CheckpointAdaptive, TheLoopStateRoundTripsThroughTheRecordBitwise) {
  // loadAdaptiveState(storeAdaptiveState(s)) stores the same entries again, byte for byte
  const std::vector<std::string> overrides = adaptiveOverrides(3);
  for (const fs::path& scene : {kPunch, kCylinders}) {
    SCOPED_TRACE(scene.filename().string());
    const fs::path cp = stopAt(scene, kTmp / "roundtrip", 1, overrides);
    const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
    obs::CheckpointRecord original, again;
    for (const auto& [name, e] : rec.entries())
      if (name.starts_with("adaptivity/")) original.set(name, e.value, e.description);
    obs::estimators::storeAdaptiveState(again, obs::estimators::loadAdaptiveState(rec));
    EXPECT_EQ(again.entries().size(), original.entries().size());
    EXPECT_EQ(obs::hexHash(again.contentHash()), obs::hexHash(original.contentHash()));
  }
}

TEST(CheckpointAdaptive, EveryNStepsAndARestartFromAnOlderCheckpoint) {
  // [output] checkpoint = { every = 2 }: after every second solve (steps 1 and 3 of 0..4)
  std::string text = slurp(kPunch);
  text.replace(text.find("[output]\n"), 9, "[output]\ncheckpoint = { every = 2 }\n");
  const fs::path scene = writeScene("punch_every", text);
  const std::vector<std::string> overrides = adaptiveOverrides(5);
  const fs::path a = kTmp / "punch_every_full", b = kTmp / "punch_every_restarted";
  fs::remove_all(a);
  std::vector<std::string> lines;
  RunOptions o = quiet(a);
  o.overrides = overrides;
  o.stepProgress = [&](const std::string& l) {
    if (l.starts_with("checkpoint:")) lines.push_back(l);
  };
  runScene(scene, o);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find("step 1 "), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("step 3 "), std::string::npos) << lines[1];
  EXPECT_EQ(obs::readCheckpoint(a / "checkpoint.h5").integer("adaptivity/next_step"), 4);
  // a copy of the finished run restarted from its checkpoint after step 3: the outputs of step 4
  // (written after the checkpoint) are written again, the same
  fs::remove_all(b);
  fs::copy(a, b);
  fs::remove(b / "summary.json");
  fs::remove(b / "steps.csv");
  restartRun(scene, b, b / "checkpoint.h5", overrides);
  expectSameAdaptiveRun(a, b, 6);
}

TEST(CheckpointAdaptive, SigintFinishesTheStepWritesACheckpointAndExitsWith3) {
  if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  // the punch with 8 solves (the last ones take longest); SIGINT once step 1 is written
  const std::vector<std::string> overrides = adaptiveOverrides(8);
  const fs::path a = kTmp / "punch_signal_full", b = kTmp / "punch_signal_stopped";
  fs::remove_all(b);
  const pid_t pid = startObs(kPunch, b, setArgs(overrides));
  ASSERT_GT(pid, 0);
  waitFor(b / "step_001.vtu");
  kill(pid, SIGINT);
  ASSERT_EQ(exitCodeOf(pid), 3) << slurp(b / "run.err");
  const std::string err = slurp(b / "run.err");
  ASSERT_NE(err.find("obs: error:"), std::string::npos) << err;
  expectContains(err.substr(err.find("obs: error:")),
                 {"interrupted by SIGINT after adaptive step", "checkpoint written to", "--restart"});
  const long long next = obs::readCheckpoint(b / "checkpoint.h5").integer("adaptivity/next_step");
  EXPECT_GE(next, 2);
  EXPECT_LT(next, 8);
  EXPECT_FALSE(fs::exists(b / "summary.json"));
  std::string args = "run '" + kPunch.string() + "' --output '" + b.string() + "' --restart '" +
                     (b / "checkpoint.h5").string() + "' -q";
  for (const std::string& o : overrides) args += " --set '" + o + "'";
  const auto restarted = obs::test::runObs(kTmp, args, "punch_signal_restart");
  ASSERT_EQ(restarted.code, 0) << restarted.err;
  fullRun(kPunch, a, overrides);
  expectSameAdaptiveRun(a, b, 9);
}

TEST(CheckpointAdaptive, RestartWithAnotherSceneGridOrDamagedFileIsAOneLineError) {
  const std::vector<std::string> overrides = adaptiveOverrides(4);
  const fs::path dir = kTmp / "punch_errors";
  const fs::path cp = stopAt(kPunch, dir, 1, overrides);
  ASSERT_TRUE(fs::exists(cp));
  auto restart = [&](const fs::path& scene, const fs::path& file, RunOptions o) {
    o.restart = file;
    return errorOf([&] { runScene(scene, o); });
  };
  RunOptions o = quiet(dir);
  o.overrides = overrides;
  // another --set
  RunOptions other = o;
  other.overrides.push_back("adaptivity.theta=1.2");
  expectContains(restart(kPunch, cp, other), {cp.string() + ": ", "written for another scene", "--set overrides differ",
                                              "'--set adaptivity.theta=1.2' now, none in the checkpoint (override 3)"});
  // another scene text
  std::string text = slurp(kPunch);
  text.replace(text.find("\nE = 3e5") + 1, 7, "E = 2e5");  // the [material] line
  const fs::path changed = writeScene("punch_changed", text);
  expectContains(restart(changed, cp, o), {cp.string() + ": ", "written for another scene", "is 'E = 2e5' in " +
                                                                                                  changed.string()});
  // another --refine: the initial grid differs
  RunOptions refined = o;
  refined.refine = 3;
  expectContains(restart(kPunch, cp, refined), {cp.string() + ": ", "initial grid of 289 vertices / 256 cells",
                                                "starts from 1089 / 1024", "another --refine"});
  // a two-body checkpoint for the one-body scene, a dynamic checkpoint for an adaptive scene
  const fs::path twoCp = stopAt(kCylinders, kTmp / "cylinders_errors", 0, adaptiveOverrides(3));
  expectContains(restart(kPunch, twoCp, o), {twoCp.string() + ": ", "a checkpoint of a multi-body run with 2 bodies",
                                             "is a one-body scene"});
  const fs::path bar = writeScene("bar_for_adaptive", barScene(100));
  const fs::path dynCp = stopAt(bar, kTmp / "bar_for_adaptive", 10);
  expectContains(restart(kPunch, dynCp, o), {dynCp.string() + ": ", "a checkpoint of a dynamic run, this is an adaptive run"});
  expectContains(restart(bar, cp, quiet(kTmp / "bar_for_adaptive")),
                 {cp.string() + ": ", "a checkpoint of an adaptive run, this is a dynamic run"});
  // a truncated and a damaged file
  const std::string bytes = slurp(cp);
  const fs::path cut = kTmp / "punch_truncated.h5";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  expectContains(restart(kPunch, cut, o), {cut.string() + ": "});
  {
    // flip a byte inside the data of the refinement history (found by its value in the file)
    const obs::CheckpointRecord rec = obs::readCheckpoint(cp);
    const std::vector<long long>& cells = rec.integers("adaptivity/refinement/marked_cells");
    ASSERT_GE(cells.size(), 4u);
    std::string damaged = bytes;
    const std::string needle(reinterpret_cast<const char*>(cells.data()), 4 * sizeof(long long));
    const std::size_t at = damaged.find(needle);
    ASSERT_NE(at, std::string::npos);
    damaged[at] = static_cast<char>(damaged[at] ^ 0x01);
    const fs::path f = kTmp / "punch_damaged.h5";
    std::ofstream(f, std::ios::binary) << damaged;
    expectContains(restart(kPunch, f, o), {f.string() + ": ", "content hash", "damaged"});
  }
  // outputs of the interrupted run missing
  fs::remove(dir / "step_000.vtu");
  expectContains(restart(kPunch, cp, o), {cp.string() + ": ", "step_000.vtu is missing", "output directory"});
  // --stop-after-step outside the steps that can be continued
  RunOptions late = o;
  late.stopAfterStep = 3;
  expectContains(errorOf([&] { runScene(kPunch, late); }),
                 {"--stop-after-step 3 must lie in [0, 2] (the run has steps 0 to 3)"});
}
