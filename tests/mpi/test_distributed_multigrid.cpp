// The distributed multigrid hierarchy under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks): built
// from a DistributedGrid, with the fine operator assembled on each rank's local mesh, a truncation
// mask and rotations given by position, its coarse operators, dead components, restrictions and
// prolongations must be those of the serial hierarchy of the uniformly refined grid, row by row on
// the owned vertices of the distributed levels and whole on the replicated levels (vertices
// matched by position; docs/architecture.md#distributed-multigrid).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <iostream>
#include <map>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/DistributedCoarseSolver.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/MultigridHierarchy.hpp"

#include "Positions.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Point;
using obs::test::Position;
using obs::test::quantise;

double field(const Point& x, int component) {
  return std::sin(3.1 * x[0] + 1.7 * x[1] - 0.9 * x[2] + 1.3 * component) + 0.1 * component;
}

/// The truncation and rotations of a contact-like problem, by position: the first component of
/// the vertices with x < 0.3 truncated (whole coarse supports there: dead coarse components), all
/// components of those with x > 0.85, and rotations on the boundary y = 0.
template <int d>
void problemByPosition(const std::vector<Point>& x, std::vector<char>& mask,
                       std::vector<obs::VertexRotation<d>>& rotations) {
  mask.assign(x.size() * d, 0);
  rotations.clear();
  for (std::size_t v = 0; v < x.size(); ++v) {
    if (x[v][0] < 0.3) mask[v * d] = 1;
    if (x[v][0] > 0.85)
      for (int c = 0; c < d; ++c) mask[v * d + c] = 1;
    if (x[v][1] == 0.0) {
      const double a = 0.4 + x[v][0];
      Eigen::Matrix<double, d, d> Q = Eigen::Matrix<double, d, d>::Identity();
      Q(0, 0) = Q(1, 1) = std::cos(a);
      Q(0, 1) = -std::sin(a);
      Q(1, 0) = std::sin(a);
      rotations.push_back({static_cast<Index>(v), Q});
    }
  }
}

template <int d>
void expectSerialHierarchy(CellType type, int cells, int refinements) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)));
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(type, cells));
  const obs::DistributedGrid dg(coarse, refinements, comm);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < refinements; ++l) serial.refineUniformly();
  const int L = serial.maxLevel(), Lp = dg.partition().level;
  ASSERT_GE(Lp, 1);
  const obs::Material material{1.0, 0.3};

  // serial
  obs::MultigridHierarchy<d> hs(serial);
  const obs::mesh::Mesh fineSerial = serial.leafView().mesh;
  const obs::BlockSparseMatrix<d> As = obs::assembleStiffness<d>(fineSerial, material);
  std::vector<char> mask;
  std::vector<obs::VertexRotation<d>> rotations;
  problemByPosition<d>(fineSerial.vertices(), mask, rotations);
  hs.setFineOperator(As, rotations, mask);

  // distributed: the fine operator on the rank's local mesh (complete owned rows)
  obs::MultigridHierarchy<d> hd(dg);
  ASSERT_EQ(hd.distributed(), comm.size() > 1);  // one rank: the serial hierarchy (docs/architecture.md#one-path)
  const obs::DistributedView leaf = dg.view();
  ASSERT_EQ(leaf.local.numVertices(), hd.numVertices(L));
  const obs::BlockSparseMatrix<d> Ad = obs::assembleStiffness<d>(leaf.local, material);
  problemByPosition<d>(leaf.local.vertices(), mask, rotations);
  hd.setFineOperator(Ad, rotations, mask);

  // the positions of every level's vertices, both hierarchies
  std::vector<std::vector<Point>> xs(L + 1), xd(L + 1);
  std::vector<std::map<Position, Index>> serialIndex(L + 1);
  for (int l = 0; l <= L; ++l) {
    const obs::mesh::Mesh ms = l == L ? serial.leafView().mesh : serial.levelView(l).mesh;
    xs[l] = ms.vertices();
    for (Index v = 0; v < ms.numVertices(); ++v) serialIndex[l][quantise(xs[l][v])] = v;
    const obs::mesh::Mesh md = l == L ? dg.grid().leafView().mesh : dg.grid().levelView(l).mesh;
    if (hd.distributed())
      for (Index v : hd.viewVertices(l)) xd[l].push_back(md.vertex(v));
    else
      xd[l] = md.vertices();  // a serial hierarchy numbers the views' vertices as the views do
    ASSERT_EQ(static_cast<Index>(xd[l].size()), hd.numVertices(l));
    EXPECT_EQ(hd.halo(l) != nullptr, hd.distributed() && l >= Lp) << "level " << l;
    if (l < Lp) {
      EXPECT_EQ(hd.ownedVertices(l), hs.numVertices(l));
    }
    EXPECT_EQ(comm.sum(static_cast<long long>(l < Lp ? 0 : hd.ownedVertices(l))),
              l < Lp ? 0LL : static_cast<long long>(hs.numVertices(l)));
  }
  const auto vectorOf = [](const std::vector<Point>& x) {
    Eigen::VectorXd v(static_cast<Eigen::Index>(x.size()) * d);
    for (std::size_t i = 0; i < x.size(); ++i)
      for (int c = 0; c < d; ++c) v[static_cast<Eigen::Index>(i) * d + c] = field(x[i], c);
    return v;
  };
  // compares the owned entries of a distributed-level vector with the serial one
  const auto expectOwned = [&](int l, const Eigen::VectorXd& vd, const Eigen::VectorXd& vs, Index rows,
                               const std::string& what) {
    const double scale = std::max(1e-300, vs.cwiseAbs().maxCoeff());
    for (Index i = 0; i < rows; ++i) {
      const Index s = serialIndex[l].at(quantise(xd[l][i]));
      for (int c = 0; c < d; ++c)
        ASSERT_NEAR(vd[i * d + c], vs[s * d + c], 1e-12 * scale) << what << ", level " << l << ", vertex " << i;
    }
  };

  for (int l = 0; l < L; ++l) {
    // the coarse operator's (owned) rows, through its product with a smooth field
    const Eigen::VectorXd yd = hd.coarseOperator(l) * vectorOf(xd[l]);
    const Eigen::VectorXd ys = hs.coarseOperator(l) * vectorOf(xs[l]);
    expectOwned(l, yd, ys, hd.ownedVertices(l), "coarse operator");
    for (Index i = 0; i < hd.ownedVertices(l); ++i)
      ASSERT_EQ(hd.deadBits(l)[i], hs.deadBits(l)[serialIndex[l].at(quantise(xd[l][i]))]) << "level " << l;
    // and the ghosts' dead bits are their owners'
    for (Index i = hd.ownedVertices(l); i < hd.numVertices(l); ++i)
      ASSERT_EQ(hd.deadBits(l)[i], hs.deadBits(l)[serialIndex[l].at(quantise(xd[l][i]))]) << "ghost, level " << l;

    // restriction from level l + 1 (owned entries of the fine vector only are read)
    Eigen::VectorXd fd = vectorOf(xd[l + 1]);
    fd.tail(static_cast<Eigen::Index>(hd.numVertices(l + 1) - hd.ownedVertices(l + 1)) * d).setConstant(1e300);
    Eigen::VectorXd rd, rs;
    hd.restrict(l, fd, rd);
    hs.restrict(l, vectorOf(xs[l + 1]), rs);
    expectOwned(l, rd, rs, hd.ownedVertices(l), "restriction");
    // prolongation to level l + 1: every held fine vertex, ghosts included
    Eigen::VectorXd pd = Eigen::VectorXd::Zero(hd.numVertices(l + 1) * d), ps = Eigen::VectorXd::Zero(hs.numVertices(l + 1) * d);
    hd.prolongateAdd(l, vectorOf(xd[l]), pd);
    hs.prolongateAdd(l, vectorOf(xs[l]), ps);
    expectOwned(l + 1, pd, ps, hd.numVertices(l + 1), "prolongation");
  }
  // a large truncation change recomputes the distributed levels whole, with the same result
  for (std::size_t i = 0; i < mask.size(); i += d) mask[i] = 0;
  hd.truncate(mask);
  std::vector<char> serialMask;
  problemByPosition<d>(fineSerial.vertices(), serialMask, rotations);
  for (std::size_t i = 0; i < serialMask.size(); i += d) serialMask[i] = 0;
  hs.truncate(serialMask);
  const Eigen::VectorXd yd = hd.coarseOperator(L - 1) * vectorOf(xd[L - 1]);
  const Eigen::VectorXd ys = hs.coarseOperator(L - 1) * vectorOf(xs[L - 1]);
  expectOwned(L - 1, yd, ys, hd.ownedVertices(L - 1), "coarse operator after truncate()");

  // a small change (the first component truncated in a small ball around the centre) updates the
  // distributed top coarse level locally, on every rank holding its rows, and the levels below
  // whole: every level's operator and dead bits are still the serial ones
  const auto nearCentre = [](const Point& x) { return (x - Point(0.5, 0.5, d == 3 ? 0.5 : 0.0)).norm() < 0.08; };
  const auto truncateCentre = [&](const std::vector<Point>& x, std::vector<char>& m) {
    for (std::size_t v = 0; v < x.size(); ++v)
      if (nearCentre(x[v])) m[v * d] = 1;
  };
  truncateCentre(leaf.local.vertices(), mask);
  truncateCentre(fineSerial.vertices(), serialMask);
  const long long recomputedBefore = hd.coarseRowsRecomputed();
  hd.truncate(mask);
  hs.truncate(serialMask);
  if (L - 1 >= Lp) {
    EXPECT_FALSE(hd.fullUpdate(L - 1)) << "the top coarse level was recomputed whole";
    EXPECT_LT(hd.coarseRowsRecomputed() - recomputedBefore, hd.numVertices(L - 1) + (L > 1 ? hd.numVertices(L - 2) : 0) + 1);
  }
  EXPECT_FALSE(hs.fullUpdate(L - 1));
  for (int l = 0; l < L; ++l) {
    const Eigen::VectorXd zd = hd.coarseOperator(l) * vectorOf(xd[l]);
    const Eigen::VectorXd zs = hs.coarseOperator(l) * vectorOf(xs[l]);
    expectOwned(l, zd, zs, hd.ownedVertices(l), "coarse operator after a local update");
    for (Index i = 0; i < hd.numVertices(l); ++i)
      ASSERT_EQ(hd.deadBits(l)[i], hs.deadBits(l)[serialIndex[l].at(quantise(xd[l][i]))])
          << "level " << l << " after a local update";
  }
}

/// Linear elasticity clamped at y = 0 under a smooth load, solved by V-cycles to 1e-10: the
/// distributed solve must converge in the serial iteration count (+-1: the sweep order differs)
/// to the serial solution.
/// partitionLevel 0: the coarse level is distributed too and solved by hypre (DistributedCoarseSolver).
template <int d>
void expectSerialSolve(CellType type, int cells, int refinements, int krylovSteps = 0, int partitionLevel = -1) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)) + (krylovSteps > 0 ? ", conjugate gradients" : "") +
               (partitionLevel == 0 ? ", distributed coarse level" : ""));
  const obs::Communicator comm = obs::Communicator::world();
  const obs::mesh::Grid coarse(obs::mesh::boxMesh(type, cells));
  obs::ForestPartitionOptions partition;
  partition.level = partitionLevel;
  const obs::DistributedGrid dg(coarse, refinements, comm, partition);
  obs::mesh::Grid serial = coarse;
  for (int l = 0; l < refinements; ++l) serial.refineUniformly();
  const obs::Material material{1.0, 0.3};
  const auto problem = [&](const obs::mesh::Mesh& m, std::vector<char>& mask, Eigen::VectorXd& b) {
    mask.assign(static_cast<std::size_t>(m.numVertices()) * d, 0);
    b.resize(static_cast<Eigen::Index>(m.numVertices()) * d);
    for (Index v = 0; v < m.numVertices(); ++v)
      for (int c = 0; c < d; ++c) {
        const bool clamped = m.vertex(v)[1] == 0.0;
        mask[static_cast<std::size_t>(v) * d + c] = clamped ? 1 : 0;
        b[v * d + c] = clamped ? 0.0 : 1e-3 * field(m.vertex(v), c);
      }
  };
  obs::LinearMultigridOptions options;
  options.tolerance = 1e-10;
  options.krylovSteps = krylovSteps;
  const obs::mesh::Mesh fs = serial.leafView().mesh;
  const obs::BlockSparseMatrix<d> As = obs::assembleStiffness<d>(fs, material);
  std::vector<char> mask;
  Eigen::VectorXd bs, xs, bd, xd;
  problem(fs, mask, bs);
  obs::LinearMultigrid<d> ms(serial, options);
  ms.setOperator(As, {}, mask);
  const obs::LinearSolverResult rs = ms.solve(bs, xs);

  const obs::DistributedView leaf = dg.view();
  const obs::BlockSparseMatrix<d> Ad = obs::assembleStiffness<d>(leaf.local, material);
  problem(leaf.local, mask, bd);
  obs::LinearMultigrid<d> md(dg, options);
  md.setOperator(Ad, {}, mask);
  const obs::LinearSolverResult rd = md.solve(bd, xd);
  if (comm.rank() == 0)
    std::cout << obs::mesh::name(type) << " on " << comm.size() << " ranks: " << rd.iterations << " V-cycles (serial "
              << rs.iterations << "), rate " << rd.convergenceRate << " (serial " << rs.convergenceRate << ")"
              << (md.distributedCoarseLevel() ? ", " + std::to_string(md.coarseIterations()) + " coarse CG iterations" : "")
              << "\n";
  EXPECT_EQ(md.distributedCoarseLevel(), partitionLevel == 0 && comm.size() > 1);
  if (md.distributedCoarseLevel()) {
    EXPECT_GT(md.coarseIterations(), 0);
  }
  ASSERT_TRUE(rs.converged);
  ASSERT_TRUE(rd.converged);
  EXPECT_LE(std::abs(rd.iterations - rs.iterations), 1);
  std::map<Position, Index> serialIndex;
  for (Index v = 0; v < fs.numVertices(); ++v) serialIndex[quantise(fs.vertex(v))] = v;
  const double scale = xs.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0);
  for (Index i = 0; i < leaf.local.numVertices(); ++i) {  // ghosts included: they are current
    const Index v = serialIndex.at(quantise(leaf.local.vertex(i)));
    for (int c = 0; c < d; ++c) ASSERT_NEAR(xd[i * d + c], xs[v * d + c], 1e-8 * scale) << "vertex " << i;
  }
}

TEST(DistributedMultigrid, SolvesAsTheSerialMultigridTriangles) { expectSerialSolve<2>(CellType::Triangle, 4, 4); }
TEST(DistributedMultigrid, SolvesAsTheSerialMultigridHexahedra) { expectSerialSolve<3>(CellType::Hexahedron, 2, 3); }
// V-cycle-preconditioned conjugate gradients (krylovSteps): the dot products over the owned entries
TEST(DistributedMultigrid, SolvesAsTheSerialConjugateGradientsTriangles) {
  expectSerialSolve<2>(CellType::Triangle, 4, 4, 3);
}
TEST(DistributedMultigrid, SolvesAsTheSerialConjugateGradientsHexahedra) {
  expectSerialSolve<3>(CellType::Hexahedron, 2, 3, 2);
}

// partition level 0: no replicated level; the coarse problem by hypre's CG + BoomerAMG to 1e-12
TEST(DistributedMultigrid, DistributedCoarseLevelSolvesAsTheSerialMultigridTriangles) {
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  expectSerialSolve<2>(CellType::Triangle, 4, 4, 0, 0);
}
TEST(DistributedMultigrid, DistributedCoarseLevelSolvesAsTheSerialMultigridHexahedra) {
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  expectSerialSolve<3>(CellType::Hexahedron, 3, 2, 0, 0);
}
TEST(DistributedMultigrid, DistributedCoarseLevelConjugateGradientsTetrahedra) {
  if (!obs::DistributedCoarseSolver::available()) GTEST_SKIP() << "obs is built without hypre";
  expectSerialSolve<3>(CellType::Tetrahedron, 2, 2, 2, 0);
}

TEST(DistributedMultigrid, SerialHierarchyTriangles) { expectSerialHierarchy<2>(CellType::Triangle, 4, 3); }
TEST(DistributedMultigrid, SerialHierarchyQuadrilaterals) { expectSerialHierarchy<2>(CellType::Quadrilateral, 4, 3); }
TEST(DistributedMultigrid, SerialHierarchyTetrahedra) { expectSerialHierarchy<3>(CellType::Tetrahedron, 2, 2); }
TEST(DistributedMultigrid, SerialHierarchyHexahedra) { expectSerialHierarchy<3>(CellType::Hexahedron, 2, 3); }

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
