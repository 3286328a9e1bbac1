// TNNMG: its parts (truncation, defect projection, exact line search), agreement with the primal-dual
// active set method for every element type (2D punch on a strip, 3D Hertz ball), KKT residuals,
// monotone energy, mesh-independent iteration counts on uniformly and locally refined grids, curved
// obstacles with varying normals, the linear limit, Dirichlet data on the contact boundary,
// penetrating starts, an exchangeable linear correction, bad input, and the stopping rules (KKT
// test, the a posteriori error bound of a diagonal lower bound).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <memory>

#include "../GridCheck.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LineSearch.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/MassMatrix.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"
#include "obs/obs/TruncatedLinearization.hpp"

using namespace obs;
using mesh::CellType;

namespace {

const Material kMaterial{3e5, 0.25};  // docs/theory.md#analytic-references

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

Point P(double x, double y, double z = 0) { return Point(x, y, z); }

BoundaryConditions pressedFromTop(const Eigen::Vector3d& top) {
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  return bc;
}

mesh::Grid uniformGrid(CellType type, int coarseCells, int levels) {
  mesh::Grid grid(mesh::boxMesh(type, coarseCells));
  for (int l = 0; l < levels; ++l) grid.refineUniformly();
  return grid;
}

using obs::test::refineNear;

/// The punch of docs/theory.md#analytic-references (strip g = 0 on [0.4375, 0.5625]) or the Hertz ball with a
/// deeper push.
template <int d>
std::unique_ptr<Obstacle> standardObstacle() {
  if constexpr (d == 2) return std::make_unique<StripObstacle>(P(0.5, 0), 0.0625, P(0, -1));
  else return std::make_unique<BallObstacle>(P(0.5, 0.5, -0.75), 0.75);
}
template <int d>
BoundaryConditions standardLoad() {
  return pressedFromTop(d == 2 ? P(0, -0.01) : P(0, 0, -0.03));
}

template <int d>
struct Outcome {
  Eigen::VectorXd u, uPdas;
  ContactResult tnnmg, pdas;
  typename TNNMG<d>::Statistics statistics;
};

template <int d>
typename TNNMG<d>::Options tightOptions() {
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-10;
  o.maxIterations = 100;
  return o;
}

/// TNNMG (and PDAS unless `withPdas` is false) on one problem on the grid's leaf view.
template <int d>
Outcome<d> solve(const mesh::Grid& grid, const ContactProblem<d>& problem, bool withPdas = true,
             const typename TNNMG<d>::Options& options = tightOptions<d>(), const std::string& label = "") {
  Outcome<d> r;
  TNNMG<d> tnnmg(grid, options);
  r.tnnmg = tnnmg.solve(problem, r.u);
  r.statistics = tnnmg.statistics();
  if (withPdas) {
    PrimalDualActiveSet<d> pdas;
    r.pdas = pdas.solve(problem, r.uPdas);
  }
  if (verbose())
    std::cout << "  " << label << ": " << problem.numDofs() << " dofs, " << grid.maxLevel() << " levels, TNNMG "
              << r.tnnmg.iterations << " it (rate " << r.tnnmg.convergenceRate << ", " << r.tnnmg.seconds
              << " s, kkt " << r.tnnmg.kkt.max() << ", updates " << r.statistics.operatorUpdates << "), active "
              << r.tnnmg.activeSetSize
              << (withPdas ? ", PDAS " + std::to_string(r.pdas.iterations) + " it, " + std::to_string(r.pdas.seconds) + " s"
                           : std::string())
              << "\n";
  return r;
}

/// The checks every scenario must pass: convergence, agreement with PDAS (displacements, identical
/// active sets), KKT residuals, feasibility, non-increasing energy.
template <int d>
void expectAgreement(const ContactProblem<d>& problem, const Outcome<d>& r, bool expectContact = true) {
  EXPECT_TRUE(r.tnnmg.converged);
  EXPECT_TRUE(r.pdas.converged);
  EXPECT_LT((r.u - r.uPdas).norm(), 1e-8 * r.uPdas.norm());
  const ContactOutputs a = computeContactOutputs(problem, r.u, 1e-6), b = computeContactOutputs(problem, r.uPdas, 1e-6);
  EXPECT_EQ(a.inContact, b.inContact);
  if (expectContact) {
    EXPECT_GT(a.contactNodes, 0);
  }
  EXPECT_EQ(r.tnnmg.activeSetSize, r.pdas.activeSetSize);
  EXPECT_LT(r.tnnmg.kkt.max(), 1e-8);
  // admissible up to the round-off of u = Q w (exact zero for constant directions)
  EXPECT_LE(problem.maxViolation(r.u), 1e-15 * r.u.template lpNorm<Eigen::Infinity>());
  const auto& h = r.tnnmg.history;
  ASSERT_FALSE(h.empty());
  for (std::size_t k = 1; k < h.size(); ++k)
    ASSERT_LE(h[k].energy, h[k - 1].energy + 1e-13 * std::abs(h[k - 1].energy)) << "iteration " << k + 1;
}

}  // namespace

// --- parts ----------------------------------------------------------------------------------------

TEST(TnnmgParts, TruncationProjectionAndLineSearch) {
  // two vertices in 2D: A = 2 I, b = (4, 0, 1, 0); bounds w_{0,1} <= 1, w_{1,1} <= 0.5; w_{1,2} prescribed
  RotatedProblem<2> rot;
  {
    BlockSparseMatrix<2> A({0, 1, 2}, {0, 1});
    A.blockAt(0) = 2 * Eigen::Matrix2d::Identity();
    A.blockAt(1) = 2 * Eigen::Matrix2d::Identity();
    rot.matrixPtr = std::make_shared<const BlockSparseMatrix<2>>(std::move(A));
  }
  rot.rhs = Eigen::Vector4d(4, 0, 1, 0);
  rot.upper = {1.0, 0.5};
  rot.prescribed = {0, 0, 0, 1};
  const Eigen::VectorXd w = Eigen::Vector4d(1.0, 0.2, 0.1, 0.0);  // vertex 0 active

  TruncatedLinearization<2> lin;
  lin.truncate(rot, w);
  EXPECT_EQ(lin.mask, (std::vector<char>{1, 0, 0, 1}));
  EXPECT_EQ(lin.active, 1);
  Eigen::VectorXd r;
  lin.truncatedResidual(rot, rot.matrix() * w, r);
  EXPECT_TRUE(r.isApprox(Eigen::Vector4d(0, -0.4, 0.8, 0)));

  Eigen::VectorXd c = Eigen::Vector4d(0, -0.2, 0.8, 0);  // would take w_{1,1} to 0.9 > 0.5
  projectCorrection(rot, w, c);
  EXPECT_DOUBLE_EQ(c[2], 0.4);
  const Eigen::VectorXd Ac = rot.matrix() * c;
  const LineSearchResult s = exactLineSearch(rot, w, c, c.dot(r), c.dot(Ac));
  EXPECT_DOUBLE_EQ(s.alphaMax, 1.0);
  EXPECT_EQ(s.limiting, 1);
  // unconstrained minimiser c'r / c'Ac = (0.08 + 0.32) / (2 * 0.2) = 1 -> alpha = min(1, 1)
  EXPECT_NEAR(s.alpha, 1.0, 1e-15);
  Eigen::VectorXd next = w;
  takeStep(rot, s, c, next);
  EXPECT_EQ(next[2], 0.5);  // exactly on the bound
  EXPECT_LE(rot.energy(next), rot.energy(w));

  // a correction that increases the energy along its direction gives alpha = 0
  const Eigen::VectorXd bad = -c;
  const LineSearchResult z = exactLineSearch(rot, w, bad, bad.dot(r), bad.dot(rot.matrix() * bad));
  EXPECT_EQ(z.alpha, 0.0);
}

// --- agreement with PDAS for every element type ---------------------------------------------------

class TnnmgElementTypes : public ::testing::TestWithParam<CellType> {};

TEST_P(TnnmgElementTypes, AgreesWithThePrimalDualActiveSetMethod) {
  const CellType type = GetParam();
  auto check = [&]<int d>(std::integral_constant<int, d>) {
    const mesh::Grid grid = uniformGrid(type, 2, d == 2 ? 3 : 2);
    const mesh::Mesh m = grid.leafView().mesh;
    const auto obstacle = standardObstacle<d>();
    const ContactSet cs(m, mesh::kBottom, *obstacle);
    const ContactProblem<d> problem(m, kMaterial, standardLoad<d>(), cs);
    const Outcome<d> r = solve(grid, problem, true, tightOptions<d>(), std::string(mesh::name(type)));
    expectAgreement(problem, r);
    EXPECT_LT(computeContactOutputs(problem, r.u, 1e-6).contactNodes, cs.size());
    if (d == 2) {
      EXPECT_EQ(r.tnnmg.activeSetSize, 3);  // the three nodes on the punch face (h = 1/16)
    }
  };
  if (mesh::dimension(type) == 2) check(std::integral_constant<int, 2>{});
  else check(std::integral_constant<int, 3>{});
}

INSTANTIATE_TEST_SUITE_P(AllTypes, TnnmgElementTypes,
                         ::testing::Values(CellType::Triangle, CellType::Quadrilateral, CellType::Tetrahedron,
                                           CellType::Hexahedron, CellType::Prism, CellType::Pyramid),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

TEST(Tnnmg, HexahedraFlatOnAPlane) {
  const mesh::Grid grid = uniformGrid(CellType::Hexahedron, 2, 2);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0, 0), P(0, 0, -1)));
  const ContactProblem<3> problem(m, kMaterial, pressedFromTop(P(0, 0, -0.01)), cs);
  const Outcome<3> r = solve(grid, problem, true, tightOptions<3>(), "hex plane");
  expectAgreement(problem, r);
  EXPECT_EQ(r.tnnmg.activeSetSize, cs.size());
}

// --- mesh independence ------------------------------------------------------------------------------

// Iterations to a relative energy-norm correction of 1e-10 over uniform levels. Asserted bound: at
// most 20 iterations on every level and no growth by more than 3 from one level to the next.
// Measured (docs/performance.md): quadrilaterals 6 8 9 9, triangles 8 11 13 14, hexahedra 6 7 8,
// tetrahedra 10 13 16.
class TnnmgMeshIndependence : public ::testing::TestWithParam<CellType> {};

TEST_P(TnnmgMeshIndependence, IterationsStayBoundedOverUniformLevels) {
  const CellType type = GetParam();
  const int dim = mesh::dimension(type);
  mesh::Grid grid(mesh::boxMesh(type, 2));
  std::vector<int> iterations;
  for (int level = 1; level <= (dim == 2 ? 4 : 3); ++level) {
    grid.refineUniformly();
    const mesh::Mesh m = grid.leafView().mesh;
    auto run = [&]<int d>(std::integral_constant<int, d>) {
      const auto obstacle = standardObstacle<d>();
      const ContactSet cs(m, mesh::kBottom, *obstacle);
      const ContactProblem<d> problem(m, kMaterial, standardLoad<d>(), cs);
      const Outcome<d> r = solve(grid, problem, false, tightOptions<d>(), std::string(mesh::name(type)));
      EXPECT_TRUE(r.tnnmg.converged);
      EXPECT_LT(r.tnnmg.kkt.max(), 1e-8);
      EXPECT_LE(r.statistics.operatorUpdates, r.tnnmg.iterations);
      iterations.push_back(r.tnnmg.iterations);
    };
    if (dim == 2) run(std::integral_constant<int, 2>{});
    else run(std::integral_constant<int, 3>{});
  }
  for (std::size_t l = 0; l < iterations.size(); ++l) {
    EXPECT_LE(iterations[l], 20) << "level " << l + 1;
    if (l > 0) {
      EXPECT_LE(iterations[l], iterations[l - 1] + 3) << "level " << l + 1;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Types, TnnmgMeshIndependence,
                         ::testing::Values(CellType::Quadrilateral, CellType::Triangle, CellType::Hexahedron,
                                           CellType::Tetrahedron),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

// Local refinement near the contact zone (red refinement with green closures, level views that
// contain coarser leaves). Asserted: at most 20 iterations after every adaptation cycle and
// agreement with PDAS on the final grid.
class TnnmgLocalRefinement : public ::testing::TestWithParam<CellType> {};

TEST_P(TnnmgLocalRefinement, IterationsStayBoundedAndAgreeWithPdas) {
  const CellType type = GetParam();
  const int dim = mesh::dimension(type);
  mesh::Grid grid = uniformGrid(type, 2, 1);
  const int cycles = dim == 2 ? 5 : 3;
  for (int cycle = 0; cycle < cycles; ++cycle) {
    refineNear(grid, dim == 2 ? P(0.5, 0) : P(0.5, 0.5, 0), dim == 2 ? 0.3 : 0.35, 1);
    const mesh::Mesh m = grid.leafView().mesh;
    auto run = [&]<int d>(std::integral_constant<int, d>) {
      const auto obstacle = standardObstacle<d>();
      const ContactSet cs(m, mesh::kBottom, *obstacle);
      const ContactProblem<d> problem(m, kMaterial, standardLoad<d>(), cs);
      const bool last = cycle + 1 == cycles;
      const Outcome<d> r = solve(grid, problem, last, tightOptions<d>(), "local " + std::string(mesh::name(type)));
      EXPECT_TRUE(r.tnnmg.converged);
      EXPECT_LE(r.tnnmg.iterations, 20) << "cycle " << cycle;
      EXPECT_LT(r.tnnmg.kkt.max(), 1e-8);
      if (last) expectAgreement(problem, r);
    };
    if (dim == 2) run(std::integral_constant<int, 2>{});
    else run(std::integral_constant<int, 3>{});
  }
  EXPECT_GE(grid.maxLevel(), cycles);
}

INSTANTIATE_TEST_SUITE_P(Types, TnnmgLocalRefinement,
                         ::testing::Values(CellType::Quadrilateral, CellType::Triangle, CellType::Hexahedron,
                                           CellType::Tetrahedron),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

// --- obstacles, boundary data, starts -------------------------------------------------------------

TEST(Tnnmg, BallObstaclesWithNormalDirections) {
  {  // 2D disk, nu_p = normal of the disk at the closest point
    const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
    const mesh::Mesh m = grid.leafView().mesh;
    const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5, -Point::UnitY(), BallObstacle::Direction::Normal));
    const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
    const Outcome<2> r = solve(grid, problem, true, tightOptions<2>(), "disk normal");
    expectAgreement(problem, r);
  }
  {  // 3D ball, normal directions
    const mesh::Grid grid = uniformGrid(CellType::Hexahedron, 2, 2);
    const mesh::Mesh m = grid.leafView().mesh;
    const ContactSet cs(m, mesh::kBottom,
                        BallObstacle(P(0.5, 0.5, -0.75), 0.75, -Point::UnitZ(), BallObstacle::Direction::Normal));
    const ContactProblem<3> problem(m, kMaterial, pressedFromTop(P(0, 0, -0.04)), cs);
    const Outcome<3> r = solve(grid, problem, true, tightOptions<3>(), "ball normal");
    expectAgreement(problem, r);
  }
}

TEST(Tnnmg, FarObstacleGivesTheLinearSolution) {
  const mesh::Grid grid = uniformGrid(CellType::Triangle, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  BoundaryConditions bc = pressedFromTop(P(0.002, -0.01));
  bc.bodyForce = [](const Point&) { return Eigen::Vector3d(0, -1e3, 0); };
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, -10), P(0.3, -1)));  // oblique: rotations
  const ContactProblem<2> problem(m, kMaterial, bc, cs);
  const Eigen::VectorXd linear = solveLinearElasticity(m, kMaterial, bc).displacement;
  auto o = tightOptions<2>();
  o.tolerance = 1e-12;
  const Outcome<2> r = solve(grid, problem, false, o, "far");
  EXPECT_TRUE(r.tnnmg.converged);
  EXPECT_EQ(r.tnnmg.activeSetSize, 0);
  EXPECT_LT((r.u - linear).norm(), 1e-9 * linear.norm());
  EXPECT_EQ(r.statistics.operatorUpdates, 0);  // the truncation never changes (Dirichlet only)
}

TEST(Tnnmg, RollerAndObliqueConstraintOnTheContactBoundary) {
  // symmetry roller u_x = 0 on the left side, whose bottom vertex is a contact node of an oblique
  // plane: the effective constraint of that node acts on u_y alone
  mesh::Grid refined(mesh::boxMesh(CellType::Quadrilateral, {4, 4, 1}, P(0, 0), P(0.5, 1)));
  refined.refineUniformly();
  refined.refineUniformly();
  const mesh::Mesh m = refined.leafView().mesh;
  BoundaryConditions bc = pressedFromTop(P(0, -0.01));
  bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, [](const Point&) { return P(0.001, 0); }});
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, -0.004), P(1, -1)));
  const ContactProblem<2> problem(m, kMaterial, bc, cs);
  const Outcome<2> r = solve(refined, problem, true, tightOptions<2>(), "roller");
  expectAgreement(problem, r);
  EXPECT_EQ(r.u[cs.vertex(0) * 2], 0.001);  // the prescribed value is kept exactly
}

TEST(Tnnmg, PenetratingStartIsPushedOut) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(P(0, 0.005), P(0, -1)));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, 0)), cs);
  const Outcome<2> r = solve(grid, problem, true, tightOptions<2>(), "penetrating");
  expectAgreement(problem, r);
  EXPECT_EQ(r.tnnmg.activeSetSize, cs.size());
}

TEST(Tnnmg, PostSmoothingAndDirectCorrection) {
  const mesh::Grid grid = uniformGrid(CellType::Triangle, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  PrimalDualActiveSet<2> pdas;
  Eigen::VectorXd ref;
  pdas.solve(problem, ref);

  auto o = tightOptions<2>();
  o.preSmoothing = 1;
  o.postSmoothing = 1;
  Outcome<2> r = solve(grid, problem, false, o, "post-smoothing");
  EXPECT_TRUE(r.tnnmg.converged);
  EXPECT_LT((r.u - ref).norm(), 1e-8 * ref.norm());

  // the exact truncated Newton step as linear correction: few iterations, same solution
  TNNMG<2> direct(grid, tightOptions<2>(), std::make_unique<DirectCorrection<2>>());
  Eigen::VectorXd u;
  const ContactResult rd = direct.solve(problem, u);
  EXPECT_TRUE(rd.converged);
  EXPECT_LE(rd.iterations, 8);
  EXPECT_LT((u - ref).norm(), 1e-8 * ref.norm());
  if (verbose()) std::cout << "  direct correction: " << rd.iterations << " it\n";
}

TEST(Tnnmg, HistoryRecordsTruncationChanges) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  const Outcome<2> r = solve(grid, problem, false);
  Index total = 0;
  int changed = 0;
  for (const IterationRecord& h : r.tnnmg.history) {
    total += h.truncationChanges;
    changed += h.truncationChanges > 0;
  }
  EXPECT_EQ(total, r.statistics.truncationChanges);
  EXPECT_EQ(changed, r.statistics.operatorUpdates);  // coarse operators recomputed exactly then
  EXPECT_GT(total, 0);
  EXPECT_EQ(r.tnnmg.history.back().truncationChanges, 0);  // the active set has settled
}

TEST(Tnnmg, IterationCapReturnsNotConvergedAndFeasible) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  auto o = tightOptions<2>();
  o.maxIterations = 2;
  const Outcome<2> r = solve(grid, problem, false, o);
  EXPECT_FALSE(r.tnnmg.converged);
  EXPECT_EQ(r.tnnmg.iterations, 2);
  EXPECT_LE(problem.maxViolation(r.u), 0.0);
}

TEST(Tnnmg, ProblemOnAnotherMeshIsAnError) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 2);
  const mesh::Mesh other = mesh::boxMesh(CellType::Quadrilateral, 5);
  const ContactSet cs(other, mesh::kBottom, PlaneObstacle(P(0, 0), P(0, -1)));
  const ContactProblem<2> problem(other, kMaterial, pressedFromTop(P(0, -0.01)), cs);
  TNNMG<2> tnnmg(grid);
  Eigen::VectorXd u;
  try {
    tnnmg.solve(problem, u);
    ADD_FAILURE() << "no obs::Error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("leaf view"), std::string::npos) << e.what();
  }
  EXPECT_THROW(TNNMG<3>{grid}, obs::Error);
  typename TNNMG<2>::Options bad;
  bad.preSmoothing = 0;
  EXPECT_THROW((TNNMG<2>{grid, bad}), obs::Error);
}

// --- extremes of the mesh (docs/reliability.md) -----------------------------------------------------
// Every cell type: twenty cycles of local refinement towards the first point of contact (cells
// 2^-22 of the domain there, 22 grid levels), and thin plates whose cells have the aspect ratio
// 1:1000. Asserted: TNNMG converges (no NaN, within its iteration cap) and agrees with PDAS.

class TnnmgExtremes : public ::testing::TestWithParam<CellType> {};

TEST_P(TnnmgExtremes, TwentyLevelsOfRefinementTowardsAPoint) {
  const CellType type = GetParam();
  const int dim = mesh::dimension(type);
  mesh::Grid grid = uniformGrid(type, 2, 1);
  const Point centre = dim == 2 ? P(0.5, 0) : P(0.5, 0.5, 0);
  for (int cycle = 0; cycle < 20; ++cycle) {
    const double h = 0.25 * std::ldexp(1.0, -cycle);  // the finest cells near the point
    refineNear(grid, centre, 1.5 * h, 1);
  }
  EXPECT_GE(grid.maxLevel(), 21);
  const mesh::Mesh m = grid.leafView().mesh;
  auto run = [&]<int d>(std::integral_constant<int, d>) {
    const auto obstacle = standardObstacle<d>();
    const ContactSet cs(m, mesh::kBottom, *obstacle);
    const ContactProblem<d> problem(m, kMaterial, standardLoad<d>(), cs);
    const Outcome<d> r = solve(grid, problem, true, tightOptions<d>(), "20 levels " + std::string(mesh::name(type)));
    ASSERT_TRUE(r.u.allFinite());
    expectAgreement(problem, r);
  };
  if (dim == 2) run(std::integral_constant<int, 2>{});
  else run(std::integral_constant<int, 3>{});
}

TEST_P(TnnmgExtremes, ThinPlateWithCellAspectRatio1To1000) {
  const CellType type = GetParam();
  const int dim = mesh::dimension(type);
  // one layer of cells 0.125 wide and 1.25e-4 thick, refined twice in 2D, once in 3D (the ratio
  // stays 1000)
  const double t = 1.25e-4;
  mesh::Grid grid(dim == 2 ? mesh::boxMesh(type, {8, 1, 1}, P(0, 0), P(1, t))
                           : mesh::boxMesh(type, {8, 8, 1}, P(0, 0, 0), P(1, 1, t)));
  for (int l = 0; l < (dim == 2 ? 2 : 1); ++l) grid.refineUniformly();
  const mesh::Mesh m = grid.leafView().mesh;
  auto run = [&]<int d>(std::integral_constant<int, d>) {
    // a large ball below the plate, the top pressed down by half the thickness
    const std::unique_ptr<Obstacle> obstacle =
        d == 2 ? std::unique_ptr<Obstacle>(std::make_unique<DiskObstacle>(P(0.5, -100), 100.0))
               : std::unique_ptr<Obstacle>(std::make_unique<BallObstacle>(P(0.5, 0.5, -100), 100.0));
    const ContactSet cs(m, mesh::kBottom, *obstacle);
    const ContactProblem<d> problem(m, kMaterial, pressedFromTop(d == 2 ? P(0, -0.5 * t) : P(0, 0, -0.5 * t)), cs);
    typename TNNMG<d>::Options o = tightOptions<d>();
    o.maxIterations = 300;
    const Outcome<d> r = solve(grid, problem, true, o, "aspect 1:1000 " + std::string(mesh::name(type)));
    ASSERT_TRUE(r.u.allFinite());
    expectAgreement(problem, r);
  };
  if (dim == 2) run(std::integral_constant<int, 2>{});
  else run(std::integral_constant<int, 3>{});
}

INSTANTIATE_TEST_SUITE_P(AllTypes, TnnmgExtremes, ::testing::ValuesIn(mesh::kVolumeCellTypes),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

// --- stopping: the correction test alone is not enough (docs/theory.md#tnnmg-stopping) -------------

namespace {

/// A deliberately weak linear correction: c = r (one Richardson step; the exact line search picks the
/// length). With one nonsmooth Gauss-Seidel sweep per iteration TNNMG then contracts like a smoother,
/// slowly on a fine grid, so the relative correction is small long before the iterate is accurate.
template <int d>
class RichardsonCorrection : public LinearCorrection<d> {
public:
  void setOperator(const BlockSparseMatrix<d>&, std::vector<VertexRotation<d>>, const std::vector<char>&) override {}
  Index truncate(const std::vector<char>&) override { return 0; }
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd& c) override { c = r; }  // r is 0 where truncated
  int operatorUpdates() const override { return 0; }
};

}  // namespace

TEST(TnnmgStopping, SmallCorrectionWithLargeKktResidualGoesOn) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  PrimalDualActiveSet<2> pdas;
  Eigen::VectorXd ref;
  ASSERT_TRUE(pdas.solve(problem, ref).converged);
  auto o = tightOptions<2>();
  o.tolerance = 1e-4;
  o.preSmoothing = 1;
  o.maxIterations = 3000;

  // the correction test alone (KKT bound 1, i.e. off) stops with a KKT residual several times the
  // tolerance (a multigrid TNNMG solve stops with one far below it, see the next test)
  auto off = o;
  off.kktTolerance = 1;
  TNNMG<2> early(grid, off, std::make_unique<RichardsonCorrection<2>>());
  Eigen::VectorXd u1;
  const ContactResult r1 = early.solve(problem, u1);
  ASSERT_TRUE(r1.converged);
  EXPECT_LT(r1.correction, o.tolerance);
  EXPECT_GT(r1.kkt.max(), 3 * o.tolerance);
  EXPECT_EQ(r1.kktRejections, 0);

  // with the KKT test (default kktTolerance 1e-8, bound max(1e-8, 1e-4)) the same iteration goes on
  // until the KKT residual is below the bound, and ends closer to the PDAS solution
  TNNMG<2> checked(grid, o, std::make_unique<RichardsonCorrection<2>>());
  Eigen::VectorXd u2;
  const ContactResult r2 = checked.solve(problem, u2);
  ASSERT_TRUE(r2.converged);
  EXPECT_GT(r2.iterations, r1.iterations);
  EXPECT_GT(r2.kktRejections, 0);
  EXPECT_LE(r2.kkt.max(), o.tolerance);
  EXPECT_LT((u2 - ref).norm(), (u1 - ref).norm());

  // capped right after the early stop: not converged, with the KKT residual that says why
  auto capped = o;
  capped.maxIterations = r1.iterations + 1;
  TNNMG<2> short_(grid, capped, std::make_unique<RichardsonCorrection<2>>());
  Eigen::VectorXd u3;
  const ContactResult r3 = short_.solve(problem, u3);
  EXPECT_FALSE(r3.converged);
  EXPECT_EQ(r3.iterations, capped.maxIterations);
  EXPECT_GT(r3.kkt.max(), o.tolerance);
  EXPECT_GT(r3.kktRejections, 0);
  if (verbose())
    std::cout << "  correction test alone: " << r1.iterations << " it, KKT " << r1.kkt.max() << ", |u - u_pdas| "
              << (u1 - ref).norm() << "; with the KKT test: " << r2.iterations << " it, KKT " << r2.kkt.max()
              << ", |u - u_pdas| " << (u2 - ref).norm() << ", " << r2.kktRejections << " rejections\n";
}

TEST(TnnmgStopping, KktTestCostsNoIterationsOnAStandardSolve) {
  // multigrid TNNMG at the default tolerance: when the correction passes, the KKT residual is far
  // below its bound, so the first check accepts and the iteration count is that of the correction test
  const mesh::Grid grid = uniformGrid(CellType::Triangle, 2, 4);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const ContactProblem<2> problem(m, kMaterial, pressedFromTop(P(0, -0.03)), cs);
  const Outcome<2> r = solve(grid, problem, false);
  EXPECT_TRUE(r.tnnmg.converged);
  EXPECT_EQ(r.tnnmg.kktRejections, 0);
  EXPECT_LT(r.tnnmg.history.back().correction, 1e-10);
  EXPECT_LE(r.tnnmg.kkt.max(), 1e-8);
}

TEST(TnnmgStopping, LumpedMassBoundsTheErrorOfEveryIterate) {
  // docs/theory.md#tnnmg-error-bound: for S = M + c A (a time step of the Newmark family, M lumped)
  // the declared lower bound M gives ||w - w*||_S <= sqrt(2 sum_i max_t (r_i t - m_i t^2/2)) for
  // every admissible iterate. A strip pushed into a disk (curved constraints, active nodes) with a
  // roller on the left side (prescribed components); mass-dominated, balanced and stiff steps.
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh m = grid.leafView().mesh;
  const ContactSet cs(m, mesh::kBottom, DiskObstacle(P(0.5, -0.5), 0.5));
  const Eigen::VectorXd lumped = assembleLumpedMass(m, kMaterial);
  const BlockSparseMatrix<2> A = assembleStiffness<2>(m, kMaterial);
  const BlockSparseMatrix<2> M = expandLumpedMass<2>(lumped, A);
  const DirichletValues roller =
      collectDirichlet(m, {{mesh::kLeft, {true, false, false}, [](const Point&) { return Point::Zero(); }}});
  const std::vector<double> bound(lumped.data(), lumped.data() + lumped.size());
  Eigen::VectorXd g(2 * m.numVertices());  // the load of a uniform step (0.01, -0.02) of the mass
  for (Index p = 0; p < m.numVertices(); ++p) g[2 * p] = 0.01, g[2 * p + 1] = -0.02;
  // c A / M per vertex about 3e5 c / 1e-3: 0.3, 3, 300
  for (double c : {1e-9, 1e-8, 1e-6}) {
    SCOPED_TRACE("c = " + std::to_string(c));
    BlockSparseMatrix<2> S = A;
    for (Index k = 0; k < S.nonZeroBlocks(); ++k) S.blockAt(k) = M.blockAt(k) + c * A.blockAt(k);
    ContactProblem<2> problem(S, M * g, roller, cs);
    Eigen::VectorXd ref;
    ASSERT_TRUE(PrimalDualActiveSet<2>().solve(problem, ref).converged);
    ASSERT_GT(computeContactOutputs(problem, ref).contactNodes, 2);
    // without a declared bound none is computed; with one, every iterate's bound is above its error
    TNNMG<2> plain(grid, tightOptions<2>());
    Eigen::VectorXd u;
    const ContactResult without = plain.solve(problem, u);
    EXPECT_TRUE(std::isnan(without.errorBound));
    problem.setDiagonalLowerBound(bound);
    double worst = 0;
    int compared = 0;
    for (int k = 1; k <= 4; ++k) {
      auto o = tightOptions<2>();
      o.tolerance = 0;  // never converged: iterate k
      o.maxIterations = k;
      TNNMG<2> capped(grid, o);
      Eigen::VectorXd uk;
      const ContactResult r = capped.solve(problem, uk);
      ASSERT_EQ(r.iterations, k);
      const double error = problem.energyNorm(uk - ref) / problem.energyNorm(uk);
      EXPECT_EQ(r.errorBound, r.history.back().errorBound);
      // TNNMG's fused sum is RotatedProblem::errorBound (its A w is updated, not recomputed)
      const RotatedProblem<2> rot = problem.rotated();
      const Eigen::VectorXd wk = problem.toRotated(uk);
      const double direct = rot.errorBound(wk, rot.matrix() * wk) / problem.energyNorm(uk);
      if (direct > 1e-10) {
        EXPECT_NEAR(r.errorBound, direct, 1e-6 * direct) << "iteration " << k;
      }
      // below 1e-12 the "error" is the round-off of the reference (an iterate at a fixed point of the
      // floating-point sweeps can have a zero residual, hence a zero bound)
      if (error > 1e-12) {
        EXPECT_GE(r.errorBound, error * (1 - 1e-9)) << "iteration " << k;
        worst = std::max(worst, r.errorBound / error);
        ++compared;
      }
      if (verbose())
        std::cout << std::setprecision(3) << "  c " << c << ", iteration " << k << ": error " << error
                  << ", bound " << r.errorBound << ", correction " << r.correction << "\n";
    }
    EXPECT_GE(compared, 1);  // not all iterates exact
    // the bound is sharp when the mass dominates: S <= (1 + 3e5 c / 1e-3 * const) M
    if (c == 1e-9) {
      EXPECT_LT(worst, 2.0);
    }
    // stopping on it: at most the iterations of the correction test, the error below the tolerance
    TNNMG<2> bounded(grid, tightOptions<2>());
    Eigen::VectorXd ub;
    const ContactResult withBound = bounded.solve(problem, ub);
    ASSERT_TRUE(withBound.converged);
    EXPECT_LE(withBound.iterations, without.iterations);
    EXPECT_LT(problem.energyNorm(ub - ref) / problem.energyNorm(ub), tightOptions<2>().tolerance);
    if (c == 1e-9) {
      EXPECT_LT(withBound.iterations, without.iterations);
    }
    if (verbose())
      std::cout << "  c " << c << ": " << without.iterations << " iterations without the bound, "
                << withBound.iterations << " with it (bound " << withBound.errorBound << "), bound / error <= "
                << worst << "\n";
  }
  // bad bounds
  ContactProblem<2> problem(A, M * g, roller, cs);
  EXPECT_THROW(problem.setDiagonalLowerBound(std::vector<double>(3, 1.0)), obs::Error);
  std::vector<double> negative = bound;
  negative[5] = -1e-3;
  EXPECT_THROW(problem.setDiagonalLowerBound(negative), obs::Error);
  negative[5] = std::nan("");
  EXPECT_THROW(problem.setDiagonalLowerBound(negative), obs::Error);
}

TEST(TnnmgStopping, ErrorBoundOfADiagonalOperator) {
  // A~ = diag(m_p I) itself: J is separable, and the bound is the exact energy-norm error in every
  // component whose minimiser lies inside the admissible set; where the bound clamps the minimiser
  // (r > m * room) it exceeds the error, as the constraint makes J(w) - J(w*) > ||w - w*||^2 / 2
  const std::vector<double> m{2.0, 0.5, 1.0};
  auto A = std::make_shared<BlockSparseMatrix<2>>(std::vector<Index>{0, 1, 2, 3}, std::vector<Index>{0, 1, 2});
  for (Index p = 0; p < 3; ++p) A->blockAt(p) = m[static_cast<std::size_t>(p)] * Eigen::Matrix2d::Identity();
  RotatedProblem<2> rot;
  rot.matrixPtr = A;
  rot.rhs = (Eigen::VectorXd(6) << 1.0, -2.0, 0.25, 0.5, -1.0, 4.0).finished();
  rot.upper = {0.25, 1.0, std::numeric_limits<double>::infinity()};  // vertex 0: the minimiser 0.5 is clamped
  rot.prescribed = {0, 0, 0, 0, 0, 1};                                 // vertex 2, second component: Dirichlet
  const Eigen::VectorXd w = (Eigen::VectorXd(6) << 0.1, 0.0, 0.9, 0.0, 0.0, 4.0).finished();
  EXPECT_FALSE(rot.hasErrorBound());
  EXPECT_TRUE(std::isnan(rot.errorBound(w, (*A * w))));
  rot.diagonalLowerBound = m;
  ASSERT_TRUE(rot.hasErrorBound());
  // the exact minimiser over w_{p,1} <= upper: componentwise min(rhs / m, upper), Dirichlet kept
  Eigen::VectorXd exact = w;
  for (Index i = 0; i < 5; ++i) exact[i] = rot.rhs[i] / m[static_cast<std::size_t>(i / 2)];
  exact[0] = std::min(exact[0], rot.upper[0]);
  exact[2] = std::min(exact[2], rot.upper[1]);
  const Eigen::VectorXd Aw = (*A * w);
  const double error = std::sqrt((w - exact).dot((*A * (w - exact))));
  // component 0 clamped: r = 0.8 > m room = 0.3, gain 0.15 (0.8 - 0.15) = 0.0975, against an error
  // of m (0.15)^2 = 0.045 in the squared norm
  const double expected = std::sqrt(error * error - 0.045 + 2 * 0.0975);
  EXPECT_NEAR(rot.errorBound(w, Aw), expected, 1e-14 * expected);
  EXPECT_GT(rot.errorBound(w, Aw), error);
  // away from the clamp (vertex 0 at its minimiser), the bound is the error
  Eigen::VectorXd w2 = w;
  w2[0] = 0.25;
  const double error2 = std::sqrt((w2 - exact).dot((*A * (w2 - exact))));
  EXPECT_NEAR(rot.errorBound(w2, (*A * w2)), error2, 1e-14 * error2);
  // a vertex with a free component needs m > 0; a fully prescribed one does not
  rot.diagonalLowerBound[1] = 0;
  EXPECT_FALSE(rot.hasErrorBound());
  rot.diagonalLowerBound[1] = 0.5;
  rot.diagonalLowerBound[2] = 0;
  EXPECT_FALSE(rot.hasErrorBound());
  rot.prescribed[4] = 1;
  EXPECT_TRUE(rot.hasErrorBound());
}
