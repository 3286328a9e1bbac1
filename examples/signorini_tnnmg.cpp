// Example 1: a Signorini problem solved with TNNMG, the obs library from the outside.
//
// The flat punch of the reference thesis (Sec. 4.2.1, Example 1; docs/theory.md#punch): the unit
// square (plane strain, E = 3e5, nu = 0.25) is pressed down by u = (0, -0.01) on its top onto a rigid
// flat punch, the strip |x - 0.5| <= 0.0625 under its bottom edge. The steps are those of every obs
// contact computation:
//   mesh::Grid  ->  ContactSet  ->  ContactProblem  ->  TNNMG  ->  computeContactOutputs
// and the result is compared with the half-space pressure under a flat punch, p(x) = P / (pi sqrt(b^2 -
// (x - 0.5)^2)), at the centre of the strip.
//
// Build and run against an installed obs (see README "Using obs from your own CMake project"):
//   cmake --install build --prefix /tmp/obs-prefix
//   cmake -S examples -B /tmp/obs-examples -DCMAKE_PREFIX_PATH=/tmp/obs-prefix
//   cmake --build /tmp/obs-examples && /tmp/obs-examples/signorini_tnnmg
// (ctest runs it as part of `embedding.examples`, which checks the numbers below.)
//
// Expected output (the time differs):
//   grid: 4225 vertices, 4096 cells on 5 levels; 8450 unknowns
//   TNNMG: converged in 10 iterations, rate 0.0664, KKT residual 1.3e-12 (0.014 s)
//   contact: 9 of 65 potential contact vertices, load P = 1577.45, half width 0.0625
//   centre pressure: s = 7598.29, half-space p = 8033.87 (-5.42 %)
//   checks passed
// The centre pressure of this uniform grid is 5 % off; adaptive refinement (Example 2) does better
// with far fewer vertices.
#include <obs/estimators/AnalyticContact.hpp>
#include <obs/mesh/BoxMesh.hpp>
#include <obs/mesh/Grid.hpp>
#include <obs/obs/ContactProblem.hpp>
#include <obs/obs/ContactSet.hpp>
#include <obs/obs/Obstacle.hpp>
#include <obs/obs/TNNMG.hpp>

#include <cmath>
#include <cstdio>

int main() {
  using namespace obs;

  // 1. The grid: a coarse 4 x 4 mesh of quadrilaterals on the unit square, refined uniformly four
  //    times. The Grid keeps every level, and TNNMG uses them as its multigrid hierarchy. Box meshes
  //    name their sides mesh::kLeft, kRight, kBottom, kTop.
  mesh::Grid grid(mesh::boxMesh(mesh::CellType::Quadrilateral, 4));
  for (int level = 0; level < 4; ++level) grid.refineUniformly();
  const mesh::Mesh leaf = grid.leafView().mesh;  // the finest mesh: the problem lives here

  // 2. Material and boundary conditions: the top is moved to (0, -0.01), i.e. held horizontally and
  //    pushed down by 0.01; the sides are free, the bottom meets the punch.
  const Material material{3e5, 0.25};  // E, nu (plane strain in 2D)
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true},
                          [](const Point&) { return Eigen::Vector3d(0, -0.01, 0); }});

  // 3. The obstacle and the potential contact boundary. A StripObstacle is a flat punch: gap 0 on the
  //    strip of half width 0.0625 around (0.5, 0), constraint direction -e_y, no constraint outside.
  //    The ContactSet collects the vertices of the bottom faces with their direction nu_p, gap g_p,
  //    rotation Q_p and boundary mass m_p^C (docs/theory.md#rotations).
  const double halfWidth = 0.0625;
  const StripObstacle punch(Point(0.5, 0, 0), halfWidth, Point(0, -1, 0));
  const ContactSet contact(leaf, mesh::kBottom, punch);

  // 4. The algebraic problem: min 1/2 u'Au - b'u subject to nu_p'u_p <= g_p
  //    (docs/theory.md#signorini-discrete). The template argument is the dimension.
  const ContactProblem<2> problem(leaf, material, bc, contact);

  // 5. TNNMG on the grid's levels (docs/theory.md#tnnmg). The solver returns a result value; it
  //    never prints. u may start empty: the solver starts from zero, projected onto the constraints.
  TNNMG<2>::Options options;
  options.tolerance = 1e-10;  // relative energy-norm correction
  TNNMG<2> solver(grid, options);
  Eigen::VectorXd u;
  const ContactResult result = solver.solve(problem, u);

  // 6. What the solution means at the contact boundary: actual contact, nodal forces mu_p, nodal
  //    pressures s_p = mu_p / m_p^C, the load P = sum_p mu_p and the size of the contact zone
  //    (docs/theory.md#contact-pressure).
  const ContactOutputs out = computeContactOutputs(problem, u);
  double load = 0;
  for (double mu : out.multiplier) load += mu;

  // The contact node nearest to the centre of the punch, and the analytic pressure there
  // (estimators::punchPressure takes the coordinate relative to the centre).
  Index centre = 0;
  for (Index k = 0; k < contact.size(); ++k)
    if (std::abs(contact.position(k).x() - 0.5) < std::abs(contact.position(centre).x() - 0.5)) centre = k;
  const double s = out.pressure[centre];
  const double exact = estimators::punchPressure(contact.position(centre).x() - 0.5, load, halfWidth);

  std::printf("grid: %ld vertices, %ld cells on %d levels; %ld unknowns\n", long(leaf.numVertices()),
              long(leaf.numCells()), grid.maxLevel() + 1, long(problem.numDofs()));
  std::printf("TNNMG: %s in %d iterations, rate %.3g, KKT residual %.2g (%.3f s)\n",
              result.converged ? "converged" : "NOT converged", result.iterations, result.convergenceRate,
              result.kkt.max(), result.seconds);
  std::printf("contact: %ld of %ld potential contact vertices, load P = %.2f, half width %.4f\n",
              long(out.contactNodes), long(contact.size()), load, out.contactRadius);
  std::printf("centre pressure: s = %.2f, half-space p = %.2f (%+.2f %%)\n", s, exact, 100 * (s - exact) / exact);

  // Checks for ctest (embedding.examples): converged to a tight KKT residual, the contact zone is the
  // whole strip (9 vertices), the load is within 3 % of the thesis' fine-grid value 1549.10, and the
  // centre pressure within 8 % of the half-space law on this grid (see docs/estimators.md for the
  // same figure).
  const bool ok = result.converged && result.kkt.max() < 1e-8 && out.contactNodes == 9 &&
                  std::abs(out.contactRadius - halfWidth) < 1e-12 && std::abs(load - 1549.10) < 0.03 * 1549.10 &&
                  std::abs(s - exact) < 0.08 * exact;
  std::printf(ok ? "checks passed\n" : "checks FAILED\n");
  return ok ? 0 : 1;
}
