// Shared blocks (BlockSparseMatrix::shareRepeatedBlocks, docs/performance.md#shared-blocks): a matrix
// that stores each distinct block once has bitwise the blocks, products and sweeps of the matrix with
// one block per entry, on one thread and on two; sharing on two threads numbers the blocks as on
// one; writing returns to one block per entry (also in the loops that write on threads); a matrix of
// distinct blocks keeps its storage; signed zeros are kept.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <set>
#include <stdexcept>
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
/// The stiffness of a red-refined box, one block per entry (assembleStiffness shares its blocks).
BlockSparseMatrix<3> cubeStiffness() {
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, 2));
  for (int l = 0; l < 3; ++l) grid.refineUniformly();
  BlockSparseMatrix<3> A = assembleStiffness<3>(grid.leafView().mesh, Material{1e3, 0.3});
  A.unshareBlocks();
  return A;
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

// Loops that write blocks on threads (Dirichlet elimination, the rotation of a contact problem) keep
// a shared matrix shared (BlockSparseMatrix::modifyBlocks), with the results of a matrix that never
// shared.
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
  plain.unshareBlocks();
  ASSERT_TRUE(shared.shareRepeatedBlocks());
  Eigen::VectorXd b1 = load, b2 = load;
  applyDirichlet(plain, b1, g);
  applyDirichlet(shared, b2, g);
  EXPECT_FALSE(plain.shared());
  EXPECT_TRUE(shared.shared());
  EXPECT_TRUE(sameBits(b1, b2));
  for (Index k = 0; k < plain.nonZeroBlocks(); ++k) ASSERT_TRUE(sameBits(plain.blockAt(k), shared.blockAt(k)));

  const ContactSet contact(mesh, mesh::kBottom, PlaneObstacle(Point(0, 0, 0), Point(0, 0, -1)));
  BlockSparseMatrix<3> stiffness = assembleStiffness<3>(mesh, material), sharedStiffness = stiffness;
  stiffness.unshareBlocks();
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

namespace {

/// A band pattern: row i couples to i - 4 .. i + 4 (clipped); n = 20,000 rows, about 180,000
/// blocks, so fromRowRanges fills it in three ranges.
BlockSparseMatrix<3>::Pattern bandPattern(Index n = 20000) {
  BlockSparseMatrix<3>::Pattern p;
  p.rowStart.push_back(0);
  for (Index i = 0; i < n; ++i) {
    for (Index j = std::max<Index>(0, i - 4); j <= std::min<Index>(n - 1, i + 4); ++j) p.columns.push_back(j);
    p.rowStart.push_back(static_cast<Index>(p.columns.size()));
  }
  return p;
}

/// Block (i, j) of the test matrices: a function of j - i only for rows below `repeatBelow` (nine
/// distinct blocks), a distinct block per entry from there on.
BlockSparseMatrix<3>::Block bandBlock(Index i, Index j, Index repeatBelow) {
  BlockSparseMatrix<3>::Block B;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) B(a, b) = 0.1 * (j - i) + a - 0.5 * b;
  if (i >= repeatBelow) B(2, 2) += 1000.0 * i;  // exact: no two rows alike
  return B;
}

struct RowRangeRun {
  BlockSparseMatrix<3> A;
  int nonZeroOnEntry = 0;  // blocks that fill found non-zero
};

RowRangeRun fillBand(Index repeatBelow) {
  RowRangeRun run;
  const auto p = bandPattern();
  const std::vector<Index> rowStart = p.rowStart;
  const BlockSparseMatrix<3>::IndexArray columns = p.columns;
  std::atomic<int> nonZero{0};
  run.A = BlockSparseMatrix<3>::fromRowRanges(p, [&](Index first, Index last, BlockSparseMatrix<3>::Block* out) {
    for (Index i = first; i < last; ++i)
      for (Index k = rowStart[i]; k < rowStart[i + 1]; ++k) {
        BlockSparseMatrix<3>::Block& B = out[k - rowStart[first]];
        if (!B.isZero(0)) ++nonZero;
        B += bandBlock(i, columns[k], repeatBelow);
      }
  });
  run.nonZeroOnEntry = nonZero;
  return run;
}

/// The changes of modifyBlocks' f made through a BlockWriter, entry by entry in the order of k.
template <class F>
void writeEntryByEntry(BlockSparseMatrix<3>& A, const F& change) {
  const BlockSparseMatrix<3>& before = A;
  std::vector<std::pair<Index, BlockSparseMatrix<3>::Block>> changes;
  for (Index i = 0; i < before.rows(); ++i)
    for (Index k = before.rowBegin(i); k < before.rowEnd(i); ++k) {
      BlockSparseMatrix<3>::Block B = before.blockAt(k);
      if (change(i, k, B)) changes.emplace_back(k, B);
    }
  BlockSparseMatrix<3>::BlockWriter writer(A);
  for (const auto& [k, B] : changes) writer.set(k, B);
}

}  // namespace

// BlockSparseMatrix::fromRowRanges: repeated blocks are shared as the ranges come in, numbered as
// shareRepeatedBlocks numbers them; blocks that stop repeating switch the matrix to one block per
// entry, also after ranges already kept shared (which are then expanded); distinct blocks from the
// start give one block per entry. The values are those filled, and the storage is the same on one
// and on two threads.
TEST(SharedBlocks, RowRangesShareRepeatedBlocksAsTheyComeAndSwitchWhenTheyStopRepeating) {
  const Index n = 20000;
  struct Case {
    const char* name;
    Index repeatBelow;
    bool shared;
  };
  for (const Case& c : {Case{"repeated", n, true}, Case{"distinct after the first range", 9000, false},
                        Case{"distinct", 0, false}}) {
    const RowRangeRun one = fillBand(c.repeatBelow);
    const RowRangeRun two = [&] {
      const ThreadScope scope(2);
      return fillBand(c.repeatBelow);
    }();
    for (const RowRangeRun* run : {&one, &two}) {
      const BlockSparseMatrix<3>& A = run->A;
      EXPECT_EQ(run->nonZeroOnEntry, 0) << c.name;
      ASSERT_EQ(A.shared(), c.shared) << c.name;
      ASSERT_EQ(A.rows(), n);
      for (Index i = 0; i < n; ++i)
        for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) {
          const BlockSparseMatrix<3>::Block B = bandBlock(i, A.column(k), c.repeatBelow);
          ASSERT_EQ(std::memcmp(A.blockAt(k).data(), B.data(), sizeof B), 0) << c.name << ", row " << i;
        }
    }
    ASSERT_EQ(one.A.storedBlocks(), two.A.storedBlocks()) << c.name;
    for (Index k = 0; k < one.A.nonZeroBlocks(); ++k)
      ASSERT_EQ(&one.A.blockAt(k) - &one.A.blockAt(0), &two.A.blockAt(k) - &two.A.blockAt(0)) << c.name;
    if (c.shared) {  // numbered in order of first appearance, as by shareRepeatedBlocks
      BlockSparseMatrix<3> shared = one.A;
      shared.unshareBlocks();
      ASSERT_TRUE(shared.shareRepeatedBlocks());
      const BlockSparseMatrix<3>& S = shared;
      EXPECT_EQ(one.A.storedBlocks(), 9);
      for (Index k = 0; k < S.nonZeroBlocks(); ++k)
        ASSERT_EQ(&one.A.blockAt(k) - &one.A.blockAt(0), &S.blockAt(k) - &S.blockAt(0));
    }
  }
}

// An exception of the fill is thrown again by fromRowRanges: the one of the lowest range that threw,
// on any number of threads.
TEST(SharedBlocks, RowRangesThrowTheErrorOfTheLowestRange) {
  for (const int t : {1, 2}) {
    const ThreadScope scope(t);
    try {
      BlockSparseMatrix<3>::fromRowRanges(bandPattern(), [](Index first, Index, BlockSparseMatrix<3>::Block*) {
        if (first > 0) throw std::runtime_error("range from row " + std::to_string(first));
      });
      ADD_FAILURE() << "no exception on " << t << " threads";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "range from row 7282") << t << " threads";
    }
  }
}

// BlockSparseMatrix::modifyBlocks keeps a shared matrix shared, with the blocks and products of the
// same changes made to one block per entry, and the storage of a BlockWriter writing the changes
// entry by entry, on one and on two threads.
TEST(SharedBlocks, ModifiedBlocksStaySharedWithTheValuesOfPlainChanges) {
  const auto change = [](Index i, Index, BlockSparseMatrix<3>::Block& B) {
    if (i % 5 != 0) return false;
    B *= 2.0;
    B(0, 0) += 1.0;
    return true;
  };
  BlockSparseMatrix<3> plain = cubeStiffness(), shared = plain, sharedTwo = plain, written = plain;
  ASSERT_TRUE(shared.shareRepeatedBlocks());
  ASSERT_TRUE(sharedTwo.shareRepeatedBlocks());
  ASSERT_TRUE(written.shareRepeatedBlocks());
  writeEntryByEntry(written, change);  // the same changes through a BlockWriter
  plain.modifyBlocks(change);
  shared.modifyBlocks(change);
  {
    const ThreadScope scope(2);
    sharedTwo.modifyBlocks(change);
  }
  EXPECT_FALSE(plain.shared());
  EXPECT_TRUE(shared.shared());
  EXPECT_TRUE(sharedTwo.shared());
  EXPECT_EQ(shared.storedBlocks(), sharedTwo.storedBlocks());
  EXPECT_EQ(shared.storedBlocks(), written.storedBlocks());
  const BlockSparseMatrix<3>& S = shared;
  const BlockSparseMatrix<3>& S2 = sharedTwo;
  const BlockSparseMatrix<3>& W = written;
  for (Index k = 0; k < plain.nonZeroBlocks(); ++k) {
    ASSERT_EQ(std::memcmp(S.blockAt(k).data(), plain.blockAt(k).data(), sizeof(double) * 9), 0) << "block " << k;
    ASSERT_EQ(&S.blockAt(k) - &S.blockAt(0), &S2.blockAt(k) - &S2.blockAt(0)) << "block " << k;
    ASSERT_EQ(&S.blockAt(k) - &S.blockAt(0), &W.blockAt(k) - &W.blockAt(0)) << "block " << k;
  }
  EXPECT_TRUE(sameBits(kernels(S), kernels(plain)));
}

// modifyBlocks on a matrix of several chunks of rows (a band of 20,000 rows), with new values that
// first appear in different chunks: the storage is that of a BlockWriter writing the changes entry
// by entry, on one and on two threads.
TEST(SharedBlocks, ModifiedBlocksOfSeveralChunksAreNumberedAsWrittenEntryByEntry) {
  const auto change = [](Index i, Index, BlockSparseMatrix<3>::Block& B) {
    if (i % 7 != 0) return false;
    B(1, 1) += 1.0 + static_cast<double>(i / 5000);
    return true;
  };
  for (const int t : {1, 2}) {
    const ThreadScope scope(t);
    BlockSparseMatrix<3> modified = fillBand(20000).A, written = modified;
    ASSERT_TRUE(modified.shared());
    ASSERT_GT(modified.rows(), 2 * kVectorChunk);
    writeEntryByEntry(written, change);
    modified.modifyBlocks(change);
    ASSERT_TRUE(modified.shared());
    ASSERT_EQ(modified.storedBlocks(), written.storedBlocks());
    const BlockSparseMatrix<3>& M = modified;
    const BlockSparseMatrix<3>& W = written;
    for (Index k = 0; k < M.nonZeroBlocks(); ++k) {
      ASSERT_EQ(&M.blockAt(k) - &M.blockAt(0), &W.blockAt(k) - &W.blockAt(0)) << t << " threads, block " << k;
      ASSERT_EQ(std::memcmp(M.blockAt(k).data(), W.blockAt(k).data(), sizeof(double) * 9), 0);
    }
  }
}
