#pragma once
/// \file RunScene.hpp
/// `obs run`: read and validate a scene, build the grid of each of its bodies (Scene::bodyScenes:
/// coarse mesh + uniform refinements as a mesh::Grid), then the runner of its kind: [adaptivity]
/// (AdaptiveScene.hpp), [dynamics] (DynamicScene.hpp) or the static solve of the linear-elastic or
/// contact problem (SceneSolver.hpp), and write the outputs in the scene's layout (one-body file:
/// <output>/<scene name>.vtu; several bodies: one .vtu per body and the .pvd; summary.json and the
/// runs.csv row). A solver that stops at max_iterations without converging writes the outputs
/// (summary.json says converged: false) and then throws obs::Error.
#include <filesystem>
#include <string>

#include "obs/drivers/RunOptions.hpp"
#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/mesh/Grid.hpp"

namespace obs::drivers {

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
