#include "obs/obs/Checkpoint.hpp"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <cstdio>
#include <cerrno>
#include <cstring>
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

void writeEntry(hid_t file, const std::string& name, const CheckpointRecord::Entry& e) {
  const CheckpointRecord::Value& v = e.value;
  hsize_t dims[1] = {0};
  if (const auto* x = std::get_if<Eigen::VectorXd>(&v)) dims[0] = static_cast<hsize_t>(x->size());
  if (const auto* x = std::get_if<std::vector<long long>>(&v)) dims[0] = static_cast<hsize_t>(x->size());
  const bool isVector = v.index() >= 3;
  Handle space(isVector ? H5Screate_simple(1, dims, nullptr) : H5Screate(H5S_SCALAR), H5Sclose);
  std::string text;  // fixed-length text type of the string's length (at least 1)
  if (const auto* x = std::get_if<std::string>(&v)) text = x->empty() ? std::string(1, '\0') : *x;
  Handle textType(std::holds_alternative<std::string>(v) ? H5Tcopy(H5T_C_S1) : -1, H5Tclose);
  if (textType.valid()) {
    H5Tset_size(textType.get(), text.size());
    H5Tset_strpad(textType.get(), H5T_STR_NULLPAD);
  }
  const bool real = std::holds_alternative<double>(v) || std::holds_alternative<Eigen::VectorXd>(v);
  const hid_t fileType = textType.valid() ? textType.get() : real ? H5T_IEEE_F64LE : H5T_STD_I64LE;
  const hid_t memType = textType.valid() ? textType.get() : real ? H5T_NATIVE_DOUBLE : H5T_NATIVE_LLONG;
  const void* data = std::visit(
      [&](const auto& x) -> const void* {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, std::string>) return text.data();
        else if constexpr (std::is_same_v<T, double> || std::is_same_v<T, long long>) return &x;
        else return x.data();
      },
      v);
  Handle set(H5Dcreate2(file, name.c_str(), fileType, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
             H5Dclose);
  if (!space.valid() || !set.valid()) throw Error("cannot create the dataset " + name);
  const bool empty = isVector && dims[0] == 0;
  if (!empty && H5Dwrite(set.get(), memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw Error("cannot write the dataset " + name);
  writeTextAttribute(set.get(), "description", e.description);
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
  return e;
}

herr_t visitObject(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto* state = static_cast<VisitState*>(data);
  if (info->type != H5O_TYPE_DATASET) return 0;
  try {
    CheckpointRecord::Entry e = readEntry(root, name);
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
    h = fnv1a(name.data(), name.size() + 1, h);  // with the terminating NUL: names cannot run together
    const unsigned char tag = static_cast<unsigned char>(entry.value.index() + 1);
    h = fnv1a(&tag, 1, h);
    std::visit(
        [&](const auto& x) {
          using T = std::decay_t<decltype(x)>;
          if constexpr (std::is_same_v<T, std::string>) {
            const std::uint64_t n = x.size();
            h = fnv1a(&n, sizeof n, h);
            h = fnv1a(x.data(), x.size(), h);
          } else if constexpr (std::is_same_v<T, double> || std::is_same_v<T, long long>) {
            h = fnv1a(&x, sizeof x, h);
          } else {
            const std::uint64_t n = static_cast<std::uint64_t>(x.size());
            h = fnv1a(&n, sizeof n, h);
            h = fnv1a(x.data(), static_cast<std::size_t>(x.size()) * sizeof(x[0]), h);
          }
        },
        entry.value);
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
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw Error(where + "no such checkpoint file");
  if (H5Fis_hdf5(file.c_str()) <= 0)
    throw Error(where + "not an HDF5 file (or its header is damaged): not an obs checkpoint");
  Handle h(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!h.valid()) throw Error(where + "HDF5 cannot open it (truncated or damaged checkpoint)");
  CheckpointRecord record;
  std::string storedHash;
  try {
    const std::string format = readTextAttribute(h.get(), "format");
    if (format != kFormatName) throw Error("format is '" + format + "', not '" + kFormatName + "'");
    const long long version = readIntegerAttribute(h.get(), "format_version");
    if (version != kCheckpointFormatVersion)
      throw Error("checkpoint format version " + std::to_string(version) + " (written by obs " +
                  readTextAttribute(h.get(), "obs_version") + "), this obs " + checkpointObsVersion() +
                  " reads version " + std::to_string(kCheckpointFormatVersion));
    record.kind = readTextAttribute(h.get(), "kind");
    storedHash = readTextAttribute(h.get(), "content_hash");
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
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
