#pragma once
/// \file RunScene.hpp
/// `obs run`: read and validate a scene, build the grid (coarse mesh + uniform refinements as a
/// mesh::Grid), solve the linear-elastic or contact problem (SceneSolver.hpp) and write the outputs
/// (<output>/<scene name>.vtu, <output>/summary.json, optional CSV row). A solver that stops at
/// max_iterations without converging writes the outputs (summary.json says converged: false) and
/// then throws obs::Error.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

struct RunOptions {
  std::optional<std::filesystem::path> outputDirectory;  ///< replaces [output] directory
  std::optional<int> refine;                             ///< replaces [mesh] refine
  /// Receives one short line per stage ("mesh built: ..."); nothing is printed by runScene itself.
  std::function<void(const std::string&)> progress;
  /// Receives one line per block of solver iterations (`obs run --verbose`); see SceneSolver.hpp.
  std::function<void(const std::string&)> iterationProgress = {};
  /// `obs run --set section.key=value` overrides (SceneParser.hpp), applied when the file is read.
  std::vector<std::string> overrides = {};
  /// [adaptivity] runs: one line per step (AdaptiveScene.hpp; `obs run` prints them on stderr).
  std::function<void(const std::string&)> stepProgress = {};
  bool plots = false;  ///< `--plots`: as [output] plots = true
  /// `--compare-schemes`: a [dynamics] scene also runs every other scheme (DynamicScene.hpp).
  bool compareSchemes = false;
  /// `--restart FILE.h5`: a [dynamics] run continues from this checkpoint (docs/checkpoint.md); the
  /// scene and grid must be those it was written for, the output directory must hold the outputs
  /// of the interrupted run.
  std::optional<std::filesystem::path> restart = {};
  /// `--stop-after-step K`: a [dynamics] run stops after time step K (< the scene's steps) with a
  /// checkpoint, as on SIGINT/SIGTERM (RunInterrupted).
  std::optional<int> stopAfterStep = {};
};

/// A run that stopped early (SIGINT/SIGTERM, RunOptions::stopAfterStep); the message says where it
/// stopped, names the checkpoint and how to continue (a scheme comparison stops without one). `obs
/// run` exits with 3.
class RunInterrupted : public Error {
public:
  using Error::Error;
};

/// Runs the scene file; throws obs::Error on any problem (invalid scene, solver failure, I/O).
RunResult runScene(const std::filesystem::path& sceneFile, const RunOptions& options = {});

/// Runs an already parsed scene.
RunResult runScene(const Scene& scene, const RunOptions& options = {});

/// The warning runScene gives (through RunOptions::stepProgress, on stderr in `obs run`) when a
/// static or dynamic scene solved by TNNMG or linear multigrid has a one-level grid (a mesh file
/// or generator without refine): the multigrid correction is then a direct solve, refactorised at
/// every active-set change, i.e. a nonsmooth Newton method with the cost of a sparse
/// factorisation per change (docs/reliability.md). Empty if there is nothing to warn about.
std::string singleLevelWarning(const Scene& scene, const mesh::Grid& grid);
/// "warning: ..." if [material] formulation = "bbar" on a mesh of simplices only (where it changes
/// nothing), else "".
std::string bbarWarning(const Scene& scene, const mesh::Mesh& mesh);

}  // namespace obs::drivers
