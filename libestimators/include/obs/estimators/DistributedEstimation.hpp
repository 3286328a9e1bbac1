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
/// Marking: markOwned() (Marking.hpp), the one marking of one process and of ranks.
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

}  // namespace obs::estimators
