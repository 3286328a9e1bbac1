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

/// potential_contact ... max_violation; empty fields without [contact].
std::string contactColumns(const RunResult& r) {
  if (!r.contact) return std::string(8, ',');  // 9 empty fields
  const ContactReport& c = *r.contact;
  return std::to_string(c.potentialVertices) + "," + std::to_string(c.actualVertices) + "," +
         number(c.force[0]) + "," + number(c.force[1]) + "," +
         (r.dimension == 3 ? number(c.force[2]) : std::string()) + "," + number(c.load) + "," +
         number(c.area) + "," + number(c.radius) + "," + number(c.maxViolation);
}

std::string kktColumns(const RunResult& r) {
  if (!r.solver.kkt) return std::string(3, ',');
  const KktResiduals& k = *r.solver.kkt;
  return number(k.primalFeasibility) + "," + number(k.dualSign) + "," + number(k.complementarity) +
         "," + number(k.stationarity);
}

}  // namespace

std::string csvHeader() {
  return "scene,cells,vertices,dofs,assembly_s,solve_s,total_s,peak_mb,max_displacement,max_von_"
         "mises,solver,iterations,converged,potential_contact,actual_contact,contact_force_x,"
         "contact_force_y,contact_force_z,load_P,contact_area,contact_radius,max_violation,"
         "kkt_feasibility,kkt_multiplier_sign,kkt_complementarity,kkt_stationarity";
}

std::string csvRow(const RunResult& r) {
  return quoted(r.scene) + "," + std::to_string(r.cells) + "," + std::to_string(r.vertices) + "," +
         std::to_string(r.dofs) + "," + number(r.assemblySeconds) + "," + number(r.solveSeconds) +
         "," + number(r.totalSeconds) + "," + number(r.peakMemoryMB) + "," +
         number(r.maxDisplacement) + "," + number(r.maxVonMises) + "," + quoted(r.solver.type) +
         "," + std::to_string(r.solver.iterations) + "," + (r.solver.converged ? "1" : "0") + "," +
         contactColumns(r) + "," + kktColumns(r);
}

void appendCsvRow(const std::filesystem::path& path, const RunResult& result) {
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  const bool fresh =
      !std::filesystem::exists(path, ec) || std::filesystem::file_size(path, ec) == 0;
  if (!fresh) {
    std::ifstream in(path);
    std::string header;
    std::getline(in, header);
    if (header != csvHeader())
      throw Error(path.string() +
                  ": has other columns than this obs version writes (an older table?); move it "
                  "away or name another file with [output] csv");
  }
  std::ofstream out(path, std::ios::app);
  if (!out) throw Error(path.string() + ": cannot open for writing");
  if (fresh) out << csvHeader() << '\n';
  out << csvRow(result) << '\n';
  if (!out) throw Error(path.string() + ": write failed");
}

}  // namespace obs::drivers
