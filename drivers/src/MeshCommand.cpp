#include "obs/drivers/MeshCommand.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <random>

#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs::drivers {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// Boundary id per vertex: the largest id of the boundary faces touching it, -1 inside.
std::vector<double> vertexBoundaryIds(const mesh::Mesh& m) {
  std::vector<double> ids(m.numVertices(), -1.0);
  for (mesh::Index f = 0; f < m.numBoundaryFaces(); ++f)
    for (mesh::Index v : m.boundaryFaceVertices(f))
      ids[v] = std::max(ids[v], static_cast<double>(m.boundaryFaceId(f)));
  return ids;
}

void writeView(const std::filesystem::path& path, const mesh::Grid& grid, const mesh::GridView& view) {
  std::vector<double> level, quality;
  std::vector<mesh::Point> corners;
  for (std::size_t c = 0; c < view.elements.size(); ++c) {
    const mesh::Index e = view.elements[c];
    level.push_back(grid.level(e));
    corners.clear();
    for (mesh::Index v : grid.vertices(e)) corners.push_back(grid.vertex(v));
    quality.push_back(mesh::shapeQuality(grid.type(e), corners));
  }
  const Field pointFields[] = {{"boundary_id", 1, vertexBoundaryIds(view.mesh), true}};
  const Field cellFields[] = {{"level", 1, level, true}, {"quality", 1, quality, false}};
  writeVtu(path, view.mesh, pointFields, cellFields);
}

}  // namespace

nlohmann::json runMeshCommand(const MeshCommandOptions& options) {
  if (options.randomCycles < 0) throw Error("obs mesh: --random-cycles must be >= 0");
  if (!(options.fraction > 0 && options.fraction <= 1))
    throw Error("obs mesh: --fraction must lie in (0, 1]");
  const Scene scene = parseScene(options.scene);
  if (scene.multiBody())
    throw Error(scene.fileName + ": obs mesh works on one-body scenes; this scene has " +
                std::to_string(scene.bodies.size()) + " [[body]] entries (obs check validates all of them)");
  const int uniform = options.uniform.value_or(scene.mesh.refine);
  if (uniform < 0 || uniform > 12) throw Error("obs mesh: --uniform must lie in [0, 12]");

  auto t0 = Clock::now();
  mesh::Grid grid(buildMesh(scene, 0));
  const double coarseSeconds = since(t0);

  t0 = Clock::now();
  for (int k = 0; k < uniform; ++k) grid.refineUniformly(threads());
  const double uniformSeconds = since(t0);

  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  double randomSeconds = 0;
  for (int c = 0; c < options.randomCycles; ++c) {
    for (mesh::Index e : grid.leafElements())
      if (U(rng) < options.fraction) grid.mark(e);
    t0 = Clock::now();
    grid.adapt(threads());
    randomSeconds += since(t0);
  }

  t0 = Clock::now();
  const mesh::GridView leaf = grid.leafView();
  const mesh::ConformityReport conformity = mesh::checkConformity(leaf.mesh);
  double qmin = std::numeric_limits<double>::infinity(), qmax = 0;
  std::vector<mesh::Point> corners;
  nlohmann::json perType = nlohmann::json::object(), perLevel = nlohmann::json::object();
  mesh::Index inverted = 0, green = 0;
  for (mesh::Index e : leaf.elements) {
    corners.clear();
    for (mesh::Index v : grid.vertices(e)) corners.push_back(grid.vertex(v));
    const double q = mesh::shapeQuality(grid.type(e), corners);
    qmin = std::min(qmin, q);
    qmax = std::max(qmax, q);
    if (q <= 0) ++inverted;
    if (grid.isGreen(e)) ++green;
    const std::string type(mesh::name(grid.type(e)));
    perType[type] = perType.value(type, 0) + 1;
    const std::string level = std::to_string(grid.level(e));
    perLevel[level] = perLevel.value(level, 0) + 1;
  }
  const double volume = mesh::totalVolume(leaf.mesh);
  const double checkSeconds = since(t0);

  nlohmann::json report;
  report["scene"] = scene.fileName;
  report["dimension"] = grid.dimension();
  report["levels"] = grid.maxLevel() + 1;
  report["leaf_elements"] = leaf.mesh.numCells();
  report["vertices"] = leaf.mesh.numVertices();
  report["leaf_elements_per_type"] = perType;
  report["leaf_elements_per_level"] = perLevel;
  report["green_leaf_elements"] = green;
  report["refinement"] = {{"uniform", uniform},
                          {"random_cycles", options.randomCycles},
                          {"random_fraction", options.fraction},
                          {"seed", options.seed}};
  report["conformity"] = {{"conforming", conformity.conforming()},
                          {"interior_faces", conformity.interiorFaces},
                          {"boundary_faces", conformity.boundaryFaces},
                          {"non_manifold_faces", conformity.nonManifoldFaces},
                          {"hanging_faces", conformity.hangingFaces},
                          {"unmatched_boundary_faces", conformity.unmatchedBoundaryFaces},
                          {"inverted_faces", conformity.misorientedFaces},
                          {"inverted_elements", inverted}};
  report["volume"] = volume;
  report["quality"] = {{"measure", "minimum corner mean ratio d det(J)^(2/d)/|J|_F^2 (1 = cube corner)"},
                       {"min", qmin},
                       {"max", qmax}};
  report["coarse_cells_reoriented"] = grid.reorientedCells();
  report["threads"] = threads();
  report["times_s"] = {{"coarse", coarseSeconds},
                       {"uniform", uniformSeconds},
                       {"random", randomSeconds},
                       {"check", checkSeconds}};

  if (options.output) {
    std::error_code ec;
    std::filesystem::create_directories(*options.output, ec);
    if (ec) throw Error(options.output->string() + ": cannot create the output directory (" + ec.message() + ")");
    nlohmann::json files = nlohmann::json::array();
    const auto leafPath = *options.output / (scene.name + "_leaf.vtu");
    writeView(leafPath, grid, leaf);
    files.push_back(leafPath.string());
    if (options.levels)
      for (int l = 0; l <= grid.maxLevel(); ++l) {
        const auto path = *options.output / (scene.name + "_level" + std::to_string(l) + ".vtu");
        writeView(path, grid, grid.levelView(l));
        files.push_back(path.string());
      }
    report["output_files"] = files;
  }
  return report;
}

}  // namespace obs::drivers
