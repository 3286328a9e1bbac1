#include "obs/drivers/CsvWriter.hpp"

#include <array>
#include <charconv>
#include <fstream>

#include "obs/mesh/Error.hpp"

namespace obs::drivers {

namespace {

std::string number(double v) {
  std::array<char, 32> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), r.ptr);
}

std::string quoted(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace

std::string csvHeader() {
  return "scene,cells,vertices,dofs,assembly_s,solve_s,total_s,peak_mb,max_displacement,max_von_"
         "mises";
}

std::string csvRow(const RunResult& r) {
  return quoted(r.scene) + "," + std::to_string(r.cells) + "," + std::to_string(r.vertices) + "," +
         std::to_string(r.dofs) + "," + number(r.assemblySeconds) + "," + number(r.solveSeconds) +
         "," + number(r.totalSeconds) + "," + number(r.peakMemoryMB) + "," +
         number(r.maxDisplacement) + "," + number(r.maxVonMises);
}

void appendCsvRow(const std::filesystem::path& path, const RunResult& result) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  const bool fresh =
      !std::filesystem::exists(path, ec) || std::filesystem::file_size(path, ec) == 0;
  std::ofstream out(path, std::ios::app);
  if (!out) throw Error(path.string() + ": cannot open for writing");
  if (fresh) out << csvHeader() << '\n';
  out << csvRow(result) << '\n';
  if (!out) throw Error(path.string() + ": write failed");
}

}  // namespace obs::drivers
