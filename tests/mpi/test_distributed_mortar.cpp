// The dual-mortar coupling on ranks (tests/CMakeLists.txt: 1, 2 and 3 ranks): two blocks with
// non-matching grids, each distributed over all ranks; every rank's rows of D, M and the weighted
// gaps must be those of one process's MortarCoupling on the uniformly refined grids (matched by
// position), the rows over all ranks must be all of them, and on more than one rank the partition
// must cut the interface (rows on several ranks; docs/architecture.md#distributed-mortar).
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <map>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/MortarCoupling.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;
using obs::mesh::Point;

/// Positions on the 2^-20 lattice: the coordinates here are multiples of 2^-k / 3, whose scaled
/// values have fractional parts 0, 1/3 or 2/3, far from the rounding boundary 1/2 whatever the last
/// bits of the arithmetic that made them.
using Position = std::array<long long, 3>;
Position key(const Point& x) {
  return {std::llround(std::ldexp(x[0], 20)), std::llround(std::ldexp(x[1], 20)), std::llround(std::ldexp(x[2], 20))};
}

obs::mesh::Mesh shifted(obs::mesh::Mesh m, const Point& by) {
  for (Index v = 0; v < m.numVertices(); ++v) m.vertex(v) += by;
  return m;
}

struct Case {
  int dim;
  CellType lower, upper;
  int nLower, nUpper, refinements;
  double liftGap;  ///< the upper block starts this far above the lower one (weighted gaps != 0)
};

void checkAgainstSerial(const Case& c) {
  const obs::Communicator comm = obs::Communicator::world();
  // flat slabs (lower [0,1]^(d-1) x [0.75,1], upper one quarter thick above it), so that every
  // partition cuts the interface
  const int a = c.dim - 1;  // the normal axis
  auto slab = [&](CellType type, int n, double bottom) {
    std::array<int, 3> cells{n, n, n};
    cells[static_cast<std::size_t>(a)] = 1;
    Point lo = Point::Zero(), hi = Point::Ones();
    lo[a] = bottom;
    hi[a] = bottom + 0.25;
    return obs::mesh::boxMesh(type, cells, lo, hi);
  };
  const obs::mesh::Mesh lowerCoarse = slab(c.lower, c.nLower, 0.75);
  const obs::mesh::Mesh upperCoarse = slab(c.upper, c.nUpper, 1 + c.liftGap);

  // one process: the serial coupling on the uniformly refined grids, rows by slave position
  obs::mesh::Grid lowerGrid(lowerCoarse), upperGrid(upperCoarse);
  for (int l = 0; l < c.refinements; ++l) {
    lowerGrid.refineUniformly();
    upperGrid.refineUniformly();
  }
  const obs::mesh::Mesh& ml = lowerGrid.leafView().mesh;
  const obs::mesh::Mesh& mu = upperGrid.leafView().mesh;
  const obs::MortarCoupling serial({&mu, obs::mesh::kBottom, ml.numVertices(), "upper bottom"},
                                   {&ml, obs::mesh::kTop, 0, "lower top"}, ml.numVertices() + mu.numVertices());
  std::map<Position, Index> serialRow;
  for (Index k = 0; k < serial.size(); ++k) serialRow[key(mu.vertex(serial.vertex(k) - ml.numVertices()))] = k;

  // ranks: both blocks distributed over all of them
  const obs::DistributedGrid lower(obs::mesh::Grid(lowerCoarse), c.refinements, comm);
  const obs::DistributedGrid upper(obs::mesh::Grid(upperCoarse), c.refinements, comm);
  const obs::DistributedView lowerLeaf = lower.view(), upperLeaf = upper.view();
  const Index lowerVertices = lowerLeaf.globalVertices();
  const obs::DistributedMortar mortar({&upperLeaf, obs::mesh::kBottom, lowerVertices, "upper bottom"},
                                      {&lowerLeaf, obs::mesh::kTop, 0, "lower top"});

  EXPECT_EQ(mortar.globalSize(), serial.size());
  std::map<Index, Point> masterAt;  // global stacked master index -> position
  for (std::size_t i = 0; i < mortar.masterVertices().size(); ++i)
    masterAt[mortar.masterVertices()[i]] = mortar.masterPositions()[i];
  const double X = 1.25 + c.liftGap;  // the largest coordinate
  for (const auto& row : mortar.rows()) {
    ASSERT_LT(row.local, upperLeaf.halo.numOwned());
    const auto it = serialRow.find(key(row.position));
    ASSERT_NE(it, serialRow.end()) << "rank " << comm.rank() << ": slave node at " << row.position.transpose()
                                   << " is not constrained on one process";
    const Index k = it->second;
    const double D = serial.D(k);
    EXPECT_NEAR(row.D, D, 1e-13 * D);
    EXPECT_NEAR(row.mass, serial.slaveMass(k), 1e-13 * D);
    EXPECT_NEAR(row.gap, serial.weightedGap(k), 64 * 2.2e-16 * X * D);
    EXPECT_LT((row.normal - serial.normal(k)).norm(), 1e-14);
    ASSERT_EQ(row.entries.size(), serial.row(k).size()) << "at " << row.position.transpose();
    std::map<Position, double> expected;
    for (const auto& e : serial.row(k)) expected[key(ml.vertex(e.vertex))] = e.value;
    for (const auto& e : row.entries) {
      ASSERT_TRUE(masterAt.count(e.vertex));
      const auto ex = expected.find(key(masterAt[e.vertex]));
      ASSERT_NE(ex, expected.end()) << "master column at " << masterAt[e.vertex].transpose();
      EXPECT_NEAR(e.value, ex->second, 1e-13 * D);
    }
  }
  // the transformation C = D^{-1} M and its transpose on ranks against one process's, on a smooth
  // field: C x from the master owners' values (the ghost entries are NaN: never read), C'y added
  // to the master owners
  const int d = c.dim;
  const Eigen::MatrixXd C = [&] {
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(serial.size(), ml.numVertices());
    for (Index k = 0; k < serial.size(); ++k)
      for (const auto& e : serial.row(k)) m(k, e.vertex) = e.value / serial.D(k);
    return m;
  }();
  auto fieldAt = [&](const Point& x, int a) { return std::sin(2.1 * x[0] - 1.3 * x[1] + 0.7 * x[2] + a); };
  Eigen::MatrixXd xSerial(ml.numVertices(), d), ySerial(serial.size(), d);
  for (Index v = 0; v < ml.numVertices(); ++v)
    for (int a = 0; a < d; ++a) xSerial(v, a) = fieldAt(ml.vertex(v), a);
  for (Index k = 0; k < serial.size(); ++k)
    for (int a = 0; a < d; ++a) ySerial(k, a) = fieldAt(mu.vertex(serial.vertex(k) - ml.numVertices()), a + 3);
  const Eigen::MatrixXd CxSerial = C * xSerial, CtySerial = C.transpose() * ySerial;

  const obs::mesh::Mesh& lowerLocal = lowerLeaf.local;
  Eigen::VectorXd x = Eigen::VectorXd::Constant(lowerLocal.numVertices() * d, std::nan(""));
  for (Index v = 0; v < lowerLeaf.halo.numOwned(); ++v)
    for (int a = 0; a < d; ++a) x[v * d + a] = fieldAt(lowerLocal.vertex(v), a);
  const Eigen::VectorXd Cx = mortar.applyTransformation(x, d);
  Eigen::VectorXd y(static_cast<Eigen::Index>(mortar.rows().size()) * d);
  for (std::size_t k = 0; k < mortar.rows().size(); ++k) {
    const Index ks = serialRow.at(key(mortar.rows()[k].position));
    for (int a = 0; a < d; ++a) {
      EXPECT_NEAR(Cx[static_cast<Eigen::Index>(k) * d + a], CxSerial(ks, a), 1e-13);
      y[static_cast<Eigen::Index>(k) * d + a] = fieldAt(mortar.rows()[k].position, a + 3);
    }
  }
  Eigen::VectorXd Cty = Eigen::VectorXd::Zero(lowerLocal.numVertices() * d);
  mortar.addTransposedTransformation(y, Cty, d);
  std::map<Position, Index> lowerVertex;
  for (Index v = 0; v < ml.numVertices(); ++v) lowerVertex[key(ml.vertex(v))] = v;
  for (Index v = 0; v < lowerLeaf.halo.numOwned(); ++v)
    for (int a = 0; a < d; ++a)
      EXPECT_NEAR(Cty[v * d + a], CtySerial(lowerVertex.at(key(lowerLocal.vertex(v))), a), 1e-13);

  // the rows are those of owned slave vertices, so no row is on two ranks: their count adds up above
  const long long ranksWithRows = comm.sum(static_cast<long long>(mortar.rows().empty() ? 0 : 1));
  if (comm.size() > 1) {
    EXPECT_GE(ranksWithRows, 2) << "the partition does not cut the interface";
  }
}

TEST(DistributedMortar, RowsOfOneProcessTrianglesOnQuadrilaterals2D) {
  checkAgainstSerial({2, CellType::Triangle, CellType::Quadrilateral, 2, 3, 3, 0.0});
}

TEST(DistributedMortar, RowsOfOneProcessWithAGap2D) {
  checkAgainstSerial({2, CellType::Quadrilateral, CellType::Triangle, 3, 2, 3, 0.01});
}

TEST(DistributedMortar, RowsOfOneProcessHexahedraOnTetrahedra3D) {
  checkAgainstSerial({3, CellType::Tetrahedron, CellType::Hexahedron, 2, 3, 1, 0.0});
}

TEST(DistributedMortar, RowsOfOneProcessPrismsOnHexahedraWithAGap3D) {
  checkAgainstSerial({3, CellType::Hexahedron, CellType::Prism, 3, 2, 1, 0.02});
}

TEST(DistributedMortar, SurfacesThatDoNotOverlapAreOneErrorOnEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const obs::DistributedGrid lower(obs::mesh::Grid(obs::mesh::boxMesh(CellType::Quadrilateral, 2)), 2, comm);
  const obs::DistributedGrid far(
      obs::mesh::Grid(shifted(obs::mesh::boxMesh(CellType::Quadrilateral, 2), Point(5, 1, 0))), 2, comm);
  const obs::DistributedView a = lower.view(), b = far.view();
  try {
    obs::DistributedMortar({&b, obs::mesh::kBottom, a.globalVertices(), "far"}, {&a, obs::mesh::kTop, 0, "lower"});
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("covers no slave node"), std::string::npos) << e.what();
  }
  try {
    obs::DistributedMortar({&b, 42, a.globalVertices(), "far"}, {&a, obs::mesh::kTop, 0, "lower"});
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no boundary face has this id"), std::string::npos) << e.what();
  }
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
