// Cost of the a posteriori estimator against the contact solve in an adaptive run: runs `obs run`
// on a scene (default data/scenes/example3b.toml --refine 1, 6 steps) and reads the per-step times of
// summary.json (adaptivity.steps[k].times: solver_s, estimator_s). With --baseline OTHER_OBS the same
// run is made with a second obs binary first (e.g. the binary of main before a change), and the table
// shows both side by side with the speed-up of the estimator and whether eta and every contribution
// eta_k of each step are bitwise equal in the two runs (summary.json keeps doubles round-trip exact).
// The baseline may also be the same binary with other scene settings (--baseline-set), e.g. the
// TNNMG V-cycle with and without local smoothing; the table then also compares the TNNMG iterations
// and the solve times. Writes the markdown block "estimator_cost" (or --block NAME; MarkdownBlock.hpp)
// of OUTPUT.md, or standard output.
//
// Sample run (a minute or two; the figures of docs/performance.md#estimator-cost):
//   build/bench/estimator_cost OUT.md --baseline /path/to/old/obs
// Options:
//   --obs PATH         the obs binary measured (default build/drivers/obs)
//   --baseline PATH    a second obs binary run first on the same scene (side by side in one run)
//   --scene FILE       default data/scenes/example3b.toml; repeat for several scenes (one table each);
//                      each scene takes the --steps given before it (or the default)
//   --refine N         --refine of obs run (default 1)
//   --steps N          adaptivity.steps (default 6)
//   --repeat N         runs per binary and scene, alternating baseline and measured; the table keeps
//                      the smallest time of each step over the runs (default 1)
//   --work DIR         output directories of the runs (default out/estimator_cost)
//   --set K=V          a --set of obs run for the measured runs (repeatable)
//   --baseline-set K=V a --set of obs run for the baseline runs (repeatable)
//   --block NAME       the markdown block written (default estimator_cost)
//   --label-old S, --label-new S   column labels of the two runs (default old, new)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "MarkdownBlock.hpp"

namespace {

struct Step {
  long long unknowns = 0;
  int iterations = 0;
  double solve = 0, estimator = 0, eta = 0, assembly = 0, refinement = 0, transfer = 0;
  double peakMemoryMb = 0;  ///< of the whole run (summary.json peak_memory_mb)
  std::vector<double> contributions;
};

std::string quote(const std::string& s) {
  std::string r = "'";
  for (char c : s) r += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return r + "'";
}

/// Runs obs on the scene into dir; the steps of summary.json. Exits on failure.
std::vector<Step> run(const std::string& obs, const std::string& scene, int refine, int steps,
                      const std::vector<std::string>& sets, int threads, const std::filesystem::path& dir) {
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir.parent_path());
  std::string cmd = quote(obs) + " run " + quote(scene) + " --refine " + std::to_string(refine) +
                    " --set adaptivity.steps=" + std::to_string(steps) + " --set 'adaptivity.vtk=\"none\"'";
  for (const std::string& kv : sets) cmd += " --set " + quote(kv);
  if (threads > 0) cmd += " --threads " + std::to_string(threads);
  cmd += " -o " + quote(dir.string()) + " > " + quote((dir.string() + ".log")) + " 2>&1";
  std::cerr << "estimator_cost: " << cmd << "\n";
  if (std::system(cmd.c_str()) != 0) {
    std::cerr << "estimator_cost: the run failed, see " << dir.string() << ".log\n";
    std::exit(1);
  }
  std::ifstream in(dir / "summary.json");
  if (!in) {
    std::cerr << "estimator_cost: no " << (dir / "summary.json").string() << "\n";
    std::exit(1);
  }
  const nlohmann::json j = nlohmann::json::parse(in);
  std::vector<Step> out;
  for (const auto& s : j.at("adaptivity").at("steps")) {
    Step r;
    r.unknowns = s.at("unknowns").get<long long>();
    r.iterations = s.at("iterations").get<int>();
    r.solve = s.at("times").at("solver_s").get<double>();
    r.estimator = s.at("times").value("estimator_s", 0.0);
    r.assembly = s.at("times").value("assembly_s", 0.0);
    r.refinement = s.at("times").value("refinement_s", 0.0);
    r.transfer = s.at("times").value("transfer_s", 0.0);
    r.peakMemoryMb = j.value("peak_memory_mb", 0.0);
    r.eta = s.value("eta", std::nan(""));
    if (s.contains("contributions"))
      for (const auto& [name, v] : s.at("contributions").items()) r.contributions.push_back(v.get<double>());
    out.push_back(std::move(r));
  }
  return out;
}

bool bitwiseEqual(const Step& a, const Step& b) {
  if (a.unknowns != b.unknowns || a.contributions.size() != b.contributions.size()) return false;
  if (std::memcmp(&a.eta, &b.eta, sizeof(double)) != 0) return false;
  for (std::size_t k = 0; k < a.contributions.size(); ++k)
    if (std::memcmp(&a.contributions[k], &b.contributions[k], sizeof(double)) != 0) return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string page, obs = "build/drivers/obs", baseline, work = "out/estimator_cost", block = "estimator_cost";
  std::string oldLabel = "old", newLabel = "new";
  std::vector<std::string> sets, baselineSets;
  std::vector<std::pair<std::string, int>> scenes;  // scene, steps
  int repeat = 1;
  int refine = 1, steps = 6;
  int threads = 0, baselineThreads = 0;  // 0: obs' default ($OBS_THREADS, else 1)
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "estimator_cost: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    try {
      if (a == "--obs") obs = next();
      else if (a == "--baseline") baseline = next();
      else if (a == "--scene") scenes.emplace_back(next(), steps);
      else if (a == "--repeat") repeat = std::stoi(next());
      else if (a == "--refine") refine = std::stoi(next());
      else if (a == "--steps") steps = std::stoi(next());
      else if (a == "--work") work = next();
      else if (a == "--set") sets.push_back(next());
      else if (a == "--baseline-set") baselineSets.push_back(next());
      else if (a == "--block") block = next();
      else if (a == "--label-old") oldLabel = next();
      else if (a == "--label-new") newLabel = next();
      else if (a == "--threads") threads = std::stoi(next());
      else if (a == "--baseline-threads") baselineThreads = std::stoi(next());
      else if (!a.starts_with("-") && page.empty()) page = a;
      else {
        std::cerr << "usage: estimator_cost [OUTPUT.md] [--obs PATH] [--baseline PATH] [--scene FILE] "
                     "[--refine N] [--steps N] [--repeat N] [--work DIR] [--set K=V] [--baseline-set K=V] "
                     "[--block NAME] [--label-old S] [--label-new S] [--threads N] [--baseline-threads N]\n";
        return 2;
      }
    } catch (const std::exception&) {
      std::cerr << "estimator_cost: " << a << " needs an integer\n";
      return 2;
    }
  }
  if (steps < 1 || refine < 0 || repeat < 1 || threads < 0 || baselineThreads < 0) {
    std::cerr << "estimator_cost: --steps and --repeat must be >= 1, --refine and --threads >= 0\n";
    return 2;
  }
  for (const auto& [scene, n] : scenes)
    if (n < 1) {
      std::cerr << "estimator_cost: --steps must be >= 1\n";
      return 2;
    }
  if (scenes.empty()) scenes.emplace_back("data/scenes/example3b.toml", steps);
  std::ostringstream md;
  const bool sameBinary = !baseline.empty() && baseline == obs;
  md << "`build/bench/estimator_cost"
     << (baseline.empty() ? "" : sameBinary ? " --baseline build/drivers/obs" : " --baseline OLD_OBS");
  for (const auto& kv : baselineSets) md << " --baseline-set " << kv;
  for (const auto& kv : sets) md << " --set " << kv;
  if (baselineThreads > 0) md << " --baseline-threads " << baselineThreads;
  if (threads > 0) md << " --threads " << threads;
  md << "`: `obs run SCENE --refine " << refine << " --set adaptivity.steps=N`, wall times of summary.json";
  if (repeat > 1) md << ", the smallest of " << repeat << " runs per step";
  md << ", ratio = estimator / solve"
     << (baseline.empty() ? "" : "; " + oldLabel + " and " + newLabel + " runs alternate on the same scene") << ".\n";
  char line[512];
  // the smallest time of each step over the runs (the results themselves must agree)
  auto keepFastest = [](std::vector<Step>& best, const std::vector<Step>& next) {
    if (best.empty()) {
      best = next;
      return;
    }
    for (std::size_t k = 0; k < best.size() && k < next.size(); ++k) {
      best[k].solve = std::min(best[k].solve, next[k].solve);
      best[k].estimator = std::min(best[k].estimator, next[k].estimator);
      best[k].assembly = std::min(best[k].assembly, next[k].assembly);
      best[k].refinement = std::min(best[k].refinement, next[k].refinement);
      best[k].transfer = std::min(best[k].transfer, next[k].transfer);
      best[k].iterations = std::max(best[k].iterations, next[k].iterations);  // equal unless ties flip
    }
  };
  for (const auto& [scene, sceneSteps] : scenes) {
    const std::string stem = std::filesystem::path(scene).stem().string();
    std::vector<Step> before, after;
    for (int r = 0; r < repeat; ++r) {
      if (!baseline.empty())
        keepFastest(before, run(baseline, scene, refine, sceneSteps, baselineSets, baselineThreads,
                                std::filesystem::path(work) / (stem + "-baseline")));
      keepFastest(after, run(obs, scene, refine, sceneSteps, sets, threads, std::filesystem::path(work) / (stem + "-measured")));
    }
    md << "\n" << scene << ", " << sceneSteps << " steps:\n\n";
    if (before.empty()) {
      // the cost of a step: the sum of the times summary.json records for it (docs/scenes.md)
      md << "| step | unknowns | TNNMG it. | assembly s | solve s | estimator s | ratio | refinement s | transfer s "
            "| step s | us per unknown |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
      for (std::size_t k = 0; k < after.size(); ++k) {
        const Step& s = after[k];
        const double total = s.assembly + s.solve + s.estimator + s.refinement + s.transfer;
        std::snprintf(line, sizeof line, "| %zu | %lld | %d | %.3f | %.3f | %.3f | %.2f | %.3f | %.3f | %.3f | %.2f |\n", k,
                      s.unknowns, s.iterations, s.assembly, s.solve, s.estimator, s.solve > 0 ? s.estimator / s.solve : 0.0,
                      s.refinement, s.transfer, total, 1e6 * total / static_cast<double>(std::max(1LL, s.unknowns)));
        md << line;
      }
      if (!after.empty()) {
        std::snprintf(line, sizeof line, "\nPeak memory of the run: %.0f MB.\n", after.back().peakMemoryMb);
        md << line;
      }
      continue;
    }
    const std::string O = " (" + oldLabel + ")", N = " (" + newLabel + ")";
    if (sameBinary && threads == baselineThreads) {  // the same code with other settings: compare the solves
      md << "| step | unknowns | TNNMG it." + O + " | TNNMG it." + N + " | solve s" + O + " | solve s" + N +
                " | solve speed-up | estimator / solve" + N + " | eta relative difference |\n"
                "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
      for (std::size_t k = 0; k < after.size() && k < before.size(); ++k) {
        const Step& n = after[k];
        const Step& o = before[k];
        std::snprintf(line, sizeof line, "| %zu | %lld | %d | %d | %.3f | %.3f | %.2f | %.2f | %.1e |\n", k, n.unknowns,
                      o.iterations, n.iterations, o.solve, n.solve, n.solve > 0 ? o.solve / n.solve : 0.0,
                      n.solve > 0 ? n.estimator / n.solve : 0.0, std::abs(n.eta - o.eta) / std::abs(o.eta));
        md << line;
      }
    } else {
      md << "| step | unknowns | solve s" + O + " | estimator s" + O + " | ratio" + O + " | solve s" + N +
                " | estimator s" + N + " | ratio" + N + " | estimator speed-up | " +
                (sameBinary ? "eta relative difference |\n" : "eta bitwise equal |\n") +
                "|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---:|\n";
      for (std::size_t k = 0; k < after.size() && k < before.size(); ++k) {
        const Step& n = after[k];
        const Step& o = before[k];
        // the same binary on other thread counts: the solves differ in the sweep order, eta with them
        char last[32];
        if (sameBinary) std::snprintf(last, sizeof last, "%.1e", std::abs(n.eta - o.eta) / std::abs(o.eta));
        else std::snprintf(last, sizeof last, "%s", bitwiseEqual(o, n) ? "yes" : "NO");
        std::snprintf(line, sizeof line, "| %zu | %lld | %.3f | %.3f | %.2f | %.3f | %.3f | %.2f | %.1f | %s |\n", k,
                      n.unknowns, o.solve, o.estimator, o.solve > 0 ? o.estimator / o.solve : 0.0, n.solve,
                      n.estimator, n.solve > 0 ? n.estimator / n.solve : 0.0,
                      n.estimator > 0 ? o.estimator / n.estimator : 0.0, last);
        md << line;
      }
    }
    if (before.size() != after.size()) md << "\nThe two runs made different numbers of steps.\n";
  }
  md << "\n";
  if (!page.empty()) {
    if (!obs::bench::writeMarkdownBlock(page, block, md.str())) {
      std::cerr << "estimator_cost: cannot write " << page << "\n";
      return 1;
    }
  } else {
    std::cout << md.str();
  }
  return 0;
}
