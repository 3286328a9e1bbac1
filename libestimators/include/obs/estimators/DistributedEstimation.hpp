#pragma once
/// \file DistributedEstimation.hpp
/// Estimation and marking on ranks (docs/architecture.md#distributed-estimation): the building
/// blocks of the adaptive loop on a distributed grid.
///
/// Estimation. A rank holds its owned cells and one layer of ghost cells around them (every cell
/// sharing a vertex with an owned one; DistributedGrid). Every piece of an owned cell's indicator
/// lives on that closure: the vertex patches of its corners (h_p, the element and face pieces),
/// the faces with their neighbours (the jumps), the contact nodes of its faces. So an estimator
/// run on the rank's local mesh, with the displacement and the contact data current on the ghost
/// vertices, gives the owned cells' indicators of one process; estimateOwned() keeps those and
/// sums the contributions eta_k^2 and eta^2 over the owned cells of all ranks.
///
/// Marking. Every strategy of Marking.hpp orders the cells by decreasing indicator, equal
/// indicators by a key per cell that is the same on every rank that holds the cell (serially: the
/// cell number). markOwned() computes the strategy's thresholds by reductions: the mean and the
/// maximum directly; for `fraction` and `doerfler` the indicator value at which the greedy selection
/// stops, by bisection over the ordered bit patterns of the non-negative doubles (64 reductions of
/// counts or sums), then the cells of that value it takes by bisection over the keys. The marked
/// set is therefore the one-process set of the same indicators and keys, whatever the rank count,
/// up to the rounding of sums over ranks (another order than one process's): a cell within
/// rounding of the mean threshold, or a doerfler greedy sum within rounding of its goal, can be
/// decided the other way.
#include <cstdint>
#include <span>
#include <vector>

#include "obs/estimators/Estimator.hpp"
#include "obs/estimators/Marking.hpp"
#include "obs/obs/Communicator.hpp"

namespace obs::estimators {

/// Runs `estimator` on this rank's local input (the local mesh: owned cells first, `ownedCells` of
/// them, then ghost cells; the displacement and contact data current on every local vertex) and
/// returns the owned cells' part: indicators and cell fields of the owned cells, the contributions
/// and the total summed over the ranks (vertex fields as computed on the local mesh). Collective;
/// an error on one rank reaches every rank (Communicator::collective).
EstimatorResult estimateOwned(const Estimator& estimator, const EstimatorInput& input, Index ownedCells,
                              const Communicator& comm);

/// The owned cells (indices into `indicators`, ascending) that `strategy` marks among the cells of
/// all ranks, `indicators` and `keys` this rank's owned cells' (see the file comment: ties by
/// increasing key). Collective. Throws obs::Error on every rank for sizes that differ or an
/// indicator that is not finite and non-negative on any rank.
std::vector<Index> markOwned(const MarkingStrategy& strategy, std::span<const double> indicators,
                             std::span<const std::uint64_t> keys, const Communicator& comm);

}  // namespace obs::estimators
