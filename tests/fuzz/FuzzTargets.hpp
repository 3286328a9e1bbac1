#pragma once
/// \file FuzzTargets.hpp
/// The three parser fuzz targets. Each takes one input and either returns (the input was
/// accepted) or throws obs::Error (it was rejected with a message); anything else, a crash, a
/// hang or running out of memory, is a defect that the fuzz driver (fuzz_parsers.cpp) reports.
#include <filesystem>
#include <string>

namespace obs::fuzz {

enum class Accepted {
  Fully,       ///< parsed and, for scenes, validated on its mesh as `obs check` does
  ParsedOnly,  ///< a valid scene whose mesh exceeds kMaxFuzzCells (not built, to keep runs short)
};

/// Cells up to which the scene target builds and validates a scene's mesh (refinement levels
/// beyond it are dropped, as `obs check --refine K` would).
inline constexpr double kMaxFuzzCells = 4096;

/// A scene file: parseSceneString (relative mesh paths resolved in `directory`), then the mesh
/// (buildMesh) and validateScene, i.e. `obs check`.
Accepted runScene(const std::string& text, const std::filesystem::path& directory);

/// An expression: Expression::parse, then evaluation at a few points (any value, NaN included,
/// is a valid result of an expression; the scene layer rejects non-finite data).
Accepted runExpression(const std::string& text);

/// A .msh file: readGmshString, then the hierarchical grid (its coarse-mesh checks) and, for small
/// meshes, one uniform refinement; then readGmshGroupsString and the grid of each of (up to 4) cell
/// groups extracted with extractCellGroup.
Accepted runGmsh(const std::string& text);

}  // namespace obs::fuzz
