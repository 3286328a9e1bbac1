#pragma once
/// \file PlotScript.hpp
/// Running the plotting scripts of scripts/ (python3 + matplotlib) from the drivers.
#include <filesystem>
#include <string>
#include <vector>

namespace obs::drivers {

/// The outcome of runPlotScript: whether an interpreter ran the script successfully, the last
/// command tried and its combined stdout/stderr.
struct PlotScriptRun {
  bool ok = false;
  std::string command, output;
};

/// Runs `PYTHON script args...` with the first interpreter that succeeds, in this order:
/// $OBS_PYTHON (if set, only it), else python3 on the PATH, then /usr/bin/python3 (a PATH python,
/// e.g. pyenv's, may lack matplotlib while the system's has it). Arguments are shell-quoted.
/// A failure is not an exception: plots are optional, the caller warns.
PlotScriptRun runPlotScript(const std::filesystem::path& script, const std::vector<std::string>& args);

}  // namespace obs::drivers
