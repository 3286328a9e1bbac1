#pragma once
/// \file DriverTestSupport.hpp
/// Small helpers shared by the driver tests: running the `obs` program, reading output files back.
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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

#ifdef OBS_BINARY
/// Exit code and captured streams of one `obs` invocation.
struct ObsOutput {
  int code = -1;
  std::string out, err;
};

/// Runs `obs <args>` with workDir as the current directory; stdout and stderr go to
/// workDir/<tag>.out and .err and are returned.
inline ObsOutput runObs(const std::filesystem::path& workDir, const std::string& args, const std::string& tag) {
  std::filesystem::create_directories(workDir);
  const auto out = workDir / (tag + ".out"), err = workDir / (tag + ".err");
  const std::string cmd = "cd '" + workDir.string() + "' && '" + std::string(OBS_BINARY) + "' " + args + " >'" +
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
