#pragma once
/// \file SceneSetup.hpp
/// Turning a parsed Scene into the inputs of the library: the mesh, the checks that need it, and
/// the boundary conditions. All problems are obs::Errors naming the scene file, line and key.
#include <optional>

#include "obs/drivers/Scene.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BoundaryConditions.hpp"

namespace obs::drivers {

/// Upper bound on the number of cells after refinement (a guard against typos like refine = 9).
inline constexpr long long kMaxCells = 50'000'000;

/// Builds the coarse mesh ([mesh] generator or file) and refines it uniformly `refine` times,
/// where `refineOverride` (the --refine option) replaces [mesh] refine when given. Throws if the
/// refined mesh would have more than kMaxCells cells.
mesh::Mesh buildMesh(const Scene& scene, std::optional<int> refineOverride = std::nullopt);

/// Checks the scene against its mesh: boundaries exist, vectors have one entry per coordinate,
/// Dirichlet components exist in the dimension, and the Dirichlet conditions fix every rigid
/// motion (obs::countFreeRigidMotions == 0).
void validateScene(const Scene& scene, const mesh::Mesh& mesh);

/// The boundary conditions of a validated scene at time t = 0. The fields evaluate the scene's
/// expressions and throw obs::Error (naming the key) if a value is not finite.
BoundaryConditions makeBoundaryConditions(const Scene& scene, const mesh::Mesh& mesh);

}  // namespace obs::drivers
