#pragma once
/// \file DistributedOutput.hpp
/// Outputs of distributed runs shared by the static and the dynamic runner
/// (docs/architecture.md#distributed-runner): each rank's piece of a solution (a .vtu of its owned
/// cells) with rank 0's .pvtu joining them, and the per-rank work of summary.json "balance".
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "obs/drivers/SolutionFields.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/Communicator.hpp"

namespace obs::drivers {

/// Each rank's piece <base>_<rank>.vtu (its owned cells, the first `ownedCells` of its local mesh,
/// with the point fields of the local vertices, the cell fields of the local cells and the rank) and
/// rank 0's <base>.pvtu joining them. Collective (an error on one rank reaches every rank). Returns
/// the files on rank 0 (the pieces, then the .pvtu), nothing on the others.
std::vector<std::filesystem::path> writePieces(const std::filesystem::path& dir, const std::string& base,
                                               const mesh::Mesh& local, mesh::Index ownedCells,
                                               const std::vector<Field>& pointFields,
                                               const std::vector<Field>& cellFields, const Communicator& comm);

/// Per-rank work of a distributed run (summary.json "balance"): each figure's maximum and mean over
/// the ranks and their ratio, the imbalance (docs/architecture.md#distributed-runner).
struct RankLoad {
  std::vector<std::pair<std::string, double>> figures;
  void add(const std::string& name, double value) { figures.emplace_back(name, value); }
  /// Collective: the same figures on every rank, in the same order.
  nlohmann::json reduced(const Communicator& comm) const;
};

/// summary.json's figures of every distributed run, added to `extra` on every rank: "ranks", the
/// peak memory of the largest rank and of all ranks, "partition_level" and "balance" (`load`
/// reduced). Collective.
void addDistributedSummary(nlohmann::json& extra, const Communicator& comm, int partitionLevel, const RankLoad& load);

}  // namespace obs::drivers
