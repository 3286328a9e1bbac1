// Cost per time step of the Newmark family (libobs Newmark.hpp, docs/theory.md#newmark) with TNNMG on three 3D
// geometries of the reference thesis (Sec. 5.2.6, 5.3.3):
//   Geometry 1: a block with a cylindrical bottom (roundedBlockMesh, hexahedra, 3 x 2 x 1 coarse cells
//               refined 3 times: 3,825 vertices, 11,475 unknowns), E = 500, nu = 0.3, rho = 1,
//               dropped with v0 = (0, 0, -1) onto the plane z = -0.01 (data/scenes/dynamics_block.toml);
//   Geometry A: a ball (ballMesh, pyramids, radius 1, 2 coarse cells per direction refined twice),
//               E = 500, nu = 0.3, v0 = (0, 0, -2), tau = 5e-3, onto the plane z = -1.01 (centre 0);
//   Geometry B: two cubes of hexahedra (sides 1.4 and 1, one cell refined 4 times each: 29,478
//               unknowns) coupled by dual mortar, E = 2e5, nu = 0.3, v0 = +-2 in z, tau = 5e-4
//               (data/scenes/dynamics_two_body.toml), improved-contact-stabilized with both warm starts
//               (NewmarkStart) at the tolerance 1e-10 and with inexact solves (inexact = 0.1).
// For every run: TNNMG iterations per step, CPU time per step (process CPU time, which a busy shared
// machine inflates far less than the wall clock), energy change, contact nodes. Energies: E (kinetic
// energy with the standard lumped mass M) for every scheme, and for the schemes with the redistributed
// mass M~ also E~ (and, for KLR, the modified energy E~ + tau^2/8 a'M~a; docs/dynamics.md "Energies"),
// each as end/start ratio and max |E - E_0| / E_0 over the run. The figures replace the block
// "dynamics" of the page given (MarkdownBlock.hpp), e.g. docs/performance.md:
//
//   OPENBLAS_NUM_THREADS=1 build/bench/dynamics docs/performance.md      # all: 5 (quiet) to 15 (busy machine) minutes
//   build/bench/dynamics out.md --steps1 200 --geometries 1 --schemes improved-contact-stabilized
//
// Options: --steps1 N (1000), --stepsA N (100), --stepsB N (40), --refineB K (4), --geometries list of
// 1, A, B (1,A,B), --schemes list of scheme names or all (all; geometries 1 and A), --vcycle
// PRE,POST[,CYCLES] smoothing steps and V-cycles of TNNMG's linear correction (3,3,1).
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

#include "MarkdownBlock.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/Newmark.hpp"

using namespace obs;

namespace {

LinearMultigridOptions gMultigrid;  ///< the V-cycle of every run (--vcycle)

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double wallSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

struct Geometry {
  std::string name;
  mesh::Grid grid;
  std::unique_ptr<PlaneObstacle> obstacle;
  std::unique_ptr<ContactSet> contact;
  Eigen::Vector3d v0;
  double tau;
};

Geometry geometry1(double tau) {
  mesh::CurvedMesh cm = mesh::roundedBlockMesh(1.5, 0.5, 1.0, 1.5, mesh::CellType::Hexahedron, {3, 2, 1});
  Geometry g{"Geometry 1 (rounded block, hexahedra)", mesh::Grid(cm.mesh), nullptr, nullptr, {0, 0, -1}, tau};
  for (auto& [id, proj] : cm.projections) g.grid.setBoundaryProjection(id, proj);
  for (int l = 0; l < 3; ++l) g.grid.refineUniformly();
  g.obstacle = std::make_unique<PlaneObstacle>(Point(0, 0, -0.01), Point(0, 0, -1));
  g.contact = std::make_unique<ContactSet>(g.grid.leafView().mesh, mesh::kBottom, *g.obstacle);
  return g;
}

Geometry geometryA() {
  mesh::CurvedMesh cm = mesh::ballMesh(Point::Zero(), 1.0, mesh::CellType::Pyramid, 2);
  Geometry g{"Geometry A (ball, pyramids)", mesh::Grid(cm.mesh), nullptr, nullptr, {0, 0, -2}, 5e-3};
  for (auto& [id, proj] : cm.projections) g.grid.setBoundaryProjection(id, proj);
  for (int l = 0; l < 2; ++l) g.grid.refineUniformly();
  g.obstacle = std::make_unique<PlaneObstacle>(Point(0, 0, -1.01), Point(0, 0, -1));
  g.contact = std::make_unique<ContactSet>(g.grid.leafView().mesh, mesh::kCurvedSurface, *g.obstacle);
  return g;
}

/// Figures of one run of a stepper over `steps` steps.
struct RunFigures {
  double setup = 0, its = 0, cpu = 0, wall = 0, devE = 0, devEt = 0, pen = 0, E0 = 0, Et0 = 0;
  int maxIts = 0;
  Index maxActive = 0;
  double itsAfterImpact = 0;  ///< mean over the steps from the first one with a node in contact on
  int stepsAfterImpact = 0;
  double rate = 0;  ///< geometric mean over the steps of TNNMG's rate per step (steps with >= 2 iterations)
  int rateSteps = 0;
  StepRecord last;
  Eigen::VectorXd u;  ///< final displacement
};

RunFigures runSteps(NewmarkFamily<3>& st, int steps) {
  RunFigures f;
  const StepRecord r0 = st.record();
  f.E0 = r0.energy;
  f.Et0 = r0.hasAcceleration ? r0.energyModified : r0.energyRedistributed;
  const double c0 = cpuSeconds(), w0 = wallSeconds();
  bool impact = false;
  for (int k = 0; k < steps; ++k) {
    const StepRecord r = st.step();
    f.its += r.solverIterations;
    f.maxIts = std::max(f.maxIts, r.solverIterations);
    impact = impact || r.activeSolution > 0;
    if (impact) {
      f.itsAfterImpact += r.solverIterations;
      ++f.stepsAfterImpact;
    }
    f.maxActive = std::max(f.maxActive, r.activeSolution);
    if (std::isfinite(r.solverRate) && r.solverRate > 0) {
      f.rate += std::log(r.solverRate);
      ++f.rateSteps;
    }
    f.pen = std::max(f.pen, r.maxPenetration);
    f.devE = std::max(f.devE, std::abs(r.energy - f.E0) / std::abs(f.E0));
    if (r.hasRedistributed)
      f.devEt = std::max(f.devEt, std::abs((r.hasAcceleration ? r.energyModified : r.energyRedistributed) - f.Et0) /
                                      std::abs(f.Et0));
    f.last = r;
  }
  f.cpu = cpuSeconds() - c0;
  f.wall = wallSeconds() - w0;
  f.its /= steps;
  if (f.stepsAfterImpact > 0) f.itsAfterImpact /= f.stepsAfterImpact;
  f.rate = f.rateSteps > 0 ? std::exp(f.rate / f.rateSteps) : std::numeric_limits<double>::quiet_NaN();
  f.u = st.state().u;
  return f;
}

void oneBodyTable(std::ostringstream& md, Geometry& g, int steps, const std::vector<NewmarkScheme>& schemes) {
  Material mat{500, 0.3};
  mat.density = 1;
  const Index n = g.contact->numMeshVertices();
  md << "\n### " << g.name << "\n\n" << n << " vertices, " << 3 * n << " unknowns, " << g.contact->size()
     << " potential contact nodes, tau = " << g.tau << ", levels " << g.grid.maxLevel() + 1 << ", " << steps
     << " steps\n\n";
  md << "| scheme | warm start | setup s | TNNMG its/step (mean, max) | CPU ms/step | total CPU s | total wall s | "
        "E_end/E_0 (max dev) | E~_end/E~_0 (max dev) | max contact nodes | max penetration |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::string notes;
  for (NewmarkScheme s : schemes) {
    // the warm start from the previous increment is shown for the two stabilized schemes of the goal
    std::vector<NewmarkStart> starts{NewmarkStart::Predictor};
    if (s == NewmarkScheme::ContactStabilized || s == NewmarkScheme::ImprovedContactStabilized)
      starts.push_back(NewmarkStart::PreviousIncrement);
    for (NewmarkStart start : starts) {
      const double c0 = cpuSeconds();
      NewmarkOptions o;
      o.scheme = s;
      o.timeStep = g.tau;
      o.start = start;
      o.solver.tolerance = 1e-11;  // Geometries 1 and A (docs/performance.md#dynamic-contact)
      o.solver.multigrid = gMultigrid;
      std::unique_ptr<NewmarkFamily<3>> stepper;
      try {
        stepper = std::make_unique<NewmarkFamily<3>>(g.grid, mat, BoundaryConditions{}, *g.contact, o);
      } catch (const obs::Error& e) {  // e.g. M~ with a non-positive diagonal entry on this mesh
        md << "| " << name(s) << " | " << name(start) << " | not run: " << e.what() << " | | | | | | | | |\n";
        std::cerr << g.name << " " << name(s) << ": not run: " << e.what() << "\n";
        continue;
      }
      NewmarkFamily<3>& st = *stepper;
      if (usesRedistributedMass(s) && !st.redistributedMassDefiniteness().positiveDefinite && notes.empty())
        notes = "M~ is indefinite on this mesh (" + std::to_string(st.redistributedMassDefiniteness().nonPositivePivots) +
                " negative eigenvalues; S = M~ + c tau^2 A is positive definite): the schemes with M~ have slowly "
                "growing modes here.\n";
      Eigen::VectorXd v(3 * n);
      for (Index p = 0; p < n; ++p) v.segment<3>(3 * p) = g.v0;
      st.initialize(Eigen::VectorXd::Zero(3 * n), v);
      const double setup = cpuSeconds() - c0;
      const RunFigures f = runSteps(st, steps);
      const StepRecord& r = f.last;
      md << "| " << name(s) << " | " << name(start) << " | " << std::setprecision(3) << setup << " | " << f.its << ", "
         << f.maxIts << " | " << 1e3 * f.cpu / steps << " | " << f.cpu << " | " << f.wall << " | " << r.energy / f.E0
         << " (" << f.devE << ") | ";
      if (r.hasRedistributed)
        md << (r.hasAcceleration ? r.energyModified : r.energyRedistributed) / f.Et0 << " (" << f.devEt << ")"
           << (r.hasAcceleration ? " mod." : "");
      else
        md << "-";
      md << " | " << f.maxActive << " | " << f.pen << " |\n";
      std::cerr << g.name << " " << name(s) << " (" << name(start) << "): " << 1e3 * f.cpu / steps << " CPU ms/step, "
                << f.its << " its/step, E_end/E_0 " << r.energy / f.E0 << "\n";
    }
  }
  if (!notes.empty()) md << "\n" << notes;
}

void geometryB(std::ostringstream& md, int steps, int refine) {
  auto cube = [&](Point lower, Point upper) {
    mesh::Grid g(mesh::boxMesh(mesh::CellType::Hexahedron, {1, 1, 1}, lower, upper));
    for (int l = 0; l < refine; ++l) g.refineUniformly();
    return g;
  };
  mesh::Grid lower = cube(Point(-0.7, -0.7, -1.4), Point(0.7, 0.7, 0.0));
  mesh::Grid upper = cube(Point(-0.5, -0.5, 0.0), Point(0.5, 0.5, 1.0));
  Material mat{2e5, 0.3};
  mat.density = 1;
  const double tau = 5e-4;
  const Index n = lower.leafView().mesh.numVertices() + upper.leafView().mesh.numVertices();
  md << "\n### Geometry B (two cubes of hexahedra, dual mortar)\n\n"
     << n << " vertices, " << 3 * n << " unknowns (" << refine << " refinements of each cube), tau = " << tau << ", "
     << steps << " steps, improved-contact-stabilized. \"after impact\": the steps from the first one with a node "
     << "in contact on (the cubes touch from the start, so all steps). Difference: max |u - u_ref| / max |u_ref| of "
     << "the final displacement against the run in the first row of the same tolerance. Rate: TNNMG's "
     << "contraction per iteration, (c_last / c_1)^(1 / (its - 1)) for the relative corrections c_k of a step, "
     << "geometric mean over the steps (from the predictor c_1 = 1).\n\n"
     << "| warm start | tolerance | TNNMG its/step (all, after impact, max) | rate | CPU ms/step | total CPU s | "
        "E_end/E_0 | max contact nodes | difference |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  struct Variant {
    NewmarkStart start;
    double inexact;
  };
  const std::vector<Variant> variants{{NewmarkStart::Predictor, 0},
                                      {NewmarkStart::PreviousIncrement, 0},
                                      {NewmarkStart::Predictor, 0.1},
                                      {NewmarkStart::PreviousIncrement, 0.1}};
  Eigen::VectorXd reference;
  const mesh::Mesh lowerMesh = lower.leafView().mesh, upperMesh = upper.leafView().mesh;  // the model keeps references
  for (const Variant& var : variants) {
    ContactModel<3> model;
    model.addBody("lower", lowerMesh, mat, BoundaryConditions{});
    model.addBody("upper", upperMesh, mat, BoundaryConditions{});
    model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "bottom / top");
    NewmarkOptions o;
    o.scheme = NewmarkScheme::ImprovedContactStabilized;
    o.timeStep = tau;
    o.solver.tolerance = 1e-10;
    o.inexactFraction = var.inexact;
    o.start = var.start;
    o.solver.multigrid = gMultigrid;
    NewmarkFamily<3> st({&lower, &upper}, model, o);
    Eigen::VectorXd v = Eigen::VectorXd::Zero(3 * n);
    for (int b = 0; b < 2; ++b) {
      const auto& body = model.bodies()[static_cast<std::size_t>(b)];
      for (Index p = 0; p < body.mesh->numVertices(); ++p) v[3 * (body.offset + p) + 2] = b == 0 ? 2.0 : -2.0;
    }
    st.initialize(Eigen::VectorXd::Zero(3 * n), v);
    const RunFigures f = runSteps(st, steps);
    if (var.start == NewmarkStart::Predictor) reference = f.u;
    const double diff = (f.u - reference).lpNorm<Eigen::Infinity>() / reference.lpNorm<Eigen::Infinity>();
    const std::string tol = var.inexact > 0 ? "inexact = " + std::to_string(var.inexact).substr(0, 3) : "1e-10";
    md << "| " << name(var.start) << " | " << tol << " | " << std::setprecision(3) << f.its << ", " << f.itsAfterImpact
       << ", " << f.maxIts << " | " << f.rate << " | " << 1e3 * f.cpu / steps << " | " << f.cpu << " | "
       << f.last.energy / f.E0 << " | "
       << f.maxActive << " | " << diff << " |\n";
    std::cerr << "Geometry B " << name(var.start) << " " << tol << ": " << 1e3 * f.cpu / steps << " CPU ms/step, "
              << f.its << " its/step (" << f.itsAfterImpact << " after impact)\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]).starts_with("-")) {
    std::cerr << "usage: dynamics PAGE.md [--steps1 N] [--stepsA N] [--stepsB N] [--refineB K] [--geometries 1,A,B] "
                 "[--schemes all|name,...]\n";
    return 2;
  }
  int steps1 = 1000, stepsA = 100, stepsB = 40, refineB = 4;
  LinearMultigridOptions& multigrid = gMultigrid;
  std::vector<std::string> geometries{"1", "A", "B"};
  std::vector<NewmarkScheme> schemes = allNewmarkSchemes();
  std::ostringstream command;
  command << "bench/dynamics " << argv[1];
  try {
    for (int i = 2; i < argc; ++i) {
      const std::string key = argv[i];
      if (i + 1 >= argc) throw Error("option " + key + " needs a value");
      const std::string value = argv[++i];
      command << " " << key << " " << value;
      if (key == "--steps1") steps1 = std::stoi(value);
      else if (key == "--stepsA") stepsA = std::stoi(value);
      else if (key == "--stepsB") stepsB = std::stoi(value);
      else if (key == "--refineB") refineB = std::stoi(value);
      else if (key == "--geometries") geometries = split(value);
      else if (key == "--vcycle") {  // PRE,POST[,CYCLES] of the linear correction (default 3,3,1)
        const std::vector<std::string> v = split(value);
        if (v.size() != 2 && v.size() != 3) throw Error("--vcycle needs PRE,POST[,CYCLES]");
        multigrid.preSmoothing = std::stoi(v[0]);
        multigrid.postSmoothing = std::stoi(v[1]);
        if (v.size() == 3) multigrid.cycles = std::stoi(v[2]);
      }
      else if (key == "--schemes") {
        if (value != "all") {
          schemes.clear();
          for (const std::string& s : split(value)) schemes.push_back(newmarkSchemeFromName(s));
        }
      } else throw Error("unknown option " + key);
    }
    if (steps1 < 1 || stepsA < 1 || stepsB < 1 || refineB < 0) throw Error("steps must be >= 1, refineB >= 0");
  } catch (const std::exception& e) {
    std::cerr << "dynamics: " << e.what() << "\n";
    return 2;
  }
  auto wanted = [&](const char* g) { return std::find(geometries.begin(), geometries.end(), g) != geometries.end(); };
  std::ostringstream md;
  md << "Produced by `OPENBLAS_NUM_THREADS=1 build/" << command.str()
     << "` (source: bench/dynamics.cpp; Release, one core). TNNMG tolerance 1e-11 (Geometries 1, A; 1e-10 for B, "
        "as its scene), relative energy-norm correction, 3 pre-smoothing sweeps, linear correction: "
     << multigrid.cycles << " V(" << multigrid.preSmoothing << "," << multigrid.postSmoothing << ") cycle(s). CPU "
        "ms/step: process CPU time of the step loop divided by the steps. E: energy with the standard lumped mass M; "
        "E~: with the redistributed mass M~ (schemes with M~; khenous-laborde-renard: the modified energy E~ + "
        "tau^2/8 a'M~a, marked mod.). Max dev = max_n |E^n - E^0| / |E^0|. E of the M~ schemes includes the "
        "velocities of the massless contact vertices (docs/dynamics.md).\n";
  try {
    if (wanted("1")) {
      Geometry g = geometry1(1e-3);
      oneBodyTable(md, g, steps1, schemes);
    }
    if (wanted("A")) {
      Geometry g = geometryA();
      oneBodyTable(md, g, stepsA, schemes);
    }
    if (wanted("B")) geometryB(md, stepsB, refineB);
  } catch (const std::exception& e) {
    std::cerr << "dynamics: " << e.what() << "\n";
    return 1;
  }
  if (!bench::writeMarkdownBlock(argv[1], "dynamics", md.str())) {
    std::cerr << "dynamics: cannot write " << argv[1] << "\n";
    return 1;
  }
  return 0;
}
