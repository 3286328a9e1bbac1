#include "obs/drivers/VtkWriter.hpp"

#include <libdeflate.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <limits>
#include <span>
#include <sstream>
#include <system_error>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs::drivers {

namespace {

static_assert(std::endian::native == std::endian::little, "writeVtu writes little-endian files");

/// VTK wedges want (0,2,1,3,5,4) of an obs/Gmsh prism, see the file comment of VtkWriter.hpp.
constexpr std::array<int, 6> kPrismToVtk{0, 2, 1, 3, 5, 4};

/// The layout of VTK's own XML writer: data cut into blocks of 32 KB (its default), each compressed on
/// its own into the zlib format (what VTK's vtkZLibDataCompressor reads). The compressor is
/// libdeflate at level 1: on the step-42 output at 64^3 (92 MB of arrays, mostly doubles that
/// hardly compress) the output phase took 0.86 s instead of zlib level 1's 1.85 s on one thread, for
/// 1.8 % fewer bytes (bench/threads, docs/performance.md#vtk-output).
constexpr std::size_t kBlockBytes = 32768;
constexpr int kDeflateLevel = 1;

/// One data array of the file: its XML attributes and its raw little-endian bytes (its own, or a
/// view of data that outlive the write: the doubles of a field), then the compressed blocks.
struct Array {
  std::string type;  // VTK type name: Float64, Int32, Int64, UInt8
  std::string name;
  int components = 1;
  std::vector<unsigned char> raw;
  std::span<const unsigned char> external;  // the bytes, if not in raw
  std::vector<std::vector<unsigned char>> blocks;
  // RangeMin/RangeMax as VTK writes them: of the values, or of the tuples' 2-norms for several
  // components (ParaView shows them before it reads the data); none for the cell connectivity
  bool ranged = false;
  double lo = 0, hi = 0;
  std::span<const unsigned char> bytes() const { return external.empty() ? std::span<const unsigned char>(raw) : external; }
  std::size_t blockCount() const { return (bytes().size() + kBlockBytes - 1) / kBlockBytes; }
};

/// The bytes of a vector of trivially copyable values.
template <class T>
std::span<const unsigned char> bytesOf(const std::vector<T>& v) {
  return {reinterpret_cast<const unsigned char*>(v.data()), v.size() * sizeof(T)};
}

template <class T>
void put(std::vector<unsigned char>& out, T value) {
  const auto at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &value, sizeof(T));
}

void setRange(Array& a, std::span<const double> values) {
  const auto k = static_cast<std::size_t>(a.components);
  const auto tuples = static_cast<Index>(values.size() / k);
  // the tuples in forRanges' chunks on the threads, then the chunks' extremes: a minimum and a
  // maximum do not depend on the order
  std::vector<std::array<double, 2>> chunk(static_cast<std::size_t>((tuples + kVectorChunk - 1) / kVectorChunk));
  forRanges(tuples, [&](Index begin, Index end) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (Index t = begin; t < end; ++t) {
      const std::size_t i = static_cast<std::size_t>(t) * k;
      double x = values[i];
      if (k > 1) {
        x = 0;
        for (std::size_t c = 0; c < k; ++c) x += values[i + c] * values[i + c];
        x = std::sqrt(x);
      }
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    chunk[static_cast<std::size_t>(begin / kVectorChunk)] = {lo, hi};
  });
  a.ranged = true;
  a.lo = std::numeric_limits<double>::infinity();
  a.hi = -a.lo;
  for (const auto& [lo, hi] : chunk) {
    a.lo = std::min(a.lo, lo);
    a.hi = std::max(a.hi, hi);
  }
  if (!std::isfinite(a.lo) || !std::isfinite(a.hi)) a.ranged = false;  // no tuples, or no finite one
}

Array fieldArray(const Field& f, std::size_t tuples, const char* kind) {
  if (f.components < 1 || f.values.size() != tuples * static_cast<std::size_t>(f.components))
    throw Error("writeVtu: " + std::string(kind) + " field '" + f.name + "' has " +
                std::to_string(f.values.size()) + " values, expected " + std::to_string(tuples) +
                " x " + std::to_string(f.components));
  Array a{f.integer ? "Int32" : "Float64", f.name, f.components, {}, {}, {}};
  if (f.integer) {
    a.raw.resize(f.values.size() * sizeof(std::int32_t));
    for (std::size_t i = 0; i < f.values.size(); ++i) {
      const auto v = static_cast<std::int32_t>(f.values[i]);
      std::memcpy(a.raw.data() + i * sizeof v, &v, sizeof v);
    }
  } else {  // little-endian doubles: the values' own bytes, not copied
    a.external = bytesOf(f.values);
  }
  setRange(a, f.values);
  return a;
}

std::string xmlEscaped(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

/// Compresses every block of every array, the blocks on threads() threads (each block on its own:
/// the bytes do not depend on the thread count). Every thread has its own compressor.
void compress(std::vector<Array>& arrays) {
  std::vector<std::pair<std::size_t, std::size_t>> jobs;  // (array, block)
  for (std::size_t a = 0; a < arrays.size(); ++a) {
    arrays[a].blocks.resize(arrays[a].blockCount());
    for (std::size_t b = 0; b < arrays[a].blockCount(); ++b) jobs.emplace_back(a, b);
  }
  const auto count = static_cast<long long>(jobs.size());
  const int nt = count > 1 ? threads() : 1;
  long long failed = count;
#pragma omp parallel num_threads(nt) reduction(min : failed) if (nt > 1)
  {
    libdeflate_compressor* compressor = libdeflate_alloc_compressor(kDeflateLevel);
    if (compressor == nullptr) failed = -1;  // out of memory
    // each block is compressed into this thread's buffer of the bound's size and kept at its own
    // size: the doubles hardly compress, and blocks of the bound's size held 2.4 times the file
    std::vector<unsigned char> buffer;
    if (compressor != nullptr) buffer.resize(libdeflate_zlib_compress_bound(compressor, kBlockBytes));
#pragma omp for schedule(dynamic, 4)
    for (long long j = 0; j < count; ++j) {
      if (compressor == nullptr) continue;
      Array& a = arrays[jobs[static_cast<std::size_t>(j)].first];
      const std::size_t b = jobs[static_cast<std::size_t>(j)].second;
      const std::span<const unsigned char> data = a.bytes();
      const std::size_t begin = b * kBlockBytes, size = std::min(kBlockBytes, data.size() - begin);
      // the bound is always enough: 0 (no room) does not happen, but is checked all the same
      const std::size_t length =
          libdeflate_zlib_compress(compressor, data.data() + begin, size, buffer.data(), buffer.size());
      if (length == 0) failed = std::min(failed, j);
      a.blocks[b].assign(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(length));
    }
    libdeflate_free_compressor(compressor);
  }
  if (failed < count) throw Error("writeVtu: could not compress the data (libdeflate)");
}

}  // namespace

int vtkCellType(mesh::CellType type) {
  switch (type) {
    case mesh::CellType::Segment:
      return 3;   // VTK_LINE
    case mesh::CellType::Triangle:
      return 5;   // VTK_TRIANGLE
    case mesh::CellType::Quadrilateral:
      return 9;   // VTK_QUAD
    case mesh::CellType::Tetrahedron:
      return 10;  // VTK_TETRA
    case mesh::CellType::Hexahedron:
      return 12;  // VTK_HEXAHEDRON
    case mesh::CellType::Prism:
      return 13;  // VTK_WEDGE
    case mesh::CellType::Pyramid:
      return 14;  // VTK_PYRAMID
  }
  return 0;  // VTK_EMPTY_CELL
}

void writeVtu(const std::filesystem::path& path, const mesh::Mesh& mesh,
              std::span<const Field> pointFields, std::span<const Field> cellFields) {
  const auto points = static_cast<std::size_t>(mesh.numVertices());
  const auto cells = static_cast<std::size_t>(mesh.numCells());
  std::vector<Array> arrays;
  for (const Field& f : pointFields) arrays.push_back(fieldArray(f, points, "point"));
  for (const Field& f : cellFields) arrays.push_back(fieldArray(f, cells, "cell"));
  // points, connectivity, offsets and types in arrays of their own, filled on the threads; the
  // file shows their bytes
  std::vector<double> coordinates(points * 3);
  forRanges(mesh.numVertices(), [&](Index begin, Index end) {
    for (Index v = begin; v < end; ++v)
      for (int k = 0; k < 3; ++k) coordinates[static_cast<std::size_t>(v) * 3 + k] = mesh.vertex(v)[k];
  });
  Array xyz{"Float64", "Points", 3, {}, bytesOf(coordinates), {}};
  setRange(xyz, coordinates);
  std::vector<std::int64_t> offsetValues(cells), connectivityValues;
  std::vector<std::uint8_t> typeValues(cells);
  std::int64_t end = 0;
  for (mesh::Index c = 0; c < mesh.numCells(); ++c) {
    end += static_cast<std::int64_t>(mesh.cellVertices(c).size());
    offsetValues[static_cast<std::size_t>(c)] = end;
  }
  connectivityValues.resize(static_cast<std::size_t>(end));
  forRanges(mesh.numCells(), [&](Index begin, Index stop) {
    for (Index c = begin; c < stop; ++c) {
      const mesh::CellType type = mesh.cellType(c);
      const auto verts = mesh.cellVertices(c);
      std::int64_t* out = connectivityValues.data() + offsetValues[static_cast<std::size_t>(c)] - verts.size();
      for (std::size_t i = 0; i < verts.size(); ++i)
        out[i] = type == mesh::CellType::Prism ? verts[kPrismToVtk[i]] : verts[i];
      typeValues[static_cast<std::size_t>(c)] = static_cast<std::uint8_t>(vtkCellType(type));
    }
  });
  Array connectivity{"Int64", "connectivity", 1, {}, bytesOf(connectivityValues), {}},
      offsets{"Int64", "offsets", 1, {}, bytesOf(offsetValues), {}}, types{"UInt8", "types", 1, {}, bytesOf(typeValues), {}};
  arrays.push_back(std::move(xyz));
  arrays.push_back(std::move(connectivity));
  arrays.push_back(std::move(offsets));
  arrays.push_back(std::move(types));
  compress(arrays);

  // appended data: per array a header of UInt64 (blocks, block size, size of a partial last block
  // or 0, compressed size of each block), then its compressed blocks
  std::vector<std::uint64_t> offsetOf;
  std::uint64_t at = 0;
  for (const Array& a : arrays) {
    offsetOf.push_back(at);
    at += 8 * (3 + a.blocks.size());
    for (const auto& b : a.blocks) at += b.size();
  }
  std::ostringstream xml;
  xml << std::setprecision(std::numeric_limits<double>::max_digits10);
  const auto dataArray = [&](std::size_t i, const char* indent) {
    const Array& a = arrays[i];
    xml << indent << "<DataArray type=\"" << a.type << "\" Name=\"" << xmlEscaped(a.name) << "\"";
    if (a.components > 1) xml << " NumberOfComponents=\"" << a.components << "\"";
    if (a.ranged) xml << " RangeMin=\"" << a.lo << "\" RangeMax=\"" << a.hi << "\"";
    xml << " format=\"appended\" offset=\"" << offsetOf[i] << "\"/>\n";
  };
  xml << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\n"
      << "  <UnstructuredGrid>\n"
      << "    <Piece NumberOfPoints=\"" << points << "\" NumberOfCells=\"" << cells << "\">\n"
      << "      <PointData>\n";
  std::size_t i = 0;
  for (; i < pointFields.size(); ++i) dataArray(i, "        ");
  xml << "      </PointData>\n      <CellData>\n";
  for (; i < pointFields.size() + cellFields.size(); ++i) dataArray(i, "        ");
  xml << "      </CellData>\n      <Points>\n";
  dataArray(i++, "        ");
  xml << "      </Points>\n      <Cells>\n";
  for (int k = 0; k < 3; ++k) dataArray(i++, "        ");
  xml << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";

  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(path.string() + ": cannot open for writing");
  const std::string head = xml.str();
  out.write(head.data(), static_cast<std::streamsize>(head.size()));
  for (const Array& a : arrays) {
    std::vector<unsigned char> header;
    put<std::uint64_t>(header, a.blocks.size());
    put<std::uint64_t>(header, kBlockBytes);
    put<std::uint64_t>(header, a.bytes().size() % kBlockBytes);
    for (const auto& b : a.blocks) put<std::uint64_t>(header, b.size());
    out.write(reinterpret_cast<const char*>(header.data()), static_cast<std::streamsize>(header.size()));
    for (const auto& b : a.blocks)
      out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  }
  out << "\n  </AppendedData>\n</VTKFile>\n";
  out.close();
  if (!out) throw Error(path.string() + ": cannot write the VTK file");
}

void writePvdCollection(const std::filesystem::path& path, const std::vector<PvdEntry>& entries) {
  std::ofstream out(path);
  if (!out) throw Error(path.string() + ": cannot write the .pvd collection");
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
  for (const PvdEntry& e : entries) {
    std::array<char, 32> time{};
    const auto end = std::to_chars(time.data(), time.data() + time.size(), e.time).ptr;  // shortest round trip
    out << "    <DataSet timestep=\"" << std::string_view(time.data(), static_cast<std::size_t>(end - time.data()))
        << "\" part=\"" << e.part << "\" file=\"" << e.file << "\"/>\n";
  }
  out << "  </Collection>\n</VTKFile>\n";
  if (!out) throw Error(path.string() + ": cannot write the .pvd collection");
}

}  // namespace obs::drivers
