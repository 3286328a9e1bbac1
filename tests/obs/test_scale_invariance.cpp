// Scale invariance of the contact solvers (docs/reliability.md): the Signorini problem
//   min 1/2 a(u, u) - l(u)  subject to u.nu <= g,  u = u_D on Gamma_D,
// driven by Dirichlet data alone has a solution independent of Young's modulus E (a scales with
// E, the constraint set does not), and scaling all lengths (mesh, obstacle, u_D) by L scales the
// solution by L. TNNMG must reproduce both: the same displacement to 1e-9 relative and the same
// number of iterations, i.e. no tolerance, threshold or eliminated row of the solver may carry an
// absolute scale. (Before TNNMG measured ||w||_A over the free components only, the unit diagonal
// of the eliminated Dirichlet rows entered the A-norm of its stopping test: the 2D punch scene took
// 9 iterations for E = 1e-3 and 10 for E >= 1.)
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;

namespace {

struct Solution {
  Eigen::VectorXd u;
  int iterations = 0;
  bool converged = false;
};

/// The punch (2D, strip obstacle) or Hertz ball (3D) pressed from the top by u_D, in the box
/// [0, L]^d with Young's modulus E.
template <int d>
Solution solveScaled(CellType type, double E, double L) {
  mesh::Grid grid(mesh::boxMesh(type, 2, Point::Zero(), L * Point::Ones()));
  for (int l = 0; l < (d == 2 ? 4 : 2); ++l) grid.refineUniformly();
  const mesh::Mesh m = grid.leafView().mesh;
  std::unique_ptr<Obstacle> obstacle;
  Eigen::Vector3d top;
  if constexpr (d == 2) {
    obstacle = std::make_unique<StripObstacle>(L * Point(0.5, 0, 0), L * 0.0625, Point(0, -1, 0));
    top = L * Eigen::Vector3d(0, -0.01, 0);
  } else {
    obstacle = std::make_unique<BallObstacle>(L * Point(0.5, 0.5, -0.75), L * 0.75);
    top = L * Eigen::Vector3d(0, 0, -0.03);
  }
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  const ContactSet cs(m, mesh::kBottom, *obstacle);
  const ContactProblem<d> problem(m, Material{E, 0.3}, bc, cs);
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-10;
  o.maxIterations = 100;
  TNNMG<d> tnnmg(grid, o);
  Solution s;
  const ContactResult r = tnnmg.solve(problem, s.u);
  s.iterations = r.iterations;
  s.converged = r.converged;
  return s;
}

template <int d>
void expectScaleInvariance(CellType type) {
  const Solution ref = solveScaled<d>(type, 1.0, 1.0);
  ASSERT_TRUE(ref.converged);
  for (const double E : {1e-3, 1e6, 1e12}) {
    const Solution s = solveScaled<d>(type, E, 1.0);
    EXPECT_TRUE(s.converged) << "E = " << E;
    EXPECT_EQ(s.iterations, ref.iterations) << "E = " << E;
    EXPECT_LE((s.u - ref.u).norm(), 1e-9 * ref.u.norm()) << "E = " << E;
  }
  for (const double L : {1e-3, 1e3}) {
    const Solution s = solveScaled<d>(type, 1.0, L);
    EXPECT_TRUE(s.converged) << "L = " << L;
    EXPECT_EQ(s.iterations, ref.iterations) << "L = " << L;
    EXPECT_LE((s.u / L - ref.u).norm(), 1e-9 * ref.u.norm()) << "L = " << L;
  }
  // both at once, to the extremes
  const Solution s = solveScaled<d>(type, 1e12, 1e-3);
  EXPECT_EQ(s.iterations, ref.iterations);
  EXPECT_LE((s.u / 1e-3 - ref.u).norm(), 1e-9 * ref.u.norm());
}

TEST(ScaleInvariance, PunchIn2DIndependentOfEAndLengthUnit) {
  expectScaleInvariance<2>(CellType::Quadrilateral);
  expectScaleInvariance<2>(CellType::Triangle);
}

TEST(ScaleInvariance, HertzIn3DIndependentOfEAndLengthUnit) {
  expectScaleInvariance<3>(CellType::Hexahedron);
  expectScaleInvariance<3>(CellType::Tetrahedron);
}

}  // namespace
