#include "obs/drivers/RunScene.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <sstream>

#include "obs/drivers/AdaptiveScene.hpp"
#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/DynamicScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/SceneSolver.hpp"
#include "obs/drivers/SolutionFields.hpp"
#include "obs/drivers/Summary.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "RunSupport.hpp"

namespace obs::drivers {

namespace {


std::string seconds(double s) {
  std::ostringstream os;
  os << std::setprecision(3) << s << " s";
  return os.str();
}

std::string describeCells(const RunResult& r) {
  std::string types;
  int kinds = 0;
  for (mesh::CellType t : mesh::kVolumeCellTypes)
    if (const long long n = r.cellsPerType[static_cast<int>(t)]; n > 0) {
      types += (types.empty() ? "" : ", ") + std::to_string(n) + " " + std::string(mesh::name(t));
      ++kinds;
    }
  if (kinds == 1) return types + " cells";
  return std::to_string(r.cells) + " cells (" + types + ")";
}

}  // namespace

RunResult runScene(const std::filesystem::path& sceneFile, const RunOptions& options) {
  return runScene(parseScene(sceneFile, options.overrides), options);
}

RunResult runScene(const Scene& scene, const RunOptions& options) {
  if (!scene.dynamics && (options.restart || options.stopAfterStep))
    throw Error(scene.fileName + ": " + (options.restart ? "--restart" : "--stop-after-step") +
                " applies to [dynamics] scenes only (static and adaptive runs write no checkpoints)");
  if (scene.adaptivity) return runAdaptiveScene(scene, options);
  const auto start = Clock::now();
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  RunResult r;
  r.scene = scene.fileName;

  // mesh
  auto t = Clock::now();
  const mesh::Grid grid = buildGrid(scene, options.refine);
  const mesh::Mesh mesh = grid.leafView().mesh;
  validateScene(scene, mesh);
  const BoundaryConditions bc = makeBoundaryConditions(scene, mesh);
  r.meshSeconds = secondsSince(t);
  r.dimension = mesh.dimension();
  r.vertices = mesh.numVertices();
  r.cells = mesh.numCells();
  const auto counts = mesh.cellCounts();
  for (std::size_t i = 0; i < counts.size(); ++i) r.cellsPerType[i] = counts[i];
  r.refine = options.refine.value_or(scene.mesh.refine);
  progress("mesh built: " + describeCells(r) + " / " + std::to_string(r.vertices) + " vertices (" +
           std::to_string(r.dimension) + "D, " + seconds(r.meshSeconds) + ")");
  if (scene.dynamics) return runDynamicScene(scene, grid, mesh, bc, options, std::move(r), start);

  // assemble and solve
  auto assembled = [&](const ElasticitySolution& e) {
    progress("assembled: " + std::to_string(e.dofs) + " dofs (" + std::to_string(e.freeDofs) +
             " free) in " + seconds(e.assemblySeconds));
  };
  const SceneSolution solved =
      solveScene(scene, grid, mesh, bc, options.iterationProgress, assembled);
  const ElasticitySolution& solution = solved.elasticity;
  r.dofs = solution.dofs;
  r.freeDofs = solution.freeDofs;
  r.assemblySeconds = solution.assemblySeconds;
  r.solveSeconds = solution.solveSeconds;
  r.solver = solved.solver;
  r.contact = solved.contact;
  for (mesh::Index v = 0; v < mesh.numVertices(); ++v)
    r.maxDisplacement = std::max(
        r.maxDisplacement, solution.displacement.segment(v * r.dimension, r.dimension).norm());
  for (const Stress& s : solution.cellStress) r.maxVonMises = std::max(r.maxVonMises, vonMises(s));
  {
    std::ostringstream os;
    os << "solved in " << seconds(r.solveSeconds);
    if (r.solver.type != "direct")
      os << " (" << r.solver.type << ", " << r.solver.iterations
         << (r.solver.iterations == 1 ? " iteration" : " iterations")
         << (r.solver.converged ? "" : ", NOT converged") << ")";
    os << ": max |u| = " << std::setprecision(6) << r.maxDisplacement
       << ", max von Mises = " << r.maxVonMises;
    if (r.contact)
      os << "; contact: " << r.contact->actualVertices << " of " << r.contact->potentialVertices
         << " vertices, P = " << r.contact->load;
    progress(os.str());
  }

  // outputs
  t = Clock::now();
  const std::filesystem::path dir = options.outputDirectory.value_or(scene.output.directory);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(dir.string() + ": cannot create the output directory (" + ec.message() + ")");
  if (scene.output.vtk) {
    const auto path = dir / (scene.name + ".vtu");
    auto pf = pointFields(mesh, solution);
    pf.insert(pf.end(), solved.contactFields.begin(), solved.contactFields.end());
    const auto cf = cellFields(mesh, solution);
    writeVtu(path, mesh, pf, cf);
    r.outputFiles.push_back(path);
  }
  recordRunRow(scene, dir, r, t, start);
  const auto summary = dir / "summary.json";
  r.outputFiles.push_back(summary);
  r.outputSeconds = secondsSince(t);
  r.totalSeconds = secondsSince(start);
  writeSummary(summary, r);

  std::string written;
  for (const auto& f : r.outputFiles) written += (written.empty() ? "" : ", ") + f.string();
  progress("written: " + written);
  if (!r.solver.converged) {
    std::ostringstream os;
    os << scene.where(scene.solver.line) << "[solver] " << r.solver.type << " did not converge in "
       << r.solver.iterations << " iterations (correction " << std::setprecision(3)
       << r.solver.correction << ", tolerance " << r.solver.tolerance;
    if (r.solver.kkt) os << ", KKT residual " << r.solver.kkt->max();
    os << "); raise [solver] max_iterations or tolerance (outputs written to " << dir.string() << ")";
    throw Error(os.str());
  }
  return r;
}

}  // namespace obs::drivers
