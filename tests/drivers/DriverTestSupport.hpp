#pragma once
/// \file DriverTestSupport.hpp
/// Small helpers shared by the driver tests: running the `obs` program, reading output files back.
#include <sys/wait.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace obs::test {

/// The whole content of a file ("" if it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The summary.json of a run's output directory.
inline nlohmann::json summaryOf(const std::filesystem::path& dir) {
  std::ifstream in(dir / "summary.json");
  return nlohmann::json::parse(in);
}

/// A CSV file as columns by header name (empty fields: NaN).
struct Table {
  std::vector<std::string> header;
  std::map<std::string, std::vector<double>> columns;
  std::size_t rows = 0;
  const std::vector<double>& operator[](const std::string& key) const { return columns.at(key); }
};

inline Table readCsv(const std::filesystem::path& p) {
  std::ifstream in(p);
  Table t;
  std::string line;
  std::getline(in, line);
  std::stringstream hs(line);
  for (std::string h; std::getline(hs, h, ',');) t.header.push_back(h);
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::size_t k = 0;
    for (std::string f; k < t.header.size(); ++k) {
      if (!std::getline(ls, f, ',')) f.clear();
      t.columns[t.header[k]].push_back(f.empty() ? std::nan("") : std::stod(f));
    }
    ++t.rows;
  }
  return t;
}

/// The points and point arrays of a .vtu file, read with VTK's own reader.
struct Vtu {
  std::vector<std::array<double, 3>> points;
  /// point array by name (components interleaved), empty if absent
  std::vector<double> array(const std::string& name) const {
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? std::vector<double>{} : arrays[static_cast<std::size_t>(it - names.begin())];
  }
  std::vector<std::string> names;
  std::vector<std::vector<double>> arrays;
};

inline Vtu readVtu(const std::filesystem::path& p) {
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(p.string().c_str());
  reader->Update();
  vtkUnstructuredGrid* g = reader->GetOutput();
  Vtu v;
  for (vtkIdType i = 0; i < g->GetNumberOfPoints(); ++i) {
    double x[3];
    g->GetPoint(i, x);
    v.points.push_back({x[0], x[1], x[2]});
  }
  vtkPointData* pd = g->GetPointData();
  for (int a = 0; a < pd->GetNumberOfArrays(); ++a) {
    vtkDataArray* arr = pd->GetArray(a);
    v.names.push_back(arr->GetName());
    std::vector<double> values;
    for (vtkIdType i = 0; i < arr->GetNumberOfTuples(); ++i)
      for (int k = 0; k < arr->GetNumberOfComponents(); ++k) values.push_back(arr->GetComponent(i, k));
    v.arrays.push_back(std::move(values));
  }
  return v;
}

#ifdef OBS_BINARY
/// Exit code and captured streams of one `obs` invocation.
struct ObsOutput {
  int code = -1;
  std::string out, err;
};

/// Runs `obs <args>` with workDir as the current directory; stdout and stderr go to
/// workDir/<tag>.out and .err and are returned. OBS_THREADS is removed from its environment: it runs
/// on one thread unless args say --threads, as the in-process runs the tests compare it with.
/// `environment`: NAME=VALUE pairs for the program's environment (space-separated, given to env).
inline ObsOutput runObs(const std::filesystem::path& workDir, const std::string& args, const std::string& tag,
                        const std::string& environment = "") {
  std::filesystem::create_directories(workDir);
  const auto out = workDir / (tag + ".out"), err = workDir / (tag + ".err");
  const std::string cmd = "cd '" + workDir.string() + "' && env -u OBS_THREADS " + environment + " '" +
                          std::string(OBS_BINARY) + "' " + args + " >'" +
                          out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  ObsOutput o;
  o.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  o.out = slurp(out);
  o.err = slurp(err);
  return o;
}
#endif

}  // namespace obs::test
