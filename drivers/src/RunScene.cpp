#include "obs/drivers/RunScene.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "obs/drivers/AdaptiveScene.hpp"
#include "obs/drivers/CsvWriter.hpp"
#include "obs/drivers/DynamicScene.hpp"
#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/drivers/SceneSolver.hpp"
#include "obs/drivers/SolutionFields.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "DistributedScene.hpp"
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

/// The figures of the solution: max |u| and max von Mises over all bodies, and per body where the
/// OutputLayout reports per body (summary.json "bodies").
void reportBodies(const Scene& scene, const std::vector<mesh::Mesh>& meshes, const SceneSolution& solved,
                  RunResult& r) {
  const std::vector<const Scene*> bodies = scene.bodyScenes();
  const bool perBody = OutputLayout(scene).perBody();
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    BodyReport b;
    b.name = bodies[i]->name;
    b.vertices = meshes[i].numVertices();
    b.cells = meshes[i].numCells();
    const ElasticitySolution& e = solved.bodies[i];
    for (mesh::Index v = 0; v < meshes[i].numVertices(); ++v)
      b.maxDisplacement = std::max(b.maxDisplacement, e.displacement.segment(v * r.dimension, r.dimension).norm());
    for (const Stress& st : e.cellStress) b.maxVonMises = std::max(b.maxVonMises, vonMises(st));
    r.maxDisplacement = std::max(r.maxDisplacement, b.maxDisplacement);
    r.maxVonMises = std::max(r.maxVonMises, b.maxVonMises);
    if (perBody) r.bodies.push_back(b);
  }
}

/// The .vtu files of a static run in the scene's OutputLayout (several bodies: with the .pvd
/// collection of them as parts), appended to r.outputFiles.
void writeStaticVtk(const Scene& scene, const std::filesystem::path& dir, const std::vector<mesh::Mesh>& meshes,
                    const SceneSolution& solved, RunResult& r) {
  const OutputLayout layout(scene);
  std::vector<PvdEntry> parts;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    const auto path = dir / layout.staticVtu(i);
    auto pf = pointFields(meshes[i], solved.bodies[i]);
    pf.insert(pf.end(), solved.contactFields[i].begin(), solved.contactFields[i].end());
    writeVtu(path, meshes[i], pf, cellFields(meshes[i], solved.bodies[i]));
    parts.push_back(PvdEntry{0, static_cast<int>(i), path.filename().string()});
    r.outputFiles.push_back(path);
  }
  if (!layout.perBody()) return;
  const auto pvd = dir / (scene.name + ".pvd");
  writePvdCollection(pvd, parts);
  r.outputFiles.push_back(pvd);
}

/// singleLevelWarning for one body of a scene: the solver and contact are the scene's, the mesh's
/// source the body's.
std::string singleLevelWarning(const Scene& scene, const Scene& body, const mesh::Grid& grid) {
  if (grid.maxLevel() > 0) return {};
  const std::string& type = scene.solver.type;
  const bool tnnmg = scene.hasContact() && (type.empty() || type == "tnnmg");
  if (!tnnmg && type != "multigrid") return {};
  return "warning: the grid has a single level (" +
         std::string(body.mesh.source == MeshSpec::Source::File ? "a mesh file" : "a generated mesh") +
         " without refine), so " + (tnnmg ? "TNNMG" : "multigrid") +
         " has no coarse levels: its linear correction is a direct (CHOLMOD) solve" +
         (tnnmg ? ", refactorised whenever the active set changes: a nonsmooth Newton method "
                  "costing one sparse factorisation per active-set change instead of one multigrid "
                  "cycle per iteration"
                : " costing one sparse factorisation") +
         "; set [mesh] refine = 1 or more (or --refine) to solve on a grid hierarchy";
}

}  // namespace

std::string singleLevelWarning(const Scene& scene, const mesh::Grid& grid) {
  return singleLevelWarning(scene, scene, grid);
}

std::string bbarWarning(const Scene& scene, const mesh::Mesh& mesh) {
  if (scene.material.formulation != VolumetricFormulation::BBar) return {};
  for (Index c = 0; c < mesh.numCells(); ++c) {
    const mesh::CellType t = mesh.cellType(c);
    if (t != mesh::CellType::Triangle && t != mesh::CellType::Tetrahedron) return {};
  }
  return "warning: [material] formulation = \"bbar\" has no effect on a mesh of triangles or tetrahedra "
         "(div u is constant in each cell), which lock as nu -> 1/2; use quadrilaterals or hexahedra "
         "(docs/theory.md#b-bar)";
}

RunResult runScene(const std::filesystem::path& sceneFile, const RunOptions& options) {
  return runScene(parseScene(sceneFile, options.overrides), options);
}

RunResult runScene(const Scene& scene, const RunOptions& options) {
  if (!scene.dynamics && !scene.adaptivity && (options.restart || options.stopAfterStep))
    throw Error(scene.fileName + ": " + (options.restart ? "--restart" : "--stop-after-step") +
                " applies to [dynamics] and [adaptivity] scenes only (static runs write no checkpoints)");
  // under mpirun -np N > 1 (obs built with MPI): the distributed runner (DistributedScene.hpp)
  if (const Communicator comm = Communicator::world(); comm.size() > 1) return runDistributedScene(scene, options, comm);
  if (scene.adaptivity) return runAdaptiveScene(scene, options);
  const auto start = Clock::now();
  auto progress = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };
  auto warn = [&](const std::string& w) {
    if (!w.empty() && options.stepProgress) options.stepProgress(w);
  };
  RunResult r;
  r.scene = scene.fileName;
  const std::vector<const Scene*> bodies = scene.bodyScenes();

  // the bodies' grids, leaf meshes and boundary conditions
  auto t = Clock::now();
  const BodyGrids built = buildBodyGrids(scene, options.refine);
  const std::vector<mesh::Mesh>& meshes = built.meshes;
  r.meshSeconds = secondsSince(t);
  r.dimension = meshes.front().dimension();
  r.refine = options.refine.value_or(bodies.front()->mesh.refine);
  for (const mesh::Mesh& m : meshes) {
    r.vertices += m.numVertices();
    r.cells += m.numCells();
    const auto counts = m.cellCounts();
    for (std::size_t k = 0; k < counts.size(); ++k) r.cellsPerType[k] += counts[k];
  }
  progress((meshes.size() == 1 ? "mesh built: " : "meshes built: " + std::to_string(meshes.size()) + " bodies, ") +
           describeCells(r) + " / " + std::to_string(r.vertices) + " vertices (" + std::to_string(r.dimension) +
           "D, " + seconds(r.meshSeconds) + ")");
  std::vector<std::string> warnings;  // each once, also when several bodies have it
  for (std::size_t i = 0; i < meshes.size(); ++i)
    for (const std::string& w : {singleLevelWarning(scene, *bodies[i], built.grids[i]), bbarWarning(*bodies[i], meshes[i])})
      if (!w.empty() && std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(w);
  for (const std::string& w : warnings) warn(w);
  const std::vector<const mesh::Grid*> grids = built.gridPointers();
  const std::vector<const mesh::Mesh*> meshPointers = built.meshPointers();
  if (scene.dynamics) return runDynamicScene(scene, grids, meshPointers, built.bcs, options, std::move(r), start);

  // assemble and solve
  auto assembled = [&](const ElasticitySolution& e) {
    progress("assembled: " + std::to_string(e.dofs) + " dofs (" + std::to_string(e.freeDofs) + " free) in " +
             seconds(e.assemblySeconds));
  };
  const SceneSolution solved = solveScene(scene, grids, meshPointers, built.bcs, options.iterationProgress, assembled);
  r.dofs = solved.dofs;
  r.freeDofs = solved.freeDofs;
  r.assemblySeconds = solved.assemblySeconds;
  r.solveSeconds = solved.solveSeconds;
  r.solver = solved.solver;
  r.contact = solved.contact;
  r.pairs = solved.pairs;
  r.increments = solved.increments;
  reportBodies(scene, meshes, solved, r);
  {
    std::ostringstream os;
    os << "solved in " << seconds(r.solveSeconds);
    if (r.solver.type != "direct")
      os << " (" << r.solver.type << ", " << r.solver.iterations
         << (r.solver.iterations == 1 ? " iteration" : " iterations") << (r.solver.converged ? "" : ", NOT converged")
         << ")";
    os << ": max |u| = " << std::setprecision(6) << r.maxDisplacement << ", max von Mises = " << r.maxVonMises;
    if (r.contact)
      os << "; contact: " << r.contact->actualVertices << " of " << r.contact->potentialVertices
         << " vertices, P = " << r.contact->load;
    for (const PairReport& p : r.pairs)
      os << "; " << p.slave << " / " << p.master << ": " << p.actualVertices << " of " << p.potentialVertices
         << " slave vertices in contact, P = " << p.load;
    progress(os.str());
  }

  // outputs
  t = Clock::now();
  const std::filesystem::path dir = options.outputDirectory.value_or(scene.output.directory);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error(dir.string() + ": cannot create the output directory (" + ec.message() + ")");
  if (scene.output.vtk) writeStaticVtk(scene, dir, meshes, solved, r);
  writeIncrementsCsv(dir, r);
  finishRun(scene, options, dir, r, t, start);
  throwIfNotConverged(scene, r, dir);
  return r;
}

}  // namespace obs::drivers
