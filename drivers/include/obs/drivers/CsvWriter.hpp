#pragma once
/// \file CsvWriter.hpp
/// One CSV row per run, appended to a table that collects runs (e.g. of a refinement study):
///   scene,cells,vertices,dofs,assembly_s,solve_s,total_s,peak_mb,max_displacement,max_von_mises,
///   solver,iterations,converged,potential_contact,actual_contact,contact_force_x,contact_force_y,
///   contact_force_z,load_P,contact_area,contact_radius,max_violation,kkt_feasibility,
///   kkt_multiplier_sign,kkt_complementarity,kkt_stationarity
/// (RunResult.hpp; contact and KKT fields are empty for scenes without [contact], contact_force_z in
/// 2D). The header is written when the file is new or empty; appending to a file with another
/// header (an older column set) is an error rather than a misaligned table.
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
