// Example 4: two elastic bodies in contact on non-matching meshes (dual mortar), solved with TNNMG.
//
// An elastic half-cylinder (radius 1, triangles) is pressed by 0.05 onto an elastic block (4 x 2,
// quadrilaterals, bottom clamped), plane strain, E = 1, nu = 0.3 for both. The meshes do not match at
// the interface: the cylinder's arc is the slave side, the block's top the master side, and the dual
// mortar coupling (docs/theory.md#dual-mortar) turns the non-penetration condition into one inequality per
// slave vertex. The steps are those of the one-body example with a ContactModel in front:
//   two mesh::Grids -> ContactModel (bodies + a mortar pair) -> ContactProblem -> TNNMG on both
//   hierarchies -> computeContactOutputs, the master's reaction from the coupling
// and the result is checked three ways: TNNMG against the primal-dual active set method (an
// independent solver), action = reaction between the bodies, and the peak pressure against Hertz's
// law for two cylinders (docs/theory.md#two-body-hertz; the block is the limit R2 -> infinity).
//
// Build and run against an installed obs (see README "Using obs from your own CMake project"):
//   cmake --install build --prefix /tmp/obs-prefix
//   cmake -S examples -B /tmp/obs-examples -DCMAKE_PREFIX_PATH=/tmp/obs-prefix
//   cmake --build /tmp/obs-examples && /tmp/obs-examples/two_body_mortar
// (ctest runs it as part of `embedding.examples`, which checks the numbers below.)
//
// Expected output (the times differ):
//   bodies: block 2145 vertices, cylinder 1601 vertices; 7492 unknowns
//   mortar: 29 constrained slave vertices (those of the arc that face the block)
//   TNNMG: converged in 14 iterations, KKT residual 2.2e-11 (0.01 s)
//   PDAS:  converged in 5 iterations, energy difference to TNNMG 6.5e-16 (relative)
//   contact: 7 vertices in contact, load P = 0.015773, reaction on the block -0.015773 (y)
//   peak pressure 0.05371, Hertz p0 = 0.05252 (+2.26 %); half width 0.147, Hertz b = 0.191
//   at the origin: u_y = -0.027925 (cylinder), -0.027925 (block)
//   checks passed
// The measured half width is that of the slave faces entirely in contact and lags by up to one face;
// the load and the peak pressure converge under refinement (docs/verification.md, two-body Hertz).
#include <obs/mesh/BoxMesh.hpp>
#include <obs/mesh/CurvedMeshes.hpp>
#include <obs/mesh/Grid.hpp>
#include <obs/obs/ContactModel.hpp>
#include <obs/obs/ContactProblem.hpp>
#include <obs/obs/PrimalDualActiveSet.hpp>
#include <obs/obs/TNNMG.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

int main() {
  using namespace obs;
  const int refinements = 3;

  // 1. Two grids. The block: 8 x 4 quadrilaterals on [-2, 2] x [-2, 0]. The half-cylinder: a half
  //    disk of triangles with centre (0, 1), its arc touching the block at the origin; its boundary
  //    projection keeps new vertices on the circle when it is refined. Each grid keeps its levels:
  //    TNNMG stacks the two hierarchies level by level.
  mesh::Grid block(mesh::boxMesh(mesh::CellType::Quadrilateral, {8, 4, 1}, Point(-2, -2, 0), Point(2, 0, 0)));
  mesh::CurvedMesh halfDisk = mesh::halfDiskMesh(Point(0, 1, 0), 1.0, mesh::CellType::Triangle, 2);
  mesh::Grid cylinder(std::move(halfDisk.mesh));
  for (auto& [boundary, projection] : halfDisk.projections) cylinder.setBoundaryProjection(boundary, projection);
  for (int level = 0; level < refinements; ++level) {
    block.refineUniformly();
    cylinder.refineUniformly();
  }
  const mesh::Mesh& blockMesh = block.leafView().mesh;
  const mesh::Mesh& cylinderMesh = cylinder.leafView().mesh;

  // 2. The contact model: each body with its material and boundary conditions, then the coupling.
  //    The block's bottom is clamped; the cylinder's flat top (kHalfDiskTop) is moved down by 0.05.
  const Material material{1.0, 0.3};
  BoundaryConditions clamped, pushed;
  clamped.dirichlet.push_back({mesh::kBottom});
  pushed.dirichlet.push_back({mesh::kHalfDiskTop, {true, true, true},
                              [](const Point&) { return Eigen::Vector3d(0, -0.05, 0); }});
  ContactModel<2> model;
  const int blockBody = model.addBody("block", blockMesh, material, clamped);
  const int cylinderBody = model.addBody("cylinder", cylinderMesh, material, pushed);
  // slave: the cylinder's arc (kCurvedSurface); master: the block's top. The slave side should be
  // the finer or the more curved one; here both are refined alike and the arc carries the pressure.
  model.addMortarPair(cylinderBody, mesh::kCurvedSurface, blockBody, mesh::kTop, "cylinder on block");

  // 3. One ContactProblem over the stacked unknowns of both bodies. Its unknowns x are the
  //    displacements after the mortar basis transformation (docs/theory.md#dual-mortar): on slave vertices
  //    they are the jump across the interface, so the constraints are again one bound per vertex.
  ContactProblem<2> problem = model.assemble();
  const MortarCoupling& mortar = *model.couplings()[0].coupling;

  // 4. TNNMG on both hierarchies (the coarse levels of the two grids are stacked block-diagonally;
  //    the coupling enters through the problem's transformation).
  TNNMG<2>::Options options;
  options.tolerance = 1e-10;
  TNNMG<2> solver({&block, &cylinder}, options);
  Eigen::VectorXd x;
  const ContactResult result = solver.solve(problem, x);
  const Eigen::VectorXd u = problem.toDisplacement(x);  // the physical displacements of both bodies

  // An independent solver on the same problem: the primal-dual active set method with CHOLMOD.
  PrimalDualActiveSet<2> pdas;
  Eigen::VectorXd xp;
  const ContactResult reference = pdas.solve(problem, xp);
  const double energyDifference = std::abs(result.energy - reference.energy) / std::abs(reference.energy);

  // 5. Contact outputs: out.multiplier / out.pressure per constraint node of the problem,
  //    out.force = sum_p mu_p n_p, the force on the master side. The coupling maps the slave
  //    multipliers to the nodal forces on the master's vertices (the reaction), which must be equal
  //    and opposite to the force on the slave.
  const ContactOutputs out = computeContactOutputs(problem, x);
  const auto& nodes = model.couplings()[0].nodes;  // this pair's nodes among the problem's
  Eigen::VectorXd mu(mortar.size());
  double peak = 0;
  for (Index k = 0; k < mortar.size(); ++k) {
    mu[k] = out.multiplier[nodes[k]];
    peak = std::max(peak, out.pressure[nodes[k]]);
  }
  const Eigen::VectorXd masterForces = mortar.masterForces(mu);
  Eigen::Vector2d reaction = Eigen::Vector2d::Zero();
  const Index first = model.bodies()[blockBody].offset, count = blockMesh.numVertices();
  for (Index v = first; v < first + count; ++v) reaction += masterForces.segment<2>(2 * v);
  const double load = out.force.norm();

  // The two bodies at the first point of contact, the origin: the same vertical displacement (no
  // gap, no penetration) up to the solver tolerance. Vertex v of body i is stacked vertex
  // offset_i + v, with d = 2 components each.
  auto atOrigin = [&](int body, const mesh::Mesh& mesh) {
    Index nearest = 0;
    for (Index v = 0; v < mesh.numVertices(); ++v)
      if (mesh.vertex(v).norm() < mesh.vertex(nearest).norm()) nearest = v;
    return u[2 * (model.bodies()[body].offset + nearest) + 1];
  };
  const double uBlock = atOrigin(blockBody, blockMesh), uCylinder = atOrigin(cylinderBody, cylinderMesh);

  // Hertz for two cylinders in plane strain (R = 1, the block as R2 -> infinity):
  // 1/E* = 2 (1 - nu^2) / E, b = sqrt(4 P R / (pi E*)), p0 = 2 P / (pi b).
  const double Estar = 1.0 / (2 * (1 - 0.3 * 0.3) / 1.0);
  const double b = std::sqrt(4 * load / (M_PI * Estar));
  const double p0 = 2 * load / (M_PI * b);

  std::printf("bodies: block %ld vertices, cylinder %ld vertices; %ld unknowns\n", long(blockMesh.numVertices()),
              long(cylinderMesh.numVertices()), long(problem.numDofs()));
  std::printf("mortar: %ld constrained slave vertices (those of the arc that face the block)\n", long(mortar.size()));
  std::printf("TNNMG: %s in %d iterations, KKT residual %.2g (%.2f s)\n",
              result.converged ? "converged" : "NOT converged", result.iterations, result.kkt.max(), result.seconds);
  std::printf("PDAS:  %s in %d iterations, energy difference to TNNMG %.2g (relative)\n",
              reference.converged ? "converged" : "NOT converged", reference.iterations, energyDifference);
  std::printf("contact: %ld vertices in contact, load P = %.6f, reaction on the block %.6f (y)\n",
              long(out.contactNodes), load, reaction.y());
  std::printf("peak pressure %.5f, Hertz p0 = %.5f (%+.2f %%); half width %.3f, Hertz b = %.3f\n", peak, p0,
              100 * (peak - p0) / p0, out.contactRadius, b);
  std::printf("at the origin: u_y = %.6f (cylinder), %.6f (block)\n", uCylinder, uBlock);

  // Checks for ctest (embedding.examples): both solvers converged to the same energy; action =
  // reaction to round-off; the load within 1 % of the converged value 0.01587 (docs/verification.md);
  // the peak pressure within 4 % of Hertz on this grid (2.3 % measured). At the origin, a vertex of both
  // meshes inside the contact zone, the two bodies move together to 1e-8 (dual mortar enforces the
  // weighted gap, not pointwise contact; here the two agree to the printed digits).
  const bool ok = result.converged && reference.converged && result.kkt.max() < 1e-8 && energyDifference < 1e-9 &&
                  (reaction - out.force.head<2>()).norm() < 1e-12 * load && reaction.y() < 0 &&
                  std::abs(uCylinder - uBlock) < 1e-8 &&
                  std::abs(load - 0.01587) < 0.01 * 0.01587 && std::abs(peak - p0) < 0.04 * p0;
  std::printf(ok ? "checks passed\n" : "checks FAILED\n");
  return ok ? 0 : 1;
}
