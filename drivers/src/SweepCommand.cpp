#include "obs/drivers/SweepCommand.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

#include "PlotScript.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/mesh/Error.hpp"

extern char** environ;

namespace obs::drivers {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

/// One run of the sweep: its overrides and, once run (or reused), its measurements.
struct Run {
  int index = 0, repeat = 0;
  std::vector<std::string> values;     ///< one per varied key
  std::vector<std::string> overrides;  ///< fixed --set first, then the varied keys
  fs::path directory;
  bool ok = false, reused = false;
  std::string error;
  double wallSeconds = 0, peakMb = 0;
  json summary;  ///< the run's summary.json (null if none)
};

std::optional<double> number(const json& j, std::initializer_list<const char*> path) {
  const json* p = &j;
  for (const char* key : path) {
    if (!p->is_object() || !p->contains(key)) return std::nullopt;
    p = &(*p)[key];
  }
  if (!p->is_number()) return std::nullopt;
  return p->get<double>();
}

/// The last adaptive step of a summary, or null.
const json* lastStep(const json& s) {
  if (!s.is_object() || !s.contains("adaptivity")) return nullptr;
  const json& steps = s["adaptivity"]["steps"];
  if (!steps.is_array() || steps.empty()) return nullptr;
  return &steps.back();
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

std::string formatNumber(std::optional<double> v) {
  if (!v || !std::isfinite(*v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", *v);
  return buf;
}

/// Dynamic runs: |E_end / E_0 - 1|, the deviation from the energy the continuous (frictionless,
/// elastic) problem conserves.
std::optional<double> energyError(std::optional<double> ratio) {
  if (!ratio) return std::nullopt;
  return std::abs(*ratio - 1);
}

/// The first "obs: error: ..." line of a run's stderr (without the prefix), else its last line.
std::string errorOf(const fs::path& stderrFile) {
  std::ifstream in(stderrFile);
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.rfind("obs: error: ", 0) == 0) return line.substr(12);
    if (!trim(line).empty()) last = line;
  }
  return last;
}

json readJson(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return nullptr;
  try {
    return json::parse(in);
  } catch (const json::exception&) {
    return nullptr;
  }
}

/// Runs `obs run` for one combination in its own process; fills ok/error/wall/peak/summary and
/// writes sweep_run.json last (its presence marks the run as done for a resumed sweep).
void execute(const SweepOptions& o, Run& run) {
  fs::remove_all(run.directory);
  fs::create_directories(run.directory);
  std::vector<std::string> args;
  if (o.mpiRanks > 0) args = {o.mpiLauncher, "-n", std::to_string(o.mpiRanks)};
  for (const std::string& a :
       {o.obsBinary.string(), std::string("run"), o.scene.string(), std::string("--output"), run.directory.string(),
        std::string("--quiet")})
    args.push_back(a);
  for (const std::string& s : run.overrides) {
    args.push_back("--set");
    args.push_back(s);
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  const std::string out = (run.directory / "stdout.txt").string(), err = (run.directory / "stderr.txt").string();
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  const auto start = std::chrono::steady_clock::now();
  pid_t pid = 0;
  // the launcher is looked up on PATH (posix_spawnp), obs itself is a path
  const int spawned = o.mpiRanks > 0 ? posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ)
                                     : posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw Error("sweep: cannot start " + std::string(argv[0]) + ": " + std::strerror(spawned));
  int status = 0;
  struct rusage usage {};
  while (wait4(pid, &status, 0, &usage) < 0) {
    if (errno != EINTR) throw Error(std::string("sweep: waiting for a run failed: ") + std::strerror(errno));
  }
  run.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.peakMb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
  run.ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  if (!run.ok)
    run.error = WIFSIGNALED(status) ? "killed by signal " + std::to_string(WTERMSIG(status)) : errorOf(err);
  if (!run.ok && run.error.empty()) run.error = "exit code " + std::to_string(WEXITSTATUS(status));
  run.summary = readJson(run.directory / "summary.json");
  // a distributed run: the largest rank's peak (the launcher's own is not the ranks')
  if (const auto largest = number(run.summary, {"peak_memory_mb_largest_rank"})) run.peakMb = *largest;

  const json record = {{"scene", fs::absolute(o.scene).lexically_normal().string()},
                       {"overrides", run.overrides},
                       {"ranks", std::max(o.mpiRanks, 1)},
                       {"status", run.ok ? "ok" : "failed"},
                       {"error", run.error},
                       {"wall_s", run.wallSeconds},
                       {"peak_mb", run.peakMb}};
  const fs::path tmp = run.directory / "sweep_run.json.tmp";
  std::ofstream(tmp) << record.dump(2) << "\n";
  fs::rename(tmp, run.directory / "sweep_run.json");
}

/// A finished run of an earlier (interrupted) sweep with the same scene and overrides.
bool reuse(const SweepOptions& o, Run& run) {
  const json record = readJson(run.directory / "sweep_run.json");
  if (!record.is_object()) return false;
  if (record.value("scene", "") != fs::absolute(o.scene).lexically_normal().string()) return false;
  if (record.value("overrides", std::vector<std::string>{}) != run.overrides) return false;
  if (record.value("ranks", 1) != std::max(o.mpiRanks, 1)) return false;
  run.ok = record.value("status", "") == "ok";
  run.error = record.value("error", "");
  run.wallSeconds = record.value("wall_s", 0.0);
  run.peakMb = record.value("peak_mb", 0.0);
  run.summary = readJson(run.directory / "summary.json");
  run.reused = true;
  return true;
}

std::string describe(const SweepOptions& o, const Run& run) {
  std::string s;
  for (std::size_t k = 0; k < o.vary.size(); ++k) s += (k ? " " : "") + o.vary[k].key + "=" + run.values[k];
  if (o.repeat > 1) s += " (repeat " + std::to_string(run.repeat + 1) + ")";
  return s;
}

}  // namespace

SweepVariable parseSweepVariable(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error("--vary '" + text + "': expected KEY=V1,V2,... (e.g. --vary mesh.refine=1,2,3)");
  SweepVariable v;
  v.key = trim(text.substr(0, eq));
  if (v.key.find('.') == std::string::npos)
    throw Error("--vary '" + text + "': the key must be SECTION.KEY as in --set (e.g. mesh.refine)");
  std::string current;
  int depth = 0;
  char quote = 0;
  for (char c : text.substr(eq + 1)) {
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[' || c == '{') {
      ++depth;
    } else if (c == ']' || c == '}') {
      --depth;
    } else if (c == ',' && depth == 0) {
      v.values.push_back(trim(current));
      current.clear();
      continue;
    }
    current += c;
  }
  if (quote || depth != 0) throw Error("--vary '" + text + "': unbalanced quotes or brackets");
  v.values.push_back(trim(current));
  for (const std::string& value : v.values)
    if (value.empty()) throw Error("--vary '" + text + "': an empty value (two commas in a row?)");
  return v;
}

SweepSummary runSweep(const SweepOptions& o) {
  if (o.vary.empty()) throw Error("sweep: nothing to vary (give at least one --vary KEY=V1,V2,...)");
  if (o.repeat < 1) throw Error("sweep: --repeat must be at least 1");
  for (std::size_t a = 0; a < o.vary.size(); ++a)
    for (std::size_t b = a + 1; b < o.vary.size(); ++b)
      if (o.vary[a].key == o.vary[b].key) throw Error("sweep: --vary " + o.vary[a].key + " is given twice");

  // every combination (the last key varies fastest), checked before anything runs
  std::vector<Run> runs;
  std::vector<std::size_t> pick(o.vary.size(), 0);
  for (bool more = true; more;) {
    Run base;
    base.overrides = o.overrides;
    for (std::size_t k = 0; k < o.vary.size(); ++k) {
      base.values.push_back(o.vary[k].values[pick[k]]);
      base.overrides.push_back(o.vary[k].key + "=" + o.vary[k].values[pick[k]]);
    }
    try {
      parseScene(o.scene, base.overrides);
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (in the sweep combination " + [&] {
                    std::string s;
                    for (std::size_t k = 0; k < o.vary.size(); ++k) s += (k ? " " : "") + base.overrides[o.overrides.size() + k];
                    return s;
                  }() + ")");
    }
    for (int r = 0; r < o.repeat; ++r) {
      Run run = base;
      run.repeat = r;
      run.index = static_cast<int>(runs.size());
      char name[32];
      std::snprintf(name, sizeof name, "run_%03d", run.index);
      run.directory = o.output / name;
      runs.push_back(std::move(run));
    }
    more = false;
    for (std::size_t k = o.vary.size(); k-- > 0;) {
      if (++pick[k] < o.vary[k].values.size()) {
        more = true;
        break;
      }
      pick[k] = 0;
    }
  }

  // the explicit reference run, last
  std::optional<Run> explicitReference;
  if (!o.referenceOverrides.empty()) {
    Run ref;
    ref.overrides = o.overrides;
    ref.overrides.insert(ref.overrides.end(), o.referenceOverrides.begin(), o.referenceOverrides.end());
    for (const SweepVariable& v : o.vary) {
      std::string value;
      for (const std::string& r : o.referenceOverrides)
        if (r.rfind(v.key + "=", 0) == 0) value = r.substr(v.key.size() + 1);
      ref.values.push_back(value);
    }
    try {
      parseScene(o.scene, ref.overrides);
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (in the sweep's reference run)");
    }
    ref.index = static_cast<int>(runs.size());
    ref.directory = o.output / "run_ref";
    explicitReference = ref;
  }

  std::error_code ec;
  fs::create_directories(o.output, ec);
  if (ec) throw Error("sweep: cannot create " + o.output.string() + ": " + ec.message());

  SweepSummary summary;
  summary.runs = static_cast<int>(runs.size());
  for (Run& run : runs) {
    if (!reuse(o, run)) execute(o, run);
    summary.failed += !run.ok;
    summary.reused += run.reused;
    if (o.progress) {
      std::ostringstream line;
      line << "[" << run.index + 1 << "/" << runs.size() << "] " << describe(o, run) << ": ";
      if (run.ok) {
        char wall[32];
        std::snprintf(wall, sizeof wall, "%.3g", run.wallSeconds);
        line << wall << " s, " << formatNumber(std::round(run.peakMb)) << " MB";
        if (const auto n = number(run.summary, {"dofs"})) line << ", " << formatNumber(n) << " unknowns";
        if (const auto p = number(run.summary, {"contact", "load_P"})) line << ", P = " << formatNumber(p);
      } else {
        line << "failed: " << run.error;
      }
      if (run.reused) line << " (done earlier, reused)";
      o.progress(line.str());
    }
  }

  if (explicitReference) {
    Run& ref = *explicitReference;
    if (!reuse(o, ref)) execute(o, ref);
    if (o.progress)
      o.progress("[reference] " + [&] {
        std::string s;
        for (const std::string& r : o.referenceOverrides) s += (s.empty() ? "" : " ") + r;
        return s;
      }() + ": " + (ref.ok ? "done" : "failed: " + ref.error) + (ref.reused ? " (done earlier, reused)" : ""));
    if (!ref.ok) throw Error("sweep: the reference run failed: " + ref.error + " (its outputs: " + ref.directory.string() + ")");
    runs.push_back(ref);
  }

  // reference: the explicit one, else the successful run with the most unknowns; among those the
  // one solved to the smallest solver tolerance; then the first
  const Run* reference = explicitReference ? &runs.back() : nullptr;
  auto better = [&](const Run& a, const Run& b) {
    const double na = *number(a.summary, {"dofs"}), nb = *number(b.summary, {"dofs"});
    if (na != nb) return na > nb;
    const double ta = number(a.summary, {"solver", "tolerance"}).value_or(INFINITY);
    const double tb = number(b.summary, {"solver", "tolerance"}).value_or(INFINITY);
    return ta < tb;
  };
  if (!reference)
    for (const Run& run : runs)
      if (run.ok && number(run.summary, {"dofs"}) && (!reference || better(run, *reference))) reference = &run;
  const auto refLoad = reference ? number(reference->summary, {"contact", "load_P"}) : std::nullopt;
  const auto refDisp = reference ? number(reference->summary, {"max_displacement"}) : std::nullopt;
  auto relative = [](std::optional<double> v, std::optional<double> ref) -> std::optional<double> {
    if (!v || !ref || *ref == 0) return std::nullopt;
    return std::abs(*v - *ref) / std::abs(*ref);
  };

  summary.csv = o.output / "sweep.csv";
  std::ofstream csv(summary.csv);
  if (!csv) throw Error("sweep: cannot write " + summary.csv.string());
  csv << "run,repeat";
  for (const SweepVariable& v : o.vary) csv << "," << csvField(v.key);
  csv << ",status,error,unknowns,vertices,iterations,load_P,max_displacement,eta,analytic_error,load_error,"
         "displacement_error,energy_ratio,energy_error,force_variation,max_penetration,wall_s,solver_s,peak_mb,"
         "reference,ranks\n";
  for (const Run& run : runs) {
    const json& s = run.summary;
    const json* step = lastStep(s);
    const bool isReference = &run == reference;
    // the load and max |u| of a dynamic run are those of its last step: no accuracy measure
    const bool compare = run.ok && !isReference && !(s.is_object() && s.contains("dynamics"));
    if (explicitReference && &run == &runs.back())
      csv << "ref," << run.repeat;
    else
      csv << run.index << "," << run.repeat;
    for (const std::string& value : run.values) csv << "," << csvField(value);
    csv << "," << (run.ok ? "ok" : "failed") << "," << csvField(run.error) << "," << formatNumber(number(s, {"dofs"}))
        << "," << formatNumber(number(s, {"vertices"})) << ","
        << formatNumber(step ? number(*step, {"iterations"}) : number(s, {"solver", "iterations"})) << ","
        << formatNumber(number(s, {"contact", "load_P"})) << "," << formatNumber(number(s, {"max_displacement"}))
        << "," << formatNumber(step ? number(*step, {"eta"}) : std::nullopt) << ","
        << formatNumber(step ? number(*step, {"reference", "pressure_error"}) : std::nullopt) << ","
        << (compare ? formatNumber(relative(number(s, {"contact", "load_P"}), refLoad)) : "") << ","
        << (compare ? formatNumber(relative(number(s, {"max_displacement"}), refDisp)) : "") << ","
        << formatNumber(number(s, {"dynamics", "energy_ratio"})) << ","
        << formatNumber(energyError(number(s, {"dynamics", "energy_ratio"}))) << ","
        << formatNumber(number(s, {"dynamics", "contact_force_variation"})) << ","
        << formatNumber(number(s, {"dynamics", "max_penetration"})) << ","
        << formatNumber(run.wallSeconds) << "," << formatNumber(number(s, {"times", "solve_s"})) << ","
        << formatNumber(run.peakMb) << "," << (isReference ? "1" : "0") << "," << std::max(o.mpiRanks, 1) << "\n";
  }
  csv.close();
  if (!csv) throw Error("sweep: cannot write " + summary.csv.string());

  if (o.plots) {
    fs::path script;
    if (const char* env = std::getenv("OBS_PLOT_SWEEP_SCRIPT"); env && *env)
      script = env;
    else
#ifdef OBS_PLOT_SWEEP_SCRIPT
      script = OBS_PLOT_SWEEP_SCRIPT;
#else
      script = "scripts/plot_sweep.py";
#endif
    const PlotScriptRun plot = runPlotScript(script, {summary.csv.string()});
    if (!plot.ok) {
      if (o.progress)
        o.progress("warning: no plots (python3 with matplotlib needed to run " + script.string() + ")");
    } else {
      for (const char* name : {"accuracy_vs_time.png", "accuracy_vs_memory.png"})
        if (fs::exists(o.output / name)) summary.plots.push_back(o.output / name);
    }
  }
  return summary;
}

}  // namespace obs::drivers
