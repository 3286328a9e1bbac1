#pragma once
/// \file RunSupport.hpp
/// Bookkeeping shared by the three scene runners (RunScene: static, AdaptiveScene, DynamicScene):
/// timing, peak memory and the final runs.csv row.
#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactSolver.hpp"

#include "obs/drivers/RunOptions.hpp"
#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/drivers/VtkWriter.hpp"

#include <nlohmann/json.hpp>

#include "obs/obs/Friction.hpp"

namespace obs::drivers {

using Clock = std::chrono::steady_clock;

/// Wall seconds since start.
double secondsSince(Clock::time_point start);

/// Peak resident memory of this process so far, MB (0 if unknown).
double peakMemoryMB();

/// The figures of a contact solve in a solver report (summary.json "solver"): iterations,
/// convergence (with friction: of its fixed point too), the solve time, tolerance, correction,
/// rate and KKT residuals.
void reportContactResult(const ContactResult& result, double seconds, double tolerance, SolverReport& report);

/// The V-cycles and the phases of a TNNMG solve (TNNMG::Statistics), for summary.json.
template <class Statistics>
void reportTnnmgPhases(const Statistics& st, SolverReport& report) {
  report.vcycles = st.vcycles;
  report.phases = TnnmgPhases{st.setupSeconds,      st.smoothingSeconds, st.updateSeconds,
                              st.correctionSeconds, st.otherSeconds,     st.operatorUpdates};
}

/// Records peak memory and, when the scene has a CSV file, the output and total times and its row
/// (appended to [output] csv, relative to dir unless absolute; the path joins r.outputFiles).
/// outputStart: when the run began writing outputs; start: when the run began.
void recordRunRow(const Scene& scene, const std::filesystem::path& dir, RunResult& r, Clock::time_point outputStart,
                  Clock::time_point start);

/// The common end of every run: the runs.csv row (recordRunRow), summary.json (summaryJson of the
/// run with the sections of `extra` added: "adaptivity", "dynamics", ...) and the "written" line
/// (RunOptions::progress; more than six files as "dir/{first six, ... (N files)}"). The run's own
/// files, plots included, are in r.outputFiles before; runs.csv and summary.json are added.
/// outputStart: when the run began writing outputs; start: when the run began.
void finishRun(const Scene& scene, const RunOptions& options, const std::filesystem::path& dir, RunResult& r,
               Clock::time_point outputStart, Clock::time_point start, const nlohmann::json& extra = nullptr);

/// One friction solve (solveFriction: Tresca, or the Coulomb fixed point) of a static run added to
/// the run's report: Tresca solves and iterations summed over the load increments, converged and
/// contracting if every increment's was, the changes of the last. Returns the progress line of a
/// fixed point ("" after a single Tresca solve).
std::string addFrictionSolve(std::optional<FrictionIterationReport>& total, const CoulombResult& solve);

/// One load increment's solve (step 1, 2, ...; x on entry: the previous increment's solution, the
/// warm start): without `friction` (nullptr) one solve; with it Tresca in one solve, Coulomb by the
/// fixed point over Tresca solves (its tolerance at least 10 times the solver's `tolerance`), the
/// slip measured from the previous increment's solution. The friction solve is added to
/// `frictionReport` (addFrictionSolve) and its line, if any, goes to `progress` (if set). `halo`:
/// the ghosts of a distributed problem (nullptr on one process). Returns the last solve and the
/// solver iterations of the increment.
template <int d>
std::pair<ContactResult, long long> solveIncrement(ContactProblem<d>& problem, ContactSolver<d>& solver,
                                                   Eigen::VectorXd& x, const NodalFriction* friction, double tolerance,
                                                   int step, const HaloExchange* halo,
                                                   std::optional<FrictionIterationReport>& frictionReport,
                                                   const std::function<void(const std::string&)>& progress);

/// [loading] runs: increments.csv in dir, one row per r.increments entry (the path joins
/// r.outputFiles). Nothing without increments.
void writeIncrementsCsv(const std::filesystem::path& dir, RunResult& r);

/// The end of a static run whose solve did not converge: the Coulomb fixed point (r.solver.friction)
/// or the solver, as one obs::Error naming what to change and where the outputs are. Returns if
/// both converged.
void throwIfNotConverged(const Scene& scene, const RunResult& r, const std::filesystem::path& dir);

/// The bodies of a scene (Scene::bodyScenes: one for a one-body file), built and checked
/// (buildGrid, validateScene, makeBoundaryConditions per body; one dimension for all): their grids,
/// leaf meshes and boundary conditions in that order. Errors of a multi-body file name the body.
struct BodyGrids {
  std::vector<mesh::Grid> grids;
  std::vector<mesh::Mesh> meshes;
  std::vector<BoundaryConditions> bcs;
  std::vector<const mesh::Grid*> gridPointers() const;
  std::vector<const mesh::Mesh*> meshPointers() const;
};
BodyGrids buildBodyGrids(const Scene& scene, const std::optional<int>& refine);

/// The file layout of a run's outputs: the one place that knows the two forms of a scene file.
/// A one-body file (the top-level [mesh], [material], [contact]) writes one .vtu per output
/// (<scene>.vtu, step_NNN.vtu, <scene>_NNNNNN.vtu) and reports its obstacle contact as summary.json
/// "contact" (adaptive runs: with pressure.csv and the analytic reference); a multi-body file
/// ([[body]]) one .vtu per body as parts of the .pvd (<scene>_<body>.vtu, step_NNN_<body>.vtu,
/// <scene>_<body>_NNNNNN.vtu) and summary.json "bodies" and "pairs" (one per coupling). The
/// runners solve and report both forms the same way (Scene::bodyScenes) and ask the layout.
class OutputLayout {
public:
  explicit OutputLayout(const Scene& scene);
  /// Files and reports per body and per coupling (a multi-body file).
  bool perBody() const { return perBody_; }
  /// The .vtu of a static run for body b.
  std::string staticVtu(std::size_t b) const;
  /// The .vtu of adaptive step k for body b.
  std::string adaptiveVtu(int k, std::size_t b) const;
  /// The .vtu of time step n for body b.
  std::string dynamicVtu(int n, std::size_t b) const;

private:
  std::string scene_;
  std::vector<std::string> bodies_;
  bool perBody_ = false;
};

}  // namespace obs::drivers
