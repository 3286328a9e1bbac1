// The vertex-patch Schwarz smoother and the CG-accelerated linear correction for nearly incompressible
// materials (docs/theory.md#vertex-patch-smoother, docs/performance.md#nearly-incompressible): exact on a
// one-patch problem (with truncated components), monotone decrease of the A-norm of the error, the linear
// multigrid and TNNMG iteration counts on the Hertz B-bar problem at nu = 0.4999 (bounds the point
// Gauss-Seidel V-cycle misses), monotone TNNMG energy with the CG correction, and bitwise identical
// results with the options at their defaults.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdlib>
#include <iostream>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/TNNMG.hpp"
#include "obs/obs/VertexPatchSmoother.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

Material bbar(double nu) {
  Material m{3e5, nu};
  m.formulation = VolumetricFormulation::BBar;
  return m;
}

mesh::Grid unitCube(int coarseCells, int levels) {
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, coarseCells));
  for (int l = 0; l < levels; ++l) grid.refineUniformly();
  return grid;
}

/// The Hertz problem of data/scenes/hertz.toml on the grid's leaf view (B-bar, Poisson ratio nu).
ContactProblem<3> hertz(const mesh::Grid& grid, double nu) {
  const mesh::Mesh m = grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Eigen::Vector3d(0, 0, -0.005); }});
  const ContactSet cs(m, mesh::kBottom, BallObstacle(Point(0.5, 0.5, -0.75), 0.75));
  return ContactProblem<3>(m, bbar(nu), bc, cs);
}

Eigen::MatrixXd dense(const BlockSparseMatrix<3>& A) {
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(A.rows() * 3, A.rows() * 3);
  for (Index i = 0; i < A.rows(); ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) M.block<3, 3>(i * 3, A.column(k) * 3) = A.blockAt(k);
  return M;
}

Eigen::VectorXd pseudoRandom(Eigen::Index n, unsigned seed) {
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    seed = seed * 1103515245u + 12345u;
    v[i] = static_cast<double>((seed >> 8) & 0xffff) / 65536.0 - 0.5;
  }
  return v;
}

TNNMG<3>::Options tnnmgOptions(LinearSmoother smoother, int krylovSteps, int maxIterations) {
  TNNMG<3>::Options o;
  o.tolerance = 1e-10;
  o.maxIterations = maxIterations;
  o.multigrid.smoother = smoother;
  o.multigrid.krylovSteps = krylovSteps;
  return o;
}

}  // namespace

TEST(MultigridVertexPatch, ExactOnOnePatchProblem) {
  // one hexahedron: every vertex is coupled to every other, so each patch is the whole problem and
  // one patch step solves A_T x = r exactly (truncated components zero, their right-hand side ignored)
  const mesh::Mesh m = mesh::boxMesh(CellType::Hexahedron, 1);
  const BlockSparseMatrix<3> A = assembleStiffness<3>(m, bbar(0.4999));
  ASSERT_EQ(A.rows(), 8);
  std::vector<std::uint8_t> bits(8, 0);
  bits[0] = 7;  // three vertices clamped: no rigid motion is left
  bits[3] = 7;
  bits[7] = 7;
  bits[2] = 2;  // the y component of vertex 2
  bits[5] = 5;  // x and z of vertex 5
  VertexPatchSmoother<3> smoother;
  smoother.setMatrix(A, &bits);
  const Eigen::VectorXd r = pseudoRandom(24, 7);
  Eigen::VectorXd x;
  smoother.sweepFromZero(r, x);
  // reference: the dense truncated system
  Eigen::MatrixXd M = dense(A);
  Eigen::VectorXd rt = r;
  for (int i = 0; i < 24; ++i)
    if (bits[i / 3] & (1u << (i % 3))) {
      M.row(i).setZero();
      M.col(i).setZero();
      M(i, i) = 1;
      rt[i] = 0;
    }
  const Eigen::VectorXd reference = M.ldlt().solve(rt);
  EXPECT_LT((x - reference).norm(), 1e-9 * reference.norm());
  for (int i = 0; i < 24; ++i)
    if (bits[i / 3] & (1u << (i % 3))) {
      EXPECT_EQ(x[i], 0.0) << i;
    }
  // a backward sweep from the exact solution changes (almost) nothing
  Eigen::VectorXd y = x;
  smoother.sweep(r, y, true);
  EXPECT_LT((y - x).norm(), 1e-9 * x.norm());
}

TEST(MultigridVertexPatch, EnergyOfTheErrorDecreasesMonotonically) {
  // B-bar Hertz stiffness at nu = 0.4999 (8^3 cells), Dirichlet components truncated; the error of
  // every sweep (forward and backward) in the A-norm never increases, and decreases clearly more
  // than with point Gauss-Seidel over the same number of sweeps
  const mesh::Grid grid = unitCube(2, 2);
  const ContactProblem<3> problem = hertz(grid, 0.4999);
  const RotatedProblem<3> rot = problem.rotated();
  const BlockSparseMatrix<3>& A = rot.matrix();
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(A.rows()), 0);
  for (std::size_t i = 0; i < rot.prescribed.size(); ++i)
    if (rot.prescribed[i]) bits[i / 3] |= static_cast<std::uint8_t>(1u << (i % 3));
  Eigen::VectorXd exact = pseudoRandom(A.rows() * 3, 11);
  for (std::size_t i = 0; i < rot.prescribed.size(); ++i)
    if (rot.prescribed[i]) exact[static_cast<Eigen::Index>(i)] = 0;
  const Eigen::VectorXd r = A * exact;  // A_T exact = A exact off the truncated rows (exact is zero there)
  auto errorEnergy = [&](const Eigen::VectorXd& x) { return A.energy(x - exact); };
  VertexPatchSmoother<3> patch;
  patch.setMatrix(A, &bits);
  TruncatedGaussSeidel<3> gs;
  gs.setMatrix(A, &bits);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(A.rows() * 3), y = x;
  double previous = errorEnergy(x);
  const double start = previous;
  for (int s = 0; s < 6; ++s) {
    patch.sweep(r, x, s % 2 == 1);
    gs.sweep(r, y, s % 2 == 1);
    const double e = errorEnergy(x);
    EXPECT_LE(e, previous * (1 + 1e-12)) << "sweep " << s;
    previous = e;
    for (std::size_t i = 0; i < rot.prescribed.size(); ++i)
      if (rot.prescribed[i]) {
        ASSERT_EQ(x[static_cast<Eigen::Index>(i)], 0.0);
      }
  }
  if (verbose())
    std::cout << "  error energy after 6 sweeps: vertex-patch " << previous / start << ", Gauss-Seidel "
              << errorEnergy(y) / start << "\n";
  EXPECT_LT(previous, start);
  EXPECT_LT(previous, errorEnergy(y));
}

TEST(MultigridVertexPatch, UpdateAfterTruncationChangeEqualsFreshSetUp) {
  const mesh::Grid grid = unitCube(2, 1);
  const ContactProblem<3> problem = hertz(grid, 0.49);
  const BlockSparseMatrix<3>& A = problem.rotatedMatrix();
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(A.rows()), 0);
  VertexPatchSmoother<3> updated, fresh;
  updated.setMatrix(A, &bits);
  const std::vector<Index> changed = {3, 40, 41};
  for (Index v : changed) bits[v] = 1;
  updated.updateVertices(changed);
  fresh.setMatrix(A, &bits);
  const Eigen::VectorXd r = pseudoRandom(A.rows() * 3, 5);
  Eigen::VectorXd x, y;
  updated.sweepFromZero(r, x);
  fresh.sweepFromZero(r, y);
  EXPECT_EQ(x, y);
}

TEST(MultigridVertexPatch, LinearMultigridRateAtNu04999) {
  // the linear V-cycle on the Hertz B-bar stiffness (8^3 cells, 2 levels), Dirichlet truncated:
  // point Gauss-Seidel stalls, the vertex-patch smoother converges, more so with CG acceleration
  const mesh::Grid grid = unitCube(4, 1);
  const ContactProblem<3> problem = hertz(grid, 0.4999);
  const RotatedProblem<3> rot = problem.rotated();
  Eigen::VectorXd b = pseudoRandom(rot.matrix().rows() * 3, 3);
  for (std::size_t i = 0; i < rot.prescribed.size(); ++i)
    if (rot.prescribed[i]) b[static_cast<Eigen::Index>(i)] = 0;
  auto run = [&](LinearSmoother s, int krylov) {
    LinearMultigridOptions o;
    o.smoother = s;
    o.krylovSteps = krylov;
    o.maxIterations = 100;
    o.tolerance = 1e-8;
    LinearMultigrid<3> mg(grid, o);
    mg.setOperator(rot.matrix(), problemRotations(problem), rot.prescribed);
    Eigen::VectorXd x;
    const LinearSolverResult r = mg.solve(b, x);
    // the residual of the truncated system
    Eigen::VectorXd res = b - rot.matrix() * x;
    for (std::size_t i = 0; i < rot.prescribed.size(); ++i)
      if (rot.prescribed[i]) res[static_cast<Eigen::Index>(i)] = 0;
    if (verbose())
      std::cout << "  smoother " << static_cast<int>(s) << ", CG " << krylov << ": " << r.iterations << " iterations, "
                << mg.vcycles() << " V-cycles, rate " << r.convergenceRate << ", residual " << res.norm() / b.norm()
                << ", smoother memory " << mg.smootherMemoryBytes() / 1e6 << " MB\n";
    EXPECT_EQ(mg.vcycles(), static_cast<long long>(r.iterations) * std::max(krylov, 1));
    return std::make_pair(r, res.norm() / b.norm());
  };
  const auto [gs, gsResidual] = run(LinearSmoother::GaussSeidel, 0);
  const auto [patch, patchResidual] = run(LinearSmoother::VertexPatch, 0);
  const auto [pcg, pcgResidual] = run(LinearSmoother::VertexPatch, 3);
  EXPECT_FALSE(gs.converged);  // 100 V(3,3) cycles are not enough with point Gauss-Seidel
  EXPECT_TRUE(patch.converged);
  EXPECT_LE(patch.iterations, 40);
  EXPECT_LT(patchResidual, 1e-6);
  EXPECT_TRUE(pcg.converged);
  EXPECT_LE(pcg.iterations, 8);
  EXPECT_LT(pcgResidual, 1e-6);
}

TEST(TnnmgNearlyIncompressible, IterationBoundAtNu04999) {
  // Hertz B-bar at nu = 0.4999 on 8^3 cells (2 levels): the default point Gauss-Seidel V-cycle needs
  // hundreds of TNNMG iterations; the vertex-patch smoother with 3 CG steps stays within 30 (and
  // within 60 without CG), with a monotone energy
  const mesh::Grid grid = unitCube(4, 1);
  const ContactProblem<3> problem = hertz(grid, 0.4999);
  auto run = [&](LinearSmoother s, int krylov, int maxIterations) {
    TNNMG<3> tnnmg(grid, tnnmgOptions(s, krylov, maxIterations));
    Eigen::VectorXd u;
    const ContactResult r = tnnmg.solve(problem, u);
    if (verbose())
      std::cout << "  smoother " << static_cast<int>(s) << ", CG " << krylov << ": " << r.iterations << " iterations, "
                << tnnmg.statistics().vcycles << " V-cycles, converged " << r.converged << ", " << r.seconds << " s\n";
    for (std::size_t k = 1; k < r.history.size(); ++k)
      EXPECT_LE(r.history[k].energy, r.history[k - 1].energy + 1e-13 * std::abs(r.history[k - 1].energy)) << k;
    return std::make_tuple(r, u, tnnmg.statistics().vcycles);
  };
  const auto [gs, uGs, gsCycles] = run(LinearSmoother::GaussSeidel, 0, 60);
  const auto [patch, uPatch, patchCycles] = run(LinearSmoother::VertexPatch, 0, 60);
  const auto [pcg, uPcg, pcgCycles] = run(LinearSmoother::VertexPatch, 3, 60);
  EXPECT_FALSE(gs.converged);  // the old smoother misses the bound (and 60 iterations)
  EXPECT_TRUE(patch.converged);
  EXPECT_LE(patch.iterations, 60);
  EXPECT_TRUE(pcg.converged);
  EXPECT_LE(pcg.iterations, 30);
  EXPECT_EQ(pcgCycles, 3LL * pcg.iterations);
  EXPECT_EQ(patchCycles, static_cast<long long>(patch.iterations));
  EXPECT_LT((uPatch - uPcg).norm(), 1e-7 * uPcg.norm());
  EXPECT_LT(pcg.kkt.max(), 1e-8);
}

TEST(TnnmgNearlyIncompressible, DefaultOptionsGiveIdenticalResults) {
  // the options at their defaults (point Gauss-Seidel, no CG) are the old solver: bitwise identical
  // iterates on a compressible Hertz problem, and the CG option changes the path but not the solution
  const mesh::Grid grid = unitCube(4, 1);
  const ContactProblem<3> problem = hertz(grid, 0.3);
  TNNMG<3>::Options plain;
  plain.tolerance = 1e-10;
  plain.maxIterations = 100;
  TNNMG<3> a(grid, plain), b(grid, tnnmgOptions(LinearSmoother::GaussSeidel, 0, 100)),
      c(grid, tnnmgOptions(LinearSmoother::GaussSeidel, 2, 100));
  Eigen::VectorXd ua, ub, uc;
  const ContactResult ra = a.solve(problem, ua), rb = b.solve(problem, ub), rc = c.solve(problem, uc);
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ(ua, ub);
  ASSERT_EQ(ra.history.size(), rb.history.size());
  for (std::size_t k = 0; k < ra.history.size(); ++k) EXPECT_EQ(ra.history[k].energy, rb.history[k].energy);
  EXPECT_EQ(a.statistics().vcycles, ra.iterations);
  EXPECT_TRUE(rc.converged);
  EXPECT_LT((uc - ua).norm(), 1e-7 * ua.norm());
}

TEST(MultigridVertexPatch, InvalidOptions) {
  const mesh::Grid grid = unitCube(1, 1);
  LinearMultigridOptions o;
  o.krylovSteps = -1;
  EXPECT_THROW(LinearMultigrid<3>(grid, o), Error);
  o.krylovSteps = 2;
  o.cycles = 2;
  EXPECT_THROW(LinearMultigrid<3>(grid, o), Error);
}

TEST(MultigridVertexPatch, LongRowsGetPointBlockPatches) {
  // a dense 60-vertex matrix: every row is longer than kMaxPatch = 54, so every patch is one vertex
  // and a sweep is a point block Gauss-Seidel sweep (the guard against the wide rows of mortar bases)
  const Index n = 60;
  std::vector<Index> rowStart(n + 1), columns;
  for (Index i = 0; i < n; ++i) {
    for (Index j = 0; j < n; ++j) columns.push_back(j);
    rowStart[i + 1] = static_cast<Index>(columns.size());
  }
  BlockSparseMatrix<3> A(rowStart, columns);
  const Eigen::MatrixXd B = Eigen::MatrixXd::NullaryExpr(3 * n, 3 * n, [](Eigen::Index i, Eigen::Index j) {
    return std::sin(1.0 + 3.0 * static_cast<double>(i) + 7.0 * static_cast<double>(j));
  });
  const Eigen::MatrixXd M = B.transpose() * B + 3.0 * n * Eigen::MatrixXd::Identity(3 * n, 3 * n);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) A(i, j) = M.block<3, 3>(3 * i, 3 * j);
  VertexPatchSmoother<3> patch;
  patch.setMatrix(A);
  TruncatedGaussSeidel<3> gs;
  gs.setMatrix(A);
  const Eigen::VectorXd r = pseudoRandom(3 * n, 9);
  Eigen::VectorXd x, y(3 * n);  // TruncatedGaussSeidel::sweepFromZero needs x of the right size
  patch.sweepFromZero(r, x);
  gs.sweepFromZero(r, y);
  patch.sweep(r, x, true);
  gs.sweep(r, y, true);
  EXPECT_LT((x - y).norm(), 1e-12 * y.norm());
  // 60 patches of 3 x 4 / 2 = 6 doubles
  EXPECT_LT(patch.memoryBytes(), 20000u);
}
