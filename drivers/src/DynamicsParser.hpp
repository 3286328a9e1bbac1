#pragma once
/// \file DynamicsParser.hpp
/// Parsing of the scene parts that dynamic contact scenes add (internal to the scene parser):
/// the [mesh] generators "ball" and "rounded_block" (libmesh CurvedMeshes.hpp), the [dynamics]
/// section (DynamicsSpec.hpp) and the checks across sections that a dynamic scene needs
/// ([material] density, [contact], a TNNMG [solver]). Messages name file, line, section and key.
#include <string>
#include <vector>

#include "TomlSection.hpp"
#include "obs/drivers/Scene.hpp"

namespace obs::drivers {

/// The [mesh] keys of the curved generators (besides generator, type, cells, refine).
const std::vector<std::string>& curvedMeshKeys();

/// True for "ball" and "rounded_block".
bool isCurvedGenerator(const std::string& generator);

/// Reads generator = "ball" (type: a 3D cell type, cells = n or [n], centre = [x, y, z],
/// radius) or "rounded_block" (type, cells = [nx, ny(, nz)], width, height, depth (3D),
/// arc_radius) into `spec`; keys of the box generator or of the other curved generator are errors.
void parseCurvedMesh(const TomlSection& s, MeshSpec& spec);

/// Reads [dynamics] (see DynamicsSpec.hpp and docs/scenes.md).
DynamicsSpec parseDynamics(const Scene& scene, const toml::value& table);

/// Checks a scene with [dynamics] across sections: [material] density given, a [contact] section,
/// [solver] type tnnmg (the only solver of the time steppers).
void checkDynamicScene(const Scene& scene);

}  // namespace obs::drivers
