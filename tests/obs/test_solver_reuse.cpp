// What the time stepping reuses from one step to the next (docs/performance.md#dynamic-contact):
// TNNMG keeps its smoother's inverted diagonal blocks across solves of one operator and only replaces
// the bounds (a vertex unbounded in one solve may be bounded in the next), the first V-cycle sweep
// from zero reads only the blocks left of the diagonal, KKT residuals are computed only when asked,
// and the Newmark warm start from the previous increment solves the same steps as the predictor start
// and restarts bitwise from its scheme state.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/Newmark.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"
#include "obs/obs/TruncatedGaussSeidel.hpp"

using namespace obs;
using mesh::CellType;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

/// A hexahedral cube (2 coarse cells refined twice) pressed from the top onto the plane z = 0.
struct Pressed {
  mesh::Grid grid{mesh::boxMesh(CellType::Hexahedron, 2)};
  mesh::Mesh mesh;
  std::unique_ptr<ContactSet> contact;
  std::unique_ptr<ContactProblem<3>> problem;
  Pressed() {
    for (int l = 0; l < 2; ++l) grid.refineUniformly();
    mesh = grid.leafView().mesh;
    contact = std::make_unique<ContactSet>(mesh, mesh::kBottom, PlaneObstacle(Point(0, 0, 0), Point(0, 0, -1)));
    BoundaryConditions bc;
    bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0.002, 0, -0.01); }});
    problem = std::make_unique<ContactProblem<3>>(mesh, Material{1e3, 0.3}, bc, *contact);
  }
};

typename TNNMG<3>::Options tight() {
  typename TNNMG<3>::Options o;
  o.tolerance = 1e-11;
  o.maxIterations = 100;
  return o;
}

}  // namespace

// Solve 1 with every second contact node unbounded, solve 2 (same operator, the reuse path) with all
// bounded: the reused solver must enforce the new bounds (the nodes unbounded before penetrate in
// solve 1 and must be pushed out) and agree with a fresh TNNMG and with PDAS.
TEST(SolverReuse, NewBoundsOnTheSameOperatorAgreeWithAFreshSolverAndPdas) {
  Pressed s;
  const Index nc = s.contact->size();
  std::vector<double> all(static_cast<std::size_t>(nc)), half(static_cast<std::size_t>(nc));
  for (Index k = 0; k < nc; ++k) {
    all[static_cast<std::size_t>(k)] = s.contact->gap(k);
    half[static_cast<std::size_t>(k)] = k % 2 ? kInf : s.contact->gap(k);
  }
  TNNMG<3> reused(s.grid, tight());
  s.problem->setGaps(half);
  Eigen::VectorXd u1;
  const ContactResult r1 = reused.solve(*s.problem, u1);
  ASSERT_TRUE(r1.converged);
  s.problem->setGaps(all);
  EXPECT_GT(s.problem->maxViolation(u1), 1e-4);  // the nodes unbounded in solve 1 violate the bounds of solve 2
  Eigen::VectorXd u2 = u1, fresh, pdas;
  const ContactResult r2 = reused.solve(*s.problem, u2);
  TNNMG<3> other(s.grid, tight());
  const ContactResult rf = other.solve(*s.problem, fresh);
  PrimalDualActiveSet<3> direct;
  const ContactResult rp = direct.solve(*s.problem, pdas);
  ASSERT_TRUE(r2.converged && rf.converged && rp.converged);
  if (verbose())
    std::cout << "reused: " << r2.iterations << " its, kkt " << r2.kkt.max() << "; fresh: " << rf.iterations
              << " its; active " << r2.activeSetSize << " / " << rp.activeSetSize << "\n";
  EXPECT_LE(s.problem->maxViolation(u2), 1e-15 * u2.lpNorm<Eigen::Infinity>());
  EXPECT_LT(r2.kkt.max(), 1e-8);
  EXPECT_LT((u2 - pdas).norm(), 1e-8 * pdas.norm());
  EXPECT_LT((u2 - fresh).norm(), 1e-8 * fresh.norm());
  EXPECT_EQ(r2.activeSetSize, rp.activeSetSize);
}

// computeKkt: TNNMG ignores it (its stopping rule needs the residual, docs/theory.md#tnnmg-stopping);
// projected Gauss-Seidel reports NaN without it and solves the same way.
TEST(SolverReuse, KktResidualsOnlyWhenAsked) {
  Pressed s;
  auto with = tight(), without = tight();
  without.computeKkt = false;
  TNNMG<3> a(s.grid, with), b(s.grid, without);
  Eigen::VectorXd ua, ub;
  const ContactResult ra = a.solve(*s.problem, ua), rb = b.solve(*s.problem, ub);
  EXPECT_LT(ra.kkt.max(), 1e-8);
  EXPECT_EQ(rb.kkt.max(), ra.kkt.max());
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ((ua - ub).lpNorm<Eigen::Infinity>(), 0.0);

  ProjectedGaussSeidel<3>::Options po;
  po.tolerance = 1e-6;
  po.maxIterations = 200;
  ProjectedGaussSeidel<3> pa(po);
  po.computeKkt = false;
  ProjectedGaussSeidel<3> pb(po);
  Eigen::VectorXd va, vb;
  const ContactResult qa = pa.solve(*s.problem, va), qb = pb.solve(*s.problem, vb);
  EXPECT_TRUE(std::isfinite(qa.kkt.max()));
  EXPECT_TRUE(std::isnan(qb.kkt.max()));
  EXPECT_TRUE(std::isnan(qb.kkt.stationarity));
  EXPECT_EQ(qa.iterations, qb.iterations);
  EXPECT_EQ((va - vb).lpNorm<Eigen::Infinity>(), 0.0);  // the solve itself is the same
}

// The half sweeps from zero against full sweeps on zero (bitwise): the linear one with truncated
// components, the nonsmooth one with bounds.
TEST(SolverReuse, FirstSweepFromZeroIsTheFullSweepOnZero) {
  Pressed s;
  const BlockSparseMatrix<3>& A = s.problem->rotatedMatrix();
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(A.rows()), 0);
  for (std::size_t p = 0; p < bits.size(); p += 5) bits[p] = p % 2 ? 0b001 : 0b111;  // some partly, some fully
  TruncatedGaussSeidel<3> gs;
  gs.setMatrix(A, &bits);
  const Eigen::VectorXd r = Eigen::VectorXd::LinSpaced(3 * A.rows(), -1.0, 2.0).array().sin();
  Eigen::VectorXd full = Eigen::VectorXd::Zero(r.size());
  gs.sweep(r, full);
  Eigen::VectorXd half = Eigen::VectorXd::Constant(r.size(), 7.0);  // overwritten entirely
  gs.sweepFromZero(r, half);
  EXPECT_EQ((full - half).lpNorm<Eigen::Infinity>(), 0.0);
  for (std::size_t p = 0; p < bits.size(); p += 10) EXPECT_EQ(half.segment<3>(3 * static_cast<Eigen::Index>(p)).norm(), 0.0);
  EXPECT_GT(half.norm(), 0.0);
  // the nonsmooth sweep of TNNMG (bounds at every second contact vertex)
  std::vector<double> upper(static_cast<std::size_t>(A.rows()), kInf);
  for (Index k = 0; k < s.contact->size(); k += 2) upper[static_cast<std::size_t>(s.contact->vertex(k))] = -1e-4;
  const BlockGaussSeidelSweep<3> nonsmooth(A, upper);
  Eigen::VectorXd w = Eigen::VectorXd::Zero(r.size()), v = Eigen::VectorXd::Constant(r.size(), -3.0);
  nonsmooth.sweep(r, w);
  nonsmooth.sweepFromZero(r, v);
  EXPECT_EQ((w - v).lpNorm<Eigen::Infinity>(), 0.0);
  EXPECT_GT(w.norm(), 0.0);
}

// A hexahedral block dropped onto a plane (impact, contact, release): the warm start from the previous
// increment gives the predictor start's states to the solver tolerance, and a stepper continued from
// its scheme state (which carries the previous increment) gives the same states bitwise.
TEST(NewmarkWarmStart, PreviousIncrementSolvesTheSameStepsAndRestartsBitwise) {
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, {4, 4, 2}, Point(0, 0, 0.005), Point(1, 1, 0.505)));
  grid.refineUniformly();
  const PlaneObstacle plane(Point(0, 0, 0), Point(0, 0, -1));
  const ContactSet contact(grid.leafView().mesh, mesh::kBottom, plane);
  Material mat{300, 0.3};
  mat.density = 1;
  const Index n = contact.numMeshVertices();
  Eigen::VectorXd v0(3 * n);
  for (Index p = 0; p < n; ++p) v0.segment<3>(3 * p) = Eigen::Vector3d(0.1, 0, -1);
  for (NewmarkScheme scheme : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::Classical}) {
    NewmarkOptions o;
    o.scheme = scheme;
    o.timeStep = 2e-3;
    o.solver.tolerance = 1e-12;
    NewmarkFamily<3> predictor(grid, mat, {}, contact, o);
    o.start = NewmarkStart::PreviousIncrement;
    NewmarkFamily<3> previous(grid, mat, {}, contact, o), restarted(grid, mat, {}, contact, o);
    predictor.initialize(Eigen::VectorXd::Zero(3 * n), v0);
    previous.initialize(Eigen::VectorXd::Zero(3 * n), v0);
    int contactSteps = 0, itsPredictor = 0, itsPrevious = 0;
    double worst = 0;
    NewmarkSchemeState saved;
    for (int k = 1; k <= 60; ++k) {
      const StepRecord a = predictor.step(), b = previous.step();
      contactSteps += a.activeSolution > 0;
      itsPredictor += a.solverIterations;
      itsPrevious += b.solverIterations;
      EXPECT_EQ(a.activeSolution, b.activeSolution) << name(scheme) << " step " << k;
      const double scale = predictor.state().u.lpNorm<Eigen::Infinity>();
      worst = std::max(worst, (predictor.state().u - previous.state().u).lpNorm<Eigen::Infinity>() / scale);
      if (k == 25) saved = previous.schemeState();
    }
    if (verbose())
      std::cout << name(scheme) << ": contact steps " << contactSteps << ", TNNMG iterations predictor "
                << itsPredictor << ", previous increment " << itsPrevious << ", max relative difference " << worst
                << "\n";
    EXPECT_GT(contactSteps, 5) << name(scheme);
    EXPECT_LT(contactSteps, 60) << name(scheme);  // released again
    EXPECT_LT(worst, 1e-8) << name(scheme);
    ASSERT_EQ(saved.previousIncrement.size(), 3 * n);
    EXPECT_GT(saved.previousIncrement.norm(), 0);
    restarted.setSchemeState(saved);
    for (int k = 26; k <= 60; ++k) restarted.step();
    EXPECT_EQ((restarted.state().u - previous.state().u).lpNorm<Eigen::Infinity>(), 0.0) << name(scheme);
    EXPECT_EQ((restarted.state().v - previous.state().v).lpNorm<Eigen::Infinity>(), 0.0) << name(scheme);
  }
  EXPECT_THROW(newmarkStartFromName("extrapolated"), Error);
  EXPECT_EQ(newmarkStartFromName(name(NewmarkStart::PreviousIncrement)), NewmarkStart::PreviousIncrement);
}
