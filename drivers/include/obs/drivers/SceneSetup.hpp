#pragma once
/// \file SceneSetup.hpp
/// Turning a parsed Scene into the inputs of the library: the mesh, the checks that need it, and
/// the boundary conditions. All problems are obs::Errors naming the scene file, line and key.
#include <optional>

#include "obs/drivers/Scene.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/SolverConfig.hpp"

namespace obs::drivers {

/// Upper bound on the number of cells after refinement (a guard against typos like refine = 9).
inline constexpr long long kMaxCells = 50'000'000;

/// Builds the coarse mesh ([mesh] generator or file) as level 0 of a hierarchical mesh::Grid and
/// refines it uniformly `refine` times (Grid::refineUniformly, so the levels exist for multigrid),
/// where `refineOverride` (the --refine option) replaces [mesh] refine when given. Throws if the
/// refined mesh would have more than kMaxCells cells. The run's mesh is grid.leafView().mesh.
mesh::Grid buildGrid(const Scene& scene, std::optional<int> refineOverride = std::nullopt);

/// The leaf mesh of buildGrid (the mesh `obs run` solves on).
mesh::Mesh buildMesh(const Scene& scene, std::optional<int> refineOverride = std::nullopt);

/// Checks the scene against its mesh: boundaries exist, vectors have one entry per coordinate,
/// Dirichlet components exist in the dimension, and the Dirichlet conditions fix every rigid
/// motion (obs::countFreeRigidMotions == 0). With [contact]: the contact boundary exists and has
/// faces, the obstacle fits the dimension (makeObstacle), its gap and direction are valid at every
/// contact vertex, and no Dirichlet vertex of the contact boundary has prescribed values that
/// violate the constraint (checkDirichletContact).
void validateScene(const Scene& scene, const mesh::Mesh& mesh);

/// Checks a multi-body scene without solving: every body as validateScene, equal dimensions, and
/// every [[contact]] pair's boundaries and mortar coupling (the surfaces overlap). Returns a one-line
/// description ("2 bodies, 3D, ... cells, ... vertices, 1 mortar pair with ... constrained slave
/// vertices"); throws obs::Error naming the file, line and body otherwise.
std::string checkMultiBodyScene(const Scene& scene, std::optional<int> refineOverride = std::nullopt);

/// Id of the boundary `ref` on the mesh; throws "file:line: <title> boundary = ... does not exist in
/// the mesh (available boundaries: ...)" otherwise.
int boundaryIdOf(const Scene& scene, const mesh::Mesh& mesh, const BoundaryRef& ref, const std::string& title);

/// Boundary id of [contact] boundary; throws (naming the file, line and the available boundaries)
/// if it does not exist or has no boundary faces.
int contactBoundaryId(const Scene& scene, const mesh::Mesh& mesh);

/// The potential contact nodes of [contact] on the mesh for the given obstacle; errors of the
/// obstacle at a vertex (NaN gap, zero direction) name the scene line.
ContactSet makeContactSet(const Scene& scene, const mesh::Mesh& mesh, const Obstacle& obstacle);

/// Throws if a contact vertex whose constrained displacement component nu.u is fully prescribed
/// by [[dirichlet]] has nu.u_D > g (the data violate the constraint); the message names the vertex,
/// its coordinates, nu.u_D, the gap and the [[dirichlet]] entry.
void checkDirichletContact(const Scene& scene, const mesh::Mesh& mesh, const ContactSet& contact);

/// The solver configuration of the scene's [solver] section (docs/scenes.md#solver), one function
/// for the static, adaptive and dynamic runs: the kind named by type (TNNMG when type names no
/// contact solver: "direct" and "multigrid" solve without contact, and a linear multigrid reads the
/// tolerance, the iteration cap and the multigrid options), every option given, SolverConfig's
/// defaults for the others. Which kinds a run accepts is the runner's check.
SolverConfig solverConfig(const Scene& scene);

/// The boundary conditions of a validated scene with the expressions' t set to `t` (0: the static
/// and dynamic runs; the load parameter i/N of increment i of [loading] steps = N). The fields
/// evaluate the scene's expressions and throw obs::Error (naming the key) if a value is not finite.
BoundaryConditions makeBoundaryConditions(const Scene& scene, const mesh::Mesh& mesh, double t = 0);

}  // namespace obs::drivers
