// Example 3: dynamic contact with a chosen scheme of the Newmark family and a diagnostic of your own.
//
// An elastic block (2D, plane strain, E = 200, nu = 0.3, rho = 1) of size 1 x 0.5 starts 0.02 above
// a rigid floor with velocity (0.1, -1), hits the floor, stays in contact while the compression wave
// runs through it, and bounces off. Each time step of a Newmark-type scheme is a contact problem
// solved by TNNMG (docs/theory.md#newmark); the stepper reports energy, momentum, contact force and
// active sets per step (StepRecord). On top of those, the program computes its own per-step
// diagnostic from the stepper's state and mass matrix: the height and vertical velocity of the
// centre of mass, from which it reports the impact and release times and the restitution
// coefficient e = v_after / v_before of the centre of mass.
//
// Usage: dynamic_newmark [scheme]   (default improved-contact-stabilized; an unknown name prints the
// valid ones: classical, contact-implicit, contact-stabilized, ..., hager-huebner-wohlmuth)
//
// Build and run: as examples/signorini_tnnmg.cpp, then /tmp/obs-examples/dynamic_newmark.
//
// Expected output:
//   scheme improved-contact-stabilized, tau = 0.005, 561 vertices, 33 potential contact vertices
//       t        energy   centre y   centre v_y  active  contact force y
//   0.050      0.244688    0.23435     -0.06098      33         -14.4932
//   0.100      0.244688    0.25992      0.73844       0          -0.0000
//   ...
//   0.500      0.244688    0.55530      0.73844       0          -0.0000
//   impact at t = 0.020, release at t = 0.090, restitution e = 0.738, E_end / E_0 = 0.9691
//   checks passed
// (E is constant after the release; the impact dissipated 3 % of it.) Try `dynamic_newmark classical`: the block never leaves the floor within the
// run, the chattering of classical Newmark with contact (thesis Sec. 5.2.6; docs/dynamics.md).
#include <obs/mesh/BoxMesh.hpp>
#include <obs/mesh/Error.hpp>
#include <obs/mesh/Grid.hpp>
#include <obs/obs/ContactSet.hpp>
#include <obs/obs/Newmark.hpp>
#include <obs/obs/Obstacle.hpp>

#include <algorithm>
#include <cstdio>
#include <string>

namespace {

using namespace obs;

/// The custom diagnostic: centre of mass height and vertical velocity, from the lumped or consistent
/// mass matrix M of the stepper: with e_y the vector that is 1 in every y component,
///   mass = e_y'M e_y,   y_c = e_y'M (x_y + u_y) / mass,   v_c = e_y'M v / mass.
struct CentreOfMass {
  double height = 0, velocity = 0;
};

CentreOfMass centreOfMass(const NewmarkFamily<2>& stepper, const mesh::Mesh& mesh) {
  const Index n = mesh.numVertices();
  Eigen::VectorXd ey = Eigen::VectorXd::Zero(2 * n), y(2 * n);
  for (Index p = 0; p < n; ++p) {
    ey[2 * p + 1] = 1;
    y[2 * p] = 0;
    y[2 * p + 1] = mesh.vertex(p).y();
  }
  const Eigen::VectorXd Mey = stepper.mass() * ey;  // M is symmetric: e_y'M x = (M e_y)'x
  const double mass = Mey.dot(ey);
  const DynamicState& state = stepper.state();
  return {Mey.dot(y + state.u) / mass, Mey.dot(state.v) / mass};
}

}  // namespace

int main(int argc, char** argv) try {
  // 1. The scheme, by its scene-file name (obs::Error with the valid names if unknown).
  NewmarkOptions options;
  options.scheme = newmarkSchemeFromName(argc > 1 ? argv[1] : "improved-contact-stabilized");
  options.timeStep = 0.005;
  const int steps = 100;

  // 2. Body, obstacle, contact boundary. The grid is refined once: TNNMG uses its two levels.
  mesh::Grid grid(mesh::boxMesh(mesh::CellType::Triangle, {16, 8, 1}, Point(0, 0.02, 0), Point(1, 0.52, 0)));
  grid.refineUniformly();
  const mesh::Mesh leaf = grid.leafView().mesh;
  Material material{200, 0.3};
  material.density = 1;
  const PlaneObstacle floor(Point(0, 0, 0), Point(0, -1, 0));  // the half-plane y <= 0, direction -e_y
  const ContactSet contact(leaf, mesh::kBottom, floor);
  const BoundaryConditions free;  // no Dirichlet data, no loads: a free flight until the impact

  // 3. The stepper assembles A, M (M~ for the redistributed schemes) and the TNNMG solver once.
  NewmarkFamily<2> stepper(grid, material, free, contact, options);
  const Index n = leaf.numVertices();
  Eigen::VectorXd v0(2 * n);
  for (Index p = 0; p < n; ++p) v0.segment<2>(2 * p) = Eigen::Vector2d(0.1, -1.0);
  stepper.initialize(Eigen::VectorXd::Zero(2 * n), v0);
  std::printf("scheme %s, tau = %g, %ld vertices, %ld potential contact vertices\n", stepper.name().c_str(),
              options.timeStep, long(n), long(contact.size()));

  // 4. Time loop: the library's record plus our diagnostic each step.
  std::printf("    t        energy   centre y   centre v_y  active  contact force y\n");
  const double energy0 = stepper.record().energy;
  const double velocity0 = centreOfMass(stepper, leaf).velocity;
  double impact = -1, release = -1, maxPenetration = 0, maxEnergy = energy0;
  for (int k = 1; k <= steps; ++k) {
    const StepRecord r = stepper.step();
    const CentreOfMass c = centreOfMass(stepper, leaf);
    if (r.activeSolution > 0 && impact < 0) impact = r.time;
    if (r.activeSolution == 0 && impact >= 0 && release < 0) release = r.time;
    maxPenetration = std::max(maxPenetration, r.maxPenetration);
    maxEnergy = std::max(maxEnergy, r.energy);
    if (k % 10 == 0)
      std::printf("%5.3f  %12.6f  %9.5f  %11.5f  %6ld  %15.4f\n", r.time, r.energy, c.height, c.velocity,
                  long(r.activeSolution), r.contactForce.y());
  }
  const double velocity1 = centreOfMass(stepper, leaf).velocity;
  std::printf("impact at t = %.3f, release at t = %.3f, restitution e = %.3f, E_end / E_0 = %.4f\n", impact,
              release, -velocity1 / velocity0, stepper.record().energy / energy0);

  // Checks for ctest (embedding.examples, default scheme): the block hit the floor and (except with
  // classical Newmark, see the header) left it again, moving up; the non-penetration schemes never
  // penetrate; the dissipative ones never gain energy.
  const NewmarkScheme s = options.scheme;
  bool ok = impact > 0;
  if (s != NewmarkScheme::Classical) ok = ok && release > impact && velocity1 > 0;
  if (!usesPersistency(s)) ok = ok && maxPenetration < 1e-9;
  if (s == NewmarkScheme::ContactImplicit || s == NewmarkScheme::ContactStabilized ||
      s == NewmarkScheme::ImprovedContactStabilized || s == NewmarkScheme::AlphaHalf)
    ok = ok && maxEnergy <= energy0 * (1 + 1e-10);
  std::printf(ok ? "checks passed\n" : "checks FAILED\n");
  return ok ? 0 : 1;
} catch (const obs::Error& e) {
  std::fprintf(stderr, "dynamic_newmark: %s\n", e.what());
  return 1;
}
