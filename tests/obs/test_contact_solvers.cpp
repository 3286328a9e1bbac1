// Contact problems solved by projected Gauss-Seidel and the primal-dual active set method: agreement,
// KKT residuals, monotone energy, the linear limit, penetrating starts, Dirichlet data at contact
// nodes, contact outputs and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <numbers>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/KktResiduals.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"

using namespace obs;
using mesh::CellType;

namespace {

const Material kMaterial{3e5, 0.25};  // docs/theory.md#analytic-references

Point P(double x, double y, double z = 0) { return Point(x, y, z); }

template <class F>
void expectErrorMentioning(F f, const std::string& word) {
  try {
    f();
    ADD_FAILURE() << "no obs::Error thrown (expected one mentioning '" << word << "')";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
}

/// Top face (id 4) moved by `top`, all components prescribed.
BoundaryConditions pressedFromTop(const Eigen::Vector3d& top) {
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  return bc;
}

/// Both solvers on one problem; displacements, results and outputs.
template <int d>
struct Comparison {
  Eigen::VectorXd uPgs, uPdas;
  ContactResult pgs, pdas;
  ContactOutputs outPgs, outPdas;
};

template <int d>
Comparison<d> solveBoth(const ContactProblem<d>& problem, double pgsTolerance = 1e-12) {
  Comparison<d> c;
  typename ProjectedGaussSeidel<d>::Options po;
  po.tolerance = pgsTolerance;
  po.maxIterations = 20000;
  ProjectedGaussSeidel<d> pgs(po);
  PrimalDualActiveSet<d> pdas;
  c.pgs = pgs.solve(problem, c.uPgs);
  c.pdas = pdas.solve(problem, c.uPdas);
  c.outPgs = computeContactOutputs(problem, c.uPgs, 1e-6);
  c.outPdas = computeContactOutputs(problem, c.uPdas, 1e-6);
  if (std::getenv("OBS_TEST_VERBOSE"))
    std::cout << "  PGS " << c.pgs.iterations << " it (rate " << c.pgs.convergenceRate << ", " << c.pgs.seconds
              << " s, kkt " << c.pgs.kkt.max() << "), PDAS " << c.pdas.iterations << " it (" << c.pdas.seconds
              << " s, kkt " << c.pdas.kkt.max() << "), contact nodes " << c.outPdas.contactNodes << " of "
              << problem.contactSet().size() << ", dofs " << problem.numDofs() << "\n";
  return c;
}

/// Primal feasibility nu_p'u_p <= g_p at every bounded constraint, up to the rounding of the solution
/// in Cartesian coordinates. The solvers keep the normal component exactly on or below the bound in
/// the rotated coordinates of the constraint; u = Q w and the evaluation of nu_p'u_p - g_p then
/// round, by at most a few ulps of |u_p| + |g_p| (the bound allows 8, for the 2 d + 1 rounded
/// operations). Which side of zero those last bits fall on depends on the BLAS kernel of CHOLMOD's
/// solves (docs/reliability.md#blas-kernels); a real violation (a wrong active set) is of the size of
/// the displacement, orders of magnitude above the bound.
template <int d>
void expectFeasible(const ContactProblem<d>& problem, const Eigen::VectorXd& u, const char* solver) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  for (Index k = 0; k < problem.contactSet().size(); ++k) {
    const auto& c = problem.constraint(k);
    if (!c.bounded()) continue;
    const auto up = u.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d);
    const double violation = c.direction.dot(up) - c.gap;
    EXPECT_LE(violation, 8 * eps * (up.norm() + std::abs(c.gap))) << solver << ", constraint " << k;
  }
}

/// The checks every contact scenario must pass.
template <int d>
void expectAgreement(const ContactProblem<d>& problem, const Comparison<d>& c, double kktPgs = 1e-6) {
  EXPECT_TRUE(c.pgs.converged);
  EXPECT_TRUE(c.pdas.converged);
  EXPECT_LT((c.uPgs - c.uPdas).norm(), 1e-6 * c.uPdas.norm());
  EXPECT_EQ(c.outPgs.inContact, c.outPdas.inContact);
  EXPECT_GT(c.outPdas.contactNodes, 0);
  EXPECT_LT(c.pdas.kkt.max(), 1e-10);
  EXPECT_LT(c.pgs.kkt.max(), kktPgs);
  expectFeasible(problem, c.uPgs, "PGS");
  expectFeasible(problem, c.uPdas, "PDAS");
  // the energy of PGS never increases (beyond the round-off of evaluating it)
  for (std::size_t k = 1; k < c.pgs.history.size(); ++k)
    ASSERT_LE(c.pgs.history[k].energy, c.pgs.history[k - 1].energy + 1e-13 * std::abs(c.pgs.history[k - 1].energy))
        << "iteration " << k + 1;
  EXPECT_LT(c.pgs.history.back().energy, c.pgs.history.front().energy);
  // pressures are non-negative (up to round-off) and zero off contact
  for (std::size_t k = 0; k < c.outPdas.pressure.size(); ++k) {
    EXPECT_GT(c.outPdas.pressure[k], -1e-8 * kMaterial.youngsModulus);
    if (!c.outPdas.inContact[k]) {
      EXPECT_NEAR(c.outPdas.pressure[k], 0.0, 1e-8 * kMaterial.youngsModulus);
    }
  }
}

}  // namespace

TEST(ContactSolvers, QuadrilateralsPressedOntoADisk) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 8);
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_LT(c.outPdas.contactNodes, cs.size());  // a proper free boundary
  EXPECT_LT(c.outPdas.force[1], 0);              // the body pushes down on the obstacle
  EXPECT_NEAR(c.outPdas.force[0], 0, 1e-8 * std::abs(c.outPdas.force[1]));
  EXPECT_GT(c.outPdas.contactRadius, 0);
}

TEST(ContactSolvers, TrianglesUnderAFlatPunch) {
  const auto m = mesh::boxMesh(CellType::Triangle, 8);
  const ContactSet cs(m, mesh::kBottom, StripObstacle(P(0.5, 0), 0.125, P(0, -1)));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.01)), cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_EQ(c.outPdas.contactNodes, 3);              // the nodes on the punch face
  EXPECT_NEAR(c.outPdas.contactRadius, 0.125, 1e-12);  // half the contact length
  // equilibrium: the contact force sum_p mu_p nu_p balances the reaction on the clamped top,
  // sum over top nodes of (A u - b) of the assembled (not Dirichlet-reduced) system
  const auto A = assembleStiffness<2>(m, kMaterial);
  const Eigen::VectorXd r = A * c.uPdas;  // no loads: b = 0
  Eigen::Vector2d reaction = Eigen::Vector2d::Zero();
  for (Index v = 0; v < m.numVertices(); ++v)
    if (m.vertex(v)[1] == 1.0) reaction += r.segment<2>(2 * v);
  EXPECT_LT((reaction - c.outPdas.force.head<2>()).norm(), 1e-8 * reaction.norm());
  double total = 0;
  for (Index k = 0; k < cs.size(); ++k) total += c.outPdas.pressure[k] * cs.boundaryMass(k);
  EXPECT_NEAR(total, -c.outPdas.force[1], 1e-8 * total);
}

TEST(ContactSolvers, DiskWithObstacleNormalDirections) {
  // nu_p = (c - x_p)/|c - x_p| varies from node to node (rotations differ)
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 6);
  const ContactSet cs(m, mesh::kBottom,
                      DiskObstacle(P(0.5, -0.5), 0.5, -Point::UnitY(), BallObstacle::Direction::Normal));
  EXPECT_GT(std::abs(cs.direction(0)[0]), 0.1);
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_LT(c.outPdas.contactNodes, cs.size());
}

TEST(ContactSolvers, HexahedraFlatOnAPlaneGiveTheWholeArea) {
  const auto m = mesh::boxMesh(CellType::Hexahedron, 2);
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0, 0), P(0, 0, -1)));
  const ContactProblem<3> problem(m, kMaterial, pressedFromTop(P(0, 0, -0.01)), cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_EQ(c.outPdas.contactNodes, 9);
  EXPECT_NEAR(c.outPdas.contactArea, 1.0, 1e-12);
  EXPECT_NEAR(c.outPdas.contactRadius, std::sqrt(1 / std::numbers::pi), 1e-12);
}

TEST(ContactSolvers, HexahedraOnTheHertzBall) {
  const auto m = mesh::boxMesh(CellType::Hexahedron, 4);
  const ContactSet cs(m, mesh::kBottom, BallObstacle(P(0.5, 0.5, -0.75), 0.75));
  const ContactProblem<3> problem(m, kMaterial, pressedFromTop(P(0, 0, -0.05)), cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_LT(c.outPdas.contactNodes, cs.size());
}

TEST(ContactSolvers, TetrahedraOnAPyramid) {
  const auto m = mesh::boxMesh(CellType::Tetrahedron, 4);
  const ContactSet cs(m, mesh::kBottom, PyramidObstacle(P(0.5, 0.5, 0), 0.05));
  const ContactProblem<3> problem(m, kMaterial, pressedFromTop(P(0, 0, -0.02)), cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_LT(c.outPdas.contactNodes, cs.size());
}

TEST(ContactSolvers, FarObstacleGivesTheLinearSolution) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 6);
  BoundaryConditions bc = pressedFromTop(P(0.002, -0.01));
  bc.bodyForce = [](const Point&) { return Eigen::Vector3d(0, -1e3, 0); };
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, -10), P(0, -1)));
  const ContactProblem<2> problem(m, kMaterial, bc, cs);
  const Eigen::VectorXd linear = solveLinearElasticity(m, kMaterial, bc).displacement;
  Eigen::VectorXd u;
  PrimalDualActiveSet<2> pdas;
  const ContactResult r = pdas.solve(problem, u);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_EQ(r.activeSetSize, 0);
  EXPECT_LT((u - linear).norm(), 1e-12 * linear.norm());
  typename ProjectedGaussSeidel<2>::Options po;
  po.tolerance = 1e-13;
  po.maxIterations = 20000;
  ProjectedGaussSeidel<2> pgs(po);
  Eigen::VectorXd v;
  const ContactResult rp = pgs.solve(problem, v);
  EXPECT_TRUE(rp.converged);
  EXPECT_EQ(rp.activeSetSize, 0);
  EXPECT_LT((v - linear).norm(), 1e-8 * linear.norm());
  EXPECT_EQ(computeContactOutputs(problem, u).contactNodes, 0);
}

TEST(ContactSolvers, PenetratingStartIsPushedOut) {
  // the obstacle plane lies 0.005 above the bottom (negative gaps); the top is clamped
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 6);
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0.005), P(0, -1)));
  for (Index k = 0; k < cs.size(); ++k) EXPECT_NEAR(cs.gap(k), -0.005, 1e-15);
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, 0)), cs);
  Eigen::VectorXd start = Eigen::VectorXd::Zero(problem.numDofs());
  EXPECT_GT(problem.maxViolation(start), 0.0049);
  problem.projectToFeasible(start);
  EXPECT_LE(problem.maxViolation(start), 0.0);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_EQ(c.outPdas.contactNodes, cs.size());  // the whole bottom is pushed onto the plane
}

TEST(ContactSolvers, RollerOnTheContactBoundary) {
  // half model: symmetry roller u_x = 0 on the left side, whose bottom vertex is a contact node
  const auto m = mesh::boxMesh(CellType::Quadrilateral, {6, 6, 1}, P(0, 0), P(0.5, 1));
  BoundaryConditions bc = pressedFromTop(P(0, -0.01));
  bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, [](const Point&) { return P(0, 0); }});
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, bc, cs);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  EXPECT_TRUE(c.outPdas.inContact[0]);  // the corner (0, 0) touches first
  // symmetric sweeps converge to the same solution
  typename ProjectedGaussSeidel<2>::Options po;
  po.tolerance = 1e-12;
  po.symmetric = true;
  ProjectedGaussSeidel<2> sgs(po);
  Eigen::VectorXd u;
  const ContactResult r = sgs.solve(problem, u);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.iterations, c.pgs.iterations);
  EXPECT_LT((u - c.uPdas).norm(), 1e-6 * c.uPdas.norm());
}

TEST(ContactSolvers, ObliqueConstraintWithAPrescribedComponent) {
  // nu = (1, -1)/sqrt 2 while u_x is prescribed on the left side: the constraint of the corner node
  // acts on u_y alone (effective constraint), and the physical constraint holds
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 6);
  BoundaryConditions bc = pressedFromTop(P(0, -0.01));
  bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, [](const Point&) { return P(0.001, 0); }});
  const PlaneObstacle plane(P(0, -0.004), P(1, -1));
  const ContactSet cs(m, mesh::kBottom, plane);
  const ContactProblem<2> problem(m, kMaterial, bc, cs);
  EXPECT_NEAR(problem.constraint(0).scale, std::sqrt(0.5), 1e-15);
  const auto c = solveBoth(problem);
  expectAgreement(problem, c);
  for (Index k = 0; k < cs.size(); ++k) {
    const Eigen::Vector2d up = c.uPdas.segment<2>(cs.vertex(k) * 2);
    EXPECT_LE(cs.direction(k).head<2>().dot(up), cs.gap(k) + 1e-14);
  }
  EXPECT_EQ(c.uPdas[cs.vertex(0) * 2], 0.001);  // the prescribed value is kept exactly
}

TEST(ContactSolvers, DirichletValuesViolatingTheConstraintAreAnError) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 4);
  BoundaryConditions bc = pressedFromTop(P(0, -0.01));
  // the left side (with the contact node (0, 0)) is moved down into the plane y = 0
  bc.dirichlet.push_back({mesh::kLeft, {true, true, false}, [](const Point&) { return P(0, -0.01); }});
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0), P(0, -1)));
  expectErrorMentioning([&] { ContactProblem<2>(m, kMaterial, bc, cs); }, "violates the contact constraint");
  // compatible values (moved up) are fine and the node is then unconstrained
  bc.dirichlet.back().value = [](const Point&) { return P(0, 0.01); };
  const ContactProblem<2> ok(m, kMaterial, bc, cs);
  EXPECT_FALSE(ok.constraint(0).bounded());
}

TEST(ContactSolvers, MismatchedInputIsAnError) {
  const auto m2 = mesh::boxMesh(CellType::Quadrilateral, 2);
  const auto m3 = mesh::boxMesh(CellType::Hexahedron, 2);
  const ContactSet cs2(m2, mesh::kBottom, PlaneObstacle(P(0, 0), P(0, -1)));
  expectErrorMentioning([&] { ContactProblem<3>(m3, kMaterial, pressedFromTop(P(0, 0)), cs2); }, "dimension");
  const auto m2b = mesh::boxMesh(CellType::Quadrilateral, 3);
  expectErrorMentioning([&] { ContactProblem<2>(m2b, kMaterial, pressedFromTop(P(0, 0)), cs2); }, "another mesh");
  expectErrorMentioning([&] { ContactProblem<2>(m2, Material{-1, 0.3}, pressedFromTop(P(0, 0)), cs2); },
                        "Young");
}

TEST(ContactSolvers, RotatedProblemIsTheSameQuadratic) {
  const auto m = mesh::boxMesh(CellType::Triangle, 4);
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0), P(0.3, -1)));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.01)), cs);
  const RotatedProblem<2> rot = problem.rotated();
  const Eigen::VectorXd u = Eigen::VectorXd::LinSpaced(problem.numDofs(), -0.01, 0.02);
  const Eigen::VectorXd w = problem.toRotated(u);
  EXPECT_NEAR(rot.energy(w), problem.energy(u), 1e-12 * std::abs(problem.energy(u)));
  EXPECT_LT((problem.fromRotated(w) - u).norm(), 1e-15);
  for (Index k = 0; k < cs.size(); ++k) {
    const auto& c = problem.constraint(k);
    EXPECT_NEAR(w[c.vertex * 2], c.direction.dot(u.segment<2>(c.vertex * 2)), 1e-16);
    EXPECT_EQ(rot.upper[c.vertex], c.gap);
  }
  EXPECT_EQ(std::count(rot.prescribed.begin(), rot.prescribed.end(), 1),
            problem.dirichlet().count());
}

TEST(ContactSolvers, LocalSolverHitsTheBound) {
  // 1/2 v'Kv - r'v with v_1 <= 0: the unconstrained minimiser violates the bound
  BlockSparseMatrix<2> A({0, 1}, {0});
  A.blockAt(0) << 2, 1, 1, 3;
  const BlockLocalSolver<2> local(A, {0.0});
  const Eigen::Vector2d v = local.solve(0, Eigen::Vector2d(2, 1));  // free minimiser (1, 0)
  EXPECT_NEAR(v[0], 0.0, 0);
  EXPECT_NEAR(v[1], 1.0 / 3.0, 1e-15);
  const Eigen::Vector2d free = local.solve(0, Eigen::Vector2d(-2, 1));  // (-1.4, 0.8): no bound hit
  EXPECT_NEAR(free[0], -1.4, 1e-15);
  EXPECT_NEAR(free[1], 0.8, 1e-15);
}

TEST(IterationMonitor, NanDivergenceAndStagnationAreErrors) {
  ContactSolverOptions o;
  o.stagnationIterations = 3;
  {
    IterationMonitor m("test", o, -1.0);
    EXPECT_FALSE(m.record(-2.0, 0.5, 0));
    expectErrorMentioning([&] { m.record(std::nan(""), 0.1, 0); }, "NaN");
  }
  {
    IterationMonitor m("test", o, -1.0);
    expectErrorMentioning([&] { m.record(1e9, 0.1, 0); }, "diverged");
  }
  {
    IterationMonitor m("test", o, -1.0);
    m.record(-2.0, 0.5, 0);
    m.record(-2.0, 0.5, 0);
    m.record(-2.0, 0.5, 0);
    expectErrorMentioning([&] { m.record(-2.0, 0.5, 0); }, "stagnated");
  }
  {
    IterationMonitor m("test", o, -1.0);
    m.record(-2.0, 0.5, 0);
    m.record(-1.5, 0.4, 0);
    expectErrorMentioning([&] { m.requireMonotone(2.0); }, "energy increased");
    EXPECT_TRUE(m.record(-2.5, 1e-12, 0));
    const ContactResult r = m.finish(true, 0);
    EXPECT_EQ(r.iterations, 3);
    EXPECT_EQ(r.history.size(), 3u);
  }
}

TEST(ContactSolvers, IterationCapReturnsNotConverged) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 4);
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.01)), cs);
  typename ProjectedGaussSeidel<2>::Options po;
  po.maxIterations = 3;
  ProjectedGaussSeidel<2> pgs(po);
  Eigen::VectorXd u;
  const ContactResult r = pgs.solve(problem, u);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_LE(problem.maxViolation(u), 0.0);  // iterates stay admissible
}
