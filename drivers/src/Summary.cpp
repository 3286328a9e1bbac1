#include "obs/drivers/Summary.hpp"

#include <fstream>

#include "obs/estimators/Version.hpp"
#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs::drivers {
namespace {

nlohmann::json frictionJson(const FrictionReport& f, int dimension) {
  nlohmann::json force = nlohmann::json::array();
  for (int i = 0; i < dimension; ++i) force.push_back(f.tangentialForce[static_cast<std::size_t>(i)]);
  return {{"law", f.law},
          {f.law == "coulomb" ? "mu" : "bound", f.value},
          {"tangential_force", force},
          {"stick_vertices", f.stickVertices},
          {"slip_vertices", f.slipVertices},
          {dimension == 3 ? "stick_area" : "stick_width", f.stickArea},
          {"stick_radius", f.stickRadius}};
}

}  // namespace

nlohmann::json summaryJson(const RunResult& r) {
  nlohmann::json perType = nlohmann::json::object();
  for (mesh::CellType t : mesh::kVolumeCellTypes)
    if (const long long n = r.cellsPerType[static_cast<int>(t)]; n > 0)
      perType[std::string(mesh::name(t))] = n;
  nlohmann::json files = nlohmann::json::array();
  for (const auto& f : r.outputFiles) files.push_back(f.string());
  nlohmann::json solver = {
      {"type", r.solver.type},
      {"iterations", r.solver.iterations},
      {"converged", r.solver.converged},
      {"time_s", r.solver.seconds},
  };
  if (r.solver.type != "direct") {
    solver["tolerance"] = r.solver.tolerance;
    solver["correction"] = r.solver.correction;
    solver["convergence_rate"] = r.solver.convergenceRate;
  }
  if (r.solver.vcycles >= 0) solver["vcycles"] = r.solver.vcycles;
  if (!r.solver.coarseSolver.empty()) solver["coarse_solver"] = r.solver.coarseSolver;
  if (r.solver.coarseIterations >= 0) solver["coarse_iterations"] = r.solver.coarseIterations;
  if (const auto& p = r.solver.phases)
    solver["phases"] = {{"setup_s", p->setup},     {"nonsmooth_s", p->nonsmooth}, {"updates_s", p->updates},
                        {"vcycles_s", p->vcycles}, {"other_s", p->other},         {"operator_updates", p->operatorUpdates}};
  if (r.solver.kkt)
    solver["kkt"] = {{"feasibility", r.solver.kkt->primalFeasibility},
                     {"multiplier_sign", r.solver.kkt->dualSign},
                     {"complementarity", r.solver.kkt->complementarity},
                     {"stationarity", r.solver.kkt->stationarity},
                     {"dirichlet", r.solver.kkt->dirichlet}};
  if (const auto& f = r.solver.friction)
    solver["friction"] = {{"iterations", f->iterations},
                          {"converged", f->converged},
                          {"contracting", f->contracting},
                          {"changes", f->changes},
                          {"inner_iterations", f->innerIterations}};
  nlohmann::json j = {
      {"obs_version", estimators::version()},
      {"threads", threads()},
      {"scene", r.scene},
      {"dimension", r.dimension},
      {"vertices", r.vertices},
      {"cells", r.cells},
      {"cells_per_type", perType},
      {"refine", r.refine},
      {"dofs", r.dofs},
      {"free_dofs", r.freeDofs},
      {"times",
       {{"mesh_s", r.meshSeconds},
        {"assembly_s", r.assemblySeconds},
        {"solve_s", r.solveSeconds},
        {"output_s", r.outputSeconds},
        {"total_s", r.totalSeconds}}},
      {"peak_memory_mb", r.peakMemoryMB},
      {"max_displacement", r.maxDisplacement},
      {"max_von_mises", r.maxVonMises},
      {"solver", solver},
      {"mass_assemblies", r.massAssemblies},
      {"output_files", files},
  };
  if (r.contact) {
    const ContactReport& c = *r.contact;
    nlohmann::json force = nlohmann::json::array();
    for (int i = 0; i < r.dimension; ++i) force.push_back(c.force[i]);
    j["contact"] = {
        {"obstacle", c.obstacle},
        {"boundary", c.boundary},
        {"boundary_vertices", c.boundaryVertices},
        {"potential_vertices", c.potentialVertices},
        {"actual_vertices", c.actualVertices},
        {"force", force},
        {"load_P", c.load},
        {r.dimension == 3 ? "area" : "width", c.area},
        {"radius", c.radius},
        {"radius_nodes", c.radiusNodes},
        {"max_violation", c.maxViolation},
    };
    if (c.friction) j["contact"]["friction"] = frictionJson(*c.friction, r.dimension);
  }
  if (!r.increments.empty()) {
    nlohmann::json inc = nlohmann::json::array();
    for (const IncrementReport& i : r.increments) {
      nlohmann::json force = nlohmann::json::array(), tangential = nlohmann::json::array();
      for (int a = 0; a < r.dimension; ++a) {
        force.push_back(i.force[static_cast<std::size_t>(a)]);
        tangential.push_back(i.tangentialForce[static_cast<std::size_t>(a)]);
      }
      inc.push_back({{"step", i.step},
                     {"t", i.t},
                     {"iterations", i.iterations},
                     {"converged", i.converged},
                     {"force", force},
                     {"tangential_force", tangential},
                     {"contact_vertices", i.contactVertices},
                     {"stick_vertices", i.stickVertices},
                     {"slip_vertices", i.slipVertices}});
    }
    j["increments"] = inc;
  }
  if (!r.bodies.empty()) {
    nlohmann::json bodies = nlohmann::json::array();
    for (const BodyReport& b : r.bodies)
      bodies.push_back({{"name", b.name},
                        {"vertices", b.vertices},
                        {"cells", b.cells},
                        {"max_displacement", b.maxDisplacement},
                        {"max_von_mises", b.maxVonMises}});
    j["bodies"] = bodies;
  }
  if (!r.pairs.empty()) {
    auto vec = [&](const Eigen::Vector3d& v) {
      nlohmann::json a = nlohmann::json::array();
      for (int i = 0; i < r.dimension; ++i) a.push_back(v[i]);
      return a;
    };
    nlohmann::json pairs = nlohmann::json::array();
    for (const PairReport& p : r.pairs) {
      pairs.push_back({{"slave", p.slave},
                       {"master", p.master},
                       {"slave_vertices", p.slaveVertices},
                       {"potential_vertices", p.potentialVertices},
                       {"actual_vertices", p.actualVertices},
                       {"force_slave", vec(p.forceSlave)},
                       {"force_master", vec(p.forceMaster)},
                       {"load_P", p.load},
                       {"pressure_min", p.pressureMin},
                       {"pressure_max", p.pressureMax},
                       {r.dimension == 3 ? "area" : "width", p.area},
                       {"radius", p.radius},
                       {"max_violation", p.maxViolation},
                       {"mortar",
                        {{"segments", p.segments >= 0 ? nlohmann::json(p.segments) : nlohmann::json()}, {"uncovered_nodes", p.uncovered}, {"seconds", p.mortarSeconds}}}});
      if (p.friction) pairs.back()["friction"] = frictionJson(*p.friction, r.dimension);
    }
    j["pairs"] = pairs;
  }
  return j;
}

}  // namespace obs::drivers
