#pragma once
/// \file CsvWriter.hpp
/// One CSV row per run, appended to a table that collects runs (e.g. of a refinement study):
///   scene,cells,vertices,dofs,assembly_s,solve_s,total_s,peak_mb,max_displacement,max_von_mises
/// The header is written when the file is new or empty.
#include <filesystem>
#include <string>

#include "obs/drivers/RunResult.hpp"

namespace obs::drivers {

/// The header line (without newline).
std::string csvHeader();
/// The row of a run (without newline); fields with commas or quotes are quoted.
std::string csvRow(const RunResult& result);
/// Appends the row (and the header first if the file is new or empty); creates directories.
/// Throws obs::Error if the file cannot be written.
void appendCsvRow(const std::filesystem::path& path, const RunResult& result);

}  // namespace obs::drivers
