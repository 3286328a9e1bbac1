#pragma once
/// \file SceneParser.hpp
/// Reading scene files (TOML, reference in docs/scenes.md) into a Scene.
///
/// Everything the file alone can reveal is checked here: TOML syntax, unknown sections and keys,
/// value types, ranges (E > 0, 0 <= nu < 0.5, refine >= 0, cells >= 1, lower < upper), known cell
/// types and generators, expression syntax, existence of mesh files. Checks that need the mesh
/// (boundary names, vector lengths in a mesh file's dimension, rigid motions) are done by
/// validateScene in SceneSetup.hpp. Every problem is an obs::Error with a one-line message
///   "<file>:<line>: [section] key ...", e.g. "cantilever.toml:12: [material] nu = 0.7 must lie in
///   [0, 0.5)".
#include <filesystem>
#include <string>
#include <vector>

#include "obs/drivers/Scene.hpp"

namespace obs::drivers {

/// Parses the scene file at `file`; relative mesh paths are resolved against its directory.
/// `overrides` ("section.key=value", `obs run --set`) replace or add keys before the checks;
/// messages about such a value say "<file> (from --set): " instead of a line.
Scene parseScene(const std::filesystem::path& file, const std::vector<std::string>& overrides = {});

/// Parses scene text held in memory. `fileName` names it in messages (and gives the scene name),
/// `directory` resolves relative mesh paths.
Scene parseSceneString(const std::string& text, const std::string& fileName,
                       const std::filesystem::path& directory,
                       const std::vector<std::string>& overrides = {});

}  // namespace obs::drivers
