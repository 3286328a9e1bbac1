// Local smoothing on adaptive hierarchies (docs/theory.md#local-multigrid): which basis functions are
// new on a level, the V-cycle with local smoothing (identical to whole-level smoothing on uniform
// hierarchies, symmetric and convergent on locally refined ones, far fewer smoothed vertices), and
// TNNMG with it (the same solution, about the same iterations), on one and two threads.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <random>

#include "../GridCheck.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultigridHierarchy.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;
using mesh::Point;

namespace {

const Material kMaterial{3e5, 0.25};

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

/// Refines `steps` times the leaves within `radius` of `centre` (radius times 0.6 each step): a
/// hierarchy whose levels are mostly copies of the coarser ones.
mesh::Grid graded(CellType type, int cells, int steps, Point centre, double radius) {
  mesh::Grid grid(mesh::boxMesh(type, cells));
  obs::test::refineNear(grid, centre, radius, steps, 0.6);
  return grid;
}

template <int d>
struct System {
  BlockSparseMatrix<d> A;
  Eigen::VectorXd b;
  DirichletValues g;
};

template <int d>
System<d> clampedSystem(const mesh::Mesh& m) {
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, [](const Point&) { return Point::Zero(); }});
  bc.bodyForce = [](const Point& x) { return d == 2 ? Point(x[1], -1e3, 0) : Point(x[2], 0, -1e3); };
  System<d> s;
  s.A = assembleStiffness<d>(m, kMaterial);
  s.b = assembleLoad<d>(m, bc);
  s.g = collectDirichlet(m, bc.dirichlet);
  applyDirichlet(s.A, s.b, s.g);
  return s;
}

Eigen::VectorXd randomVector(Eigen::Index n, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v[i] = u(gen);
  return v;
}

template <int d>
std::unique_ptr<LinearMultigrid<d>> multigrid(const mesh::Grid& grid, const System<d>& s, bool local) {
  LinearMultigridOptions o;
  o.localSmoothing = local;
  auto mg = std::make_unique<LinearMultigrid<d>>(grid, o);
  mg->setOperator(s.A);
  mg->truncate(s.g.constrained);
  return mg;
}

}  // namespace

TEST(LocalMultigrid, NewBasisFunctionsOnAGradedGrid) {
  const mesh::Grid grid = graded(CellType::Triangle, 8, 6, Point(0, 0, 0), 0.3);
  MultigridHierarchy<2> h(grid);
  const int L = h.maxLevel();
  ASSERT_EQ(L, 6);
  Index markedAll = 0, verticesAll = 0;
  EXPECT_TRUE(h.newBasis(0).empty());
  EXPECT_TRUE(h.newBasis(L).empty());
  for (int l = 1; l < L; ++l) {
    const auto& mark = h.newBasis(l);
    ASSERT_EQ(static_cast<Index>(mark.size()), h.numVertices(l));
    const mesh::CsrMatrix& P = h.prolongation(l - 1);
    Index marked = 0;
    std::vector<Index> columnCount(static_cast<std::size_t>(P.cols), 0);
    for (Index c : P.columns) ++columnCount[c];
    for (Index p = 0; p < P.rows; ++p) {
      marked += mark[p] != 0;
      const Index k = P.rowStart[p];
      const bool copy = P.rowStart[p + 1] - k == 1 && P.values[k] == 1.0 && columnCount[P.columns[k]] == 1;
      EXPECT_EQ(mark[p] != 0, !copy) << "level " << l << " vertex " << p;
    }
    // every vertex created on level l is new
    EXPECT_GE(marked, h.numVertices(l) - h.numVertices(l - 1));
    markedAll += marked;
    verticesAll += h.numVertices(l);
  }
  // most of the levels are copies of coarser ones
  EXPECT_LT(markedAll, verticesAll / 2);
}

TEST(LocalMultigrid, UniformHierarchyGivesTheWholeLevelCycleBitForBit) {
  mesh::Grid grid(mesh::boxMesh(CellType::Quadrilateral, 4));
  for (int l = 0; l < 3; ++l) grid.refineUniformly();
  const auto s = clampedSystem<2>(grid.leafView().mesh);
  auto whole = multigrid<2>(grid, s, false);
  auto local = multigrid<2>(grid, s, true);
  EXPECT_EQ(local->smoothedVerticesPerSweep(), whole->smoothedVerticesPerSweep());
  const Eigen::VectorXd r = randomVector(s.b.size(), 1);
  Eigen::VectorXd a, b;
  whole->vcycle(r, a);
  local->vcycle(r, b);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
}

template <int d>
void checkLocalCycle(CellType type, int cells, int steps, Point centre, double radius, double maxRate) {
  const mesh::Grid grid = graded(type, cells, steps, centre, radius);
  const auto s = clampedSystem<d>(grid.leafView().mesh);
  auto whole = multigrid<d>(grid, s, false);
  auto local = multigrid<d>(grid, s, true);
  // far fewer vertices smoothed per sweep on the levels between the coarsest and the finest
  const Index fine = grid.leafView().vertices.size();
  ASSERT_GE(grid.maxLevel(), steps - 1);
  EXPECT_LT(static_cast<double>(local->smoothedVerticesPerSweep() - fine),
            0.6 * static_cast<double>(whole->smoothedVerticesPerSweep() - fine));
  // the local V(3,3)-cycle is a symmetric operator (a wrong local defect breaks it)
  Eigen::VectorXd r1 = randomVector(s.b.size(), 2), r2 = randomVector(s.b.size(), 3), v1, v2;
  for (Index p = 0; p < static_cast<Index>(s.g.constrained.size()); ++p)
    if (s.g.constrained[p]) r1[p] = r2[p] = 0;
  local->vcycle(r1, v1);
  local->vcycle(r2, v2);
  EXPECT_NEAR(v1.dot(r2), v2.dot(r1), 1e-10 * std::abs(v1.dot(r2)));
  EXPECT_GT(v1.dot(r1), 0);
  // converges to the same solution at a rate close to the whole-level cycle's
  Eigen::VectorXd xw, xl;
  const LinearSolverResult rw = whole->solve(s.b, xw);
  const LinearSolverResult rl = local->solve(s.b, xl);
  EXPECT_TRUE(rw.converged);
  EXPECT_TRUE(rl.converged);
  EXPECT_LE(rl.convergenceRate, maxRate);
  EXPECT_LT((xl - xw).norm(), 1e-8 * xw.norm());
  if (verbose())
    std::cout << "  " << mesh::name(type) << ": " << grid.maxLevel() << " levels, " << s.b.size()
              << " dofs, smoothed per sweep " << local->smoothedVerticesPerSweep() << " of "
              << whole->smoothedVerticesPerSweep() << ", cycles " << rl.iterations << " (whole " << rw.iterations
              << "), rates " << rl.convergenceRate << " / " << rw.convergenceRate << "\n";
}

TEST(LocalMultigrid, TrianglesConvergeWithFewerSmoothedVertices) {
  checkLocalCycle<2>(CellType::Triangle, 4, 8, Point(0.5, 1, 0), 0.4, 0.3);
}
TEST(LocalMultigrid, QuadrilateralsConvergeWithFewerSmoothedVertices) {
  checkLocalCycle<2>(CellType::Quadrilateral, 4, 8, Point(0.5, 1, 0), 0.4, 0.3);
}
TEST(LocalMultigrid, TetrahedraConvergeWithFewerSmoothedVertices) {
  checkLocalCycle<3>(CellType::Tetrahedron, 2, 5, Point(0.5, 0.5, 1), 0.4, 0.4);
}
TEST(LocalMultigrid, HexahedraConvergeWithFewerSmoothedVertices) {
  checkLocalCycle<3>(CellType::Hexahedron, 2, 5, Point(0, 0, 1), 0.45, 0.4);
}

namespace {

/// Signorini contact of a graded square pressed onto a flat obstacle: TNNMG with the given smoothing.
ContactResult solveContact(const mesh::Grid& grid, bool local, Eigen::VectorXd& x) {
  const mesh::Mesh m = grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, -0.01, 0); }});
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(Point(0, 0, 0), Point(0, -1, 0)));
  const ContactProblem<2> problem(m, kMaterial, bc, cs);
  TNNMG<2>::Options o;
  o.multigrid.localSmoothing = local;
  o.tolerance = 1e-12;
  o.maxIterations = 200;
  TNNMG<2> solver(grid, o);
  return solver.solve(problem, x);
}

}  // namespace

TEST(LocalMultigrid, TnnmgGivesTheSameContactSolution) {
  const mesh::Grid grid = graded(CellType::Quadrilateral, 8, 6, Point(0.3, 0, 0), 0.3);
  Eigen::VectorXd xw, xl;
  const ContactResult w = solveContact(grid, false, xw);
  const ContactResult l = solveContact(grid, true, xl);
  ASSERT_TRUE(w.converged);
  ASSERT_TRUE(l.converged);
  EXPECT_LT((xl - xw).norm(), 1e-8 * xw.norm());
  EXPECT_LE(l.iterations, w.iterations + 2);
  if (verbose()) std::cout << "  TNNMG iterations: local " << l.iterations << ", whole " << w.iterations << "\n";
}

TEST(LocalMultigrid, TwoThreadsAreReproducible) {
  const mesh::Grid grid = graded(CellType::Quadrilateral, 32, 5, Point(0.5, 1, 0), 0.4);
  const auto s = clampedSystem<2>(grid.leafView().mesh);
  const int before = threads();
  setThreads(2);
  Eigen::VectorXd a, b;
  {
    auto mg = multigrid<2>(grid, s, true);
    mg->vcycle(s.b, a);
  }
  {
    auto mg = multigrid<2>(grid, s, true);
    mg->vcycle(s.b, b);
  }
  setThreads(before);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
}
