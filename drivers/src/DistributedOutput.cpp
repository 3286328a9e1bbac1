#include "DistributedOutput.hpp"

#include <fstream>

#include "RunSupport.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

using mesh::Index;

namespace {

/// The owned cells of a rank's local mesh (its first `cells` cells) on the vertices they use:
/// piece vertex -> local vertex in `vertex`.
struct OwnedPiece {
  mesh::Mesh mesh;
  std::vector<Index> vertex;
};

OwnedPiece ownedPiece(const mesh::Mesh& local, Index cells) {
  OwnedPiece p{mesh::Mesh(local.dimension()), {}};
  std::vector<Index> pieceOf(static_cast<std::size_t>(local.numVertices()), -1);
  std::vector<Index> corners;
  for (Index c = 0; c < cells; ++c) {
    corners.clear();
    for (Index v : local.cellVertices(c)) {
      if (pieceOf[v] < 0) {
        pieceOf[v] = p.mesh.addVertex(local.vertex(v));
        p.vertex.push_back(v);
      }
      corners.push_back(pieceOf[v]);
    }
    p.mesh.addCell(local.cellType(c), corners);
  }
  return p;
}

/// A field of the local mesh's vertices restricted to a piece's vertices.
Field pieceField(const Field& f, const std::vector<Index>& vertex) {
  Field out{f.name, f.components, {}, f.integer};
  out.values.reserve(vertex.size() * static_cast<std::size_t>(f.components));
  for (Index v : vertex)
    for (int k = 0; k < f.components; ++k) out.values.push_back(f.values[static_cast<std::size_t>(v) * f.components + k]);
  return out;
}

/// The .pvtu joining the ranks' pieces (ParaView's parallel unstructured grid).
void writePvtu(const std::filesystem::path& path, const std::vector<std::string>& pieces,
               const std::vector<Field>& pointFields, const std::vector<Field>& cellFields) {
  std::ofstream out(path);
  const auto array = [&](const Field& f) {
    out << "      <PDataArray type=\"" << (f.integer ? "Int32" : "Float64") << "\" Name=\"" << f.name
        << "\" NumberOfComponents=\"" << f.components << "\"/>\n";
  };
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n  <PUnstructuredGrid GhostLevel=\"0\">\n    <PPointData>\n";
  for (const Field& f : pointFields) array(f);
  out << "    </PPointData>\n    <PCellData>\n";
  for (const Field& f : cellFields) array(f);
  out << "    </PCellData>\n    <PPoints>\n      <PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n    </PPoints>\n";
  for (const std::string& p : pieces) out << "    <Piece Source=\"" << p << "\"/>\n";
  out << "  </PUnstructuredGrid>\n</VTKFile>\n";
  if (!out) throw Error(path.string() + ": cannot write");
}

}  // namespace

std::vector<std::filesystem::path> writePieces(const std::filesystem::path& dir, const std::string& base,
                                               const mesh::Mesh& local, Index ownedCells, const std::vector<Field>& pf,
                                               const std::vector<Field>& cf, const Communicator& comm) {
  comm.collective([&] {
    const OwnedPiece p = ownedPiece(local, ownedCells);
    std::vector<Field> points, cells;
    for (const Field& f : pf) points.push_back(pieceField(f, p.vertex));
    for (const Field& f : cf) {
      Field g{f.name, f.components, {}, f.integer};
      g.values.assign(f.values.begin(), f.values.begin() + static_cast<std::ptrdiff_t>(ownedCells) * f.components);
      cells.push_back(std::move(g));
    }
    cells.push_back(Field{"rank", 1, std::vector<double>(static_cast<std::size_t>(ownedCells), comm.rank()), true});
    writeVtu(dir / (base + "_" + std::to_string(comm.rank()) + ".vtu"), p.mesh, points, cells);
    if (comm.rank() == 0) {
      std::vector<std::string> pieces;
      for (int q = 0; q < comm.size(); ++q) pieces.push_back(base + "_" + std::to_string(q) + ".vtu");
      writePvtu(dir / (base + ".pvtu"), pieces, points, cells);
    }
  });
  std::vector<std::filesystem::path> files;
  if (comm.rank() == 0) {
    for (int q = 0; q < comm.size(); ++q) files.push_back(dir / (base + "_" + std::to_string(q) + ".vtu"));
    files.push_back(dir / (base + ".pvtu"));
  }
  return files;
}

nlohmann::json RankLoad::reduced(const Communicator& comm) const {
  std::vector<double> sums, maxima;
  for (const auto& f : figures) {
    sums.push_back(f.second);
    maxima.push_back(f.second);
  }
  comm.sum(sums);
  comm.max(maxima);
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t k = 0; k < figures.size(); ++k) {
    const double mean = sums[k] / comm.size();
    j[figures[k].first] = {{"max", maxima[k]}, {"mean", mean}, {"max_over_mean", mean > 0 ? maxima[k] / mean : 1.0}};
  }
  return j;
}

void addDistributedSummary(nlohmann::json& extra, const Communicator& comm, int partitionLevel, const RankLoad& load) {
  const double memory = peakMemoryMB();
  extra["ranks"] = comm.size();
  extra["peak_memory_mb_largest_rank"] = comm.max(memory);
  extra["peak_memory_mb_all_ranks"] = comm.sum(memory);
  extra["partition_level"] = partitionLevel;
  extra["balance"] = load.reduced(comm);
}

}  // namespace obs::drivers
