#include "obs/drivers/Summary.hpp"

#include <fstream>

#include "obs/estimators/Version.hpp"
#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

nlohmann::json summaryJson(const RunResult& r) {
  nlohmann::json perType = nlohmann::json::object();
  for (mesh::CellType t : mesh::kVolumeCellTypes)
    if (const long long n = r.cellsPerType[static_cast<int>(t)]; n > 0)
      perType[std::string(mesh::name(t))] = n;
  nlohmann::json files = nlohmann::json::array();
  for (const auto& f : r.outputFiles) files.push_back(f.string());
  return {
      {"obs_version", estimators::version()},
      {"scene", r.scene},
      {"dimension", r.dimension},
      {"vertices", r.vertices},
      {"cells", r.cells},
      {"cells_per_type", perType},
      {"refine", r.refine},
      {"dofs", r.dofs},
      {"free_dofs", r.freeDofs},
      {"times",
       {{"mesh_s", r.meshSeconds},
        {"assembly_s", r.assemblySeconds},
        {"solve_s", r.solveSeconds},
        {"output_s", r.outputSeconds},
        {"total_s", r.totalSeconds}}},
      {"peak_memory_mb", r.peakMemoryMB},
      {"max_displacement", r.maxDisplacement},
      {"max_von_mises", r.maxVonMises},
      {"output_files", files},
  };
}

void writeSummary(const std::filesystem::path& path, const RunResult& result) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  std::ofstream out(path);
  if (!out) throw Error(path.string() + ": cannot open for writing");
  out << summaryJson(result).dump(2) << '\n';
  if (!out) throw Error(path.string() + ": write failed");
}

}  // namespace obs::drivers
