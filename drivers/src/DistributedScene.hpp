#pragma once
/// \file DistributedScene.hpp
/// `mpirun -np N obs run scene.toml` with N > 1 (docs/architecture.md#distributed-runner): a static
/// one-body scene on a DistributedGrid, solved by distributed TNNMG (contact against an obstacle, with
/// friction inside solveFriction's fixed point) or distributed multigrid (linear elasticity); or a
/// static two-body scene with one mortar pair, each body a DistributedGrid, solved by TNNMG with
/// the stacked distributed multigrid correction (DistributedMultiBody,
/// docs/architecture.md#distributed-two-body; with friction as for one body), reported per body
/// and pair. Every rank calls it;
/// rank 0 reports progress and writes summary.json (figures reduced over the ranks), every rank
/// writes its piece of the solution (.vtu of its owned cells) and rank 0 the .pvtu that joins them.
/// Errors reach every rank as the same obs::Error (Communicator::collective), so every rank exits
/// with the same code and nothing hangs. Other scene kinds are refused with an error naming what
/// is not distributed yet.
#include "obs/drivers/RunOptions.hpp"
#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/obs/Communicator.hpp"

namespace obs::drivers {

RunResult runDistributedScene(const Scene& scene, const RunOptions& options, const Communicator& comm);

}  // namespace obs::drivers
