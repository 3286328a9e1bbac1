#include "RunSupport.hpp"

#include <sys/resource.h>

#include <fstream>

#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double peakMemoryMB() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

void recordRunRow(const Scene& scene, const std::filesystem::path& dir, RunResult& r, Clock::time_point outputStart,
                  Clock::time_point start) {
  r.peakMemoryMB = peakMemoryMB();
  if (scene.output.csv.empty()) return;
  const auto path = scene.output.csv.is_absolute() ? scene.output.csv : dir / scene.output.csv;
  r.outputSeconds = secondsSince(outputStart);
  r.totalSeconds = secondsSince(start);
  appendCsvRow(path, r);
  r.outputFiles.push_back(path);
}

std::vector<const mesh::Grid*> BodyGrids::gridPointers() const {
  std::vector<const mesh::Grid*> p;
  for (const mesh::Grid& g : grids) p.push_back(&g);
  return p;
}

std::vector<const mesh::Mesh*> BodyGrids::meshPointers() const {
  std::vector<const mesh::Mesh*> p;
  for (const mesh::Mesh& m : meshes) p.push_back(&m);
  return p;
}

BodyGrids buildBodyGrids(const Scene& scene, const std::optional<int>& refine) {
  BodyGrids b;
  b.grids.reserve(scene.bodies.size());
  for (const Scene& body : scene.bodies) {
    try {
      b.grids.push_back(buildGrid(body, refine));
      b.meshes.push_back(b.grids.back().leafView().mesh);
      validateScene(body, b.meshes.back());
      b.bcs.push_back(makeBoundaryConditions(body, b.meshes.back()));
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (in [[body]] '" + body.name + "')");
    }
    if (b.meshes.back().dimension() != b.meshes.front().dimension())
      throw Error(scene.where(body.bodyLine) + "[[body]] '" + body.name + "' has dimension " +
                  std::to_string(b.meshes.back().dimension()) + ", body '" + scene.bodies.front().name + "' " +
                  std::to_string(b.meshes.front().dimension()) + " (all bodies must have the same dimension)");
  }
  return b;
}

}  // namespace obs::drivers
