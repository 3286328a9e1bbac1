/// \file FuzzTargets.cpp
/// The fuzz targets of FuzzTargets.hpp: thin wrappers around the public parsing entry points.
#include "FuzzTargets.hpp"

#include <algorithm>
#include <limits>

#include "obs/drivers/Expression.hpp"
#include "obs/drivers/MeshSize.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Gmsh.hpp"
#include "obs/mesh/Grid.hpp"

namespace obs::fuzz {

Accepted runScene(const std::string& text, const std::filesystem::path& directory) {
  const drivers::Scene scene = drivers::parseSceneString(text, "fuzz.toml", directory);
  const drivers::MeshSpec& spec = scene.mesh;
  double coarse = drivers::generatedCoarseCells(spec);
  mesh::CellType type = spec.cellType;
  if (spec.source == drivers::MeshSpec::Source::File) {
    const mesh::Mesh m = drivers::buildMesh(scene, 0);
    coarse = static_cast<double>(m.numCells());
    type = m.dimension() == 2 ? mesh::CellType::Quadrilateral : mesh::CellType::Pyramid;
  }
  if (coarse > kMaxFuzzCells) return Accepted::ParsedOnly;
  int refine = spec.refine;
  while (refine > 0 && drivers::refinedCells(coarse, type, refine) > kMaxFuzzCells) --refine;
  const mesh::Mesh m = drivers::buildMesh(scene, refine);
  drivers::validateScene(scene, m);
  return Accepted::Fully;
}

Accepted runExpression(const std::string& text) {
  const drivers::Expression e = drivers::Expression::parse(text);
  constexpr double big = std::numeric_limits<double>::max();
  const double points[][4] = {{0, 0, 0, 0},
                              {1, -2, 3, 0.5},
                              {-1e-300, 1e300, big, -big},
                              {std::numeric_limits<double>::quiet_NaN(), 0, 1, 2}};
  volatile double sink = 0;
  for (const auto& p : points) sink = sink + e(p[0], p[1], p[2], p[3]);
  if (e.isConstant()) sink = sink + e.value();
  return Accepted::Fully;
}

Accepted runGmsh(const std::string& text) {
  const mesh::Mesh m = mesh::readGmshString(text, "fuzz.msh");
  mesh::Grid grid(m);
  if (m.numCells() <= 512) grid.refineUniformly();
  volatile auto cells = grid.leafMesh().numCells();
  (void)cells;
  // the bodies of the file's cell groups (docs/scenes.md#gmsh-bodies), each as a grid of its own
  const mesh::GmshMesh file = mesh::readGmshGroupsString(text, "fuzz.msh");
  int bodies = 0;
  for (const mesh::GmshPhysicalGroup& g : file.groups)
    if (g.dimension == m.dimension() && g.elements > 0 && bodies++ < 4) {
      const mesh::Mesh body = mesh::extractCellGroup(file, g.tag);
      cells = mesh::Grid(body).leafMesh().numCells();
    }
  return Accepted::Fully;
}

}  // namespace obs::fuzz
