// Threads (obs/obs/Parallel.hpp, docs/performance.md#threads): the parallel Gauss-Seidel order is a
// valid order (a permutation whose concurrently swept groups are uncoupled), a threaded sweep gives
// bitwise what a sequential sweep in that order gives, the loops over rows and cells give bitwise the
// results of one thread, and a threaded TNNMG solve is reproducible and agrees with one thread.
#include <gtest/gtest.h>

#include <dlfcn.h>

#include <cstdlib>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "../ThreadScope.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultigridHierarchy.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TNNMG.hpp"
#include "obs/obs/TruncatedGaussSeidel.hpp"

using namespace obs;
using obs::test::ThreadScope;
using mesh::CellType;

namespace {


bool bitwiseEqual(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

/// Hexahedral cube, 2^3 coarse cells refined three times (16^3 cells, 4,913 vertices: above the
/// threshold below which sweeps stay sequential), pressed onto the plane z = 0.
struct Cube {
  mesh::Grid grid{mesh::boxMesh(CellType::Hexahedron, 2)};
  mesh::Mesh mesh;
  Material material{1e3, 0.3};
  BoundaryConditions bc;
  std::unique_ptr<ContactSet> contact;
  explicit Cube(int levels = 3) {
    for (int l = 0; l < levels; ++l) grid.refineUniformly();
    mesh = grid.leafView().mesh;
    contact = std::make_unique<ContactSet>(mesh, mesh::kBottom, PlaneObstacle(Point(0, 0, 0), Point(0, 0, -1)));
    bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0.002, 0, -0.01); }});
  }
};

Eigen::VectorXd wave(Index n) { return Eigen::VectorXd::LinSpaced(n, -1.0, 2.0).array().sin(); }

}  // namespace

TEST(Threads, ThreadCountIsValidated) {
  EXPECT_THROW(setThreads(0), Error);
  EXPECT_THROW(setThreads(-2), Error);
  EXPECT_EQ(threads(), 1);
}

TEST(Threads, SweepOrderIsAPermutationWithUncoupledParts) {
  Cube c;
  const auto A = assembleStiffness<3>(c.mesh, c.material);
  for (int parts : {2, 3, 4}) {
    const SweepOrder order(A.rowStarts(), A.columns(), parts);
    ASSERT_EQ(order.parts(), parts);
    std::vector<int> group(static_cast<std::size_t>(A.rows()), -1);
    Index counted = 0;
    for (int k = 0; k < parts; ++k) {
      EXPECT_GT(order.interior(k).size(), 0u);
      for (std::size_t i = 0; i < order.interior(k).size(); ++i) {
        const Index p = order.interior(k)[i];
        if (i > 0) {
          EXPECT_LT(order.interior(k)[i - 1], p);  // ascending
        }
        EXPECT_EQ(group[p], -1);
        group[p] = k;
        EXPECT_FALSE(order.isInterface(p));
        ++counted;
      }
    }
    for (Index p : order.interface()) {
      EXPECT_EQ(group[p], -1);
      group[p] = parts;
      EXPECT_TRUE(order.isInterface(p));
      ++counted;
    }
    EXPECT_EQ(counted, A.rows());
    // interior vertices of different parts are never coupled
    for (Index p = 0; p < A.rows(); ++p)
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k) {
        const int gp = group[p], gq = group[A.column(k)];
        if (gp < parts && gq < parts) {
          EXPECT_EQ(gp, gq) << "vertices " << p << " and " << A.column(k);
        }
      }
    // the interface: `parts` groups, each ascending, never coupled to another group, then the rest
    ASSERT_GE(order.interface().size(), static_cast<std::size_t>(kInterfaceSplitMinRows));
    ASSERT_EQ(order.interfaceGroups(), parts);
    std::vector<int> faceGroup(static_cast<std::size_t>(A.rows()), -1);
    std::size_t inFace = order.interfaceRest().size();
    for (int k = 0; k < parts; ++k) {
      const auto g = order.interfaceGroup(k);
      EXPECT_GT(g.size(), 0u) << parts;
      inFace += g.size();
      for (std::size_t i = 0; i < g.size(); ++i) {
        if (i > 0) {
          EXPECT_LT(g[i - 1], g[i]);
        }
        EXPECT_TRUE(order.isInterface(g[i]));
        faceGroup[g[i]] = k;
      }
    }
    for (std::size_t i = 1; i < order.interfaceRest().size(); ++i) EXPECT_LT(order.interfaceRest()[i - 1], order.interfaceRest()[i]);
    EXPECT_EQ(inFace, order.interface().size());
    for (Index p = 0; p < A.rows(); ++p)
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k) {
        const int gp = faceGroup[p], gq = faceGroup[A.column(k)];
        if (gp >= 0 && gq >= 0) {
          EXPECT_EQ(gp, gq) << "interface vertices " << p << " and " << A.column(k);
        }
      }
    // a small fraction of the vertices is swept sequentially
    EXPECT_LT(static_cast<double>(order.interface().size()), 0.5 * static_cast<double>(A.rows())) << parts;
    EXPECT_LT(static_cast<double>(order.interfaceRest().size()), 0.5 * static_cast<double>(order.interface().size()))
        << parts;
  }
  // one part, or a pattern below the threshold: the natural order
  EXPECT_TRUE(SweepOrder(A.rowStarts(), A.columns(), 1).sequential());
  EXPECT_TRUE(SweepOrder(std::vector<Index>{0, 1, 2}, std::vector<Index>{0, 1}, 2).sequential());
}

// On N > 1 threads the multigrid gives the fine matrix the order of the next coarser level's METIS
// partition carried through the prolongation (no METIS on the fine graph): a valid order of the fine
// pattern (uncoupled interiors), parts balanced in fine vertices, an interface about as small as
// METIS' own on the fine graph; a given partition of the wrong size or range is an error.
TEST(Threads, FineSweepOrderCarriedFromTheCoarserLevelIsValidAndBalanced) {
  Cube c(4);  // 32^3 cells, 35,937 fine and 4,913 coarser vertices (both above the threshold)
  const auto A = assembleStiffness<3>(c.mesh, c.material);
  const ThreadScope scope(2);
  ASSERT_FALSE(A.hasSweepOrder());
  LinearMultigrid<3> mg(c.grid);
  mg.setOperator(A, {}, std::vector<char>(static_cast<std::size_t>(A.rows()) * 3, 0));
  ASSERT_TRUE(A.hasSweepOrder());
  const SweepOrder& order = A.sweepOrder();
  ASSERT_EQ(order.parts(), 2);
  std::vector<int> group(static_cast<std::size_t>(A.rows()), -1);
  for (int k = 0; k < 2; ++k)
    for (Index p : order.interior(k)) group[p] = k;
  for (Index p : order.interface()) group[p] = 2;
  for (Index p = 0; p < A.rows(); ++p) {
    ASSERT_GE(group[p], 0) << "vertex " << p << " is not in the order";
    for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
      if (group[p] < 2 && group[A.column(k)] < 2) {
        ASSERT_EQ(group[p], group[A.column(k)]) << "vertices " << p << " and " << A.column(k);
      }
  }
  const double n0 = static_cast<double>(order.interior(0).size()), n1 = static_cast<double>(order.interior(1).size());
  EXPECT_LT(std::abs(n0 - n1), 0.1 * (n0 + n1)) << n0 << " / " << n1;
  const SweepOrder metis(A.rowStarts(), A.columns(), 2);
  EXPECT_LE(static_cast<double>(order.interface().size()), 1.5 * static_cast<double>(metis.interface().size()))
      << order.interface().size() << " against " << metis.interface().size();
  // the same partition gives the same order; a malformed one is an error
  std::vector<int> part(static_cast<std::size_t>(A.rows()));
  for (Index p = 0; p < A.rows(); ++p) part[p] = group[p] == 1 ? 1 : 0;
  EXPECT_THROW(SweepOrder(A.rowStarts(), A.columns(), 2, std::span<const int>(part.data(), part.size() - 1)), Error);
  part[0] = 2;
  EXPECT_THROW(SweepOrder(A.rowStarts(), A.columns(), 2, part), Error);
}

// With more than one level above the threshold, one METIS partition of the lowest such level (the
// base) is carried up to every finer level: each of those levels gets its order at setOperator (no
// METIS on its own graph in the first V-cycle), levels below the base do not, and the parts agree
// across levels: a vertex interior to part k whose parent is interior on the coarser level has its
// parent in part k.
TEST(Threads, SweepOrdersOfAllThreadedLevelsAreCarriedFromOnePartition) {
  mesh::Grid grid(mesh::boxMesh(mesh::CellType::Quadrilateral, 2));
  for (int l = 0; l < 7; ++l) grid.refineUniformly();  // 257^2 vertices; levels 6, 5 above 2048, 4 below
  const mesh::Mesh m = grid.leafView().mesh;
  const auto A = assembleStiffness<2>(m, Material{1e3, 0.3});
  const ThreadScope scope(2);
  LinearMultigrid<2> mg(grid);
  mg.setOperator(A, {}, std::vector<char>(static_cast<std::size_t>(A.rows()) * 2, 0));
  const auto& h = mg.hierarchy();
  const int L = h.maxLevel();
  ASSERT_EQ(L, 7);
  ASSERT_LT(h.numVertices(4), kParallelMinRows);
  ASSERT_GE(h.numVertices(5), kParallelMinRows);
  EXPECT_FALSE(h.coarseOperator(4).hasSweepOrder());
  std::vector<std::vector<int>> group(static_cast<std::size_t>(L) + 1);  // part, or 2 on the interface
  for (int l = 5; l <= L; ++l) {
    const BlockSparseMatrix<2>& C = l == L ? A : h.coarseOperator(l);
    ASSERT_TRUE(C.hasSweepOrder()) << "level " << l;
    const SweepOrder& order = C.sweepOrder();
    ASSERT_EQ(order.parts(), 2) << "level " << l;
    auto& g = group[static_cast<std::size_t>(l)];
    g.assign(static_cast<std::size_t>(C.rows()), 2);
    for (int k = 0; k < 2; ++k)
      for (Index p : order.interior(k)) g[static_cast<std::size_t>(p)] = k;
    const double n0 = static_cast<double>(order.interior(0).size()), n1 = static_cast<double>(order.interior(1).size());
    EXPECT_LT(std::abs(n0 - n1), 0.1 * (n0 + n1)) << "level " << l << ": " << n0 << " / " << n1;
    EXPECT_LT(static_cast<double>(order.interface().size()), 0.05 * static_cast<double>(C.rows())) << "level " << l;
  }
  for (int l = 6; l <= L; ++l) {
    const mesh::CsrMatrix& P = h.prolongation(l - 1);
    Index checked = 0;
    for (Index p = 0; p < P.rows; ++p) {
      Index parent = -1;
      for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k)
        if (parent < 0 || P.values[k] > P.values[parent]) parent = k;
      const int mine = group[static_cast<std::size_t>(l)][static_cast<std::size_t>(p)];
      const int theirs = group[static_cast<std::size_t>(l) - 1][static_cast<std::size_t>(P.columns[parent])];
      if (mine == 2 || theirs == 2) continue;
      ++checked;
      ASSERT_EQ(mine, theirs) << "level " << l << ", vertex " << p;
    }
    EXPECT_GT(checked, P.rows / 2) << "level " << l;
  }
}

// The threaded linear sweep is the sequential sweep in the order interiors (part by part), interface
// groups (group by group), interface rest.
TEST(Threads, ThreadedSweepsAreSequentialSweepsInTheirOrder) {
  Cube c;
  const ThreadScope scope(2);
  const auto A = assembleStiffness<3>(c.mesh, c.material);
  const SweepOrder& order = A.sweepOrder();
  ASSERT_EQ(order.parts(), 2);
  ASSERT_EQ(order.interfaceGroups(), 2);  // interiors, interface groups and the rest all take part
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(A.rows()), 0);
  for (std::size_t p = 0; p < bits.size(); p += 7) bits[p] = p % 2 ? 0b010 : 0b111;
  TruncatedGaussSeidel<3> gs;
  gs.setMatrix(A, &bits);
  const Eigen::VectorXd r = wave(3 * A.rows());

  // reference: the same local solves, one thread, in the documented order
  std::vector<Index> sequence;
  for (int k = 0; k < order.parts(); ++k) sequence.insert(sequence.end(), order.interior(k).begin(), order.interior(k).end());
  sequence.insert(sequence.end(), order.interface().begin(), order.interface().end());
  // with the vertices visited in `sequence`, the update of p reads the current values of all
  // neighbours (no permuted copy of the problem needed)
  const auto sweepIn = [&](const std::vector<Index>& visits, Eigen::VectorXd x) {
    for (Index p : visits) {
      if (bits[p] == 0b111) continue;
      Eigen::Vector3d s = r.segment<3>(3 * p);
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
        if (A.column(k) != p) s -= A.blockAt(k) * x.segment<3>(3 * A.column(k));
      Eigen::Matrix3d D = A.blockAt(A.diagonal(p));
      for (int a = 0; a < 3; ++a)
        if (bits[p] & (1u << a)) {
          D.row(a).setZero();
          D.col(a).setZero();
          D(a, a) = 1;
          s[a] = 0;
        }
      x.segment<3>(3 * p) = D.llt().solve(s);
    }
    return x;
  };
  const Eigen::VectorXd x0 = 0.1 * r;
  const Eigen::VectorXd reference = sweepIn(sequence, x0);
  Eigen::VectorXd x = x0;
  gs.sweep(r, x);
  EXPECT_LT((x - reference).lpNorm<Eigen::Infinity>(), 1e-13 * reference.lpNorm<Eigen::Infinity>());
  // and twice the same threaded sweep: the same bits
  Eigen::VectorXd y = x0;
  gs.sweep(r, y);
  EXPECT_TRUE(bitwiseEqual(x, y));
  // the backward sweep is the same order reversed, and reproducible
  const Eigen::VectorXd backward = sweepIn(std::vector<Index>(sequence.rbegin(), sequence.rend()), x);
  gs.sweep(r, x, true);
  gs.sweep(r, y, true);
  EXPECT_LT((x - backward).lpNorm<Eigen::Infinity>(), 1e-13 * backward.lpNorm<Eigen::Infinity>());
  EXPECT_TRUE(bitwiseEqual(x, y));
}

TEST(Threads, ThreadedHalfSweepsFromZeroAreFullSweepsOnZero) {
  Cube c;
  const ThreadScope scope(2);
  const auto A = assembleStiffness<3>(c.mesh, c.material);
  ASSERT_FALSE(A.sweepOrder().sequential());
  ASSERT_EQ(A.sweepOrder().interfaceGroups(), 2);
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(A.rows()), 0);
  for (std::size_t p = 0; p < bits.size(); p += 5) bits[p] = p % 2 ? 0b001 : 0b111;
  TruncatedGaussSeidel<3> gs;
  gs.setMatrix(A, &bits);
  const Eigen::VectorXd r = wave(3 * A.rows());
  Eigen::VectorXd full = Eigen::VectorXd::Zero(r.size()), half = Eigen::VectorXd::Constant(r.size(), 7.0);
  gs.sweep(r, full);
  gs.sweepFromZero(r, half);
  EXPECT_TRUE(bitwiseEqual(full, half));

  std::vector<double> upper(static_cast<std::size_t>(A.rows()), std::numeric_limits<double>::infinity());
  for (std::size_t p = 0; p < upper.size(); p += 3) upper[p] = -1e-3;
  const BlockGaussSeidelSweep<3> ngs(A, upper);
  Eigen::VectorXd nfull = Eigen::VectorXd::Zero(r.size()), nhalf = Eigen::VectorXd::Constant(r.size(), -3.0);
  ngs.sweep(r, nfull);
  ngs.sweepFromZero(r, nhalf);
  EXPECT_TRUE(bitwiseEqual(nfull, nhalf));
}

// Rows, cells and the Galerkin operators (chunks of coarse rows, each entry one sum in a fixed
// order): bitwise the results of one thread.
TEST(Threads, ProductsAssemblyTransfersAndGalerkinOperatorsDoNotDependOnTheThreadCount) {
  Cube c;
  const auto A1 = assembleStiffness<3>(c.mesh, c.material);
  const Eigen::VectorXd x = wave(3 * A1.rows());
  Eigen::VectorXd y1, y2;
  A1.multiply(x, y1);
  MultigridHierarchy<3> h1(c.grid);
  h1.setFineOperator(A1, {}, std::vector<char>(static_cast<std::size_t>(3 * A1.rows()), 0));
  const int L = h1.maxLevel();
  Eigen::VectorXd coarse1, fine1 = x;
  h1.restrict(L - 1, x, coarse1);
  h1.prolongateAdd(L - 1, coarse1, fine1);
  {
    const ThreadScope scope(2);
    const auto A2 = assembleStiffness<3>(c.mesh, c.material);
    ASSERT_EQ(A1.nonZeroBlocks(), A2.nonZeroBlocks());
    // the same storage (shared blocks in the same numbering) and the same bits
    ASSERT_EQ(A1.shared(), A2.shared());
    ASSERT_EQ(A1.storedBlocks(), A2.storedBlocks());
    for (Index k = 0; k < A1.nonZeroBlocks(); ++k) {
      ASSERT_EQ(&A1.blockAt(k) - &A1.blockAt(0), &A2.blockAt(k) - &A2.blockAt(0)) << "block " << k;
      ASSERT_EQ(std::memcmp(&A1.blockAt(k), &A2.blockAt(k), sizeof(A1.blockAt(k))), 0) << "block " << k;
    }
    A2.multiply(x, y2);
    EXPECT_TRUE(bitwiseEqual(y1, y2));
    Eigen::VectorXd coarse2, fine2 = x;
    h1.restrict(L - 1, x, coarse2);
    h1.prolongateAdd(L - 1, coarse2, fine2);
    EXPECT_TRUE(bitwiseEqual(coarse1, coarse2));
    EXPECT_TRUE(bitwiseEqual(fine1, fine2));
  }
  // the Galerkin operators of every level (the top one has 4,913 vertices: 32^3 fine cells, on
  // the threads), with a truncated fine vertex every seventh: the same bits
  {
    const Cube big(4);
    const auto A = assembleStiffness<3>(big.mesh, big.material);
    std::vector<char> mask(static_cast<std::size_t>(3 * A.rows()), 0);
    for (std::size_t i = 0; i < mask.size(); i += 21) mask[i] = mask[i + 2] = 1;
    MultigridHierarchy<3> h1(big.grid);
    h1.setFineOperator(A, {}, mask);
    const ThreadScope scope(2);
    MultigridHierarchy<3> h2(big.grid);
    h2.setFineOperator(A, {}, mask);
    const int L = h1.maxLevel();
    ASSERT_GE(h1.coarseOperator(L - 1).rows(), kParallelMinRows);
    for (int l = 0; l < L; ++l) {
      const auto& C1 = h1.coarseOperator(l);
      const auto& C2 = h2.coarseOperator(l);
      ASSERT_EQ(C1.nonZeroBlocks(), C2.nonZeroBlocks());
      Index differing = 0;
      for (Index k = 0; k < C1.nonZeroBlocks(); ++k)
        differing += std::memcmp(&C1.blockAt(k), &C2.blockAt(k), sizeof(C1.blockAt(k))) != 0;
      EXPECT_EQ(differing, 0) << "level " << l;
    }
  }
}

// Dirichlet elimination on threads (rows in parallel, blocks without constrained components skipped):
// bitwise the one-thread result, and every block as the plain rule (identity on constrained rows
// and columns) applied to all blocks gives it.
TEST(Threads, DirichletEliminationDoesNotDependOnTheThreadCount) {
  Cube c;
  c.bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, [](const Point&) { return Point(0.001, 0, 0); }});
  const auto A = assembleStiffness<3>(c.mesh, c.material);
  ASSERT_GE(A.rows(), kParallelMinRows);
  const DirichletValues g = collectDirichlet(c.mesh, c.bc.dirichlet);
  auto A1 = A;
  Eigen::VectorXd b1 = wave(3 * A.rows());
  applyDirichlet(A1, b1, g);
  // the plain rule on every block
  auto expected = A;
  for (Index i = 0; i < A.rows(); ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k)
      for (int a = 0; a < 3; ++a)
        for (int col = 0; col < 3; ++col)
          if (g.constrained[static_cast<std::size_t>(i) * 3 + a] || g.constrained[static_cast<std::size_t>(A.column(k)) * 3 + col])
            expected.blockAt(k)(a, col) = (i == A.column(k) && a == col) ? 1.0 : 0.0;
  EXPECT_EQ(std::memcmp(&A1.blockAt(0), &expected.blockAt(0), sizeof(A1.blockAt(0)) * A1.nonZeroBlocks()), 0);
  const ThreadScope scope(2);
  auto A2 = A;
  Eigen::VectorXd b2 = wave(3 * A.rows());
  applyDirichlet(A2, b2, g);
  EXPECT_EQ(std::memcmp(&A1.blockAt(0), &A2.blockAt(0), sizeof(A1.blockAt(0)) * A1.nonZeroBlocks()), 0);
  EXPECT_TRUE(bitwiseEqual(b1, b2));
}

// Two products in one pass over the blocks (TNNMG's A w and A (w - w^k)): each bitwise the single
// product, on one and on two threads.
TEST(Threads, TwoProductsInOnePassAreBitwiseTheSingleProducts) {
  Cube c;
  const BlockSparseMatrix<3> A = assembleStiffness<3>(c.mesh, c.material);
  const Eigen::VectorXd x1 = wave(3 * c.mesh.numVertices()), x2 = x1.reverse() - 0.5 * x1;
  for (int t : {1, 2}) {
    const ThreadScope scope(t);
    Eigen::VectorXd y1, y2, z1, z2;
    A.multiply(x1, y1);
    A.multiply(x2, y2);
    A.multiply(x1, z1, x2, z2);
    EXPECT_TRUE(bitwiseEqual(y1, z1)) << t << " threads";
    EXPECT_TRUE(bitwiseEqual(y2, z2)) << t << " threads";
    EXPECT_GT(y2.norm(), 0);
  }
}

TEST(Threads, StressRecoveryDoesNotDependOnTheThreadCount) {
  Cube c;  // 4,096 cells: above the threshold below which the cell loop stays sequential
  ElasticitySolution s1;
  s1.displacement = 1e-3 * wave(3 * c.mesh.numVertices());
  ElasticitySolution s2 = s1;
  recoverStresses(c.mesh, c.material, s1);
  {
    const ThreadScope scope(2);
    recoverStresses(c.mesh, c.material, s2);
  }
  ASSERT_EQ(s1.cellStress.size(), s2.cellStress.size());
  EXPECT_EQ(std::memcmp(s1.cellStress.data(), s2.cellStress.data(), sizeof(Stress) * s1.cellStress.size()), 0);
  EXPECT_EQ(std::memcmp(s1.vertexStress.data(), s2.vertexStress.data(), sizeof(Stress) * s1.vertexStress.size()), 0);
  EXPECT_GT(s1.vertexStress.front().norm(), 0);
}

// TNNMG on two threads: reproducible bit for bit, and the same solution as on one thread (to the
// solver tolerance: the sweep order differs).
TEST(Threads, TnnmgOnTwoThreadsIsReproducibleAndAgreesWithOneThread) {
  Cube c;
  typename TNNMG<3>::Options o;
  o.tolerance = 1e-11;
  o.maxIterations = 100;
  const auto solve = [&](Eigen::VectorXd& u) {
    const ContactProblem<3> problem(c.mesh, c.material, c.bc, *c.contact);
    TNNMG<3> solver(c.grid, o);
    const ContactResult r = solver.solve(problem, u);
    EXPECT_TRUE(r.converged);
    return std::make_pair(r.iterations, problem.energy(u));
  };
  Eigen::VectorXd u1, u2a, u2b;
  const auto [it1, e1] = solve(u1);
  const ThreadScope scope(2);
  const auto [it2, e2] = solve(u2a);
  solve(u2b);
  EXPECT_TRUE(bitwiseEqual(u2a, u2b));
  EXPECT_LE(std::abs(it2 - it1), 2);
  EXPECT_NEAR(e2, e1, 1e-12 * std::abs(e1));
  EXPECT_LT((u2a - u1).lpNorm<Eigen::Infinity>(), 1e-8 * u1.lpNorm<Eigen::Infinity>());
}

// The problem keeps only the rotated operator; its products with A are those of the assembled matrix.
TEST(Threads, ContactProblemProductsMatchTheUnrotatedMatrix) {
  Cube c;
  const ContactProblem<3> problem(c.mesh, c.material, c.bc, *c.contact);
  auto A = assembleStiffness<3>(c.mesh, c.material);
  Eigen::VectorXd b = assembleLoad<3>(c.mesh, c.bc);
  applyDirichlet(A, b, collectDirichlet(c.mesh, c.bc.dirichlet));
  const Eigen::VectorXd u = 1e-3 * wave(3 * A.rows());
  Eigen::VectorXd Au;
  problem.multiply(u, Au);
  const Eigen::VectorXd ref = A * u;
  EXPECT_LT((Au - ref).lpNorm<Eigen::Infinity>(), 1e-12 * ref.lpNorm<Eigen::Infinity>());
  EXPECT_NEAR(problem.energy(u), 0.5 * u.dot(ref) - problem.rhs().dot(u), 1e-12 * std::abs(u.dot(ref)));
  EXPECT_LT((problem.gradient(u) - (ref - problem.rhs())).lpNorm<Eigen::Infinity>(), 1e-12 * ref.lpNorm<Eigen::Infinity>());
  EXPECT_NEAR(problem.energyNorm(u), std::sqrt(u.dot(ref)), 1e-12 * std::sqrt(u.dot(ref)));
  // the rotated problem shares the matrix: no second copy
  EXPECT_EQ(&problem.rotated().matrix(), &problem.rotatedMatrix());
}

// An error inside a threaded loop (a degenerate cell in the assembly) is the same obs::Error as on
// one thread, not a terminate: the first bad cell is reported.
TEST(Threads, DegenerateCellIsTheSameErrorOnThreads) {
  Cube c;
  mesh::Mesh bad = c.mesh;
  const auto verts = bad.cellVertices(bad.numCells() / 2);
  bad.vertex(verts[0]) = bad.vertex(verts[bad.cellVertices(0).size() - 1]);  // collapse the cell
  std::string one, two;
  try {
    assembleStiffness<3>(bad, c.material);
  } catch (const Error& e) {
    one = e.what();
  }
  {
    const ThreadScope scope(2);
    try {
      assembleStiffness<3>(bad, c.material);
    } catch (const Error& e) {
      two = e.what();
    }
  }
  EXPECT_NE(one.find("degenerate or inverted"), std::string::npos) << one;
  EXPECT_EQ(one, two);
}

TEST(Threads, BlasThreadsFollowTheUserWhenOpenblasNumThreadsIsSet) {
  EXPECT_THROW(setBlasThreads(0), Error);
  // ctest runs every test with OPENBLAS_NUM_THREADS=1 (tests/CMakeLists.txt): the user's choice wins
  const char* env = std::getenv("OPENBLAS_NUM_THREADS");
  if (env && *env) {
    EXPECT_FALSE(setBlasThreads(2));
  }
}

// Once obs manages the BLAS threads (setBlasThreads succeeded), a CHOLMOD factorisation or solve
// below kBlasMinUnknowns runs on one BLAS thread and a larger one on setBlasThreads()' count.
TEST(Threads, SmallCholmodSolvesUseOneBlasThreadAndLargeOnesTheRunsThreads) {
  const auto get = reinterpret_cast<int (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  if (!get) GTEST_SKIP() << "BLAS is not OpenBLAS";
  unsetenv("OPENBLAS_NUM_THREADS");  // ctest sets it; this process runs this test alone
  ASSERT_TRUE(setBlasThreads(2));
  ASSERT_EQ(get(), 2);
  const auto stiffness = [](int levels) {  // Dirichlet rows at the top: positive definite
    const Cube c(levels);
    BlockSparseMatrix<3> A = assembleStiffness<3>(c.mesh, c.material);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(3 * A.rows());
    applyDirichlet(A, b, collectDirichlet(c.mesh, c.bc.dirichlet));
    return A;
  };
  const BlockSparseMatrix<3> small = stiffness(1), large = stiffness(2);  // 375 and 2,187 unknowns
  ASSERT_LT(3 * small.rows(), kBlasMinUnknowns);
  ASSERT_GE(3 * large.rows(), kBlasMinUnknowns);
  const CholmodSolver smallSolver(small);
  EXPECT_EQ(get(), 1);
  const CholmodSolver largeSolver(large);
  EXPECT_EQ(get(), 2);
  smallSolver.solve(Eigen::VectorXd::Ones(3 * small.rows()));
  EXPECT_EQ(get(), 1);
  largeSolver.solve(Eigen::VectorXd::Ones(3 * large.rows()));
  EXPECT_EQ(get(), 2);
}
