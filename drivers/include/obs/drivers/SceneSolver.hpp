#pragma once
/// \file SceneSolver.hpp
/// Solving a validated scene on its bodies' grids (the solve step of `obs run`), one body or several:
///  - without contact (one body): linear elasticity, [solver] type "direct" (CHOLMOD, default) or
///    "multigrid" (V-cycle iteration of LinearMultigrid on the grid's levels);
///  - with contact: the ContactModel of the bodies, their obstacle couplings and mortar pairs
///    (docs/theory.md#signorini, docs/theory.md#dual-mortar), min 1/2 u'Au - b'u subject to the
///    nodal constraints, with "tnnmg" (default; docs/theory.md#tnnmg, on the grid hierarchies),
///    "pdas" (primal-dual active set with CHOLMOD) or "pgs" (projected block Gauss-Seidel), then
///    the contact quantities (computeContactOutputs) and the contact point fields of the .vtu.
/// Solver failures (NaN, divergence, stagnation) are obs::Errors naming the scene and solver; an
/// iteration that reaches max_iterations returns converged = false (the caller decides).
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs::drivers {

/// Receives one line per block of solver iterations: every iteration up to 10, then every 10th up
/// to 100, every 100th up to 1000, ... (the `obs run --verbose` lines).
using IterationProgress = std::function<void(const std::string&)>;

/// True for the iterations that iterationProgress reports (1..10, 20, 30, ..., 100, 200, ...).
bool reportsIteration(int iteration);

/// Called once the system is assembled (before an iterative solve starts; after the solve for
/// "direct", which assembles and factorises in one call) with the solution's dofs, freeDofs and
/// assemblySeconds filled in.
using AssembledCallback = std::function<void(const ElasticitySolution&)>;

/// The solution of a scene, one body or several (Scene::bodyScenes): per body the displacement
/// (stresses recovered) and the contact point fields of its .vtu, the solver report, and the
/// contact report in the layout of the scene file: `contact` for a one-body file with [contact]
/// (summary.json "contact"), `pairs` for a multi-body file, one per coupling (summary.json "pairs").
struct SceneSolution {
  std::vector<ElasticitySolution> bodies;
  /// Per body: gap, normal_displacement, contact_pressure, contact_state, constraint_direction
  /// (and contact_force for multi-body files; SolutionFields.hpp documents them); empty without contact.
  std::vector<std::vector<Field>> contactFields;
  SolverReport solver;
  std::optional<ContactReport> contact;
  std::vector<PairReport> pairs;
  std::vector<IncrementReport> increments;  ///< [loading]: per load increment
  long long dofs = 0, freeDofs = 0;
  double assemblySeconds = 0, solveSeconds = 0;
};

/// Solves a validated scene on its bodies' grids, leaf meshes and boundary conditions (in the
/// order of Scene::bodyScenes). With contact the problem is the ContactModel of the bodies and
/// couplings (sceneCouplings, makeContactModel), solved by the [solver] (TNNMG on the block-stacked hierarchies by
/// default); without contact (one body) linear elasticity by CHOLMOD or linear multigrid.
SceneSolution solveScene(const Scene& scene, const std::vector<const mesh::Grid*>& grids,
                         const std::vector<const mesh::Mesh*>& meshes, const std::vector<BoundaryConditions>& bcs,
                         const IterationProgress& progress = {}, const AssembledCallback& assembled = {});

/// The contact model of a scene without meshes (ContactModelSpec), resolved once for every runner:
/// the bodies (Scene::bodyScenes with their boundary conditions), then the couplings in the order
/// every runner uses: the [[contact]] mortar pairs in scene order, then the rigid obstacles of single
/// bodies (a one-body scene: its [contact]), whose contact sets makeContactSet makes (with its
/// checks and the scene's lines in messages). Static and dynamic runs build the model with
/// makeContactModel on the bodies' meshes; the adaptive loop keeps the specification and builds
/// the model on every step's leaf views.
struct SceneCouplings {
  ContactModelSpec spec;
  std::vector<std::unique_ptr<Obstacle>> obstacles;  ///< of the obstacle couplings (owned here)
  /// Per coupling: the side labels "body:boundary" of the slave and master side ("obstacle <type>").
  std::vector<std::pair<std::string, std::string>> sides;
};

/// The SceneCouplings of a scene on its bodies' meshes (boundaries are resolved on them; obs::Error
/// naming the scene line if one does not exist) with the boundary conditions `bcs` (kept by
/// pointer: they must outlive the specification's use).
SceneCouplings sceneCouplings(const Scene& scene, const std::vector<const mesh::Mesh*>& meshes,
                              const std::vector<BoundaryConditions>& bcs);

/// The report of one contact pair (summary.json "pairs") from the model's CouplingRecord, with the
/// side labels "body:boundary" (or "obstacle <type>") and the radius of the contact zone (3D:
/// sqrt(area / pi), 2D: area / 2); shared by the static and the adaptive runner.
PairReport pairReport(const CouplingRecord& record, const std::string& slave, const std::string& master, int dim);

}  // namespace obs::drivers
