#pragma once
/// \file RunOptions.hpp
/// The options of a run that do not come from the scene file (`obs run` flags, progress callbacks),
/// shared by the static (RunScene.hpp), adaptive (AdaptiveScene.hpp) and dynamic (DynamicScene.hpp)
/// runners, and RunInterrupted, the early stop of the adaptive and dynamic ones.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

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
  /// `--partition-level L`: distributed runs (mpirun -np N, N > 1) replicate the levels below L
  /// and distribute the rest; 0 distributes the coarse level too, solved by hypre
  /// (docs/architecture.md#distributed-coarse-solve). Default: the coarsest level from 1 on with 8
  /// cells per rank. No effect on one process.
  std::optional<int> partitionLevel = {};
  /// `--imbalance-tolerance T`: distributed adaptive runs repartition the grid after a refinement
  /// when the owned leaves of the largest rank exceed the mean by more than the factor T (>= 1;
  /// `inf`: never; docs/architecture.md#load-balancing). Default: 1.1.
  std::optional<double> imbalanceTolerance = {};
  /// `--balance-contact`: distributed adaptive runs balance the contact boundary's faces as well as
  /// the leaves (METIS multi-constraint; docs/architecture.md#load-balancing). Default: the leaves.
  bool balanceContact = false;
};

/// A run that stopped early (SIGINT/SIGTERM, RunOptions::stopAfterStep); the message says where it
/// stopped, names the checkpoint and how to continue (a scheme comparison stops without one). `obs
/// run` exits with 3.
class RunInterrupted : public Error {
public:
  using Error::Error;
};

}  // namespace obs::drivers
