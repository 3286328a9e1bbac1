#pragma once
/// \file RunResult.hpp
/// Figures of one `obs run`: problem size, cost (times, memory) and solution extremes. Written to
/// summary.json (Summary.hpp) and as a CSV row (CsvWriter.hpp).
#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace obs::drivers {

struct RunResult {
  std::string scene;  ///< scene file as given
  int dimension = 0;
  long long vertices = 0;
  long long cells = 0;
  std::array<long long, 7> cellsPerType{};  ///< indexed by static_cast<int>(mesh::CellType)
  int refine = 0;                           ///< uniform refinements applied
  long long dofs = 0;
  long long freeDofs = 0;

  // wall times in seconds
  double meshSeconds = 0;      ///< build or read the mesh, refine, validate
  double assemblySeconds = 0;  ///< matrix and load assembly
  double solveSeconds = 0;     ///< factorise and solve
  double outputSeconds = 0;    ///< .vtu and CSV
  double totalSeconds = 0;     ///< from reading the scene until summary.json is written

  double peakMemoryMB = 0;     ///< getrusage ru_maxrss of the process
  double maxDisplacement = 0;  ///< max over vertices of |u|
  double maxVonMises = 0;      ///< max over cells of the von Mises stress of the cell mean

  std::vector<std::filesystem::path> outputFiles;  ///< everything written, summary.json last
};

}  // namespace obs::drivers
