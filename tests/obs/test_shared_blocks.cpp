// Shared blocks (BlockSparseMatrix::shareRepeatedBlocks, docs/performance.md#shared-blocks): a matrix
// that stores each distinct block once has bitwise the blocks, products and sweeps of the matrix with
// one block per entry, on one thread and on two; sharing on two threads numbers the blocks as on
// one; writing returns to one block per entry (also in the loops that write on threads); a matrix of
// distinct blocks keeps its storage; signed zeros are kept.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "../ThreadScope.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TruncatedGaussSeidel.hpp"

using namespace obs;
using obs::test::ThreadScope;
using mesh::CellType;

namespace {

template <class T>
bool sameBits(const T& a, const T& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

/// Stiffness matrix of a cube of 16^3 hexahedra (4,913 vertices: above the size from which loops
/// run on threads).
BlockSparseMatrix<3> cubeStiffness() {
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, 2));
  for (int l = 0; l < 3; ++l) grid.refineUniformly();
  return assembleStiffness<3>(grid.leafView().mesh, Material{1e3, 0.3});
}

/// Number of distinct bit patterns among the blocks.
template <int d>
std::size_t distinctBlocks(const BlockSparseMatrix<d>& A) {
  std::set<std::string> seen;
  for (Index k = 0; k < A.nonZeroBlocks(); ++k)
    seen.emplace(reinterpret_cast<const char*>(A.blockAt(k).data()), sizeof(typename BlockSparseMatrix<d>::Block));
  return seen.size();
}

Eigen::VectorXd wave(Index n, double phase = 0) {
  return (Eigen::VectorXd::LinSpaced(n, -1.0, 2.0).array() + phase).sin();
}

/// Products and the four sweeps of A, concatenated.
Eigen::VectorXd kernels(const BlockSparseMatrix<3>& A) {
  const Index n = 3 * A.rows();
  const Eigen::VectorXd x = wave(n), x2 = wave(n, 0.5), r = wave(n, 1.0);
  Eigen::VectorXd y, y1, y2;
  A.multiply(x, y);
  A.multiply(x, y1, x2, y2);
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(A.rows()), 0);
  for (std::size_t p = 0; p < bits.size(); p += 7) bits[p] = p % 2 ? 0b010 : 0b111;
  TruncatedGaussSeidel<3> gs;
  gs.setMatrix(A, &bits);
  Eigen::VectorXd forward = 0.1 * x, backward = 0.1 * x, fromZero(n);
  gs.sweep(r, forward);
  gs.sweep(r, backward, true);
  gs.sweepFromZero(r, fromZero);
  std::vector<double> upper(static_cast<std::size_t>(A.rows()), std::numeric_limits<double>::infinity());
  for (std::size_t p = 0; p < upper.size(); p += 3) upper[p] = -1e-3;
  const BlockGaussSeidelSweep<3> ngs(A, upper);
  Eigen::VectorXd nforward = Eigen::VectorXd::Zero(n), nbackward = Eigen::VectorXd::Zero(n), nfromZero(n);
  ngs.sweep(r, nforward);
  ngs.sweep(r, nbackward, true);
  ngs.sweepFromZero(r, nfromZero);
  Eigen::VectorXd all(11 * n);
  all << y, y1, y2, forward, backward, fromZero, nforward, nbackward, nfromZero, x, r;
  return all;
}

}  // namespace

TEST(SharedBlocks, StiffnessOfABoxStoresEachDistinctBlockOnceWithTheSameValues) {
  const BlockSparseMatrix<3> A = cubeStiffness();
  BlockSparseMatrix<3> S = A;
  ASSERT_TRUE(S.shareRepeatedBlocks());
  EXPECT_TRUE(S.shared());
  EXPECT_FALSE(A.shared());
  EXPECT_EQ(static_cast<std::size_t>(S.storedBlocks()), distinctBlocks(A));
  EXPECT_LE(4 * S.storedBlocks(), A.nonZeroBlocks());
  EXPECT_EQ(S.nonZeroBlocks(), A.nonZeroBlocks());
  EXPECT_LT(4 * S.memoryBytes(), A.memoryBytes());
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) ASSERT_TRUE(sameBits(S.blockAt(k), A.blockAt(k))) << "block " << k;
  EXPECT_TRUE(S.shareRepeatedBlocks());  // a second call keeps the shared storage
}

/// The distinct blocks of a shared matrix and the block number of every entry, as bytes.
std::string sharedStorage(const BlockSparseMatrix<3>& S) {
  return S.withBlocks([&](const auto view) {
    std::string bytes;
    if constexpr (std::is_same_v<decltype(view), const BlockSparseMatrix<3>::SharedBlocks>) {
      bytes.append(reinterpret_cast<const char*>(view.blocks), sizeof(BlockSparseMatrix<3>::Block) * S.storedBlocks());
      bytes.append(reinterpret_cast<const char*>(view.index), sizeof(std::uint32_t) * S.nonZeroBlocks());
    }
    return bytes;
  });
}

TEST(SharedBlocks, SharingOnTwoThreadsNumbersTheBlocksAsOnOne) {
  // the matrix has two chunks of 65,536 blocks, numbered on the threads and then merged
  const BlockSparseMatrix<3> A = cubeStiffness();
  ASSERT_GT(A.nonZeroBlocks(), 65536);
  BlockSparseMatrix<3> one = A, two = A;
  ASSERT_TRUE(one.shareRepeatedBlocks());
  {
    const ThreadScope scope(2);
    ASSERT_TRUE(two.shareRepeatedBlocks());
  }
  const std::string bytes = sharedStorage(one);
  ASSERT_FALSE(bytes.empty());
  EXPECT_EQ(bytes, sharedStorage(two));
  // numbered in order of first appearance: each entry's number is at most one more than the largest
  // number before it (entry 0 has number 0)
  std::vector<std::uint32_t> index(static_cast<std::size_t>(A.nonZeroBlocks()));
  std::memcpy(index.data(), bytes.data() + bytes.size() - sizeof(std::uint32_t) * index.size(),
              sizeof(std::uint32_t) * index.size());
  std::uint32_t next = 0;
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) {
    const std::uint32_t number = index[static_cast<std::size_t>(k)];
    ASSERT_LE(number, next) << "entry " << k;
    if (number == next) ++next;
  }
  EXPECT_EQ(static_cast<Index>(next), one.storedBlocks());
}

TEST(SharedBlocks, ProductsAndSweepsAreBitwiseThoseOfOneBlockPerEntryOnOneAndTwoThreads) {
  const BlockSparseMatrix<3> A = cubeStiffness();
  BlockSparseMatrix<3> S = A;
  ASSERT_TRUE(S.shareRepeatedBlocks());
  EXPECT_TRUE(sameBits(kernels(S), kernels(A)));
  const ThreadScope scope(2);
  ASSERT_FALSE(A.sweepOrder().sequential());
  EXPECT_TRUE(sameBits(kernels(S), kernels(A)));
}

TEST(SharedBlocks, WritingReturnsToOneBlockPerEntryAndChangesOnlyThatEntry) {
  const BlockSparseMatrix<3> A = cubeStiffness();
  BlockSparseMatrix<3> S = A;
  ASSERT_TRUE(S.shareRepeatedBlocks());
  const BlockSparseMatrix<3> copy = S;  // copies share nothing with S
  const Index k = A.diagonal(100);
  S.blockAt(k)(0, 0) += 1.0;
  EXPECT_FALSE(S.shared());
  EXPECT_TRUE(copy.shared());
  for (Index m = 0; m < A.nonZeroBlocks(); ++m) {
    ASSERT_TRUE(sameBits(copy.blockAt(m), A.blockAt(m)));
    if (m != k) {
      ASSERT_TRUE(sameBits(S.blockAt(m), A.blockAt(m))) << "block " << m;
    }
  }
  EXPECT_EQ(S.blockAt(k)(0, 0), A.blockAt(k)(0, 0) + 1.0);

  BlockSparseMatrix<3> Z = copy;
  Z.setZero();
  EXPECT_FALSE(Z.shared());
  for (Index m = 0; m < Z.nonZeroBlocks(); ++m) ASSERT_TRUE(Z.blockAt(m).isZero(0));
}

TEST(SharedBlocks, DistinctBlocksKeepOneBlockPerEntry) {
  BlockSparseMatrix<3> A = cubeStiffness();
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) A.blockAt(k)(2, 1) = static_cast<double>(k);
  const BlockSparseMatrix<3> before = A;
  EXPECT_FALSE(A.shareRepeatedBlocks());
  EXPECT_FALSE(A.shared());
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) ASSERT_TRUE(sameBits(A.blockAt(k), before.blockAt(k)));
  // more than a quarter distinct: still one block per entry
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) A.blockAt(k).setConstant(static_cast<double>(k % 3 == 0 ? k : 0));
  EXPECT_FALSE(A.shareRepeatedBlocks());
  // an empty matrix has nothing to share
  BlockSparseMatrix<3> empty;
  EXPECT_FALSE(empty.shareRepeatedBlocks());
}

TEST(SharedBlocks, BlocksCompareBitwiseSoSignedZerosAreKept) {
  BlockSparseMatrix<3> A = cubeStiffness();
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) A.blockAt(k).setConstant(k % 2 ? -0.0 : 0.0);
  ASSERT_TRUE(A.shareRepeatedBlocks());
  EXPECT_EQ(A.storedBlocks(), 2);
  for (Index k = 0; k < A.nonZeroBlocks(); ++k) ASSERT_EQ(std::signbit(A.blockAt(k)(1, 2)), k % 2 == 1);
}

TEST(SharedBlocks, ContactProblemOnABoxSharesItsRotatedOperator) {
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, 2));
  for (int l = 0; l < 3; ++l) grid.refineUniformly();
  const mesh::Mesh mesh = grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0.002, 0, -0.01); }});
  const ContactSet contact(mesh, mesh::kBottom, PlaneObstacle(Point(0, 0, 0), Point(0, 0, -1)));
  const ContactProblem<3> problem(mesh, Material{1e3, 0.3}, bc, contact);
  EXPECT_TRUE(problem.rotatedMatrix().shared());
  EXPECT_LE(4 * problem.rotatedMatrix().storedBlocks(), problem.rotatedMatrix().nonZeroBlocks());
}

// Loops that write blocks on threads (Dirichlet elimination, the rotation of a contact problem)
// return a shared matrix to one block per entry first, with the results of a matrix that never shared.
TEST(SharedBlocks, WritersOnThreadsAcceptSharedMatrices) {
  const ThreadScope scope(2);
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, 2));
  for (int l = 0; l < 3; ++l) grid.refineUniformly();
  const mesh::Mesh mesh = grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0.002, 0, -0.01); }});
  const Material material{1e3, 0.3};
  const DirichletValues g = collectDirichlet(mesh, bc.dirichlet);
  const Eigen::VectorXd load = assembleLoad<3>(mesh, bc);

  BlockSparseMatrix<3> plain = assembleStiffness<3>(mesh, material), shared = plain;
  ASSERT_TRUE(shared.shareRepeatedBlocks());
  Eigen::VectorXd b1 = load, b2 = load;
  applyDirichlet(plain, b1, g);
  applyDirichlet(shared, b2, g);
  EXPECT_FALSE(shared.shared());
  EXPECT_TRUE(sameBits(b1, b2));
  for (Index k = 0; k < plain.nonZeroBlocks(); ++k) ASSERT_TRUE(sameBits(plain.blockAt(k), shared.blockAt(k)));

  const ContactSet contact(mesh, mesh::kBottom, PlaneObstacle(Point(0, 0, 0), Point(0, 0, -1)));
  BlockSparseMatrix<3> stiffness = assembleStiffness<3>(mesh, material), sharedStiffness = stiffness;
  ASSERT_TRUE(sharedStiffness.shareRepeatedBlocks());
  const ContactProblem<3> fromPlain(std::move(stiffness), load, g, contact);
  const ContactProblem<3> fromShared(std::move(sharedStiffness), load, g, contact);
  const auto& A1 = fromPlain.rotatedMatrix();
  const auto& A2 = fromShared.rotatedMatrix();
  ASSERT_EQ(A1.nonZeroBlocks(), A2.nonZeroBlocks());
  for (Index k = 0; k < A1.nonZeroBlocks(); ++k) ASSERT_TRUE(sameBits(A1.blockAt(k), A2.blockAt(k)));
}

// BlockSparseMatrix::BlockWriter: writes into a shared matrix keep it shared. A value equal (bit
// for bit) to a stored block takes its number; a new one is appended once, however many entries
// get it. The matrix reads, multiplies and sweeps as the plain matrix with the same writes.
TEST(SharedBlocks, WriterKeepsTheBlocksSharedAndEqualToPlainWrites) {
  const BlockSparseMatrix<3> A = cubeStiffness();
  BlockSparseMatrix<3> plain = A, S = A;
  ASSERT_TRUE(S.shareRepeatedBlocks());
  const Index stored = S.storedBlocks();
  using Block = BlockSparseMatrix<3>::Block;
  Block fresh = A.blockAt(0);
  fresh(0, 1) += 0.125;  // a value no entry has
  std::vector<char> diagonal(static_cast<std::size_t>(A.nonZeroBlocks()), 0);  // kept: the sweeps invert them
  for (Index i = 0; i < A.rows(); ++i) diagonal[static_cast<std::size_t>(A.diagonal(i))] = 1;
  {
    BlockSparseMatrix<3>::BlockWriter writer(S), plainWriter(plain);
    for (Index k = 5; k < A.nonZeroBlocks(); k += 97) {
      if (diagonal[static_cast<std::size_t>(k)]) continue;
      const Block value = (k / 97) % 2 ? fresh : Block(A.blockAt(k + 1));  // new, or stored already
      writer.set(k, value);
      plainWriter.set(k, value);
    }
  }
  EXPECT_TRUE(S.shared());
  EXPECT_FALSE(plain.shared());
  EXPECT_EQ(S.storedBlocks(), stored + 1);
  Index differing = 0;
  for (Index k = 0; k < A.nonZeroBlocks(); ++k)
    differing += std::memcmp(S.blockAt(k).data(), plain.blockAt(k).data(), sizeof(Block)) != 0;
  EXPECT_EQ(differing, 0);
  EXPECT_TRUE(sameBits(kernels(S), kernels(plain)));
}
