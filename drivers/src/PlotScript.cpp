#include "PlotScript.hpp"

#include <cstdio>
#include <cstdlib>

namespace obs::drivers {

namespace {

std::string quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace

PlotScriptRun runPlotScript(const std::filesystem::path& script, const std::vector<std::string>& args) {
  std::vector<std::string> pythons;
  if (const char* env = std::getenv("OBS_PYTHON"); env && *env)
    pythons.emplace_back(env);
  else
    pythons = {"python3", "/usr/bin/python3"};
  std::string tail = " " + quoted(script.string());
  for (const std::string& a : args) tail += " " + quoted(a);
  PlotScriptRun run;
  for (const std::string& python : pythons) {
    run.command = quoted(python) + tail;
    FILE* pipe = popen((run.command + " 2>&1").c_str(), "r");
    if (!pipe) continue;
    run.output.clear();
    char buffer[512];
    while (std::fgets(buffer, sizeof buffer, pipe)) run.output += buffer;
    if (pclose(pipe) == 0) {
      run.ok = true;
      break;
    }
  }
  while (!run.output.empty() && (run.output.back() == '\n' || run.output.back() == '\r')) run.output.pop_back();
  return run;
}

}  // namespace obs::drivers
