#pragma once
/// \file RunSupport.hpp
/// Bookkeeping shared by the three scene runners (RunScene: static, AdaptiveScene, DynamicScene):
/// timing, peak memory and the final runs.csv row.
#include <chrono>
#include <filesystem>
#include <optional>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"

#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/drivers/VtkWriter.hpp"

namespace obs::drivers {

using Clock = std::chrono::steady_clock;

/// Wall seconds since start.
double secondsSince(Clock::time_point start);

/// Peak resident memory of this process so far, MB (0 if unknown).
double peakMemoryMB();

/// Records peak memory and, when the scene has a CSV file, the output and total times and its row
/// (appended to [output] csv, relative to dir unless absolute; the path joins r.outputFiles).
/// outputStart: when the run began writing outputs; start: when the run began.
void recordRunRow(const Scene& scene, const std::filesystem::path& dir, RunResult& r, Clock::time_point outputStart,
                  Clock::time_point start);

/// The bodies of a multi-body scene, built and checked (buildGrid, validateScene,
/// makeBoundaryConditions per body; one dimension for all): their grids, coarse leaf meshes and
/// boundary conditions in the order of Scene::bodies. Errors name the body.
struct BodyGrids {
  std::vector<mesh::Grid> grids;
  std::vector<mesh::Mesh> meshes;
  std::vector<BoundaryConditions> bcs;
  std::vector<const mesh::Grid*> gridPointers() const;
  std::vector<const mesh::Mesh*> meshPointers() const;
};
BodyGrids buildBodyGrids(const Scene& scene, const std::optional<int>& refine);

}  // namespace obs::drivers
