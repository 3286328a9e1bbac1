#pragma once
/// \file SweepCommand.hpp
/// `obs sweep`: one scene run for every combination of varied scene keys, each run in its own
/// process (so that its wall time and peak memory are its own), collected into one table with the
/// accuracy and the cost of every run (docs/tradeoffs.md).
///
///   obs sweep SCENE --vary mesh.refine=1,2,3 --vary 'solver.tolerance=1e-6,1e-10' -o DIR
///
/// writes DIR/run_NNN/ (the run's own outputs, its stdout/stderr and sweep_run.json) and
/// DIR/sweep.csv, one row per run:
///   run, repeat, <one column per varied key>, status (ok | failed), error, unknowns, vertices,
///   iterations, load_P, max_displacement, eta (adaptive: the last step's estimate),
///   analytic_error (adaptive scenes with an analytic reference: the last step's relative pressure
///   error), load_error, displacement_error, energy_ratio, energy_error, force_variation,
///   max_penetration (dynamic runs: E_end/E_0, |E_end/E_0 - 1| against the energy the continuous
///   problem conserves, the total variation of the contact force, the largest penetration),
///   wall_s, solver_s, peak_mb, reference, ranks
/// The accuracy measures load_error = |P - P_ref| / |P_ref| and displacement_error (the same for
/// max |u|) are taken against the reference run: with --reference-set KEY=VALUE (repeatable) an extra
/// run "ref" of the scene with the sweep's --set and these overrides (e.g. a finer grid; it is the
/// last row); otherwise the successful run with the most unknowns (ties: the smallest solver
/// tolerance, then the first). Their columns are empty for the reference itself (reference = 1) and
/// for dynamic runs (whose load and max |u| are those of the last step; energy_error measures them). peak_mb is the child's peak resident
/// memory (getrusage), wall_s its wall-clock time including start-up and output.
///
/// With mpiRanks > 0 (`obs sweep --mpi N`) every run, the reference included, is launched through the
/// MPI launcher on N ranks; peak_mb is then the largest rank's peak (summary.json
/// peak_memory_mb_largest_rank), and ranks is N (1 for runs in one process). A finished run is reused
/// only with the same rank count.
///
/// Failures do not stop the sweep: a run that fails is a row with status "failed" and the first
/// line of its error. An interrupted sweep resumes: a run whose directory holds a sweep_run.json for
/// the same scene and overrides is not repeated. With plots, scripts/plot_sweep.py draws
/// accuracy against wall time and against peak memory (PNG, Pareto front marked).
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace obs::drivers {

/// One --vary KEY=V1,V2,...: the key in --set syntax and its values (TOML literals).
struct SweepVariable {
  std::string key;
  std::vector<std::string> values;
};

/// Parses "KEY=V1,V2,..." (values split at commas outside brackets, braces and quotes, so that
/// "dirichlet.value=[0,0,-1],[0,0,-2]" has two values). Throws obs::Error naming the problem.
SweepVariable parseSweepVariable(const std::string& text);

struct SweepOptions {
  std::filesystem::path scene;
  std::vector<SweepVariable> vary;
  std::vector<std::string> overrides;  ///< --set for every run
  std::vector<std::string> referenceOverrides;  ///< --reference-set: an extra reference run (empty: none)
  int repeat = 1;                      ///< runs per combination (timings: take the minimum)
  std::filesystem::path output;        ///< the sweep directory
  bool plots = false;
  std::filesystem::path obsBinary;     ///< the program to run (the running obs itself)
  /// > 0: every run is `LAUNCHER -n mpiRanks obs run ...` (a distributed run,
  /// docs/architecture.md#distributed-runner); 0: `obs run ...` in one process.
  int mpiRanks = 0;
  std::string mpiLauncher = "mpiexec";  ///< found on PATH unless a path
  std::function<void(const std::string&)> progress;  ///< one line per run
};

struct SweepSummary {
  int runs = 0, failed = 0, reused = 0;
  std::filesystem::path csv;
  std::vector<std::filesystem::path> plots;
};

/// Runs the sweep. Every combination is checked first (parseScene with its overrides), so a wrong
/// key or value is an error before anything runs. Throws obs::Error on such errors and when the
/// output directory cannot be written; failed runs are counted, not thrown.
SweepSummary runSweep(const SweepOptions& options);

}  // namespace obs::drivers
