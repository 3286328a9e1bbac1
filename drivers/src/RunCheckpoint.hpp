#pragma once
/// \file RunCheckpoint.hpp
/// Checkpoint support of the scene runners (internal to the drivers; the file format is libobs
/// Checkpoint.hpp, the entries docs/checkpoint.md): what identifies a run (scene text and hash, the
/// leaf grid), the check a restart makes against it, the schedule of [output] checkpoint, and the
/// SIGINT/SIGTERM guard that lets a run finish its step and write a checkpoint before stopping.
#include <csignal>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/Scene.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/Communicator.hpp"
#include "RunSupport.hpp"

namespace obs::drivers {

/// FNV-1a 64 (hex) of the scene text followed by its --set overrides (one "\n--set <override>"
/// each): two runs with the same hash read the same scene.
std::string sceneHash(const Scene& scene);

/// A body of the run whose grid a checkpoint identifies: its name ([[body]] name; empty for a
/// one-body scene) and leaf mesh. A multi-body run lists its bodies in stacked order.
struct RunBody {
  std::string name;
  const mesh::Mesh* leaf = nullptr;
  /// Keyed identity (dynamic runs, whose checkpoints hold rows: docs/checkpoint.md#rows): the grid
  /// is known by its vertex and cell counts and the sum of its vertex keys (vertexKey), which does
  /// not depend on the numbering, so that a run on another number of ranks recognises it. With
  /// `comm` (a distributed run) the first ownedVertices vertices and ownedCells cells of `leaf` are
  /// this rank's and the figures are summed over the ranks: the identity functions are then
  /// collective.
  bool keyed = false;
  std::size_t index = 0;  ///< the body's place in the stacked order (part of its vertices' keys)
  const Communicator* comm = nullptr;
  mesh::Index ownedVertices = -1, ownedCells = -1;
};

/// The key of a vertex at x of body `body` (stacked order) in checkpoints with rows
/// (docs/checkpoint.md#rows): FNV-1a 64 of the body index and the bits of the coordinates, the
/// same for every numbering and partition of the grid.
std::uint64_t vertexKey(std::size_t body, const mesh::Point& x);

/// Stores "scene/text", "scene/overrides", "scene/hash", "grid/leaf_vertices", "grid/leaf_cells"
/// and "grid/leaf_checksum" (FNV-1a of the leaf vertex coordinates and cell vertex lists; several
/// bodies: of all bodies in stacked order). A multi-body scene (scene.multiBody()) adds
/// "bodies/count" and per body b "bodies/<b>/name", "vertex_offset", "leaf_vertices", "leaf_cells",
/// "leaf_checksum" (docs/checkpoint.md#several-bodies); a one-body checkpoint has no "bodies/".
void storeRunIdentity(CheckpointRecord& record, const Scene& scene, const std::vector<RunBody>& bodies);

/// The first part of checkRunIdentity: the kind of run, the bodies (names in stacked order; ignored
/// for a one-body scene) and the scene text and overrides, without the grid (an adaptive restart
/// checks the scene before it replays the refinements, and the grids after).
void checkRunScene(const CheckpointRecord& record, const std::filesystem::path& file, const std::string& kind,
                   const Scene& scene, const std::vector<std::string>& bodyNames);

/// Adaptive runs: "initial_grid/leaf_vertices", "leaf_cells", "leaf_checksum" of the bodies' grids
/// before any refinement (stacked), and the one-line obs::Error "<file>: ..." of a restart whose
/// initial grids differ (another --refine).
void storeInitialGrid(CheckpointRecord& record, const std::vector<RunBody>& bodies);
void checkInitialGrid(const CheckpointRecord& record, const std::filesystem::path& file,
                      const std::vector<RunBody>& bodies);

/// Throws a one-line obs::Error "<file>: ..." naming what differs if the checkpoint was written for
/// another kind of run, another set of bodies (one body against several, their number or names),
/// another scene (first differing line of the text, or the overrides) or another grid (vertex/cell
/// counts or checksum, e.g. another --refine; several bodies: naming the body).
void checkRunIdentity(const CheckpointRecord& record, const std::filesystem::path& file, const std::string& kind,
                      const Scene& scene, const std::vector<RunBody>& bodies);

/// [output] checkpoint: due after step k if k is a multiple of `every`, or if `seconds` have passed
/// since the schedule began or the last checkpoint.
class CheckpointSchedule {
public:
  explicit CheckpointSchedule(const std::optional<CheckpointSpec>& spec) : spec_(spec), last_(Clock::now()) {}
  bool due(int step) const;
  void written() { last_ = Clock::now(); }

private:
  std::optional<CheckpointSpec> spec_;
  Clock::time_point last_;
};

/// While alive, SIGINT and SIGTERM only set a flag (requested()); the handlers reset themselves, so
/// a second signal terminates the process as usual. The previous handlers are restored at exit.
class InterruptGuard {
public:
  InterruptGuard();
  ~InterruptGuard();
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;
  static bool requested();
  /// "SIGINT" / "SIGTERM" (the first signal received).
  static std::string signalName();

private:
  struct sigaction oldInt_ {}, oldTerm_{};
};

}  // namespace obs::drivers
