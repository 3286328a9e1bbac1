#pragma once
/// \file AdaptiveScene.hpp
/// `obs run` for a scene with [adaptivity] (AdaptivitySpec.hpp, docs/scenes.md): the adaptive loop
/// solve -> estimate -> mark -> refine of libestimators (AdaptiveLoop.hpp; thesis Sec. 4.1, 4.2;
/// docs/theory.md#adaptive-loop) on the grids of the scene's bodies (Scene::bodyScenes: [mesh] of a
/// one-body file, or each [[body]]; the cells of all bodies marked together) and its couplings
/// (sceneCouplings), with TNNMG or the primal-dual active set method from [solver] (contact scenes;
/// without contact the bodies are solved directly with CHOLMOD), the estimator, marking and
/// stopping rules of [adaptivity] and, for one body against an obstacle, an optional analytic
/// reference (punch, wedge, Hertz: AnalyticContact.hpp, parameters taken from [contact] and
/// [material]). Several bodies write step_NNN_<body>.vtu (parts of the .pvd) and summary.json
/// "bodies" and "pairs" instead of the one-body files below (OutputLayout).
///
/// Outputs in the output directory:
///   steps.csv      one row per step: step, cells, vertices, unknowns, potential/actual/semi/full
///                  contact vertices, eta, each eta_k (the estimator's contributions), eoc
///                  (docs/theory.md#eoc, on the vertex count), solver, iterations, converged,
///                  solver/estimator/
///                  refinement/transfer seconds, marked cells, and the reference columns load,
///                  pressure_error (docs/theory.md#pressure-error), radius, exact_radius, radius_error,
///                  centre_pressure, exact_centre_pressure, centre_error, nodal_pressure_error (the
///                  discrete variant sqrt(sum m_p (s_p - p(x_p))^2 / sum m_p p(x_p)^2) over the potential
///                  contact vertices with 0 < p < inf, P the computed load), and
///                  nodal_pressure_error_fixed_load (the same with P = [adaptivity] reference_load);
///                  empty where not applicable;
///   pressure.csv   contact scenes, last step: one row per potential contact vertex sorted by s
///                  (x, y, z, s, s_p, exact_p, m_p): s the signed tangential coordinate from the
///                  reference centre in 2D, the radial distance in 3D (centre: the reference's, else
///                  the mean of the potential contact vertices); exact_p (for the computed load)
///                  empty without a reference; m_p the lumped boundary mass;
///   pressure_NNN.csv  the same for every step k = NNN with [adaptivity] pressure = "every";
///   step_NNN.vtu + <scene name>.pvd   vtk = "every" (all steps) or "last": displacement, stress,
///                  von_mises, boundary_id, contact_pressure (s_p), node_class (0 none, 1 potential,
///                  2 semi, 3 full contact), the estimator's vertex fields (eta_k as eta_{k,p}, eta,
///                  ...), cell data stress, von_mises, indicator (eta_e), marked (1 if refined after
///                  the step), cell_<eta_k> (eta_{k,e});
///   summary.json   as for a static run, describing the final step, plus "adaptivity": the options
///                  and "steps" (the step records as in steps.csv);
///   runs.csv       ([output] csv) one row describing the final step;
///   PNG plots      with [output] plots = true or RunOptions::plots: scripts/plot_adaptivity.py
///                  (python3 + matplotlib; if either is missing a warning line, not an error).
/// Progress: RunOptions::progress gets the usual lines, RunOptions::stepProgress one line per step.
/// Checkpoints (docs/checkpoint.md#adaptive-runs), the same for one body and several:
///   checkpoint.h5  after step k (its refinement done) on the [output] checkpoint schedule (every N
///                  solves / S seconds), at RunOptions::stopAfterStep and on SIGINT/SIGTERM (the
///                  last two then throw RunInterrupted); RunOptions::restart continues such a run
///                  with step k + 1 into its output directory, with the same outputs, bit for bit
///                  (wall times aside), as a run that was never interrupted.
#include <chrono>

#include "obs/drivers/RunOptions.hpp"
#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/DistributedGrid.hpp"

namespace obs::drivers {

/// Runs a scene with [adaptivity] (see the file comment); throws obs::Error like runScene.
RunResult runAdaptiveScene(const Scene& scene, const RunOptions& options);

/// The same on the ranks of a distributed run (`mpirun -np N obs run`,
/// docs/architecture.md#distributed-adaptivity): one body against the scene's obstacle, or two
/// bodies with the scene's one mortar pair, by estimators::DistributedAdaptiveLoop; `grids` (refined
/// in place), `bcs` and `coarseMeshes` (on which the boundaries were resolved) per body in the
/// scene's order. Every rank holds the same step records (the reference errors over all ranks);
/// rank 0 writes steps.csv, balance.csv (per step the owned cells and contact nodes per rank,
/// summed over the bodies: largest, mean, imbalance; the leaves each rank's grids hold: largest,
/// mean), the .pvd of the .pvtu files and summary.json (with "ranks", the memory per rank and
/// "balance" of the last step; several bodies: "bodies" and "pairs"), every rank its piece of each
/// written step of each body. Checkpoints and --restart as docs/checkpoint.md#distributed-adaptive-runs
/// describes. Collective; errors reach every rank.
RunResult runDistributedAdaptiveScene(const Scene& scene, const std::vector<DistributedGrid*>& grids,
                                      const std::vector<BoundaryConditions>& bcs,
                                      const std::vector<const mesh::Mesh*>& coarseMeshes, const RunOptions& options,
                                      RunResult result, std::chrono::steady_clock::time_point start);

/// The loop options of the scene's [adaptivity] and [solver] sections (the solver by solverConfig,
/// as for a static and a dynamic run); `contact`: the scene has a contact coupling, whose solver
/// must then be tnnmg or pdas (obs::Error naming the [solver] line otherwise).
estimators::AdaptiveLoopOptions adaptiveLoopOptions(const Scene& scene, bool contact);

/// The header of steps.csv for the given contribution names (without newline).
std::string stepsCsvHeader(const std::vector<std::string>& contributions);

}  // namespace obs::drivers
