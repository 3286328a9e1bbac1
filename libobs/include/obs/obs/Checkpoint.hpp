#pragma once
/// \file Checkpoint.hpp
/// Checkpoint files (HDF5) for resuming long runs, and the record they hold.
///
/// A CheckpointRecord is a flat set of named entries, each a text, a real number, an integer, a
/// real vector or an integer vector, with a one-line description. Names are HDF5 paths
/// ("state/displacement"); the groups are created as needed. writeCheckpoint stores every entry as a
/// dataset with a "description" attribute, so `h5dump -A file.h5` or h5py explain the file without
/// obs. The root group carries the attributes
///   format          "obs checkpoint"
///   format_version  kCheckpointFormatVersion (a reader refuses any other version)
///   obs_version     the obs version that wrote the file
///   kind            what the record describes ("dynamic", ...; set by the caller)
///   content_hash    FNV-1a 64 over every entry (name, type, bytes), 16 hex digits
/// The content hash makes a corrupted dataset an error on reading even where HDF5 itself reads
/// the damaged bytes without complaint.
///
/// Atomicity: writeCheckpoint writes `file.tmp`, flushes it to disk and renames it to `file`
/// (rename is atomic on POSIX file systems), so a process killed while writing (even by SIGKILL)
/// leaves the previous checkpoint intact; only the .tmp file may be incomplete.
///
/// Rows (docs/checkpoint.md#rows): a record may hold *row entries*, per-vertex data with a
/// fixed number of values per vertex (setRows), and then the entry "rows/keys": one key per row,
/// identifying the vertex independently of how the grid is numbered or partitioned (an integer
/// vector holding the bits of 64-bit keys). Each row dataset carries the attribute
/// "row_components". A distributed run writes one file from all ranks, each rank's rows in rank
/// order (writeCheckpoint with a Communicator, collective writes with parallel HDF5); a reader on
/// any number of ranks asks for the keys of its vertices (readCheckpoint with keys), so a run
/// written on N ranks continues on M. The file is the one a single process writing all rows in
/// that order would write, content hash included.
///
/// A plain record format: the solvers store their states themselves (a Newmark time stepper by
/// storeNewmarkState / loadNewmarkState in Newmark.hpp, the adaptive loop by its checkpoint functions
/// in AdaptiveLoop.hpp); the obs program adds its own entries (docs/checkpoint.md lists them).
/// Embedding codes may add theirs: a record holds any entries.
#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "obs/obs/Communicator.hpp"

namespace obs {

inline constexpr int kCheckpointFormatVersion = 1;

class CheckpointRecord {
public:
  using Value = std::variant<std::string, double, long long, Eigen::VectorXd, std::vector<long long>>;
  struct Entry {
    Value value;
    std::string description;
    int rowComponents = 0;  ///< > 0: a row entry with this many values per row (setRows)
  };

  /// What the record describes (root attribute "kind").
  std::string kind;

  /// Adds or replaces an entry. Names: non-empty path components of [A-Za-z0-9_] separated by
  /// '/', no leading or trailing '/'; a name cannot also be a group of other entries. Throws
  /// obs::Error otherwise.
  void set(const std::string& name, Value value, std::string description);

  /// Adds or replaces a row entry (see the file comment): a real or integer vector of
  /// `components` values per row, in the order of "rows/keys". Throws obs::Error for another value
  /// type, components < 1, or a length that is not a multiple of it.
  void setRows(const std::string& name, Value value, int components, std::string description);
  /// Sets "rows/keys" (a row entry of one component).
  void setRowKeys(const std::vector<std::uint64_t>& keys);
  /// The row keys; obs::Error if the record has none.
  std::vector<std::uint64_t> rowKeys() const;
  /// Values per row of a row entry, 0 for the other entries (obs::Error if missing).
  int rowComponents(const std::string& name) const;

  bool has(const std::string& name) const { return entries_.count(name) > 0; }
  /// Typed access; obs::Error naming the entry if it is missing or of another type.
  const std::string& text(const std::string& name) const;
  double real(const std::string& name) const;
  long long integer(const std::string& name) const;
  const Eigen::VectorXd& vector(const std::string& name) const;
  const std::vector<long long>& integers(const std::string& name) const;
  const std::map<std::string, Entry>& entries() const { return entries_; }

  /// FNV-1a 64 over the entries in name order (name, type tag, data bytes): the "content_hash".
  std::uint64_t contentHash() const;

private:
  template <class T>
  const T& get(const std::string& name, const char* type) const;
  std::map<std::string, Entry> entries_;
};

/// Writes the record to `file` atomically (see above); obs::Error if the file cannot be written
/// (the previous `file`, if any, is then unchanged).
void writeCheckpoint(const std::filesystem::path& file, const CheckpointRecord& record);

/// Reads a checkpoint; one-line obs::Error naming the file if it is missing, not HDF5, truncated
/// or damaged (HDF5 cannot read it, or the content hash differs), not an obs checkpoint, or of
/// another format version.
CheckpointRecord readCheckpoint(const std::filesystem::path& file);

/// Writes a record with rows from every rank of `comm` to one file (collective; see the file
/// comment): the entries other than row entries must be the same on every rank, each rank's row
/// entries hold its rows (every rank has the same row entries, "rows/keys" among them). The file
/// holds the rows in rank order; on more than one rank it is written with parallel HDF5 (MPI-IO,
/// collective writes), then renamed into place by rank 0 as writeCheckpoint does. One rank:
/// writeCheckpoint(file, record). Every rank throws the same one-line obs::Error if it cannot be
/// written, or (several ranks) if obs is built without parallel HDF5.
void writeCheckpoint(const std::filesystem::path& file, const CheckpointRecord& record, const Communicator& comm);

/// Reads a checkpoint with rows on every rank of `comm` (collective), whatever number of ranks
/// wrote it: the entries other than row entries as readCheckpoint(file), and each row entry for
/// the rows of `keys`, in that order ("rows/keys" = keys; several ranks may ask for the same key).
/// Each rank reads a slab of the rows and sends each row to the rank that asked for it. Every rank
/// throws the same one-line obs::Error for what readCheckpoint(file) refuses, for a file without
/// rows (written without "rows/keys", e.g. by an older obs), for a key the file does not hold (a
/// vertex of another grid) and for a key the file holds twice. With `missingRows` the first two
/// are not errors, so that the caller can first check what the record is: a file without rows
/// gives its entries and *missingRows = -1, keys the file does not hold get zero rows and their
/// number over all ranks in *missingRows (0: all found).
CheckpointRecord readCheckpoint(const std::filesystem::path& file, const std::vector<std::uint64_t>& keys,
                                const Communicator& comm, long long* missingRows = nullptr);

/// The obs version written into checkpoints ("major.minor.patch").
const char* checkpointObsVersion();

/// FNV-1a 64 of bytes, continuing from `hash` (start: kFnvOffset); as 16 lower-case hex digits.
inline constexpr std::uint64_t kFnvOffset = 14695981039346656037ull;
std::uint64_t fnv1a(const void* data, std::size_t bytes, std::uint64_t hash = kFnvOffset);
std::string hexHash(std::uint64_t hash);

}  // namespace obs
