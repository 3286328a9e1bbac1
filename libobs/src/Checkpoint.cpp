#include "obs/obs/Checkpoint.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>
#ifdef OBS_HAVE_PARALLEL_HDF5
#include <mpi.h>  // the communicator of HDF5's MPI-IO driver (Communicator::world() is MPI_COMM_WORLD)
#endif

#include <algorithm>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <unordered_map>
#include <type_traits>
#include <set>
#include <sstream>
#include <system_error>

#include "obs/mesh/Error.hpp"

#ifndef OBS_VERSION_STRING
#define OBS_VERSION_STRING "unknown"
#endif

namespace obs {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFormatName = "obs checkpoint";

// type tags of the content hash (and of the entry types below)
enum Tag : unsigned char { kText = 1, kReal = 2, kInteger = 3, kVector = 4, kIntegers = 5 };

/// Silences HDF5's automatic error printing while alive (errors are reported as obs::Error).
class QuietHdf5 {
public:
  QuietHdf5() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietHdf5() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietHdf5(const QuietHdf5&) = delete;
  QuietHdf5& operator=(const QuietHdf5&) = delete;

private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

/// An HDF5 identifier closed by `close` at scope exit.
class Handle {
public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

bool validName(const std::string& name) {
  if (name.empty() || name.front() == '/' || name.back() == '/') return false;
  char previous = '/';
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '/';
    if (!ok || (c == '/' && previous == '/')) return false;
    previous = c;
  }
  return true;
}

std::string typeName(const CheckpointRecord::Value& v) {
  switch (v.index()) {
    case 0: return "text";
    case 1: return "real number";
    case 2: return "integer";
    case 3: return "real vector";
    default: return "integer vector";
  }
}

// --- writing ---------------------------------------------------------------------------------

void writeTextAttribute(hid_t object, const char* name, const std::string& value) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), std::max<std::size_t>(value.size(), 1));
  H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  std::string buffer = value.empty() ? std::string(1, '\0') : value;
  if (!attr.valid() || H5Awrite(attr.get(), type.get(), buffer.data()) < 0)
    throw Error(std::string("cannot write the attribute ") + name);
}

void writeIntegerAttribute(hid_t object, const char* name, long long value) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(object, name, H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid() || H5Awrite(attr.get(), H5T_NATIVE_LLONG, &value) < 0)
    throw Error(std::string("cannot write the attribute ") + name);
}

/// Creates the groups of `name` below the root (all but the last component).
void createGroups(hid_t file, const std::string& name, std::set<std::string>& made) {
  for (std::size_t pos = name.find('/'); pos != std::string::npos; pos = name.find('/', pos + 1)) {
    const std::string group = name.substr(0, pos);
    if (!made.insert(group).second) continue;
    Handle g(H5Gcreate2(file, group.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!g.valid()) throw Error("cannot create the group " + group);
  }
}

/// The HDF5 types of an entry's value and its data in memory (text: a fixed-length type of the
/// string's length, at least 1).
struct StoredValue {
  explicit StoredValue(const CheckpointRecord::Value& v)
      : isVector(v.index() >= 3), textType(std::holds_alternative<std::string>(v) ? H5Tcopy(H5T_C_S1) : -1, H5Tclose) {
    if (const auto* x = std::get_if<std::string>(&v)) text = x->empty() ? std::string(1, '\0') : *x;
    if (textType.valid()) {
      H5Tset_size(textType.get(), text.size());
      H5Tset_strpad(textType.get(), H5T_STR_NULLPAD);
    }
    const bool real = std::holds_alternative<double>(v) || std::holds_alternative<Eigen::VectorXd>(v);
    fileType = textType.valid() ? textType.get() : real ? H5T_IEEE_F64LE : H5T_STD_I64LE;
    memType = textType.valid() ? textType.get() : real ? H5T_NATIVE_DOUBLE : H5T_NATIVE_LLONG;
    if (const auto* x = std::get_if<Eigen::VectorXd>(&v)) length = static_cast<hsize_t>(x->size());
    if (const auto* x = std::get_if<std::vector<long long>>(&v)) length = static_cast<hsize_t>(x->size());
    data = std::visit(
        [&](const auto& x) -> const void* {
          using T = std::decay_t<decltype(x)>;
          if constexpr (std::is_same_v<T, std::string>) return text.data();
          else if constexpr (std::is_same_v<T, double> || std::is_same_v<T, long long>) return &x;
          else return x.data();
        },
        v);
  }
  bool isVector;
  hsize_t length = 0;  ///< values of a vector
  std::string text;
  Handle textType;
  hid_t fileType = -1, memType = -1;
  const void* data = nullptr;
};

/// The attributes every dataset carries.
void writeDatasetAttributes(hid_t set, const CheckpointRecord::Entry& e) {
  writeTextAttribute(set, "description", e.description);
  if (e.rowComponents > 0) writeIntegerAttribute(set, "row_components", e.rowComponents);
}

void writeEntry(hid_t file, const std::string& name, const CheckpointRecord::Entry& e) {
  const StoredValue v(e.value);
  hsize_t dims[1] = {v.length};
  Handle space(v.isVector ? H5Screate_simple(1, dims, nullptr) : H5Screate(H5S_SCALAR), H5Sclose);
  Handle set(H5Dcreate2(file, name.c_str(), v.fileType, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
             H5Dclose);
  if (!space.valid() || !set.valid()) throw Error("cannot create the dataset " + name);
  const bool empty = v.isVector && dims[0] == 0;
  if (!empty && H5Dwrite(set.get(), v.memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data) < 0)
    throw Error("cannot write the dataset " + name);
  writeDatasetAttributes(set.get(), e);
}

/// FNV-1a of an entry's name, type tag and value (of `length` values for a vector) from h: the
/// content hash's step per entry, up to the vector's data, which the caller hashes (`data`, `bytes`).
std::uint64_t hashEntryHead(const std::string& name, const CheckpointRecord::Value& value, std::uint64_t length,
                            std::uint64_t h) {
  h = fnv1a(name.data(), name.size() + 1, h);  // with the terminating NUL: names cannot run together
  const unsigned char tag = static_cast<unsigned char>(value.index() + 1);
  h = fnv1a(&tag, 1, h);
  if (const auto* x = std::get_if<std::string>(&value)) {
    const std::uint64_t n = x->size();
    h = fnv1a(&n, sizeof n, h);
    return fnv1a(x->data(), x->size(), h);
  }
  if (const auto* x = std::get_if<double>(&value)) return fnv1a(x, sizeof *x, h);
  if (const auto* x = std::get_if<long long>(&value)) return fnv1a(x, sizeof *x, h);
  return fnv1a(&length, sizeof length, h);  // a vector: its length, then its data
}

void writeFile(const fs::path& path, const CheckpointRecord& record) {
  Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw Error("cannot create the HDF5 file");
  writeTextAttribute(file.get(), "format", kFormatName);
  writeIntegerAttribute(file.get(), "format_version", kCheckpointFormatVersion);
  writeTextAttribute(file.get(), "obs_version", checkpointObsVersion());
  writeTextAttribute(file.get(), "kind", record.kind);
  writeTextAttribute(file.get(), "content_hash", hexHash(record.contentHash()));
  std::set<std::string> groups;
  for (const auto& [name, entry] : record.entries()) {
    createGroups(file.get(), name, groups);
    writeEntry(file.get(), name, entry);
  }
  if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) throw Error("cannot flush the HDF5 file");
}

// --- reading ---------------------------------------------------------------------------------

std::string readTextAttribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) throw Error(std::string("attribute ") + name + " is missing");
  Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (!type.valid() || H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) > 0)
    throw Error(std::string("attribute ") + name + " is not a fixed-length text");
  const std::size_t size = H5Tget_size(type.get());
  std::string buffer(size, '\0');
  if (H5Aread(attr.get(), type.get(), buffer.data()) < 0) throw Error(std::string("cannot read the attribute ") + name);
  buffer.resize(std::strlen(buffer.c_str()));
  return buffer;
}

long long readIntegerAttribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) throw Error(std::string("attribute ") + name + " is missing");
  Handle attr(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
  long long value = 0;
  if (H5Aread(attr.get(), H5T_NATIVE_LLONG, &value) < 0) throw Error(std::string("cannot read the attribute ") + name);
  return value;
}

/// Opens a checkpoint for reading; one-line obs::Error naming `where` if it is missing, not HDF5 or
/// cannot be opened. The caller closes it.
hid_t openCheckpoint(const fs::path& file, const std::string& where) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw Error(where + "no such checkpoint file");
  if (H5Fis_hdf5(file.c_str()) <= 0)
    throw Error(where + "not an HDF5 file (or its header is damaged): not an obs checkpoint");
  const hid_t h = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (h < 0) throw Error(where + "HDF5 cannot open it (truncated or damaged checkpoint)");
  return h;
}

/// The root attributes: the format and its version checked, the kind and the stored content hash.
void readHeader(hid_t h, const std::string& where, std::string& kind, std::string& storedHash) {
  try {
    const std::string format = readTextAttribute(h, "format");
    if (format != kFormatName) throw Error("format is '" + format + "', not '" + kFormatName + "'");
    const long long version = readIntegerAttribute(h, "format_version");
    if (version != kCheckpointFormatVersion)
      throw Error("checkpoint format version " + std::to_string(version) + " (written by obs " +
                  readTextAttribute(h, "obs_version") + "), this obs " + checkpointObsVersion() +
                  " reads version " + std::to_string(kCheckpointFormatVersion));
    kind = readTextAttribute(h, "kind");
    storedHash = readTextAttribute(h, "content_hash");
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
}

struct VisitState {
  CheckpointRecord* record = nullptr;
  std::string error;
};

CheckpointRecord::Entry readEntry(hid_t file, const std::string& name) {
  Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid()) throw Error("cannot open the dataset " + name);
  Handle type(H5Dget_type(set.get()), H5Tclose);
  Handle space(H5Dget_space(set.get()), H5Sclose);
  if (!type.valid() || !space.valid()) throw Error("cannot read the dataset " + name);
  const H5T_class_t cls = H5Tget_class(type.get());
  const int rank = H5Sget_simple_extent_ndims(space.get());
  hsize_t dims[1] = {0};
  if (rank == 1) H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  CheckpointRecord::Entry e;
  herr_t status = 0;
  if (cls == H5T_STRING && rank == 0 && H5Tis_variable_str(type.get()) <= 0) {
    std::string buffer(H5Tget_size(type.get()), '\0');
    status = H5Dread(set.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data());
    buffer.resize(std::strlen(buffer.c_str()));
    e.value = std::move(buffer);
  } else if (cls == H5T_FLOAT && rank == 0) {
    double x = 0;
    status = H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, &x);
    e.value = x;
  } else if (cls == H5T_INTEGER && rank == 0) {
    long long x = 0;
    status = H5Dread(set.get(), H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, &x);
    e.value = x;
  } else if (cls == H5T_FLOAT && rank == 1) {
    Eigen::VectorXd x(static_cast<Eigen::Index>(dims[0]));
    if (dims[0] > 0) status = H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, x.data());
    e.value = std::move(x);
  } else if (cls == H5T_INTEGER && rank == 1) {
    std::vector<long long> x(static_cast<std::size_t>(dims[0]));
    if (dims[0] > 0) status = H5Dread(set.get(), H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, x.data());
    e.value = std::move(x);
  } else {
    throw Error("dataset " + name + " has a type obs does not write");
  }
  if (status < 0) throw Error("cannot read the dataset " + name + " (truncated or damaged)");
  if (H5Aexists(set.get(), "description") > 0) e.description = readTextAttribute(set.get(), "description");
  if (H5Aexists(set.get(), "row_components") > 0)
    e.rowComponents = static_cast<int>(readIntegerAttribute(set.get(), "row_components"));
  return e;
}

herr_t visitObject(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto* state = static_cast<VisitState*>(data);
  if (info->type != H5O_TYPE_DATASET) return 0;
  try {
    CheckpointRecord::Entry e = readEntry(root, name);
    if (e.rowComponents > 0)
      state->record->setRows(name, std::move(e.value), e.rowComponents, std::move(e.description));
    else
      state->record->set(name, std::move(e.value), std::move(e.description));
  } catch (const Error& e) {
    state->error = e.what();
    return -1;
  }
  return 0;
}

}  // namespace

// --- CheckpointRecord ----------------------------------------------------------------------------

void CheckpointRecord::set(const std::string& name, Value value, std::string description) {
  if (!validName(name))
    throw Error("checkpoint: invalid entry name '" + name + "' (path components of letters, digits and _)");
  for (const auto& [other, entry] : entries_) {
    (void)entry;
    if ((other.size() > name.size() && other.compare(0, name.size(), name) == 0 && other[name.size()] == '/') ||
        (name.size() > other.size() && name.compare(0, other.size(), other) == 0 && name[other.size()] == '/'))
      throw Error("checkpoint: entry '" + name + "' and entry '" + other + "' cannot both exist (one is a group)");
  }
  entries_[name] = Entry{std::move(value), std::move(description)};
}

void CheckpointRecord::setRows(const std::string& name, Value value, int components, std::string description) {
  const Eigen::Index n = std::holds_alternative<Eigen::VectorXd>(value)              ? std::get<Eigen::VectorXd>(value).size()
                         : std::holds_alternative<std::vector<long long>>(value) ? static_cast<Eigen::Index>(
                                                                                          std::get<std::vector<long long>>(value).size())
                                                                                    : -1;
  if (n < 0) throw Error("checkpoint: row entry '" + name + "' must be a real or integer vector");
  if (components < 1 || n % components != 0)
    throw Error("checkpoint: row entry '" + name + "' has " + std::to_string(n) + " values, not a multiple of " +
                std::to_string(components) + " per row");
  set(name, std::move(value), std::move(description));
  entries_[name].rowComponents = components;
}

void CheckpointRecord::setRowKeys(const std::vector<std::uint64_t>& keys) {
  std::vector<long long> bits(keys.size());
  std::memcpy(bits.data(), keys.data(), keys.size() * sizeof(std::uint64_t));
  setRows("rows/keys", std::move(bits), 1,
          "per row of the row entries: the key of its vertex (64 bits, independent of the numbering and the "
          "partition of the grid)");
}

std::vector<std::uint64_t> CheckpointRecord::rowKeys() const {
  const std::vector<long long>& bits = integers("rows/keys");
  std::vector<std::uint64_t> keys(bits.size());
  std::memcpy(keys.data(), bits.data(), bits.size() * sizeof(std::uint64_t));
  return keys;
}

int CheckpointRecord::rowComponents(const std::string& name) const {
  const auto it = entries_.find(name);
  if (it == entries_.end()) throw Error("checkpoint: entry '" + name + "' is missing");
  return it->second.rowComponents;
}

template <class T>
const T& CheckpointRecord::get(const std::string& name, const char* type) const {
  const auto it = entries_.find(name);
  if (it == entries_.end()) throw Error("checkpoint: entry '" + name + "' is missing");
  if (const T* x = std::get_if<T>(&it->second.value)) return *x;
  throw Error("checkpoint: entry '" + name + "' is a " + typeName(it->second.value) + ", expected a " + type);
}

const std::string& CheckpointRecord::text(const std::string& name) const { return get<std::string>(name, "text"); }
double CheckpointRecord::real(const std::string& name) const { return get<double>(name, "real number"); }
long long CheckpointRecord::integer(const std::string& name) const { return get<long long>(name, "integer"); }
const Eigen::VectorXd& CheckpointRecord::vector(const std::string& name) const {
  return get<Eigen::VectorXd>(name, "real vector");
}
const std::vector<long long>& CheckpointRecord::integers(const std::string& name) const {
  return get<std::vector<long long>>(name, "integer vector");
}

std::uint64_t CheckpointRecord::contentHash() const {
  std::uint64_t h = fnv1a(kind.data(), kind.size());
  for (const auto& [name, entry] : entries_) {
    const StoredValue v(entry.value);
    h = hashEntryHead(name, entry.value, v.length, h);
    if (v.isVector) h = fnv1a(v.data, static_cast<std::size_t>(v.length) * 8, h);  // doubles, 64-bit integers
  }
  return h;
}

// --- files ---------------------------------------------------------------------------------------

void writeCheckpoint(const fs::path& file, const CheckpointRecord& record) {
  const QuietHdf5 quiet;
  const fs::path tmp = fs::path(file.string() + ".tmp");
  std::error_code ec;
  fs::remove(tmp, ec);
  try {
    writeFile(tmp, record);
  } catch (const Error& e) {
    fs::remove(tmp, ec);
    throw Error(file.string() + ": cannot write the checkpoint (" + e.what() + " in " + tmp.string() + ")");
  }
  // on disk before the rename, so that the new name never refers to unwritten data
  const int fd = ::open(tmp.c_str(), O_RDONLY);
  const bool synced = fd >= 0 && ::fsync(fd) == 0;
  if (fd >= 0) ::close(fd);
  if (!synced || std::rename(tmp.c_str(), file.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    fs::remove(tmp, ec);
    throw Error(file.string() + ": cannot write the checkpoint (" + reason + ")");
  }
}

CheckpointRecord readCheckpoint(const fs::path& file) {
  const QuietHdf5 quiet;
  const std::string where = file.string() + ": ";
  Handle h(openCheckpoint(file, where), H5Fclose);
  CheckpointRecord record;
  std::string storedHash;
  readHeader(h.get(), where, record.kind, storedHash);
  VisitState state{&record, {}};
  if (H5Ovisit(h.get(), H5_INDEX_NAME, H5_ITER_NATIVE, visitObject, &state) < 0)
    throw Error(where + (state.error.empty() ? "HDF5 cannot read its contents" : state.error) +
                " (truncated or damaged checkpoint)");
  const std::string computed = hexHash(record.contentHash());
  if (computed != storedHash)
    throw Error(where + "content hash " + computed + " differs from the stored " + storedHash +
                " (the checkpoint is damaged)");
  return record;
}

// --- rows on several ranks ------------------------------------------------------------------

namespace {

/// FNV-1a continued over bytes split across the ranks in rank order (this rank's `data`), from the
/// state h (the same on every rank): the state after the last rank's bytes, on every rank. One
/// message from each rank to the next and a broadcast from the last.
std::uint64_t chainedFnv(const void* data, std::size_t bytes, std::uint64_t h, const Communicator& comm) {
  if (comm.size() == 1) return fnv1a(data, bytes, h);
  std::vector<std::vector<double>> none;
  if (comm.rank() > 0) {
    std::vector<std::vector<double>> in(1, std::vector<double>(1));
    comm.exchange({}, {}, {comm.rank() - 1}, in);
    std::memcpy(&h, in[0].data(), sizeof h);
  }
  h = fnv1a(data, bytes, h);
  if (comm.rank() + 1 < comm.size()) {
    std::vector<std::vector<double>> out(1, std::vector<double>(1));
    std::memcpy(out[0].data(), &h, sizeof h);
    comm.exchange({comm.rank() + 1}, out, {}, none);
  }
  return std::stoull(comm.broadcast(hexHash(h), comm.size() - 1), nullptr, 16);
}

/// CheckpointRecord::contentHash of the record whose row entries are the concatenation over the
/// ranks (in rank order) of each rank's row entries in `record` (the other entries the same on
/// every rank). Collective.
std::uint64_t distributedContentHash(const CheckpointRecord& record, const Communicator& comm) {
  std::uint64_t h = fnv1a(record.kind.data(), record.kind.size());
  for (const auto& [name, entry] : record.entries()) {
    const StoredValue v(entry.value);
    if (entry.rowComponents == 0) {  // the same on every rank
      h = hashEntryHead(name, entry.value, v.length, h);
      if (v.isVector) h = fnv1a(v.data, static_cast<std::size_t>(v.length) * 8, h);
      continue;
    }
    // a row entry: its length over the ranks, then each rank's rows in rank order
    const auto n = static_cast<std::uint64_t>(comm.sum(static_cast<long long>(v.length)));
    h = hashEntryHead(name, entry.value, n, h);
    h = chainedFnv(v.data, static_cast<std::size_t>(v.length) * 8, h, comm);
  }
  return h;
}

/// The local length of a row entry (values).
std::size_t rowLength(const CheckpointRecord::Entry& e) {
  if (const auto* x = std::get_if<Eigen::VectorXd>(&e.value)) return static_cast<std::size_t>(x->size());
  return std::get<std::vector<long long>>(e.value).size();
}

#ifdef OBS_HAVE_PARALLEL_HDF5
/// The file written by every rank with MPI-IO: the entries as writeFile, the row entries' rows at
/// the rank's offset (rows before it: rowOffset), the others written by rank 0 (collective writes).
void writeFileDistributed(const fs::path& path, const CheckpointRecord& record, std::uint64_t hash, long long rowOffset,
                          long long totalRows, const Communicator& comm) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (!fapl.valid() || H5Pset_fapl_mpio(fapl.get(), MPI_COMM_WORLD, MPI_INFO_NULL) < 0)
    throw Error("cannot set up HDF5's MPI-IO driver");
  Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
  if (!file.valid()) throw Error("cannot create the HDF5 file");
  Handle xfer(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
  if (!xfer.valid() || H5Pset_dxpl_mpio(xfer.get(), H5FD_MPIO_COLLECTIVE) < 0)
    throw Error("cannot set up collective writes");
  // attributes and groups are collective: every rank makes the same calls with the same values
  writeTextAttribute(file.get(), "format", kFormatName);
  writeIntegerAttribute(file.get(), "format_version", kCheckpointFormatVersion);
  writeTextAttribute(file.get(), "obs_version", checkpointObsVersion());
  writeTextAttribute(file.get(), "kind", record.kind);
  writeTextAttribute(file.get(), "content_hash", hexHash(hash));
  std::set<std::string> groups;
  for (const auto& [name, e] : record.entries()) {
    createGroups(file.get(), name, groups);
    const StoredValue v(e.value);
    const bool row = e.rowComponents > 0;
    const bool isVector = v.isVector;
    // the dataset's length: a row entry's over all ranks, components per row
    hsize_t dims[1] = {0};
    hsize_t local = 0, offset = 0;
    if (row) {
      local = rowLength(e);
      dims[0] = static_cast<hsize_t>(totalRows) * static_cast<hsize_t>(e.rowComponents);
      offset = static_cast<hsize_t>(rowOffset) * static_cast<hsize_t>(e.rowComponents);
      // an entry empty on every rank (e.g. no acceleration) stays empty
      if (comm.sum(static_cast<long long>(local)) == 0) dims[0] = 0;
    } else if (isVector) {
      dims[0] = v.length;
    }
    Handle space(isVector ? H5Screate_simple(1, dims, nullptr) : H5Screate(H5S_SCALAR), H5Sclose);
    Handle set(H5Dcreate2(file.get(), name.c_str(), v.fileType, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
               H5Dclose);
    if (!space.valid() || !set.valid()) throw Error("cannot create the dataset " + name);
    if (!isVector || dims[0] > 0) {
      // rows: this rank's slab; other entries: rank 0 writes, the others select nothing
      hsize_t count[1] = {row ? local : dims[0]};
      Handle memSpace(isVector ? H5Screate_simple(1, count[0] > 0 ? count : dims, nullptr) : H5Screate(H5S_SCALAR),
                      H5Sclose);
      if (row) {
        hsize_t start[1] = {offset};
        if (local > 0)
          H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr);
        else {
          H5Sselect_none(space.get());
          H5Sselect_none(memSpace.get());
        }
      } else if (comm.rank() != 0) {
        H5Sselect_none(space.get());
        H5Sselect_none(memSpace.get());
      }
      if (H5Dwrite(set.get(), v.memType, memSpace.get(), space.get(), xfer.get(), v.data) < 0)
        throw Error("cannot write the dataset " + name);
    }
    writeDatasetAttributes(set.get(), e);
  }
  if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) throw Error("cannot flush the HDF5 file");
}
#endif

/// A file's entry names (datasets), in name order.
herr_t collectName(hid_t, const char* name, const H5O_info_t* info, void* data) {
  if (info->type == H5O_TYPE_DATASET) static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}

/// Rows [first, first + count) of a row dataset (components per row) as an entry.
CheckpointRecord::Entry readRowSlab(hid_t file, const std::string& name, hsize_t first, hsize_t count) {
  Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid()) throw Error("cannot open the dataset " + name);
  Handle type(H5Dget_type(set.get()), H5Tclose);
  Handle space(H5Dget_space(set.get()), H5Sclose);
  if (!type.valid() || !space.valid() || H5Sget_simple_extent_ndims(space.get()) != 1)
    throw Error("cannot read the dataset " + name);
  CheckpointRecord::Entry e;
  e.rowComponents = static_cast<int>(readIntegerAttribute(set.get(), "row_components"));
  if (H5Aexists(set.get(), "description") > 0) e.description = readTextAttribute(set.get(), "description");
  hsize_t dims[1] = {0};
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  const H5T_class_t cls = H5Tget_class(type.get());
  const auto c = static_cast<hsize_t>(std::max(e.rowComponents, 1));
  const hsize_t length = dims[0] == 0 ? 0 : count * c;  // an empty entry stays empty
  herr_t status = 0;
  hsize_t start[1] = {first * c}, block[1] = {length};
  if (length > 0) {
    if (start[0] + length > dims[0]) throw Error("dataset " + name + " is shorter than its rows (damaged)");
    H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, block, nullptr);
  }
  Handle mem(H5Screate_simple(1, block, nullptr), H5Sclose);
  if (cls == H5T_FLOAT) {
    Eigen::VectorXd x(static_cast<Eigen::Index>(length));
    if (length > 0) status = H5Dread(set.get(), H5T_NATIVE_DOUBLE, mem.get(), space.get(), H5P_DEFAULT, x.data());
    e.value = std::move(x);
  } else if (cls == H5T_INTEGER) {
    std::vector<long long> x(static_cast<std::size_t>(length));
    if (length > 0) status = H5Dread(set.get(), H5T_NATIVE_LLONG, mem.get(), space.get(), H5P_DEFAULT, x.data());
    e.value = std::move(x);
  } else {
    throw Error("row dataset " + name + " is neither real nor integer");
  }
  if (status < 0) throw Error("cannot read the dataset " + name + " (truncated or damaged)");
  return e;
}

}  // namespace

void writeCheckpoint(const fs::path& file, const CheckpointRecord& record, const Communicator& comm) {
  // the rows of the ranks: every row entry holds the rank's rows of "rows/keys"
  long long rows = 0;
  comm.collective([&] {
    if (!record.has("rows/keys") || record.rowComponents("rows/keys") != 1)
      throw Error(file.string() + ": cannot write the checkpoint (a record with rows needs rows/keys)");
    rows = static_cast<long long>(record.rowKeys().size());
    for (const auto& [name, e] : record.entries())
      if (e.rowComponents > 0 && rowLength(e) != 0 && rowLength(e) != static_cast<std::size_t>(rows * e.rowComponents))
        throw Error(file.string() + ": cannot write the checkpoint (row entry " + name + " has " +
                    std::to_string(rowLength(e)) + " values for " + std::to_string(rows) + " rows)");
  });
  if (comm.size() == 1) {
    writeCheckpoint(file, record);
    return;
  }
#ifndef OBS_HAVE_PARALLEL_HDF5
  throw Error(file.string() + ": cannot write the checkpoint of " + std::to_string(comm.size()) +
              " ranks: obs is built without parallel HDF5 (install libhdf5-openmpi-dev and build again)");
#else
  const QuietHdf5 quiet;
  const std::uint64_t hash = distributedContentHash(record, comm);
  const std::vector<long long> counts = comm.allGather(rows);
  long long offset = 0, total = 0;
  for (int r = 0; r < comm.size(); ++r) {
    if (r < comm.rank()) offset += counts[static_cast<std::size_t>(r)];
    total += counts[static_cast<std::size_t>(r)];
  }
  const fs::path tmp = fs::path(file.string() + ".tmp");
  comm.collective([&] {
    std::error_code ec;
    if (comm.rank() == 0) fs::remove(tmp, ec);
  });
  // HDF5's collective calls fail together (the file is one); the error of any rank reaches all
  std::string error;
  try {
    writeFileDistributed(tmp, record, hash, offset, total, comm);
  } catch (const Error& e) {
    error = e.what();
  }
  comm.collective([&] {
    if (!error.empty()) throw Error(error);
  });
  comm.collective([&] {
    if (comm.rank() != 0) return;
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    const bool synced = fd >= 0 && ::fsync(fd) == 0;
    if (fd >= 0) ::close(fd);
    if (!synced || std::rename(tmp.c_str(), file.c_str()) != 0) {
      const std::string reason = std::strerror(errno);
      std::error_code ec;
      fs::remove(tmp, ec);
      throw Error(reason);
    }
  });
#endif
}

CheckpointRecord readCheckpoint(const fs::path& file, const std::vector<std::uint64_t>& keys, const Communicator& comm,
                                long long* missingRows) {
  const QuietHdf5 quiet;
  const std::string where = file.string() + ": ";
  const int ranks = comm.size(), me = comm.rank();
  // every rank reads the entries and its slab of the rows (independent reads of one file)
  CheckpointRecord slab;
  std::string storedHash;
  long long totalRows = 0;
  bool rows = true;  // the file has rows/keys
  comm.collective([&] {
    Handle h(openCheckpoint(file, where), H5Fclose);
    readHeader(h.get(), where, slab.kind, storedHash);
    std::vector<std::string> names;
    if (H5Ovisit(h.get(), H5_INDEX_NAME, H5_ITER_NATIVE, collectName, &names) < 0)
      throw Error(where + "HDF5 cannot read its contents (truncated or damaged checkpoint)");
    rows = std::find(names.begin(), names.end(), "rows/keys") != names.end();
    if (!rows && !missingRows)
      throw Error(where + "the checkpoint has no rows/keys (written by an obs before " +
                  "checkpoints with rows): it cannot be continued by this obs; start the run again");
    try {
      if (rows) {
        Handle set(H5Dopen2(h.get(), "rows/keys", H5P_DEFAULT), H5Dclose);
        Handle space(H5Dget_space(set.get()), H5Sclose);
        hsize_t dims[1] = {0};
        if (!set.valid() || !space.valid() || H5Sget_simple_extent_ndims(space.get()) != 1)
          throw Error("cannot read the dataset rows/keys");
        H5Sget_simple_extent_dims(space.get(), dims, nullptr);
        totalRows = static_cast<long long>(dims[0]);
      }
      const auto first = static_cast<hsize_t>(totalRows * me / ranks);
      const auto count = static_cast<hsize_t>(totalRows * (me + 1) / ranks) - first;
      for (const std::string& name : names) {
        Handle set(H5Dopen2(h.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
        const bool row = set.valid() && H5Aexists(set.get(), "row_components") > 0;
        if (row) {
          CheckpointRecord::Entry e = readRowSlab(h.get(), name, first, count);
          slab.setRows(name, std::move(e.value), e.rowComponents, std::move(e.description));
        } else {
          CheckpointRecord::Entry e = readEntry(h.get(), name);
          slab.set(name, std::move(e.value), std::move(e.description));
        }
      }
    } catch (const Error& e) {
      throw Error(where + e.what() + " (truncated or damaged checkpoint)");
    }
  });
  const std::string computed = hexHash(distributedContentHash(slab, comm));
  if (computed != storedHash)  // the same on every rank
    throw Error(where + "content hash " + computed + " differs from the stored " + storedHash +
                " (the checkpoint is damaged)");
  if (!rows) {  // the entries alone (missingRows given)
    *missingRows = -1;
    return slab;
  }

  // the rows to the ranks that ask for them, through the rank key % ranks: the rows read and the
  // keys asked for go there, the matches come back
  std::vector<std::string> rowNames;
  std::vector<int> components;
  for (const auto& [name, e] : slab.entries())
    if (e.rowComponents > 0 && name != "rows/keys" && rowLength(e) > 0) {
      if (!std::holds_alternative<Eigen::VectorXd>(e.value))
        throw Error(where + "row entry " + name + " is not real (not written by obs)");
      rowNames.push_back(name);
      components.push_back(e.rowComponents);
    }
  int width = 0;
  for (int c : components) width += c;
  const std::vector<std::uint64_t> slabKeys = slab.rowKeys();
  const auto home = [&](std::uint64_t key) { return static_cast<int>(key % static_cast<std::uint64_t>(ranks)); };
  std::vector<std::vector<std::uint64_t>> keyOut(static_cast<std::size_t>(ranks)), askOut(static_cast<std::size_t>(ranks));
  std::vector<std::vector<double>> rowOut(static_cast<std::size_t>(ranks));
  for (std::size_t r = 0; r < slabKeys.size(); ++r) {
    const auto to = static_cast<std::size_t>(home(slabKeys[r]));
    keyOut[to].push_back(slabKeys[r]);
    for (std::size_t k = 0; k < rowNames.size(); ++k) {
      const Eigen::VectorXd& x = slab.vector(rowNames[k]);
      for (int c = 0; c < components[k]; ++c) rowOut[to].push_back(x[static_cast<Eigen::Index>(r) * components[k] + c]);
    }
  }
  for (std::uint64_t key : keys) askOut[static_cast<std::size_t>(home(key))].push_back(key);
  const auto keyIn = comm.exchange(keyOut);
  const auto rowIn = comm.exchange(rowOut);
  const auto askIn = comm.exchange(askOut);
  // this rank's part of the directory: key -> (sending rank, row)
  std::unordered_map<std::uint64_t, std::pair<int, std::size_t>> directory;
  long long duplicates = 0, missing = 0;
  for (int q = 0; q < ranks; ++q)
    for (std::size_t r = 0; r < keyIn[static_cast<std::size_t>(q)].size(); ++r)
      if (!directory.emplace(keyIn[static_cast<std::size_t>(q)][r], std::make_pair(q, r)).second) ++duplicates;
  std::vector<std::vector<double>> answer(static_cast<std::size_t>(ranks));
  for (int q = 0; q < ranks; ++q)
    for (std::uint64_t key : askIn[static_cast<std::size_t>(q)]) {
      const auto it = directory.find(key);
      if (it == directory.end()) {
        ++missing;
        answer[static_cast<std::size_t>(q)].insert(answer[static_cast<std::size_t>(q)].end(), static_cast<std::size_t>(width), 0.0);
        continue;
      }
      const auto& [from, row] = it->second;
      const std::vector<double>& values = rowIn[static_cast<std::size_t>(from)];
      answer[static_cast<std::size_t>(q)].insert(answer[static_cast<std::size_t>(q)].end(),
                                                 values.begin() + static_cast<std::ptrdiff_t>(row * width),
                                                 values.begin() + static_cast<std::ptrdiff_t>((row + 1) * width));
    }
  duplicates = comm.sum(duplicates);
  missing = comm.sum(missing);
  if (duplicates > 0)
    throw Error(where + "the checkpoint holds " + std::to_string(duplicates) + " vertex keys twice (damaged)");
  if (missing > 0 && !missingRows)
    throw Error(where + std::to_string(missing) + " vertices of this run are not in the checkpoint (written for another " +
                "grid: another --refine?)");
  if (missingRows) *missingRows = missing;
  const auto answers = comm.exchange(answer);
  // the record: the entries, and the row entries in the order of `keys`
  CheckpointRecord out;
  out.kind = slab.kind;
  for (const auto& [name, e] : slab.entries()) {
    if (e.rowComponents == 0) out.set(name, e.value, e.description);
    else if (rowLength(e) == 0 && name != "rows/keys") out.setRows(name, e.value, e.rowComponents, e.description);
  }
  out.setRowKeys(keys);
  std::vector<Eigen::VectorXd> values;
  for (std::size_t k = 0; k < rowNames.size(); ++k)
    values.emplace_back(static_cast<Eigen::Index>(keys.size()) * components[k]);
  std::vector<std::size_t> next(static_cast<std::size_t>(ranks), 0);  // per home rank: the next answer
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const auto q = static_cast<std::size_t>(home(keys[i]));
    const double* row = answers[q].data() + next[q] * static_cast<std::size_t>(width);
    ++next[q];
    for (std::size_t k = 0, at = 0; k < rowNames.size(); at += static_cast<std::size_t>(components[k]), ++k)
      for (int c = 0; c < components[k]; ++c) values[k][static_cast<Eigen::Index>(i) * components[k] + c] = row[at + c];
  }
  for (std::size_t k = 0; k < rowNames.size(); ++k)
    out.setRows(rowNames[k], std::move(values[k]), components[k], slab.entries().at(rowNames[k]).description);
  return out;
}

const char* checkpointObsVersion() { return OBS_VERSION_STRING; }

std::uint64_t fnv1a(const void* data, std::size_t bytes, std::uint64_t hash) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) {
    hash ^= p[i];
    hash *= 1099511628211ull;
  }
  return hash;
}

std::string hexHash(std::uint64_t hash) {
  char buffer[17];
  std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(hash));
  return buffer;
}

}  // namespace obs
