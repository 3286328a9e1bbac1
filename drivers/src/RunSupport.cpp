#include "RunSupport.hpp"

#include <algorithm>
#include <cstdio>

#include <sys/resource.h>

#include <fstream>
#include <iomanip>
#include <sstream>

#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/Summary.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double peakMemoryMB() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

void recordRunRow(const Scene& scene, const std::filesystem::path& dir, RunResult& r, Clock::time_point outputStart,
                  Clock::time_point start) {
  r.peakMemoryMB = peakMemoryMB();
  if (scene.output.csv.empty()) return;
  const auto path = scene.output.csv.is_absolute() ? scene.output.csv : dir / scene.output.csv;
  r.outputSeconds = secondsSince(outputStart);
  r.totalSeconds = secondsSince(start);
  appendCsvRow(path, r);
  r.outputFiles.push_back(path);
}

void finishRun(const Scene& scene, const RunOptions& options, const std::filesystem::path& dir, RunResult& r,
               Clock::time_point outputStart, Clock::time_point start, const nlohmann::json& extra) {
  recordRunRow(scene, dir, r, outputStart, start);
  const std::filesystem::path summary = dir / "summary.json";
  r.outputFiles.push_back(summary);
  r.outputSeconds = secondsSince(outputStart);
  r.totalSeconds = secondsSince(start);
  nlohmann::json j = summaryJson(r);
  if (extra.is_object())
    for (const auto& [key, value] : extra.items()) j[key] = value;
  {
    std::ofstream out(summary);
    out << j.dump(2) << "\n";
    if (!out) throw Error(summary.string() + ": cannot write the summary");
  }
  if (!options.progress) return;
  std::string written;
  if (r.outputFiles.size() <= 6) {
    for (const auto& f : r.outputFiles) written += (written.empty() ? "" : ", ") + f.string();
  } else {
    written = dir.string() + "/{";
    for (std::size_t i = 0; i < 6; ++i) written += (i ? ", " : "") + r.outputFiles[i].filename().string();
    written += ", ... (" + std::to_string(r.outputFiles.size()) + " files)}";
  }
  options.progress("written: " + written);
}

std::vector<const mesh::Grid*> BodyGrids::gridPointers() const {
  std::vector<const mesh::Grid*> p;
  for (const mesh::Grid& g : grids) p.push_back(&g);
  return p;
}

std::vector<const mesh::Mesh*> BodyGrids::meshPointers() const {
  std::vector<const mesh::Mesh*> p;
  for (const mesh::Mesh& m : meshes) p.push_back(&m);
  return p;
}

BodyGrids buildBodyGrids(const Scene& scene, const std::optional<int>& refine) {
  BodyGrids b;
  const std::vector<const Scene*> bodies = scene.bodyScenes();
  b.grids.reserve(bodies.size());
  for (const Scene* spec : bodies) {
    const Scene& body = *spec;
    try {
      b.grids.push_back(buildGrid(body, refine));
      b.meshes.push_back(b.grids.back().leafView().mesh);
      validateScene(body, b.meshes.back());
      b.bcs.push_back(makeBoundaryConditions(body, b.meshes.back()));
    } catch (const Error& e) {
      if (!scene.multiBody()) throw;
      throw Error(std::string(e.what()) + " (in [[body]] '" + body.name + "')");
    }
    if (b.meshes.back().dimension() != b.meshes.front().dimension())
      throw Error(scene.where(body.bodyLine) + "[[body]] '" + body.name + "' has dimension " +
                  std::to_string(b.meshes.back().dimension()) + ", body '" + bodies.front()->name + "' " +
                  std::to_string(b.meshes.front().dimension()) + " (all bodies must have the same dimension)");
  }
  return b;
}

OutputLayout::OutputLayout(const Scene& scene) : scene_(scene.name), perBody_(scene.multiBody()) {
  for (const Scene* b : scene.bodyScenes()) bodies_.push_back(b->name);
}

std::string OutputLayout::staticVtu(std::size_t b) const {
  return perBody_ ? scene_ + "_" + bodies_[b] + ".vtu" : scene_ + ".vtu";
}

std::string OutputLayout::adaptiveVtu(int k, std::size_t b) const {
  char step[32];
  std::snprintf(step, sizeof step, "step_%03d", k);
  return std::string(step) + (perBody_ ? "_" + bodies_[b] : std::string()) + ".vtu";
}

std::string OutputLayout::dynamicVtu(int n, std::size_t b) const {
  char step[32];
  std::snprintf(step, sizeof step, "%06d", n);
  return scene_ + "_" + (perBody_ ? bodies_[b] + "_" : std::string()) + step + ".vtu";
}

std::string addFrictionSolve(std::optional<FrictionIterationReport>& total, const CoulombResult& solve) {
  FrictionIterationReport t = total.value_or(FrictionIterationReport{0, true, true, {}, 0});
  t.iterations += solve.iterations;
  t.converged = t.converged && solve.converged;
  t.contracting = t.contracting && solve.contracting;
  t.innerIterations += solve.innerIterations;
  t.changes = solve.changes;  // of the last increment
  total = t;
  if (solve.iterations <= 1) return "";
  std::ostringstream line;
  line << "friction: " << solve.iterations << " Tresca solves (" << solve.innerIterations
       << " iterations), last relative change of the slip bounds " << std::setprecision(3) << solve.changes.back()
       << (solve.converged ? "" : ", not converged") << (solve.contracting ? "" : " (the iteration did not contract)");
  return line.str();
}

template <int d>
std::pair<ContactResult, long long> solveIncrement(ContactProblem<d>& problem, ContactSolver<d>& solver,
                                                   Eigen::VectorXd& x, const NodalFriction* friction, double tolerance,
                                                   int step, const HaloExchange* halo,
                                                   std::optional<FrictionIterationReport>& frictionReport,
                                                   const std::function<void(const std::string&)>& progress) {
  if (!friction) {
    const ContactResult result = solver.solve(problem, x);
    return {result, result.iterations};
  }
  CoulombOptions options;
  options.tolerance = std::max(options.tolerance, 10 * tolerance);
  const Eigen::VectorXd origin = step > 1 ? x : Eigen::VectorXd();
  const CoulombResult fr = solveFriction(problem, solver, x, *friction, options, origin, halo);
  if (const std::string line = addFrictionSolve(frictionReport, fr); progress && !line.empty()) progress(line);
  return {fr.last, fr.innerIterations};
}

template std::pair<ContactResult, long long> solveIncrement<2>(ContactProblem<2>&, ContactSolver<2>&, Eigen::VectorXd&,
                                                               const NodalFriction*, double, int, const HaloExchange*,
                                                               std::optional<FrictionIterationReport>&,
                                                               const std::function<void(const std::string&)>&);
template std::pair<ContactResult, long long> solveIncrement<3>(ContactProblem<3>&, ContactSolver<3>&, Eigen::VectorXd&,
                                                               const NodalFriction*, double, int, const HaloExchange*,
                                                               std::optional<FrictionIterationReport>&,
                                                               const std::function<void(const std::string&)>&);

void writeIncrementsCsv(const std::filesystem::path& dir, RunResult& r) {
  if (r.increments.empty()) return;
  {  // [loading]: one row per increment
    const std::filesystem::path csv = dir / "increments.csv";
    std::ofstream f(csv);
    f << std::setprecision(12)
      << "step,t,iterations,converged,force_x,force_y,force_z,tangential_x,tangential_y,tangential_z,contact_vertices,"
         "stick_vertices,slip_vertices\n";
    for (const IncrementReport& i : r.increments) {
      f << i.step << ',' << i.t << ',' << i.iterations << ',' << (i.converged ? 1 : 0);
      for (double v : i.force) f << ',' << v;
      for (double v : i.tangentialForce) f << ',' << v;
      f << ',' << i.contactVertices << ',' << i.stickVertices << ',' << i.slipVertices << '\n';
    }
    if (!f) throw Error(csv.string() + ": cannot write");
    r.outputFiles.push_back(csv);
  }
}

void throwIfNotConverged(const Scene& scene, const RunResult& r, const std::filesystem::path& dir) {
  if (r.solver.friction && !r.solver.friction->converged) {  // the Coulomb fixed point, not the solver
    const FrictionIterationReport& f = *r.solver.friction;
    std::ostringstream os;
    os << scene.fileName << ": the Coulomb fixed point (friction) did not converge in " << f.iterations
       << " Tresca solves (last relative change of the slip bounds " << std::setprecision(3)
       << (f.changes.empty() ? 0.0 : f.changes.back()) << ", "
       << (f.contracting ? "the changes decreased" : "the changes stopped decreasing: mu may be too large for the "
                                                     "iteration to contract")
       << "; docs/theory.md#friction-coulomb; outputs written to " << dir.string() << ")";
    throw Error(os.str());
  }
  if (!r.solver.converged) {
    std::ostringstream os;
    os << scene.where(scene.solver.line) << "[solver] " << r.solver.type << " did not converge in "
       << r.solver.iterations << " iterations (correction " << std::setprecision(3)
       << r.solver.correction << ", tolerance " << r.solver.tolerance;
    if (r.solver.kkt) os << ", KKT residual " << r.solver.kkt->max();
    os << "); raise [solver] max_iterations or tolerance (outputs written to " << dir.string() << ")";
    throw Error(os.str());
  }
}

void reportContactResult(const ContactResult& result, double seconds, double tolerance, SolverReport& report) {
  report.iterations = result.iterations;
  report.converged = result.converged && (!report.friction || report.friction->converged);
  report.seconds = seconds;
  report.tolerance = tolerance;
  report.correction = result.correction;
  report.convergenceRate = result.convergenceRate;
  report.kkt = result.kkt;
}

}  // namespace obs::drivers
