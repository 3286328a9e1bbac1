// Cost per time step of the Newmark family (libobs Newmark.hpp, docs/theory.md#newmark) with TNNMG on two 3D
// geometries of the reference thesis (Sec. 5.3.3):
//   Geometry 1: a block with a cylindrical bottom (roundedBlockMesh, hexahedra, 3 x 2 x 1 coarse cells
//               refined 3 times: 3,825 vertices, 11,475 unknowns), E = 500, nu = 0.3, rho = 1,
//               dropped with v0 = (0, 0, -1) onto the plane z = -0.01;
//   Geometry A: a ball (ballMesh, pyramids, radius 1, 2 coarse cells per direction refined twice),
//               E = 500, nu = 0.3, v0 = (0, 0, -2), tau = 5e-3, onto the plane z = -1.01 (centre 0).
// For every scheme: steps, mean TNNMG iterations per step, mean solver and step time, energy
// change, contact nodes; written as a markdown table to the file given on the command line.
// Energies: E (kinetic energy with the standard lumped mass M) for every scheme, and for the schemes
// with the redistributed mass M~ also E~ (kinetic energy with M~, the energy these schemes are
// analysed with: thesis Sec. 5.2.6; the velocities at the massless contact vertices follow the
// recursion v^{n+1} = -v^n + 2/tau (u^{n+1} - u^n) without feeding back into the motion, and E
// weights them with the mass that M~ moved away, see docs/dynamics.md "Energies") and, for KLR, the
// modified energy E~ + tau^2/8 a'M~a. Each as end/start ratio and max |E - E_0| / E_0 over the run.
//
//   dynamics results.md [steps of geometry 1 = 200] [steps of geometry A = 100] [tau geometry 1 = 1e-3]
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Newmark.hpp"

using namespace obs;

namespace {

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

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: dynamics results.md [steps geometry 1 = 200] [steps geometry A = 100] [tau 1 = 1e-3]\n";
    return 2;
  }
  const int steps1 = argc > 2 ? std::atoi(argv[2]) : 200;
  const int stepsA = argc > 3 ? std::atoi(argv[3]) : 100;
  const double tau1 = argc > 4 ? std::atof(argv[4]) : 1e-3;
  Material mat{500, 0.3};
  mat.density = 1;
  std::ostringstream md;
  md << "# Dynamic contact: cost per time step\n\n";
  md << "Produced by `bench/dynamics " << argv[1] << " " << steps1 << " " << stepsA << " " << tau1
     << "` (one core, Release). TNNMG tolerance 1e-11 (relative energy-norm correction), 3 pre-smoothing sweeps.\n"
     << "E: energy with the standard lumped mass M; E~: with the redistributed mass M~ (schemes with M~; "
        "khenous-laborde-renard: the modified energy E~ + tau^2/8 a'M~a, marked mod.). Max dev = max_n |E^n - E^0| / "
        "|E^0|. E of the M~ schemes includes the velocities of the massless contact vertices (docs/dynamics.md).\n";
  try {
    for (int gi = 0; gi < 2; ++gi) {
      Geometry g = gi == 0 ? geometry1(tau1) : geometryA();
      const int steps = gi == 0 ? steps1 : stepsA;
      const Index n = g.contact->numMeshVertices();
      md << "\n## " << g.name << "\n\n" << n << " vertices, " << 3 * n << " unknowns, " << g.contact->size()
         << " potential contact nodes, tau = " << g.tau << ", levels " << g.grid.maxLevel() + 1 << ", " << steps
         << " steps\n\n";
      md << "| scheme | setup s | TNNMG its/step (mean, max) | solver ms/step | step ms/step | total s | E_end/E_0 "
            "(max dev) | E~_end/E~_0 (max dev) | max contact nodes | max penetration |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n";
      std::string notes;
      for (NewmarkScheme s : allNewmarkSchemes()) {
        const auto t0 = std::chrono::steady_clock::now();
        NewmarkOptions o;
        o.scheme = s;
        o.timeStep = g.tau;
        std::unique_ptr<NewmarkFamily<3>> stepper;
        try {
          stepper = std::make_unique<NewmarkFamily<3>>(g.grid, mat, BoundaryConditions{}, *g.contact, o);
        } catch (const obs::Error& e) {  // e.g. M~ with a non-positive diagonal entry on this mesh
          md << "| " << name(s) << " | not run: " << e.what() << " | | | | | | | | |\n";
          std::cerr << g.name << " " << name(s) << ": not run: " << e.what() << "\n";
          continue;
        }
        NewmarkFamily<3>& st = *stepper;
        if (usesRedistributedMass(s) && !st.redistributedMassDefiniteness().positiveDefinite && notes.empty())
          notes = "M~ is indefinite on this mesh (" +
                  std::to_string(st.redistributedMassDefiniteness().nonPositivePivots) +
                  " negative eigenvalues; S = M~ + c tau^2 A is positive definite): the schemes with M~ have slowly "
                  "growing modes here.\n";
        Eigen::VectorXd v(3 * n);
        for (Index p = 0; p < n; ++p) v.segment<3>(3 * p) = g.v0;
        st.initialize(Eigen::VectorXd::Zero(3 * n), v);
        const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const StepRecord r0 = st.record();
        const double E0 = r0.energy;
        const double Et0 = r0.hasAcceleration ? r0.energyModified : r0.energyRedistributed;
        double its = 0, solver = 0, step = 0, pen = 0, devE = 0, devEt = 0;
        int maxIts = 0;
        Index maxActive = 0;
        StepRecord r;
        const auto t1 = std::chrono::steady_clock::now();
        for (int k = 0; k < steps; ++k) {
          r = st.step();
          its += r.solverIterations;
          maxIts = std::max(maxIts, r.solverIterations);
          solver += r.solverSeconds;
          step += r.stepSeconds;
          maxActive = std::max(maxActive, r.activeSolution);
          pen = std::max(pen, r.maxPenetration);
          devE = std::max(devE, std::abs(r.energy - E0) / std::abs(E0));
          if (r.hasRedistributed)
            devEt = std::max(devEt, std::abs((r.hasAcceleration ? r.energyModified : r.energyRedistributed) - Et0) /
                                        std::abs(Et0));
        }
        const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        md << "| " << name(s) << " | " << std::setprecision(3) << setup << " | " << its / steps << ", " << maxIts
           << " | " << 1e3 * solver / steps << " | " << 1e3 * step / steps << " | " << total << " | "
           << r.energy / E0 << " (" << devE << ") | ";
        if (r.hasRedistributed)
          md << (r.hasAcceleration ? r.energyModified : r.energyRedistributed) / Et0 << " (" << devEt << ")"
             << (r.hasAcceleration ? " mod." : "");
        else
          md << "-";
        md << " | " << maxActive << " | " << pen << " |\n";
        std::cerr << g.name << " " << name(s) << ": " << 1e3 * step / steps << " ms/step, " << its / steps
                  << " its/step, E_end/E_0 " << r.energy / E0;
        if (r.hasRedistributed)
          std::cerr << ", E~_end/E~_0 " << (r.hasAcceleration ? r.energyModified : r.energyRedistributed) / Et0;
        std::cerr << "\n";
      }
      if (!notes.empty()) md << "\n" << notes;
    }
  } catch (const std::exception& e) {
    std::cerr << "dynamics: " << e.what() << "\n";
    return 1;
  }
  std::ofstream(argv[1]) << md.str();
  return 0;
}
