#pragma once
/// \file MeshCommand.hpp
/// `obs mesh`: build the mesh of a scene as a hierarchical Grid, refine it uniformly and/or locally
/// at random (reproducibly, from a seed), check the result and report it as JSON: leaf elements per
/// type and level, conformity violations of the leaf view, total volume, the shape quality range
/// (Grid.hpp: minimum corner mean ratio, 1 for a cube corner), coarse cells reoriented, and times.
/// Writes the leaf view (and optionally every level view) as .vtu with the element level, the
/// element quality and the boundary ids.
#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>

namespace obs::drivers {

struct MeshCommandOptions {
  std::filesystem::path scene;                 ///< only its [mesh] section is used
  std::optional<int> uniform;                  ///< uniform refinements (default: [mesh] refine)
  int randomCycles = 0;                        ///< cycles of random local refinement
  double fraction = 0.1;                       ///< share of leaves marked per random cycle
  unsigned seed = 1;                           ///< seed of the random marking
  std::optional<std::filesystem::path> output; ///< directory for .vtu files (none: no files)
  bool levels = false;                         ///< also write every level view
};

/// Runs the command; throws obs::Error on bad input. The returned report is what `obs mesh`
/// prints.
nlohmann::json runMeshCommand(const MeshCommandOptions& options);

}  // namespace obs::drivers
