#pragma once
/// \file DynamicScene.hpp
/// `obs run` for scenes with [dynamics]: dynamic frictionless contact of one linear-elastic body
/// with a rigid obstacle, or of several bodies coupled by dual mortar (multi-body scenes), integrated by a scheme of the Newmark family (libobs Newmark.hpp,
/// docs/theory.md#newmark; thesis Sec. 5.2, 5.3), optionally compared with other schemes on the same scene.
///
/// Per scheme: M u'' + A u = f + contact forces from u^0, v^0 ([dynamics] initial_displacement,
/// initial_velocity; Dirichlet components take the prescribed value and velocity 0) with time step
/// tau for `steps` (or ceil(end_time / tau)) steps; every step is a variational inequality solved
/// by TNNMG ([solver] tolerance, max_iterations, pre_smoothing, post_smoothing). The initial state
/// is checked (obs::Error naming the scene line) before the first step.
///
/// Outputs in the output directory:
///  - timeseries.csv (one scheme) or timeseries_<scheme>.csv (comparison): one row per time
///    level n = 0..N with t, step, energy E = 1/2 v'Mv + 1/2 u'Au - f'u, energy_redistributed (E~,
///    schemes with M~; empty otherwise), kinetic/elastic energy, momentum M v, total contact force
///    sum_p F_p nu_p, node counts active for solution / predictor / predictor only / solution only,
///    max penetration, TNNMG iterations, solver and step seconds, and per tracked point k the nearest
///    vertex's normal displacement nu'u, normal velocity nu'v and gap g - nu'u (trackedK_...);
///  - <scene>_NNNNNN.vtu every output_stride steps (and the last) with displacement, velocity,
///    stress, von_mises, boundary_id, gap, normal_displacement, normal_velocity, contact_pressure
///    (s_p = F_p / m_p^C), contact_state, and <scene>.pvd, the collection over time (first scheme
///    only);
///  - summary.json as for static scenes plus "dynamics" (scheme, tau, steps, end time, initial /
///    final energy and their ratio, max penetration, contact-force total variation, mean TNNMG
///    iterations per step, times, tracked vertices with first contact, detachment (gap open again)
///    and release (normal velocity pointing away) times) and, with a comparison,
///    "dynamics_comparison" (the same object per scheme); "mass_assemblies" counts the mass matrices;
///  - a runs.csv row as for static scenes, for the final state of the first scheme;
///  - with [output] plots = true or --plots: PNG figures by scripts/plot_dynamics.py (a missing
///    python3 / matplotlib is a warning).
#include <chrono>
#include <string>
#include <vector>

#include "obs/drivers/RunOptions.hpp"
#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Newmark.hpp"

namespace obs::drivers {

/// The schemes a dynamic scene runs: [dynamics] scheme first, then the ones of compare (all
/// schemes with `compareAll`, the --compare-schemes option), without repetitions.
std::vector<std::string> dynamicSchemes(const Scene& scene, bool compareAll);

/// The time stepper's options for one scheme of the scene: [dynamics] time step, mass, inexact
/// solves and warm start, and the [solver] section by solverConfig (as for a static and an adaptive
/// run); the tracked vertices are the runner's.
NewmarkOptions newmarkOptions(const Scene& scene, const std::string& scheme);

/// Runs the scene (scene.dynamics set, its bodies built and validated): body i of
/// Scene::bodyScenes on grids[i] with leaf mesh meshes[i] and conditions bcs[i], stacked in this
/// order, with the contact model of the scene (SceneSolver.hpp sceneCouplings). `result` holds
/// the mesh figures of runScene, `start` the time the run began. Initial states per body
/// ([[body]] initial_velocity / initial_displacement, default the [dynamics] ones); one .vtu per
/// body and output step (a one-body file: <scene>_NNNNNN.vtu; several bodies:
/// <scene>_<body>_NNNNNN.vtu, parts of the .pvd); tracked points are the nearest vertex of any body
/// (a slave node of a pair reports the normal jump [u]_nu). Checkpoints and --restart of the
/// stacked state with per-body grid identities (docs/checkpoint.md#several-bodies).
RunResult runDynamicScene(const Scene& scene, const std::vector<const mesh::Grid*>& grids,
                          const std::vector<const mesh::Mesh*>& meshes, const std::vector<BoundaryConditions>& bcs,
                          const RunOptions& options, RunResult result, std::chrono::steady_clock::time_point start);

/// The same on the ranks of a distributed run (`mpirun -np N obs run`, docs/architecture.md#distributed-dynamics):
/// body i on grids[i] with the rank's leaf view leaves[i] (its local mesh; bcs[i] its boundary
/// conditions, resolved on coarseMeshes[i], the body's coarse mesh, as the couplings' boundaries),
/// integrated by NewmarkFamily on the DistributedGrids: one body with the scene's obstacle coupling
/// (with friction), or two bodies with one frictionless mortar pair (DistributedMortar and
/// DistributedMultiBody, whose numbering is the stacked one). Every rank holds the same step
/// records; rank 0 writes the time series, the .pvd of the .pvtu files and summary.json (with
/// "ranks", the memory per rank and "balance"), every rank its piece of each .vtu. Checkpoints: one
/// file from all ranks, the state as rows keyed by vertex (docs/checkpoint.md#rows), and --restart
/// from a file of any number of ranks. Collective; errors reach every rank. Refused (obs::Error):
/// other numbers of bodies and couplings.
RunResult runDistributedDynamicScene(const Scene& scene, const std::vector<const DistributedGrid*>& grids,
                                     const std::vector<const DistributedView*>& leaves,
                                     const std::vector<const mesh::Mesh*>& coarseMeshes,
                                     const std::vector<BoundaryConditions>& bcs, const RunOptions& options,
                                     RunResult result, std::chrono::steady_clock::time_point start);

}  // namespace obs::drivers
