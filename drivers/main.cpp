// obs — the command-line program of the obs finite element library.
//
// Reads a scene file (TOML, see docs/scenes.md) describing a linear-elastic body — mesh, material,
// Dirichlet and Neumann data, body force, optionally a rigid obstacle ([contact], Signorini
// problem solved by TNNMG, PDAS or PGS) and the solver, outputs — solves it and writes a .vtu file
// for ParaView, summary.json (sizes, times, memory, extremes, solver and contact figures) and a CSV
// row per run. Contact example: build/drivers/obs run data/scenes/punch.toml --verbose
//
// Sample run:
//   build/drivers/obs run data/scenes/cantilever.toml
//     mesh built: 256 quadrilateral cells / 297 vertices (2D, 0.000443 s)
//     assembled: 594 dofs (576 free) in 0.000368 s
//     solved in 0.0111 s: max |u| = 0.244503, max von Mises = 17.4829
//     written: out/cantilever/cantilever.vtu, out/cantilever/summary.json
//
// `obs mesh SCENE.toml [--uniform K] [--random-cycles N --fraction F --seed S] [--output DIR]`
// builds the scene's mesh as a hierarchical grid, refines it, checks it and prints a JSON report.
// `obs sweep SCENE --vary KEY=V1,V2 ... -o DIR` runs every combination in its own process and
// writes DIR/sweep.csv (accuracy and cost per run, docs/tradeoffs.md).
// `obs estimators [--plugin lib.so]...` lists the registered error estimators (after loading plugins).
//
// Exit codes: 0 success, 1 error (invalid scene, solver or I/O failure), 2 command-line misuse,
// 3 a [dynamics] or [adaptivity] run stopped early (SIGINT/SIGTERM or --stop-after-step) with a
// checkpoint to continue it with --restart (docs/checkpoint.md); scheme comparisons stop without one.
// Every error is one line "obs: error: ..." on stderr. Launched by mpirun with more than one rank,
// `obs run` runs distributed (static one-body and two-body scenes; rank 0 prints progress and errors,
// every rank exits with the same code); other commands stop with exit code 1 on every rank.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <new>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "obs/drivers/MeshCommand.hpp"
#include "obs/drivers/RunScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/SweepCommand.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Version.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/mesh/Error.hpp"

namespace {

constexpr int kExitError = 1;
constexpr int kExitUsage = 2;
constexpr int kExitInterrupted = 3;

/// The rank count and this process's rank when launched by an MPI launcher (mpirun / mpiexec of
/// Open MPI or MPICH-derived ones, which set these variables), else {1, 0}. obs does not link MPI:
/// it only has to recognise the launch.
std::pair<long, long> launcherRanks() {
  const auto number = [](const char* name) -> long {
    const char* v = std::getenv(name);
    if (!v || !*v) return -1;
    char* end = nullptr;
    const long n = std::strtol(v, &end, 10);
    return *end == '\0' ? n : -1;
  };
  for (const auto& [size, rank] : {std::pair{"OMPI_COMM_WORLD_SIZE", "OMPI_COMM_WORLD_RANK"}, std::pair{"PMI_SIZE", "PMI_RANK"}})
    if (const long n = number(size); n >= 1) return {n, std::max(0L, number(rank))};
  return {1, 0};
}

void printError(std::string message) {
  for (char& c : message)
    if (c == '\n' || c == '\r') c = ' ';
  std::cerr << "obs: error: " << message << std::endl;
}

int runCommand(const std::string& scene, const std::optional<std::string>& output,
               std::optional<int> refine, bool quiet, bool verbose,
               const std::vector<std::string>& plugins, const std::vector<std::string>& overrides,
               bool plots, bool compareSchemes, const std::optional<std::string>& restart,
               std::optional<int> stopAfterStep, std::optional<int> partitionLevel,
               std::optional<double> imbalanceTolerance, bool balanceContact) {
  // plugins first, so that their estimators are valid names in [adaptivity]
  for (const std::string& plugin : plugins)
    obs::estimators::EstimatorRegistry::global().loadPlugin(plugin);
  obs::drivers::RunOptions options;
  options.overrides = overrides;
  options.plots = plots;
  options.compareSchemes = compareSchemes;
  if (restart) options.restart = *restart;
  options.stopAfterStep = stopAfterStep;
  if (!quiet) options.stepProgress = [](const std::string& line) { std::cerr << line << std::endl; };
  if (output) options.outputDirectory = *output;
  options.refine = refine;
  options.partitionLevel = partitionLevel;
  options.imbalanceTolerance = imbalanceTolerance;
  options.balanceContact = balanceContact;
  if (!quiet) options.progress = [](const std::string& line) { std::cout << line << std::endl; };
  if (verbose)
    options.iterationProgress = [](const std::string& line) { std::cerr << line << std::endl; };
  obs::drivers::runScene(std::filesystem::path(scene), options);
  return 0;
}

int checkCommand(const std::vector<std::string>& scenes, std::optional<int> refine) {
  int status = 0;
  for (const std::string& file : scenes) {
    try {
      const obs::drivers::Scene scene = obs::drivers::parseScene(file);
      if (scene.multiBody()) {
        // checked before anything is printed: an invalid scene prints no "valid (" on stdout
        const std::string report = obs::drivers::checkMultiBodyScene(scene, refine);
        std::cout << file << ": valid (" << report << ")" << std::endl;
        continue;
      }
      const obs::mesh::Mesh mesh = obs::drivers::buildMesh(scene, refine);
      obs::drivers::validateScene(scene, mesh);
      std::cout << file << ": valid (" << mesh.dimension() << "D, " << mesh.numCells() << " cells, "
                << mesh.numVertices() << " vertices)" << std::endl;
    } catch (const obs::Error& e) {
      printError(e.what());
      status = kExitError;
    }
  }
  return status;
}

/// `obs sweep`: every combination of the varied keys in its own `obs run` process; sweep.csv.
int sweepCommand(obs::drivers::SweepOptions options, const std::vector<std::string>& vary, bool quiet) {
  for (const std::string& v : vary) options.vary.push_back(obs::drivers::parseSweepVariable(v));
  if (options.mpiRanks > 0) {
    if (!obs::Communicator::built())
      throw obs::Error("sweep --mpi: this obs is built without MPI (configure with -DOBS_WITH_MPI=ON and an MPI "
                       "installation, scripts/install-deps)");
    if (const char* launcher = std::getenv("OBS_MPIEXEC"); launcher && *launcher) options.mpiLauncher = launcher;
  }
  options.obsBinary = std::filesystem::read_symlink("/proc/self/exe");
  if (!quiet) options.progress = [](const std::string& line) { std::cerr << line << std::endl; };
  const obs::drivers::SweepSummary s = obs::drivers::runSweep(options);
  if (!quiet) {
    std::cout << "written: " << s.csv.string();
    for (const auto& p : s.plots) std::cout << ", " << p.string();
    std::cout << " (" << s.runs << " runs";
    if (s.reused > 0) std::cout << ", " << s.reused << " reused from an earlier sweep";
    std::cout << ")" << std::endl;
  }
  if (s.failed > 0)
    throw obs::Error("sweep: " + std::to_string(s.failed) + " of " + std::to_string(s.runs) +
                     " runs failed (status and error in " + s.csv.string() + ")");
  return 0;
}

/// `obs mesh`: refine and check the grid of a scene, print the JSON report.
int meshCommand(const obs::drivers::MeshCommandOptions& options) {
  std::cout << obs::drivers::runMeshCommand(options).dump(2) << "\n";
  return 0;
}

/// `obs estimators`: loads the plugins, then prints one line per registered estimator.
int estimatorsCommand(const std::vector<std::string>& plugins) {
  auto& registry = obs::estimators::EstimatorRegistry::global();
  for (const std::string& plugin : plugins) registry.loadPlugin(plugin);
  const auto entries = registry.entries();
  std::size_t width = 0;
  for (const auto& e : entries) width = std::max(width, e.name.size());
  for (const auto& e : entries)
    std::cout << e.name << std::string(width + 2 - e.name.size(), ' ') << e.description << "\n";
  std::cout.flush();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "obs — adaptive finite elements for contact in linear elasticity.\n"
      "Solves the problem described by a scene file (TOML) and writes VTK, JSON and CSV "
      "output.",
      "obs"};
  app.set_version_flag("--version", std::string("obs ") + obs::estimators::version(),
                       "Print the version and exit");
  app.require_subcommand(1);
  app.footer(
      "Examples:\n"
      "  obs run data/scenes/cantilever.toml               solve, write out/cantilever/\n"
      "  obs run data/scenes/cantilever.toml --refine 2    the same on a twice refined mesh\n"
      "  obs check data/scenes/*.toml                      validate scenes without solving\n"
      "  obs mesh data/scenes/cantilever.toml --random-cycles 10  refine, check a grid\n"
      "  obs sweep data/scenes/hertz.toml --vary mesh.refine=1,2,3 -o out/sweep   runs and sweep.csv\n"
      "  obs estimators                                    list the error estimators\n"
      "Run 'obs <command> --help' for the options of a command. Scene files: docs/scenes.md\n");

  std::string scene;
  std::optional<std::string> output;
  std::optional<int> refine;
  bool quiet = false, verbose = false, runPlots = false;
  bool compareSchemes = false;  // [dynamics]: run every scheme
  std::optional<std::string> restart;
  std::optional<int> stopAfterStep;
  std::optional<int> partitionLevel;
  std::optional<double> imbalanceTolerance;
  bool balanceContact = false;
  std::optional<int> threadCount;
  std::vector<std::string> runPlugins, overrides;
  CLI::App* run =
      app.add_subcommand("run", "Solve the scene in a scene file and write the results");
  run->add_option("scene", scene, "Scene file (TOML), see docs/scenes.md")
      ->required()
      ->type_name("SCENE.toml");
  run->add_option("--output,-o", output,
                  "Output directory (replaces [output] directory; default out/<scene name>)")
      ->type_name("DIR");
  run->add_option("--refine,-r", refine, "Uniform refinements of the mesh (replaces [mesh] refine)")
      ->type_name("K")
      ->check(CLI::Range(0, 12));
  run->add_option("--set,-s", overrides,
                  "Override a scene key before the checks, TOML value syntax (repeatable), e.g. "
                  "--set adaptivity.steps=3 --set 'adaptivity.estimator=\"residual\"'")
      ->type_name("SECTION.KEY=VALUE");
  run->add_option("--plugin,-p", runPlugins,
                  "Load estimators from a shared library before the scene is read (repeatable)")
      ->type_name("LIB.so");
  run->add_flag("--plots", runPlots,
                "[adaptivity] runs: PNG plots by scripts/plot_adaptivity.py, [dynamics] runs: by "
                "scripts/plot_dynamics.py (as [output] plots = true)");
  run->add_flag("--compare-schemes", compareSchemes,
                "[dynamics] scenes: also run every other Newmark scheme (timeseries_<scheme>.csv each)");
  run->add_option("--restart", restart,
                  "[dynamics] and [adaptivity] scenes: continue from a checkpoint written by an interrupted "
                  "run of the same scene, into its output directory (docs/checkpoint.md)")
      ->type_name("FILE.h5");
  run->add_option("--stop-after-step", stopAfterStep,
                  "[dynamics] scenes: stop after time step K, [adaptivity] scenes after adaptive step K (0, 1, "
                  "...; its refinement included), with a checkpoint (as on SIGINT/SIGTERM; exit code 3)")
      ->type_name("K");
  run->add_option("--partition-level", partitionLevel,
                  "mpirun runs: the levels below L are held by every rank, the others distributed; 0 "
                  "distributes the coarse level too, solved by hypre's CG + BoomerAMG (default: the coarsest "
                  "level from 1 on with 8 cells per rank; docs/architecture.md#distributed-coarse-solve)")
      ->type_name("L")
      ->check(CLI::Range(0, 64));
  run->add_option("--imbalance-tolerance", imbalanceTolerance,
                  "mpirun adaptive runs: repartition after a refinement when the largest rank's leaves exceed "
                  "the mean by more than the factor T (>= 1; inf: never; default 1.1; "
                  "docs/architecture.md#load-balancing)")
      ->type_name("T")
      ->check(CLI::Range(1.0, std::numeric_limits<double>::infinity()));
  run->add_flag("--balance-contact", balanceContact,
                "mpirun adaptive runs: balance the contact boundary's faces over the ranks as well as the leaves "
                "(METIS multi-constraint; docs/architecture.md#load-balancing)");
  run->add_option("--threads,-t", threadCount,
                  "Threads for assembly, sweeps and products (default: $OBS_THREADS, else 1). Results are "
                  "bitwise reproducible for a fixed N; different N differ in the last bits "
                  "(docs/performance.md#threads)")
      ->type_name("N")
      ->check(CLI::Range(1, 1024));
  run->add_flag("--quiet,-q", quiet, "Print nothing but errors");
  run->add_flag("--verbose,-v", verbose,
                "Contact solvers: one line per block of iterations on stderr (1-10, 20, 30, ..., "
                "100, 200, ...)");
  run->footer(
      "Writes <output>/<scene name>.vtu (displacement, stress, von_mises, boundary_id,\n"
      "element_type; contact scenes also gap, normal_displacement, contact_pressure,\n"
      "contact_state, constraint_direction; open it in ParaView), <output>/summary.json (sizes,\n"
      "times, memory, solver, contact) and\n"
      "appends one row per run to <output>/runs.csv ([output] csv names another file).\n"
      "Example: obs run data/scenes/cantilever.toml --output out/cantilever --refine 1\n"
      "With [adaptivity] the adaptive loop runs instead (one line per step on stderr) and writes\n"
      "steps.csv, pressure.csv, step_NNN.vtu + <scene name>.pvd and summary.json \"adaptivity\".\n"
      "Example: obs run data/scenes/example1a.toml --set adaptivity.steps=12 --set\n"
      "  'adaptivity.refinement=\"uniform\"' --plugin ./libmy_estimators.so --plots\n"
      "With [dynamics] the time steppers run (progress on stderr) and write timeseries.csv,\n"
      "<scene name>_NNNNNN.vtu + <scene name>.pvd and summary.json \"dynamics\".\n"
      "Example: obs run data/scenes/dynamics_ball.toml --compare-schemes --plots\n"
      "SIGINT/SIGTERM stop a [dynamics] or [adaptivity] run after the current step with\n"
      "<output>/checkpoint.h5 (exit code 3; [output] checkpoint = { every = N } writes one every N\n"
      "steps); continue with\n"
      "  obs run SCENE --restart <output>/checkpoint.h5\n"
      "The scene file format is documented in docs/scenes.md.\n");

  std::vector<std::string> checkScenes;
  std::optional<int> checkRefine;
  CLI::App* check =
      app.add_subcommand("check",
                         "Validate scene files (syntax, keys, values, mesh, boundaries) "
                         "without solving");
  check->add_option("scenes", checkScenes, "Scene files (TOML)")
      ->required()
      ->type_name("SCENE.toml");
  check->add_option("--refine,-r", checkRefine, "Uniform refinements (replaces [mesh] refine)")
      ->type_name("K")
      ->check(CLI::Range(0, 12));
  check->footer("Example: obs check data/scenes/*.toml\nScene files: docs/scenes.md\n");

  obs::drivers::SweepOptions sweepOptions;
  std::vector<std::string> sweepVary;
  std::string sweepScene, sweepOutput;
  bool sweepQuiet = false;
  CLI::App* sweep = app.add_subcommand(
      "sweep", "Run a scene for every combination of varied keys (each in its own process); sweep.csv and plots");
  sweep->add_option("scene", sweepScene, "Scene file (TOML)")->required()->type_name("SCENE.toml");
  sweep->add_option("--vary", sweepVary,
                    "A key in --set syntax and its values, comma-separated (repeatable; every combination runs), "
                    "e.g. --vary mesh.refine=1,2,3 --vary 'solver.tolerance=1e-6,1e-10'")
      ->required()
      ->type_name("KEY=V1,V2,...");
  sweep->add_option("--set,-s", sweepOptions.overrides, "Override a scene key in every run (repeatable)")
      ->type_name("SECTION.KEY=VALUE");
  sweep->add_option("--reference-set", sweepOptions.referenceOverrides,
                    "An extra reference run with these overrides (repeatable, e.g. --reference-set mesh.refine=4); "
                    "default reference: the run with the most unknowns")
      ->type_name("SECTION.KEY=VALUE");
  sweep->add_option("--repeat", sweepOptions.repeat, "Runs per combination (default 1)")->check(CLI::Range(1, 100));
  sweep->add_option("--output,-o", sweepOutput, "Sweep directory (run_NNN/ per run, sweep.csv)")
      ->required()
      ->type_name("DIR");
  sweep->add_option("--mpi", sweepOptions.mpiRanks,
                    "Launch every run on N MPI ranks (mpiexec -n N obs run ...; the launcher from OBS_MPIEXEC, "
                    "default mpiexec on PATH)")
      ->check(CLI::Range(1, 1 << 20))
      ->type_name("N");
  sweep->add_flag("--plots", sweepOptions.plots,
                  "Accuracy against wall time and against peak memory as PNG (scripts/plot_sweep.py)");
  sweep->add_flag("--quiet,-q", sweepQuiet, "Print nothing but errors");
  sweep->footer(
      "Each run is `obs run SCENE --output DIR/run_NNN --set ...`; a failed run is a row with its error\n"
      "(the sweep goes on; the exit code is 1 if any failed); running the same sweep again reuses the\n"
      "finished runs (resume after an interrupt). sweep.csv: varied values, status, unknowns,\n"
      "iterations, load P, max |u|, eta, analytic error, load and displacement error against the run\n"
      "with the most unknowns, wall time, solver time, peak memory, ranks (--mpi N: every run on N MPI\n"
      "ranks). See docs/tradeoffs.md.\n");

  std::vector<std::string> plugins;
  obs::drivers::MeshCommandOptions meshOptions;
  std::string meshScene, meshOutput;
  CLI::App* meshCmd = app.add_subcommand(
      "mesh", "Build, refine (uniformly and/or randomly) and check the grid of a scene; JSON report");
  meshCmd->add_option("scene", meshScene, "Scene file (TOML); its [mesh] section is used")
      ->required()
      ->type_name("SCENE.toml");
  meshCmd->add_option("--uniform,-u", meshOptions.uniform, "Uniform refinements (default: [mesh] refine)")
      ->type_name("K")
      ->check(CLI::Range(0, 12));
  meshCmd->add_option("--random-cycles", meshOptions.randomCycles,
                      "Cycles of random local refinement after the uniform ones (default 0)")
      ->check(CLI::Range(0, 40));
  meshCmd->add_option("--fraction", meshOptions.fraction,
                      "Share of the leaves marked in each random cycle (default 0.1)")
      ->check(CLI::Range(1e-9, 1.0));
  meshCmd->add_option("--seed", meshOptions.seed, "Seed of the random marking (default 1)");
  meshCmd->add_option("--output,-o", meshOutput, "Write <scene name>_leaf.vtu (level, quality, boundary ids) here")
      ->type_name("DIR");
  meshCmd->add_flag("--levels", meshOptions.levels, "With --output: also write every level view");
  meshCmd->add_option("--threads,-t", threadCount,
                      "Threads for the red refinement (default: $OBS_THREADS, else 1); the grid is the same "
                      "for any N (docs/performance.md#refinement-threads)")
      ->type_name("N")
      ->check(CLI::Range(1, 1024));
  meshCmd->footer(
      "Prints leaf elements per type and level, conformity violations, total volume, the shape\n"
      "quality range (minimum corner mean ratio, 1 for a cube corner) and times as JSON.\n"
      "Example: obs mesh data/scenes/mixed_bar.toml --uniform 1 --random-cycles 4 --seed 7\n");

  CLI::App* estimators = app.add_subcommand(
      "estimators", "List the registered a posteriori error estimators, one line each");
  estimators->add_option("--plugin,-p", plugins,
                         "Load more estimators from a shared library first (repeatable)")
      ->type_name("LIB.so");
  estimators->footer(
      "A plugin is a shared library exporting extern \"C\" void obs_register_estimators(\n"
      "obs::estimators::EstimatorRegistry&); see libestimators/examples/ExamplePlugin.cpp.\n"
      "Example: obs estimators --plugin ./libmy_estimators.so\n");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string message = e.what();
    if (message.empty()) message = e.get_name();
    printError(message + " (run 'obs --help' for usage)");
    return kExitUsage;
  }

  // Under `mpirun -np N` (N > 1) `obs run` runs distributed (obs built with MPI: the launch's
  // ranks share the scene, DistributedScene.cpp). Everything else would run N times into the same
  // files: every rank stops at once with the same exit code (no rank waits for another, so nothing
  // hangs) and rank 0 says why. `-np 1` runs the ordinary program.
  std::optional<obs::MpiSession> mpi;
  bool rank0 = true;
  if (const auto [ranks, rank] = launcherRanks(); ranks > 1) {
    if (!run->parsed() || !obs::Communicator::built()) {
      if (rank == 0)
        printError("launched as " + std::to_string(ranks) + " MPI ranks: " +
                   (obs::Communicator::built() ? std::string("only `obs run` runs distributed")
                                               : std::string("this obs is built without MPI (OBS_WITH_MPI)")) +
                   ", and each rank would do the same work and write the same files; run it without mpirun (or with "
                   "-np 1) and use --threads N for the cores of one machine (docs/performance.md#threads)");
      return kExitError;
    }
    mpi.emplace(argc, argv);
    rank0 = obs::Communicator::world().rank() == 0;
    if (!rank0) {  // progress from rank 0 only
      quiet = true;
      verbose = false;
    }
  }
  // errors: one line from rank 0 (distributed errors reach every rank as the same obs::Error)
  const auto printError = [&](const std::string& message) {
    if (rank0) ::printError(message);
  };

  try {
    // --threads, else $OBS_THREADS, else 1 (obs run and obs mesh)
    const auto setThreadCount = [&] {
      if (threadCount) {
        obs::setThreads(*threadCount);
      } else if (const char* env = std::getenv("OBS_THREADS"); env && *env) {
        char* end = nullptr;
        const long n = std::strtol(env, &end, 10);
        if (*end != '\0' || n < 1 || n > 1024)
          throw obs::Error(std::string("OBS_THREADS=") + env + ": a thread count from 1 to 1024 expected");
        obs::setThreads(static_cast<int>(n));
      }
    };
    if (run->parsed()) {
      setThreadCount();
      obs::setBlasThreads(obs::threads());  // CHOLMOD's BLAS: the run's thread count, not every core
      return runCommand(scene, output, refine, quiet, verbose, runPlugins, overrides, runPlots,
                        compareSchemes, restart, stopAfterStep, partitionLevel,
                        imbalanceTolerance, balanceContact);
    }
    if (check->parsed()) return checkCommand(checkScenes, checkRefine);
    if (sweep->parsed()) {
      sweepOptions.scene = sweepScene;
      sweepOptions.output = sweepOutput;
      return sweepCommand(sweepOptions, sweepVary, sweepQuiet);
    }
    if (meshCmd->parsed()) {
      setThreadCount();
      meshOptions.scene = meshScene;
      if (!meshOutput.empty()) meshOptions.output = meshOutput;
      return meshCommand(meshOptions);
    }
    if (estimators->parsed()) return estimatorsCommand(plugins);
    printError("no command given (run 'obs --help' for usage)");
    return kExitUsage;
  } catch (const obs::drivers::RunInterrupted& e) {
    printError(e.what());
    return kExitInterrupted;
  } catch (const obs::Error& e) {
    printError(e.what());
  } catch (const std::bad_alloc&) {
    printError("out of memory");
  } catch (const std::exception& e) {
    printError(std::string("internal error: ") + e.what());
  } catch (...) {
    printError("internal error: unknown exception");
  }
  return kExitError;
}
