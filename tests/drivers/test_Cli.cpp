// The `obs` program itself (built from drivers/main.cpp): help, version, exit codes, one-line
// errors on stderr, progress on stdout and --quiet. Skipped when the program is not built.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridReader.h>

#include "DriverTestSupport.hpp"
#include "obs/obs/DistributedCoarseSolver.hpp"

using obs::test::readVtu;
using obs::test::slurp;
using obs::test::Vtu;
namespace fs = std::filesystem;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "cli";

using Output = obs::test::ObsOutput;

/// Runs `obs <args>` in kTmp, capturing stdout and stderr.
Output runObs(const std::string& args, const std::string& tag, const std::string& environment = "") {
  return obs::test::runObs(kTmp, args, tag, environment);
}

int countLines(const std::string& s) {
  return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

class Cli : public ::testing::Test {
protected:
  void SetUp() override {
    if (!fs::exists(OBS_BINARY)) GTEST_SKIP() << "obs not built: " << OBS_BINARY;
  }
};

}  // namespace

TEST_F(Cli, HelpListsCommandsAndExample) {
  const Output o = runObs("--help", "help");
  EXPECT_EQ(o.code, 0);
  for (const char* part :
       {"run", "check", "Examples:", "obs run data/scenes/cantilever.toml", "docs/scenes.md"})
    EXPECT_NE(o.out.find(part), std::string::npos) << part << "\n" << o.out;
  const Output r = runObs("run --help", "run_help");
  EXPECT_EQ(r.code, 0);
  for (const char* part : {"--output", "--refine", "--quiet", "docs/scenes.md"})
    EXPECT_NE(r.out.find(part), std::string::npos) << part << "\n" << r.out;
}

TEST_F(Cli, Version) {
  const Output o = runObs("--version", "version");
  EXPECT_EQ(o.code, 0);
  EXPECT_EQ(o.out.rfind("obs 0.", 0), 0u) << o.out;
}

TEST_F(Cli, UsageErrorsExitWith2) {
  for (const auto& [args, tag] : std::vector<std::pair<std::string, std::string>>{
           {"", "none"},
           {"frobnicate", "unknown"},
           {"run", "missing_scene"},
           {"run x.toml --refine -1", "negative_refine"},
           {"run x.toml --bogus", "bogus"}}) {
    const Output o = runObs(args, "usage_" + tag);
    EXPECT_EQ(o.code, 2) << args;
    EXPECT_EQ(o.err.rfind("obs: error: ", 0), 0u) << args << ": " << o.err;
    EXPECT_EQ(countLines(o.err), 1) << args << ": " << o.err;
  }
}

TEST_F(Cli, InvalidSceneIsOneErrorLineAndExit1) {
  fs::create_directories(kTmp);
  std::ofstream(kTmp / "bad_nu.toml")
      << "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = [2, 2]\n"
         "[material]\nE = 1\nnu = 0.7\n";
  const Output o = runObs("run bad_nu.toml", "bad_nu");
  EXPECT_EQ(o.code, 1);
  EXPECT_EQ(o.err, "obs: error: bad_nu.toml:7: [material] nu = 0.7 must lie in [0, 0.5)\n");
  EXPECT_TRUE(o.out.empty()) << o.out;

  std::ofstream(kTmp / "bad_syntax.toml") << "[mesh\n";
  const Output s = runObs("run bad_syntax.toml", "bad_syntax");
  EXPECT_EQ(s.code, 1);
  EXPECT_EQ(countLines(s.err), 1) << s.err;
  EXPECT_NE(s.err.find("bad_syntax.toml:1:"), std::string::npos) << s.err;

  const Output m = runObs("run missing.toml", "missing");
  EXPECT_EQ(m.code, 1);
  EXPECT_EQ(m.err, "obs: error: missing.toml: cannot open the scene file\n");
}

// Under an MPI launcher with more than one rank (the variables Open MPI's and MPICH's mpirun set),
// every command but `obs run` stops at once on every rank with exit code 1 and writes nothing:
// rank 0 says why in one line, the others are silent. One rank is the ordinary run. (`obs run`
// itself runs distributed under a real launcher: MpirunRunsStaticScenesDistributed.)
TEST_F(Cli, SeveralMpiRanksAreRefusedOnEveryRankButForRun) {
  const std::string scene = (fs::path(OBS_DATA_DIR) / "scenes" / "cantilever.toml").string();
  const std::string check = "check '" + scene + "'";
  const Output r0 = runObs(check, "mpi_rank0", "OMPI_COMM_WORLD_SIZE=2 OMPI_COMM_WORLD_RANK=0");
  EXPECT_EQ(r0.code, 1);
  EXPECT_EQ(std::count(r0.err.begin(), r0.err.end(), '\n'), 1) << r0.err;
  EXPECT_EQ(r0.err.rfind("obs: error: launched as 2 MPI ranks: ", 0), 0u) << r0.err;
  EXPECT_TRUE(r0.out.empty()) << r0.out;
  const Output r1 = runObs(check, "mpi_rank1", "OMPI_COMM_WORLD_SIZE=2 OMPI_COMM_WORLD_RANK=1");
  EXPECT_EQ(r1.code, 1);
  EXPECT_TRUE(r1.err.empty()) << r1.err;
  const Output p3 = runObs(check, "pmi_rank2", "PMI_SIZE=3 PMI_RANK=2");
  EXPECT_EQ(p3.code, 1);
  EXPECT_TRUE(p3.err.empty()) << p3.err;
  const std::string run = "run '" + scene + "' --output out_mpi";
  fs::remove_all(kTmp / "out_mpi");
  const Output one = runObs(run, "mpi_one", "OMPI_COMM_WORLD_SIZE=1 OMPI_COMM_WORLD_RANK=0");
  EXPECT_EQ(one.code, 0) << one.err;
  EXPECT_TRUE(fs::exists(kTmp / "out_mpi" / "summary.json"));
}

#ifdef OBS_MPIEXEC
// `mpirun -np 2 obs run` on step-42 (refine 2): the distributed runner's summary has the serial
// run's iterations, contact vertices, area and load (the load to 1e-10), and its .pvtu joins two
// pieces that VTK reads back as the whole mesh. The punch on 3 ranks likewise, the friction_peer
// scene (Coulomb friction, two load increments) on 2, and the compressed block (linear
// elasticity, distributed multigrid) to its exact solution. With --partition-level 0 (the coarse
// level distributed, hypre) step-42 takes the serial iterations (+-1) to the serial load. A scene
// that is not distributed yet, or a partition level the grid does not have, stops every rank with
// exit code 1 and one error line.
TEST_F(Cli, MpirunRunsStaticScenesDistributed) {
  const std::string mpirun = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE " +
                             std::string(OBS_MPIEXEC) + " --oversubscribe -np 2";
  const std::string scene = (fs::path(OBS_DATA_DIR) / "scenes" / "step42.toml").string();
  fs::remove_all(kTmp / "out_mpi2");
  fs::remove_all(kTmp / "out_serial2");
  const Output d = runObs("run '" + scene + "' --refine 2 --output out_mpi2", "mpirun2", mpirun);
  ASSERT_EQ(d.code, 0) << d.err;
  EXPECT_EQ(countLines(d.out), 4) << d.out;  // progress from rank 0 only
  EXPECT_NE(d.out.find("on 2 ranks"), std::string::npos) << d.out;
  const Output s = runObs("run '" + scene + "' --refine 2 --output out_serial2", "serial2");
  ASSERT_EQ(s.code, 0) << s.err;
  const auto json = [](const fs::path& p) { return nlohmann::json::parse(slurp(p)); };
  const nlohmann::json jd = json(kTmp / "out_mpi2" / "summary.json"), js = json(kTmp / "out_serial2" / "summary.json");
  EXPECT_EQ(jd["ranks"], 2);
  for (const char* key : {"dofs", "free_dofs", "vertices", "cells"}) EXPECT_EQ(jd[key], js[key]) << key;
  EXPECT_EQ(jd["solver"]["iterations"], js["solver"]["iterations"]);
  for (const char* key : {"actual_vertices", "potential_vertices", "boundary_vertices"})
    EXPECT_EQ(jd["contact"][key], js["contact"][key]) << key;
  const double load = js["contact"]["load_P"];
  EXPECT_NEAR(jd["contact"]["load_P"].get<double>(), load, 1e-10 * load);
  EXPECT_NEAR(jd["contact"]["area"].get<double>(), js["contact"]["area"].get<double>(), 1e-12);
  EXPECT_NEAR(jd["max_displacement"].get<double>(), js["max_displacement"].get<double>(),
              1e-9 * js["max_displacement"].get<double>());
  // the pieces, joined by the .pvtu
  vtkNew<vtkXMLPUnstructuredGridReader> reader;
  reader->SetFileName((kTmp / "out_mpi2" / "step42.pvtu").string().c_str());
  reader->Update();
  vtkUnstructuredGrid* grid = reader->GetOutput();
  EXPECT_EQ(grid->GetNumberOfCells(), js["cells"].get<long long>());
  ASSERT_NE(grid->GetPointData()->GetArray("displacement"), nullptr);
  ASSERT_NE(grid->GetCellData()->GetArray("rank"), nullptr);
  EXPECT_EQ(grid->GetCellData()->GetArray("rank")->GetRange()[1], 1.0);
  EXPECT_NE(slurp(kTmp / "out_mpi2" / "step42.pvd").find("file=\"step42.pvtu\""), std::string::npos);
  EXPECT_EQ(jd["solver"]["coarse_solver"], "cholmod");

  // the coarse level distributed too (--partition-level 0): hypre's CG + BoomerAMG solve it, and
  // the run takes the serial iterations (+-1) to the serial load within the solver tolerance; a
  // partition level beyond the grid's levels stops both ranks with one line
  if (obs::DistributedCoarseSolver::available()) {
    fs::remove_all(kTmp / "out_mpi2_level0");
    const Output h = runObs("run '" + scene + "' --refine 2 --partition-level 0 --output out_mpi2_level0 -q", "mpirun2_level0",
                            mpirun);
    ASSERT_EQ(h.code, 0) << h.err;
    const nlohmann::json jh = json(kTmp / "out_mpi2_level0" / "summary.json");
    EXPECT_EQ(jh["partition_level"], 0);
    EXPECT_EQ(jh["solver"]["coarse_solver"], "hypre");
    EXPECT_GT(jh["solver"]["coarse_iterations"].get<long long>(), 0);
    EXPECT_LE(std::abs(jh["solver"]["iterations"].get<int>() - js["solver"]["iterations"].get<int>()), 1);
    EXPECT_EQ(jh["contact"]["actual_vertices"], js["contact"]["actual_vertices"]);
    EXPECT_NEAR(jh["contact"]["load_P"].get<double>(), load, 1e-8 * load);
  }
  const Output bad = runObs("run '" + scene + "' --refine 2 --partition-level 9 --output out_mpi2_bad", "mpirun2_bad", mpirun);
  EXPECT_EQ(bad.code, 1);
  std::size_t badErrors = 0;  // obs' own lines (mpirun adds its report of the exit code)
  for (std::size_t at = bad.err.find("obs: error:"); at != std::string::npos; at = bad.err.find("obs: error:", at + 1))
    ++badErrors;
  EXPECT_EQ(badErrors, 1u) << bad.err;
  EXPECT_NE(bad.err.find("partition level 9"), std::string::npos) << bad.err;

  // 2D on 3 ranks, one of which holds no face of the contact boundary
  const std::string punch = (fs::path(OBS_DATA_DIR) / "scenes" / "punch.toml").string();
  const std::string mpirun3 = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE " +
                              std::string(OBS_MPIEXEC) + " --oversubscribe -np 3";
  fs::remove_all(kTmp / "out_punch3");
  fs::remove_all(kTmp / "out_punch1");
  ASSERT_EQ(runObs("run '" + punch + "' --output out_punch3 -q", "punch3", mpirun3).code, 0);
  ASSERT_EQ(runObs("run '" + punch + "' --output out_punch1 -q", "punch1").code, 0);
  const nlohmann::json p3 = json(kTmp / "out_punch3" / "summary.json"), p1 = json(kTmp / "out_punch1" / "summary.json");
  EXPECT_EQ(p3["solver"]["iterations"], p1["solver"]["iterations"]);
  EXPECT_EQ(p3["contact"]["actual_vertices"], p1["contact"]["actual_vertices"]);
  const double punchLoad = p1["contact"]["load_P"];
  EXPECT_NEAR(p3["contact"]["load_P"].get<double>(), punchLoad, 1e-10 * punchLoad);

  // Coulomb friction on 2 ranks in two load increments (the fixed point over distributed Tresca
  // solves): the serial number of Tresca solves, stick and slip vertices, friction force and stick
  // width, and the serial increments.csv
  const std::string peer = (fs::path(OBS_DATA_DIR) / "scenes" / "friction_peer.toml").string();
  fs::remove_all(kTmp / "out_peer2");
  fs::remove_all(kTmp / "out_peer1");
  const Output f2 = runObs("run '" + peer + "' --set loading.steps=2 --output out_peer2", "peer2", mpirun);
  ASSERT_EQ(f2.code, 0) << f2.err;
  EXPECT_NE(f2.out.find("Tresca solves"), std::string::npos) << f2.out;
  EXPECT_NE(f2.out.find("increment 2 of 2"), std::string::npos) << f2.out;
  ASSERT_EQ(runObs("run '" + peer + "' --set loading.steps=2 --output out_peer1 -q", "peer1").code, 0);
  {
    const auto rows = [](const fs::path& p) {
      std::vector<std::vector<double>> out;
      std::istringstream in(slurp(p));
      std::string line;
      std::getline(in, line);  // header
      while (std::getline(in, line)) {
        std::vector<double> row;
        std::istringstream cells(line);
        for (std::string cell; std::getline(cells, cell, ',');) row.push_back(std::stod(cell));
        out.push_back(row);
      }
      return out;
    };
    const auto r2 = rows(kTmp / "out_peer2" / "increments.csv"), r1 = rows(kTmp / "out_peer1" / "increments.csv");
    ASSERT_EQ(r2.size(), 2u);
    ASSERT_EQ(r1.size(), 2u);
    EXPECT_GT(r1[0][12], 0);  // the first increment slips partly (the second sticks: the slip is
    EXPECT_GT(r1[0][11], 0);  // measured from the first's solution)
    for (std::size_t i = 0; i < 2; ++i) {
      ASSERT_EQ(r2[i].size(), 13u);
      for (std::size_t c : {0u, 1u, 3u, 10u, 11u, 12u}) EXPECT_EQ(r2[i][c], r1[i][c]) << "row " << i << " column " << c;
      for (std::size_t c = 4; c < 10; ++c)  // forces, to the solver tolerance of the load
        EXPECT_NEAR(r2[i][c], r1[i][c], 1e-8 * std::abs(r1[i][5])) << "row " << i << " column " << c;
    }
  }
  const nlohmann::json q2 = json(kTmp / "out_peer2" / "summary.json"), q1 = json(kTmp / "out_peer1" / "summary.json");
  EXPECT_EQ(q2["solver"]["friction"]["iterations"], q1["solver"]["friction"]["iterations"]);
  EXPECT_TRUE(q2["solver"]["friction"]["converged"].get<bool>());
  const nlohmann::json& fr2 = q2["contact"]["friction"];
  const nlohmann::json& fr1 = q1["contact"]["friction"];
  for (const char* key : {"stick_vertices", "slip_vertices"}) EXPECT_EQ(fr2[key], fr1[key]) << key;
  EXPECT_GT(fr1["stick_vertices"].get<int>(), 0);
  const double ft = fr1["tangential_force"][0];
  EXPECT_NEAR(fr2["tangential_force"][0].get<double>(), ft, 1e-8 * std::abs(ft));
  EXPECT_NEAR(fr2["stick_width"].get<double>(), fr1["stick_width"].get<double>(), 1e-12);
  const double peerLoad = q1["contact"]["load_P"];
  EXPECT_NEAR(q2["contact"]["load_P"].get<double>(), peerLoad, 1e-9 * peerLoad);
  // the contact point fields of the pieces: the serial .vtu's ranges
  vtkNew<vtkXMLPUnstructuredGridReader> pieces;
  pieces->SetFileName((kTmp / "out_peer2" / "friction_peer.pvtu").string().c_str());
  pieces->Update();
  vtkNew<vtkXMLUnstructuredGridReader> whole;
  whole->SetFileName((kTmp / "out_peer1" / "friction_peer.vtu").string().c_str());
  whole->Update();
  for (const char* name : {"gap", "contact_pressure", "contact_state", "friction_force", "slip", "stick_slip"}) {
    vtkDataArray* a = pieces->GetOutput()->GetPointData()->GetArray(name);
    vtkDataArray* b = whole->GetOutput()->GetPointData()->GetArray(name);
    ASSERT_NE(a, nullptr) << name;
    ASSERT_NE(b, nullptr) << name;
    for (int end : {0, 1}) {
      const double x = a->GetRange(-1)[end], y = b->GetRange(-1)[end];
      EXPECT_NEAR(x, y, 1e-8 * std::max(1.0, std::abs(y))) << name;
    }
  }

  // linear elasticity on 3 ranks (distributed multigrid): the compressed block's exact solution,
  // uniaxial compression that Q1 reproduces (max |u| = sqrt(0.01^2 + 2 * 0.003^2), von Mises = p = 10)
  const std::string block = (fs::path(OBS_DATA_DIR) / "scenes" / "block_compression.toml").string();
  fs::remove_all(kTmp / "out_block3");
  const Output b3 = runObs("run '" + block + "' --refine 1 --output out_block3", "block3", mpirun3);
  ASSERT_EQ(b3.code, 0) << b3.err;
  EXPECT_NE(b3.out.find("(multigrid, "), std::string::npos) << b3.out;
  const nlohmann::json jb = json(kTmp / "out_block3" / "summary.json");
  EXPECT_EQ(jb["ranks"], 3);
  EXPECT_EQ(jb["dofs"], 3 * 17 * 17 * 17);
  EXPECT_EQ(jb["solver"]["type"], "multigrid");
  EXPECT_TRUE(jb["solver"]["converged"].get<bool>());
  const double exact = std::sqrt(0.01 * 0.01 + 2 * 0.003 * 0.003);
  EXPECT_NEAR(jb["max_displacement"].get<double>(), exact, 1e-9 * exact);
  EXPECT_NEAR(jb["max_von_mises"].get<double>(), 10.0, 1e-8 * 10.0);
  // a one-process baseline solver (naming the distributed one: multigrid without contact), and a
  // single-level grid, are refused
  const Output direct = runObs("run '" + block + "' --refine 1 --set 'solver.type=\"direct\"' --output out_block_direct",
                               "block_direct", mpirun);
  EXPECT_EQ(direct.code, 1);
  EXPECT_NE(direct.err.find("[solver] type = \"direct\" is a one-process baseline"), std::string::npos) << direct.err;
  EXPECT_NE(direct.err.find("use type = \"multigrid\""), std::string::npos) << direct.err;
  const Output level = runObs("run '" + block + "' --output out_block_level", "block_level", mpirun);
  EXPECT_EQ(level.code, 1);
  EXPECT_NE(level.err.find("needs refine >= 1"), std::string::npos) << level.err;

  // two bodies on 2 ranks (docs/architecture.md#distributed-two-body): the mortar patch test's
  // constant pressure p = 10 to round-off, and pieces per body joined by the scene's .pvd
  const std::string twoBody = (fs::path(OBS_DATA_DIR) / "scenes" / "twobody_patch.toml").string();
  fs::remove_all(kTmp / "out_patch2");
  const Output t2 = runObs("run '" + twoBody + "' --refine 1 --output out_patch2", "patch2", mpirun);
  ASSERT_EQ(t2.code, 0) << t2.err;
  const nlohmann::json jp = json(kTmp / "out_patch2" / "summary.json");
  ASSERT_EQ(jp["pairs"].size(), 1u);
  const nlohmann::json& pair = jp["pairs"][0];
  EXPECT_EQ(pair["actual_vertices"], 121);
  EXPECT_NEAR(pair["pressure_min"].get<double>(), 10.0, 1e-9);
  EXPECT_NEAR(pair["pressure_max"].get<double>(), 10.0, 1e-9);
  EXPECT_NEAR(pair["load_P"].get<double>(), 10.0, 1e-9);
  EXPECT_NEAR(pair["force_master"][2].get<double>(), -10.0, 1e-9);
  EXPECT_NEAR(pair["area"].get<double>(), 1.0, 1e-12);
  EXPECT_EQ(jp["solver"]["coarse_solver"], "cholmod");  // the stacked multigrid's replicated coarse level
  // the per-rank work: the owned vertices and slave vertices of the ranks add up to the scene's
  const nlohmann::json& balance = jp["balance"];
  EXPECT_DOUBLE_EQ(2 * balance["owned_vertices"]["mean"].get<double>(), jp["vertices"].get<double>());
  EXPECT_DOUBLE_EQ(2 * balance["slave_vertices"]["mean"].get<double>(), pair["slave_vertices"].get<double>());
  EXPECT_GE(balance["received_blocks"]["max_over_mean"].get<double>(), 1.0);
  EXPECT_EQ(jp["bodies"].size(), 2u);
  for (const char* f : {"twobody_patch.pvd", "twobody_patch_upper.pvtu", "twobody_patch_lower_1.vtu"})
    EXPECT_TRUE(fs::exists(kTmp / "out_patch2" / f)) << f;
  // 2D on 3 ranks against one process: the load, the contact vertices and the width
  const std::string cylinders = (fs::path(OBS_DATA_DIR) / "scenes" / "twobody_cylinders.toml").string();
  fs::remove_all(kTmp / "out_cyl3");
  fs::remove_all(kTmp / "out_cyl1");
  ASSERT_EQ(runObs("run '" + cylinders + "' --output out_cyl3 -q", "cyl3", mpirun3).code, 0);
  ASSERT_EQ(runObs("run '" + cylinders + "' --output out_cyl1 -q", "cyl1").code, 0);
  const nlohmann::json c3 = json(kTmp / "out_cyl3" / "summary.json")["pairs"][0];
  const nlohmann::json c1 = json(kTmp / "out_cyl1" / "summary.json")["pairs"][0];
  // the stacked multigrid correction on the ranks: TNNMG's iterations within one of one process's
  const int cylIterations3 = json(kTmp / "out_cyl3" / "summary.json")["solver"]["iterations"];
  const int cylIterations1 = json(kTmp / "out_cyl1" / "summary.json")["solver"]["iterations"];
  EXPECT_LE(std::abs(cylIterations3 - cylIterations1), 1) << cylIterations3 << " on 3 ranks, " << cylIterations1;
  EXPECT_EQ(c3["actual_vertices"], c1["actual_vertices"]);
  EXPECT_EQ(c3["potential_vertices"], c1["potential_vertices"]);
  EXPECT_EQ(c3["slave_vertices"], c1["slave_vertices"]);
  const double cylLoad = c1["load_P"];
  EXPECT_NEAR(c3["load_P"].get<double>(), cylLoad, 1e-8 * cylLoad);
  EXPECT_NEAR(c3["width"].get<double>(), c1["width"].get<double>(), 1e-12);
  EXPECT_NEAR(c3["force_master"][1].get<double>(), c1["force_master"][1].get<double>(), 1e-8 * cylLoad);
  // each body refined by its own [mesh] refine (the cylinder once less than the block), as serially
  {
    std::string text = slurp(cylinders);
    const std::string from = "refine = 4";
    text.replace(text.rfind(from), from.size(), "refine = 3");
    std::ofstream(kTmp / "cylinders_mixed.toml") << text;
  }
  fs::remove_all(kTmp / "out_mixed2");
  fs::remove_all(kTmp / "out_mixed1");
  ASSERT_EQ(runObs("run cylinders_mixed.toml --output out_mixed2 -q", "mixed2", mpirun).code, 0);
  ASSERT_EQ(runObs("run cylinders_mixed.toml --output out_mixed1 -q", "mixed1").code, 0);
  const nlohmann::json m2 = json(kTmp / "out_mixed2" / "summary.json"), m1 = json(kTmp / "out_mixed1" / "summary.json");
  EXPECT_EQ(m2["vertices"], m1["vertices"]);
  EXPECT_LT(m1["vertices"].get<long long>(), json(kTmp / "out_cyl1" / "summary.json")["vertices"].get<long long>());
  EXPECT_EQ(m2["pairs"][0]["actual_vertices"], m1["pairs"][0]["actual_vertices"]);
  const double mixedLoad = m1["pairs"][0]["load_P"];
  EXPECT_NEAR(m2["pairs"][0]["load_P"].get<double>(), mixedLoad, 1e-8 * mixedLoad);

  // Coulomb friction between two bodies on 2 ranks: the serial Tresca solves, stick and slip
  // vertices and friction force
  const std::string friction = (fs::path(OBS_DATA_DIR) / "scenes" / "twobody_friction.toml").string();
  fs::remove_all(kTmp / "out_tbf2");
  fs::remove_all(kTmp / "out_tbf1");
  ASSERT_EQ(runObs("run '" + friction + "' --output out_tbf2 -q", "tbf2", mpirun).code, 0);
  ASSERT_EQ(runObs("run '" + friction + "' --output out_tbf1 -q", "tbf1").code, 0);
  const nlohmann::json t2j = json(kTmp / "out_tbf2" / "summary.json"), t1j = json(kTmp / "out_tbf1" / "summary.json");
  EXPECT_EQ(t2j["solver"]["friction"]["iterations"], t1j["solver"]["friction"]["iterations"]);
  const nlohmann::json& pf2 = t2j["pairs"][0]["friction"];
  const nlohmann::json& pf1 = t1j["pairs"][0]["friction"];
  for (const char* key : {"stick_vertices", "slip_vertices"}) EXPECT_EQ(pf2[key], pf1[key]) << key;
  EXPECT_GT(pf1["slip_vertices"].get<int>(), 0);
  const double tf = pf1["tangential_force"][0];
  EXPECT_NEAR(pf2["tangential_force"][0].get<double>(), tf, 1e-8 * std::abs(tf));
  EXPECT_NEAR(pf2["stick_width"].get<double>(), pf1["stick_width"].get<double>(), 1e-12);

  // what is not distributed yet (here: a one-process baseline solver) stops every rank with one line
  const std::string adaptive = (fs::path(OBS_DATA_DIR) / "scenes" / "twobody_hertz_adaptive.toml").string();
  const Output e = runObs("run '" + adaptive + "' --refine 1 --set 'solver.type=\"pdas\"' --output out_mpi_refused",
                          "mpirun_refused", mpirun);
  EXPECT_EQ(e.code, 1);
  std::size_t errors = 0;  // obs' own lines (mpirun adds its report of the exit code)
  for (std::size_t at = e.err.find("obs: error:"); at != std::string::npos; at = e.err.find("obs: error:", at + 1)) ++errors;
  EXPECT_EQ(errors, 1u) << e.err;
  EXPECT_NE(e.err.find("[solver] type = \"pdas\" is a one-process baseline"), std::string::npos) << e.err;
  EXPECT_NE(e.err.find("use type = \"tnnmg\""), std::string::npos) << e.err;
}

/// A table (timeseries.csv, steps.csv): the header's columns and the rows' values (empty cells and
/// text: NaN).
struct Series {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  double at(std::size_t row, const std::string& column) const {
    const auto c = std::find(columns.begin(), columns.end(), column);
    if (c == columns.end()) ADD_FAILURE() << "no column " << column;
    return c == columns.end() ? std::nan("") : rows.at(row).at(static_cast<std::size_t>(c - columns.begin()));
  }
};

Series readSeries(const fs::path& p) {
  Series s;
  std::ifstream in(p);
  std::string line;
  const auto cells = [](const std::string& l) {
    std::vector<std::string> out;
    std::string cell;
    std::istringstream is(l);
    while (std::getline(is, cell, ',')) out.push_back(cell);
    if (!l.empty() && l.back() == ',') out.emplace_back();
    return out;
  };
  if (std::getline(in, line)) s.columns = cells(line);
  while (std::getline(in, line)) {
    std::vector<double> row;
    for (const std::string& c : cells(line)) {  // empty cells and text (a solver's name): NaN
      char* end = nullptr;
      const double v = std::strtod(c.c_str(), &end);
      row.push_back(c.empty() || end != c.c_str() + c.size() ? std::nan("") : v);
    }
    s.rows.push_back(row);
  }
  return s;
}

/// The largest difference of the columns of two series over all rows, relative to the largest
/// |value| of the columns in `a` (a group shares one scale: the components of a vector).
double seriesDeviation(const Series& a, const Series& b, const std::vector<std::string>& columns) {
  double scale = 1e-300, worst = 0;
  for (std::size_t r = 0; r < a.rows.size(); ++r)
    for (const std::string& c : columns)
      if (!std::isnan(a.at(r, c))) scale = std::max(scale, std::abs(a.at(r, c)));
  for (std::size_t r = 0; r < a.rows.size() && r < b.rows.size(); ++r)
    for (const std::string& c : columns)
      if (!std::isnan(a.at(r, c))) worst = std::max(worst, std::abs(a.at(r, c) - b.at(r, c)));
  return worst / scale;
}

// `mpirun -np N obs run` on dynamic scenes (docs/architecture.md#distributed-dynamics): the time
// series of the serial run, energies, momentum, contact force and the tracked vertex to 1e-8 of
// their scales and the same active node counts every step; rank 0 writes the series, summary.json
// (ranks, balance, the bodies) and the .pvd of .pvtu files whose pieces VTK reads back as the whole
// mesh. Geometry 1 (hexahedra) with mass redistribution on 2 ranks, the ball of pyramids on 3,
// Coulomb friction on 2, Geometry B (two cubes, dual mortar) on 3; a checkpoint written on 2 ranks
// continues on 2, 3 and 1, one of Geometry B written on 3 ranks on 3 and 2.
TEST_F(Cli, MpirunRunsDynamicScenesDistributed) {
  const auto launcher = [](int ranks) {
    return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE " + std::string(OBS_MPIEXEC) +
           " --oversubscribe -np " + std::to_string(ranks);
  };
  const auto json = [](const fs::path& p) { return nlohmann::json::parse(slurp(p)); };
  struct Run {
    const char* scene;
    std::string options;
    int ranks;
  };
  for (const Run& run : {Run{"dynamics_block.toml", "--set 'dynamics.scheme=\"khenous-laborde-renard\"' --set dynamics.steps=80", 2},
                         Run{"dynamics_ball.toml", "--set dynamics.steps=60", 3},
                         Run{"dynamics_sliding_block.toml", "--set dynamics.steps=40", 2},
                         Run{"dynamics_two_body.toml", "--refine 3 --set dynamics.steps=40", 3}}) {
    SCOPED_TRACE(run.scene);
    const std::string scene = (fs::path(OBS_DATA_DIR) / "scenes" / run.scene).string();
    const std::string name = fs::path(run.scene).stem().string();
    fs::remove_all(kTmp / ("out_dyn_mpi_" + name));
    fs::remove_all(kTmp / ("out_dyn_one_" + name));
    const Output d = runObs("run '" + scene + "' " + run.options + " --output out_dyn_mpi_" + name, "dyn_mpi_" + name,
                            launcher(run.ranks));
    ASSERT_EQ(d.code, 0) << d.err;
    EXPECT_NE(d.out.find("on " + std::to_string(run.ranks) + " ranks"), std::string::npos) << d.out;
    const Output s = runObs("run '" + scene + "' " + run.options + " -q --output out_dyn_one_" + name, "dyn_one_" + name);
    ASSERT_EQ(s.code, 0) << s.err;
    const fs::path dd = kTmp / ("out_dyn_mpi_" + name), ds = kTmp / ("out_dyn_one_" + name);
    const Series a = readSeries(ds / "timeseries.csv"), b = readSeries(dd / "timeseries.csv");
    ASSERT_EQ(a.columns, b.columns);
    ASSERT_EQ(a.rows.size(), b.rows.size());
    EXPECT_LE(seriesDeviation(a, b, {"energy", "kinetic_energy", "elastic_energy", "energy_redistributed"}), 1e-8);
    EXPECT_LE(seriesDeviation(a, b, {"momentum_x", "momentum_y", "momentum_z"}), 1e-8);
    EXPECT_LE(seriesDeviation(a, b, {"contact_force_x", "contact_force_y", "contact_force_z"}), 1e-8);
    const auto has = [&](const char* column) {
      return std::find(a.columns.begin(), a.columns.end(), column) != a.columns.end();
    };
    if (has("tracked0_gap")) {
      EXPECT_LE(seriesDeviation(a, b, {"tracked0_normal_displacement", "tracked0_gap"}), 1e-8);
    }
    const bool friction = has("friction_dissipation");
    if (friction) {
      EXPECT_LE(seriesDeviation(a, b, {"friction_dissipation"}), 1e-8);
      EXPECT_LE(seriesDeviation(a, b, {"friction_force_x", "friction_force_y", "friction_force_z"}), 1e-8);
    }
    double active = 0;
    for (std::size_t r = 0; r < a.rows.size(); ++r) {
      EXPECT_EQ(a.at(r, "active_solution"), b.at(r, "active_solution")) << "row " << r;
      EXPECT_EQ(a.at(r, "active_predictor"), b.at(r, "active_predictor")) << "row " << r;
      if (friction) {
        EXPECT_EQ(a.at(r, "stick_nodes") + a.at(r, "slip_nodes"), b.at(r, "stick_nodes") + b.at(r, "slip_nodes"));
      }
      active = std::max(active, a.at(r, "active_solution"));
    }
    EXPECT_GT(active, 0) << "the body must touch the obstacle (or the other body)";
    const nlohmann::json jd = json(dd / "summary.json"), js = json(ds / "summary.json");
    EXPECT_EQ(jd["ranks"], run.ranks);
    for (const char* key : {"dofs", "free_dofs", "vertices", "cells"}) EXPECT_EQ(jd[key], js[key]) << key;
    for (const char* key : {"boundary", "boundary_vertices", "potential_vertices", "actual_vertices"})
      EXPECT_EQ(jd["contact"][key], js["contact"][key]) << key;
    ASSERT_EQ(jd["dynamics"]["tracked"].size(), js["dynamics"]["tracked"].size());
    for (std::size_t k = 0; k < js["dynamics"]["tracked"].size(); ++k) {
      EXPECT_EQ(jd["dynamics"]["tracked"][k]["contact_node"], js["dynamics"]["tracked"][k]["contact_node"]);
      EXPECT_EQ(jd["dynamics"]["tracked"][k]["coordinates"], js["dynamics"]["tracked"][k]["coordinates"]);
    }
    EXPECT_TRUE(jd["balance"].contains("contact_vertices"));
    EXPECT_EQ(jd["balance"]["owned_vertices"]["mean"].get<double>() * run.ranks, js["vertices"].get<double>());
    // the last .vtu step, joined from its pieces
    const std::string pvd = slurp(dd / (name + ".pvd"));
    const std::size_t at = pvd.rfind("file=\"");
    ASSERT_NE(at, std::string::npos) << pvd;
    const std::string last = pvd.substr(at + 6, pvd.find('"', at + 6) - at - 6);
    EXPECT_EQ(fs::path(last).extension(), ".pvtu");
    vtkNew<vtkXMLPUnstructuredGridReader> reader;
    reader->SetFileName((dd / last).string().c_str());
    reader->Update();
    // (two bodies: the last body's file of the last time)
    const long long cells = js.contains("bodies") ? js["bodies"].back()["cells"].get<long long>() : js["cells"].get<long long>();
    EXPECT_EQ(reader->GetOutput()->GetNumberOfCells(), cells);
    if (js.contains("bodies")) {
      ASSERT_EQ(jd["bodies"].size(), js["bodies"].size());
      for (std::size_t b = 0; b < js["bodies"].size(); ++b)
        for (const char* key : {"vertices", "cells"}) EXPECT_EQ(jd["bodies"][b][key], js["bodies"][b][key]) << key;
      EXPECT_TRUE(jd["balance"].contains("extra_ghosts"));
    }
    ASSERT_NE(reader->GetOutput()->GetPointData()->GetArray("contact_state"), nullptr);
  }
  // checkpoints (docs/checkpoint.md#rows): the ball stopped after step 30 on 2 ranks (one file,
  // written by both) continues on 2 ranks bit for bit (every column but the times), and on 3 ranks
  // and on one process to the uninterrupted run within 1e-8
  const std::string ball = (fs::path(OBS_DATA_DIR) / "scenes" / "dynamics_ball.toml").string();
  const std::string steps = " --set dynamics.steps=60 -q";
  fs::remove_all(kTmp / "out_cp_full2");
  ASSERT_EQ(runObs("run '" + ball + "'" + steps + " --output out_cp_full2", "cp_full2", launcher(2)).code, 0);
  fs::remove_all(kTmp / "out_cp_stop");
  const Output stop = runObs("run '" + ball + "'" + steps + " --stop-after-step 30 --output out_cp_stop", "cp_stop",
                             launcher(2));
  EXPECT_EQ(stop.code, 3) << stop.err;
  ASSERT_TRUE(fs::exists(kTmp / "out_cp_stop" / "checkpoint.h5"));
  EXPECT_FALSE(fs::exists(kTmp / "out_cp_stop" / "checkpoint.h5.tmp"));
  const Series full2 = readSeries(kTmp / "out_cp_full2" / "timeseries.csv");
  const Series full1 = readSeries(kTmp / "out_dyn_one_dynamics_ball" / "timeseries.csv");
  for (int ranks : {2, 3, 1}) {
    SCOPED_TRACE("restart on " + std::to_string(ranks) + " rank(s)");
    const std::string dir = "out_cp_restart" + std::to_string(ranks);
    fs::remove_all(kTmp / dir);
    fs::copy(kTmp / "out_cp_stop", kTmp / dir, fs::copy_options::recursive);
    const Output r = runObs("run '" + ball + "'" + steps + " --restart " + (kTmp / dir / "checkpoint.h5").string() +
                                " --output " + dir,
                            "cp_restart" + std::to_string(ranks), ranks > 1 ? launcher(ranks) : std::string());
    ASSERT_EQ(r.code, 0) << r.err;
    const Series b = readSeries(kTmp / dir / "timeseries.csv");
    ASSERT_EQ(b.rows.size(), 61u);
    if (ranks == 2) {
      for (std::size_t row = 0; row < b.rows.size(); ++row)
        for (std::size_t k = 0; k < b.columns.size(); ++k) {
          if (b.columns[k].find("seconds") != std::string::npos) continue;
          const double x = full2.rows[row][k], y = b.rows[row][k];
          EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << b.columns[k] << " row " << row;
        }
    } else {
      EXPECT_LE(seriesDeviation(full1, b, {"energy", "kinetic_energy", "elastic_energy"}), 1e-8);
      EXPECT_LE(seriesDeviation(full1, b, {"contact_force_x", "contact_force_y", "contact_force_z"}), 1e-8);
    }
  }
  // two bodies (Geometry B, stopped after step 20 on 3 ranks): the same on 3 ranks bit for bit, on 2
  // to the serial run within 1e-8 (the coupling's extra ghosts restored from their owners' rows)
  {
    const std::string cubes = (fs::path(OBS_DATA_DIR) / "scenes" / "dynamics_two_body.toml").string();
    const std::string options = " --refine 3 --set dynamics.steps=40 -q";
    fs::remove_all(kTmp / "out_cp_tb_stop");
    ASSERT_EQ(runObs("run '" + cubes + "'" + options + " --stop-after-step 20 --output out_cp_tb_stop", "cp_tb_stop",
                     launcher(3)).code, 3);
    const Series full3 = readSeries(kTmp / "out_dyn_mpi_dynamics_two_body" / "timeseries.csv");
    const Series one = readSeries(kTmp / "out_dyn_one_dynamics_two_body" / "timeseries.csv");
    for (int ranks : {3, 2}) {
      SCOPED_TRACE("two bodies restarted on " + std::to_string(ranks) + " ranks");
      const std::string dir = "out_cp_tb_restart" + std::to_string(ranks);
      fs::remove_all(kTmp / dir);
      fs::copy(kTmp / "out_cp_tb_stop", kTmp / dir, fs::copy_options::recursive);
      const Output r = runObs("run '" + cubes + "'" + options + " --restart " + (kTmp / dir / "checkpoint.h5").string() +
                                  " --output " + dir, "cp_tb_restart" + std::to_string(ranks), launcher(ranks));
      ASSERT_EQ(r.code, 0) << r.err;
      const Series b = readSeries(kTmp / dir / "timeseries.csv");
      ASSERT_EQ(b.rows.size(), 41u);
      if (ranks == 3) {
        for (std::size_t row = 0; row < b.rows.size(); ++row)
          for (std::size_t k = 0; k < b.columns.size(); ++k) {
            if (b.columns[k].find("seconds") != std::string::npos) continue;
            const double x = full3.rows[row][k], y = b.rows[row][k];
            EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << b.columns[k] << " row " << row;
          }
      } else {
        EXPECT_LE(seriesDeviation(one, b, {"energy", "kinetic_energy", "elastic_energy"}), 1e-8);
        EXPECT_LE(seriesDeviation(one, b, {"contact_force_x", "contact_force_y", "contact_force_z"}), 1e-8);
      }
    }
  }
  // a checkpoint of another grid: one line on every rank
  fs::remove_all(kTmp / "out_cp_refined");
  fs::copy(kTmp / "out_cp_stop", kTmp / "out_cp_refined", fs::copy_options::recursive);
  const Output refined = runObs("run '" + ball + "'" + steps + " --refine 2 --restart " +
                                    (kTmp / "out_cp_refined" / "checkpoint.h5").string() + " --output out_cp_refined",
                                "cp_refined", launcher(3));
  EXPECT_EQ(refined.code, 1);
  std::size_t errors = 0;
  for (std::size_t at = refined.err.find("obs: error:"); at != std::string::npos; at = refined.err.find("obs: error:", at + 1))
    ++errors;
  EXPECT_EQ(errors, 1u) << refined.err;
  EXPECT_NE(refined.err.find("another --refine"), std::string::npos) << refined.err;
}

// `mpirun -np N obs run` on adaptive scenes (docs/architecture.md#distributed-adaptivity): steps.csv
// of the serial run, with the same grids every step (cells, vertices, contact counts, marked,
// red, closure and green refinements; the TNNMG iterations +-1) and eta, its contributions, the load and
// the reference errors to 1e-8 of their scales; summary.json has the ranks and the balance, the
// .pvd lists .pvtu files, balance.csv has a row per step. Example 1A (flat punch, quadrilaterals)
// on 2 ranks, Example 3A (ball, hexahedra, from 512 cells) on 3, Example 3B (tetrahedra, from 3,072
// cells, to 52,760) on 2. Example 1A stopped on 2 ranks continues on 2 (bit for bit) and on 3.
/// The pieces <base>_<rank>.vtu of a distributed run agree where they meet: every point array has
/// the same values at the same position in every piece (within 1e-12 of the array's largest value:
/// a piece holds the vertices of its owned cells, all of whose cells the rank holds, so their
/// averaged stresses and contact rows are whole). Returns the number of shared points compared.
std::size_t expectPiecesAgree(const fs::path& dir, const std::string& base, int ranks) {
  std::map<std::array<long long, 3>, std::vector<std::vector<double>>> seen;  // position -> arrays
  std::vector<std::string> names;
  std::vector<double> largest;
  std::size_t shared = 0;
  for (int q = 0; q < ranks; ++q) {
    const Vtu piece = readVtu(dir / (base + "_" + std::to_string(q) + ".vtu"));
    if (q == 0) {
      names = piece.names;
      largest.assign(names.size(), 0.0);
    }
    EXPECT_EQ(piece.names, names);
    for (std::size_t a = 0; a < names.size(); ++a)
      for (double x : piece.arrays[a]) largest[a] = std::max(largest[a], std::abs(x));
    for (std::size_t i = 0; i < piece.points.size(); ++i) {
      std::array<long long, 3> key;
      for (int c = 0; c < 3; ++c) key[c] = std::llround(piece.points[i][c] * 1e9);
      std::vector<std::vector<double>> values(names.size());
      for (std::size_t a = 0; a < names.size(); ++a) {
        const std::size_t k = piece.arrays[a].size() / piece.points.size();
        values[a].assign(piece.arrays[a].begin() + static_cast<std::ptrdiff_t>(i * k),
                         piece.arrays[a].begin() + static_cast<std::ptrdiff_t>((i + 1) * k));
      }
      const auto [it, fresh] = seen.emplace(key, values);
      if (fresh) continue;
      ++shared;
      for (std::size_t a = 0; a < names.size(); ++a)
        for (std::size_t c = 0; c < values[a].size(); ++c)
          EXPECT_NEAR(values[a][c], it->second[a][c], 1e-12 * std::max(largest[a], 1e-300))
              << names[a] << " at a point of pieces " << base << " (rank " << q << ")";
    }
  }
  return shared;
}

TEST_F(Cli, MpirunRunsAdaptiveScenesDistributed) {
  const auto launcher = [](int ranks) {
    return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE " + std::string(OBS_MPIEXEC) +
           " --oversubscribe -np " + std::to_string(ranks);
  };
  struct Run {
    const char* scene;
    std::string options;
    int ranks;
  };
  const std::vector<std::string> exact = {"cells", "vertices", "unknowns", "potential_contact", "actual_contact",
                                          "semi_contact", "full_contact", "marked", "refined_red", "closure_red",
                                          "green_closed"};
  for (const Run& run : {Run{"example1a.toml", "--set adaptivity.steps=7", 2},
                         Run{"example3a.toml", "--refine 1 --set adaptivity.steps=4", 3},
                         Run{"example3b.toml", "--refine 1 --set adaptivity.steps=5", 2},
                         Run{"twobody_cylinders_adaptive.toml", "--set adaptivity.steps=5", 2}}) {
    SCOPED_TRACE(run.scene);
    const std::string scene = (fs::path(OBS_DATA_DIR) / "scenes" / run.scene).string();
    const std::string name = fs::path(run.scene).stem().string();
    const bool twoBody = name.starts_with("twobody");  // (no analytic reference; a pair and two bodies)
    fs::remove_all(kTmp / ("out_ad_mpi_" + name));
    fs::remove_all(kTmp / ("out_ad_one_" + name));
    const Output d = runObs("run '" + scene + "' " + run.options + " --output out_ad_mpi_" + name, "ad_mpi_" + name,
                            launcher(run.ranks));
    ASSERT_EQ(d.code, 0) << d.err;
    EXPECT_NE(d.out.find("on " + std::to_string(run.ranks) + " ranks"), std::string::npos) << d.out;
    const Output s = runObs("run '" + scene + "' " + run.options + " -q --output out_ad_one_" + name, "ad_one_" + name);
    ASSERT_EQ(s.code, 0) << s.err;
    const fs::path dd = kTmp / ("out_ad_mpi_" + name), ds = kTmp / ("out_ad_one_" + name);
    const Series a = readSeries(ds / "steps.csv"), b = readSeries(dd / "steps.csv");
    ASSERT_EQ(a.columns, b.columns);
    ASSERT_EQ(a.rows.size(), b.rows.size());
    ASSERT_GE(a.rows.size(), 4u);
    for (std::size_t r = 0; r < a.rows.size(); ++r) {
      for (const std::string& c : exact) EXPECT_EQ(a.at(r, c), b.at(r, c)) << c << ", step " << r;
      // the distributed sweep visits the vertices in another order: the serial iterations +-1
      EXPECT_LE(std::abs(a.at(r, "iterations") - b.at(r, "iterations")), 1) << "step " << r;
    }
    const auto first = std::find(a.columns.begin(), a.columns.end(), "eta");
    const auto eoc = std::find(a.columns.begin(), a.columns.end(), "eoc");
    for (auto c = first; c != eoc; ++c) EXPECT_LT(seriesDeviation(a, b, {*c}), 1e-8) << *c;
    for (const char* c : {"load", "pressure_error", "radius", "radius_error", "centre_pressure", "nodal_pressure_error"})
      if (!twoBody || std::string(c) == "load") {
        EXPECT_LT(seriesDeviation(a, b, {c}), 1e-8) << c;
      }
    EXPECT_NE(std::isnan(a.at(a.rows.size() - 1, "pressure_error")), !twoBody);
    const nlohmann::json summary = nlohmann::json::parse(slurp(dd / "summary.json"));
    if (twoBody) {  // the pair's and the bodies' report as one process's
      const nlohmann::json one = nlohmann::json::parse(slurp(ds / "summary.json"));
      ASSERT_EQ(summary["bodies"].size(), 2u);
      ASSERT_EQ(summary["pairs"].size(), 1u);
      const nlohmann::json &p = summary["pairs"][0], &q = one["pairs"][0];
      for (const char* key : {"slave_vertices", "potential_vertices", "actual_vertices"}) EXPECT_EQ(p[key], q[key]) << key;
      EXPECT_EQ(p["mortar"]["uncovered_nodes"], q["mortar"]["uncovered_nodes"]);
      const double load = q["load_P"];
      EXPECT_NEAR(p["load_P"].get<double>(), load, 1e-8 * load);
      EXPECT_NEAR(p["force_master"][1].get<double>(), q["force_master"][1].get<double>(), 1e-8 * load);
      EXPECT_NEAR(p["width"].get<double>(), q["width"].get<double>(), 1e-12);
      for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(summary["bodies"][i]["vertices"], one["bodies"][i]["vertices"]);
        EXPECT_NEAR(summary["bodies"][i]["max_displacement"].get<double>(),
                    one["bodies"][i]["max_displacement"].get<double>(), 1e-8);
      }
      for (const char* f : {"step_004_block.pvtu", "step_004_cylinder.pvtu"}) EXPECT_TRUE(fs::exists(dd / f)) << f;
    }
    EXPECT_EQ(summary["ranks"], run.ranks);
    EXPECT_TRUE(summary.contains("balance"));
    EXPECT_NE(slurp(dd / (name + ".pvd")).find(".pvtu"), std::string::npos);
    const Series balance = readSeries(dd / "balance.csv");
    EXPECT_EQ(balance.rows.size(), a.rows.size());
    EXPECT_GE(balance.at(0, "cells_imbalance"), 1.0);
    // rebalanced (default tolerance 1.1) exactly when the refined grid was unbalanced beyond it and
    // the new split is better; the owned cells' imbalance is then the new split's (two bodies:
    // refined_imbalance is the larger of the bodies', each grid is balanced on its own)
    double rebalances = 0;
    for (std::size_t r = 0; r < balance.rows.size(); ++r) {
      const double refined = balance.at(r, "refined_imbalance"), now = balance.at(r, "cells_imbalance");
      if (balance.at(r, "rebalanced") == 1) {
        rebalances += 1;
        EXPECT_GT(refined, 1.1) << "step " << r;
        EXPECT_LT(now, refined) << "step " << r;
      } else if (!twoBody) {
        EXPECT_DOUBLE_EQ(now, refined) << "step " << r;
      } else {  // the bodies' cells together are no worse balanced than the worse body's
        EXPECT_LE(now, refined * (1 + 1e-9)) << "step " << r;
      }
    }
    EXPECT_EQ(summary["rebalances"], rebalances);
    if (name == "example3b") {  // the refinement at the ball's contact zone unbalances 2 ranks
      EXPECT_GE(rebalances, 1);
    }
    // the last step's pieces agree where they meet
    const std::string pvd = slurp(dd / (name + ".pvd"));
    const std::size_t at = pvd.rfind(".pvtu\""), from = pvd.rfind('"', at - 1) + 1;
    ASSERT_NE(at, std::string::npos);
    EXPECT_GT(expectPiecesAgree(dd, pvd.substr(from, at - from), run.ranks), 0u);
  }
  // checkpoints (docs/checkpoint.md#distributed-adaptive-runs): Example 1A stopped after step 3 on 2
  // ranks (and the adaptive two-body scene after step 2) continues on 2 to the uninterrupted run's
  // steps.csv and balance.csv bit for bit (every column but the times and memory), on 3 to its
  // steps within 1e-8; a checkpoint of one process is refused on ranks and one of ranks by one
  // process, with one line each
  const auto withoutTimes = [](const Series& s, std::size_t row) {
    std::vector<double> v;
    for (std::size_t k = 0; k < s.columns.size(); ++k)
      if (s.columns[k].find("seconds") == std::string::npos && !s.columns[k].ends_with("_s") &&
          s.columns[k].rfind("memory", 0) != 0)
        v.push_back(std::isnan(s.rows[row][k]) ? -1e300 : s.rows[row][k]);
    return v;
  };
  struct Restart {
    const char* name;
    const char* options;
    int stopAfter;
  };
  for (const Restart& c : {Restart{"example1a", " --set adaptivity.steps=7 -q", 3},
                           Restart{"twobody_cylinders_adaptive", " --set adaptivity.steps=5 -q", 2}}) {
    SCOPED_TRACE(c.name);
    const std::string scene = (fs::path(OBS_DATA_DIR) / "scenes" / (std::string(c.name) + ".toml")).string();
    const std::string stopDir = "out_ad_stop_" + std::string(c.name);
    fs::remove_all(kTmp / stopDir);
    const Output stop = runObs("run '" + scene + "'" + c.options + " --stop-after-step " + std::to_string(c.stopAfter) +
                                   " --output " + stopDir, "ad_stop_" + std::string(c.name), launcher(2));
    ASSERT_EQ(stop.code, 3) << stop.err;
    const fs::path fullDir = kTmp / ("out_ad_mpi_" + std::string(c.name));
    const Series full = readSeries(fullDir / "steps.csv");
    for (int ranks : {2, 3}) {
      SCOPED_TRACE("adaptive restart on " + std::to_string(ranks) + " ranks");
      const std::string dir = "out_ad_restart" + std::to_string(ranks) + "_" + c.name;
      fs::remove_all(kTmp / dir);
      fs::copy(kTmp / stopDir, kTmp / dir, fs::copy_options::recursive);
      const Output r = runObs("run '" + scene + "'" + c.options + " --restart " + (kTmp / dir / "checkpoint.h5").string() +
                                  " --output " + dir, "ad_restart" + std::to_string(ranks) + c.name, launcher(ranks));
      ASSERT_EQ(r.code, 0) << r.err;
      const Series b = readSeries(kTmp / dir / "steps.csv");
      ASSERT_EQ(b.rows.size(), full.rows.size());
      if (ranks == 2) {
        for (std::size_t row = 0; row < b.rows.size(); ++row) EXPECT_EQ(withoutTimes(full, row), withoutTimes(b, row)) << row;
        const Series fb = readSeries(fullDir / "balance.csv"), bb = readSeries(kTmp / dir / "balance.csv");
        ASSERT_EQ(fb.rows.size(), bb.rows.size());
        for (std::size_t row = 0; row < bb.rows.size(); ++row) EXPECT_EQ(withoutTimes(fb, row), withoutTimes(bb, row)) << row;
      } else {
        for (std::size_t row = 0; row < b.rows.size(); ++row)
          for (const std::string& col : exact) EXPECT_EQ(full.at(row, col), b.at(row, col)) << col << ", step " << row;
        EXPECT_LE(seriesDeviation(full, b, {"eta"}), 1e-8);
        EXPECT_LE(seriesDeviation(full, b, {"load"}), 1e-8);
      }
      const std::string pvd = std::string(c.name) + ".pvd";
      EXPECT_EQ(slurp(kTmp / dir / pvd), slurp(fullDir / pvd));
    }
  }
  const std::string punch = (fs::path(OBS_DATA_DIR) / "scenes" / "example1a.toml").string();
  const std::string steps = " --set adaptivity.steps=7 -q";
  const auto oneLine = [](const Output& o, const char* what) {
    EXPECT_EQ(o.code, 1);
    std::size_t errors = 0;
    for (std::size_t at = o.err.find("obs: error:"); at != std::string::npos; at = o.err.find("obs: error:", at + 1)) ++errors;
    EXPECT_EQ(errors, 1u) << o.err;
    EXPECT_NE(o.err.find(what), std::string::npos) << o.err;
  };
  fs::remove_all(kTmp / "out_ad_serial_stop");
  ASSERT_EQ(runObs("run '" + punch + "'" + steps + " --stop-after-step 2 --output out_ad_serial_stop", "ad_serial_stop").code, 3);
  oneLine(runObs("run '" + punch + "'" + steps + " --restart " + (kTmp / "out_ad_serial_stop" / "checkpoint.h5").string() +
                     " --output out_ad_serial_stop", "ad_serial_on_ranks", launcher(2)),
          "written by one process");
  oneLine(runObs("run '" + punch + "'" + steps + " --restart " + (kTmp / "out_ad_stop_example1a" / "checkpoint.h5").string() +
                     " --output out_ad_stop_example1a", "ad_ranks_serially"),
          "written by a distributed run");
}
#endif

TEST_F(Cli, RunPrintsProgressAndQuietDoesNot) {
  const std::string scene = (fs::path(OBS_DATA_DIR) / "scenes" / "cantilever.toml").string();
  const Output o = runObs("run '" + scene + "' --output out_cli", "run");
  EXPECT_EQ(o.code, 0) << o.err;
  EXPECT_TRUE(o.err.empty()) << o.err;
  for (const char* part :
       {"mesh built:", "assembled:", "solved in", "written:", "out_cli/cantilever.vtu"})
    EXPECT_NE(o.out.find(part), std::string::npos) << part << "\n" << o.out;
  EXPECT_TRUE(fs::exists(kTmp / "out_cli" / "summary.json"));

  const Output q =
      runObs("run '" + scene + "' --output out_cli_quiet --quiet --refine 1", "run_quiet");
  EXPECT_EQ(q.code, 0) << q.err;
  EXPECT_TRUE(q.out.empty()) << q.out;
  EXPECT_TRUE(q.err.empty()) << q.err;
  EXPECT_NE(slurp(kTmp / "out_cli_quiet" / "summary.json").find("\"refine\": 1"),
            std::string::npos);
}

TEST_F(Cli, CheckValidatesSeveralScenes) {
  const fs::path scenes = fs::path(OBS_DATA_DIR) / "scenes";
  const Output o = runObs("check '" + (scenes / "cantilever.toml").string() + "' '" +
                           (scenes / "block_compression.toml").string() + "'",
                       "check");
  EXPECT_EQ(o.code, 0) << o.err;
  EXPECT_EQ(countLines(o.out), 2) << o.out;
  const Output bad =
      runObs("check '" + (scenes / "cantilever.toml").string() + "' missing.toml", "check_bad");
  EXPECT_EQ(bad.code, 1);
  EXPECT_EQ(countLines(bad.out), 1) << bad.out;
  EXPECT_EQ(bad.err, "obs: error: missing.toml: cannot open the scene file\n");
}

TEST_F(Cli, CheckOfAnInvalidMultiBodySceneWritesOnlyTheError) {
  // a body that selects a boundary group of the Gmsh file: the error names the scene line and key,
  // and stdout stays empty (it used to get "<scene>: valid (" before the error)
  std::string text = slurp(fs::path(OBS_DATA_DIR) / "scenes" / "twobody_gmsh.toml");
  const std::string from = "physical = \"lower\"";
  text.replace(text.find(from), from.size(), "physical = \"top\"");
  const std::string meshes = "\"../meshes/";
  const std::string absolute = std::string(1, '"').append((fs::path(OBS_DATA_DIR) / "meshes").string()).append("/");
  for (std::size_t at; (at = text.find(meshes)) != std::string::npos;) text.replace(at, meshes.size(), absolute);
  fs::create_directories(kTmp);
  std::ofstream(kTmp / "gmsh_top.toml") << text;
  const Output o = runObs("check gmsh_top.toml", "check_gmsh_top");
  EXPECT_EQ(o.code, 1);
  EXPECT_EQ(o.out, "");
  EXPECT_EQ(countLines(o.err), 1) << o.err;
  EXPECT_EQ(o.err.rfind("obs: error: gmsh_top.toml:15: [mesh] physical = \"top\": ", 0), 0u) << o.err;
  EXPECT_NE(o.err.find("has dimension 2, not the mesh dimension 3"), std::string::npos) << o.err;
}
