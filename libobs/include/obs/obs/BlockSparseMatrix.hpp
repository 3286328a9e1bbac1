#pragma once
/// \file BlockSparseMatrix.hpp
/// Sparse matrix of d x d blocks in compressed-row form: one block row per vertex, columns sorted.
/// The natural storage for vector-valued P1/Q1 problems (d unknowns per vertex), and the format the
/// block Gauss-Seidel smoothers of the contact solvers work on.
///
/// Two storages of the blocks, with the same values: one block per pattern entry (the default), or
/// each distinct block once with an index per entry (shareRepeatedBlocks(); the stiffness matrices of
/// grids made of translated copies of a few cells repeat a few hundred blocks millions of times,
/// docs/performance.md#shared-blocks). Kernels read either through withBlocks(); a non-const
/// accessor returns to one block per entry first.
#include <Eigen/Core>

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/LargeArrayAllocator.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {

using mesh::Index;

template <int d>
class BlockSparseMatrix {
public:
  using Block = Eigen::Matrix<double, d, d>;
  static constexpr int blockSize = d;
  /// The column indices: their pages are first touched by the threads that fill them
  /// (LargeArrayAllocator leaves new entries unset).
  using IndexArray = std::vector<Index, LargeArrayAllocator<Index>>;

  BlockSparseMatrix() = default;

  /// Pattern from compressed rows: rowStart has n + 1 entries, columns of each row sorted and
  /// unique. Blocks are zero.
  BlockSparseMatrix(std::vector<Index> rowStart, const std::vector<Index>& columns);

  /// Pattern coupling every pair of vertices that share a cell (diagonal included).
  static BlockSparseMatrix withMeshPattern(const mesh::Mesh& mesh);

  /// A pattern in compressed rows: rowStart has n + 1 entries, the columns of each row sorted.
  struct Pattern {
    std::vector<Index> rowStart;
    IndexArray columns;
  };
  /// The same from a Pattern (its arrays are moved in). Blocks are zero.
  explicit BlockSparseMatrix(Pattern pattern);
  /// The pattern of withMeshPattern(); `cells` is mesh::vertexCells(mesh).
  static Pattern meshPattern(const mesh::Mesh& mesh, const mesh::VertexCells& cells);

  /// Writes the blocks of the rows [first, last): block k to blocks[k - rowBegin(first)]; the
  /// blocks are zero on entry.
  using RowRangeFill = std::function<void(Index first, Index last, Block* blocks)>;
  /// A matrix of `pattern` whose blocks `fill` writes, range of rows by range of rows (whole rows of
  /// about 2^16 blocks each, on threads() threads, each range once). While at most a quarter of the
  /// blocks written so far are distinct (bit for bit), the blocks are shared() as the ranges come
  /// in, so that one block per entry is never stored; from the first range that breaks this on,
  /// one block per entry. The values are the ones `fill` wrote in either case, and neither the
  /// storage nor the numbering of the shared blocks depends on the thread count
  /// (docs/performance.md#assembly-shared). An exception of `fill` is thrown again here, the one of
  /// the lowest range that threw.
  static BlockSparseMatrix fromRowRanges(Pattern pattern, const RowRangeFill& fill);
  /// Sets every block of this matrix by fromRowRanges()' procedure; the pattern and the sweep order
  /// stay. The old blocks are freed first. If `fill` throws, the blocks are zero and the exception
  /// is thrown again.
  void fillByRowRanges(const RowRangeFill& fill);

  Index rows() const { return static_cast<Index>(rowStart_.size()) - 1; }
  Index nonZeroBlocks() const { return static_cast<Index>(cols_.size()); }

  Index rowBegin(Index i) const { return rowStart_[i]; }
  Index rowEnd(Index i) const { return rowStart_[i + 1]; }
  Index column(Index k) const { return cols_[k]; }
  std::span<const Index> rowStarts() const { return rowStart_; }
  std::span<const Index> columns() const { return cols_; }
  /// Block at position k, writable (a matrix with shared blocks returns to one block per entry).
  Block& blockAt(Index k) {
    if (shared()) unshareBlocks();
    return blocks_[k];
  }
  const Block& blockAt(Index k) const { return shared() ? blocks_[blockIndex_[k]] : blocks_[k]; }

  /// Read access for kernels: calls f(blocks), where blocks[k] is the block at position k, with a
  /// type of its own for each storage (no test per block), and returns f's result.
  template <class F>
  decltype(auto) withBlocks(F&& f) const {
    if (shared()) return f(SharedBlocks{blocks_.data(), blockIndex_.data()});
    return f(PlainBlocks{blocks_.data()});
  }

  /// Stores each distinct block (bit for bit) once, with a 32-bit index per entry, if at most a
  /// quarter of the blocks are distinct; returns whether the blocks are shared. The values, and
  /// every product, sweep and sum over them, stay bit for bit the same; only the bytes read per pass
  /// shrink.
  bool shareRepeatedBlocks();
  /// Whether the blocks are stored once each (shareRepeatedBlocks()).
  bool shared() const { return !blockIndex_.empty(); }
  /// One block per entry again (nothing to do if not shared()). The non-const accessors do this on
  /// the first write, which must not happen inside a parallel region: loops that write blocks on
  /// threads use modifyBlocks() or call this first (a write on threads to a shared matrix aborts
  /// with a message).
  void unshareBlocks();
  /// Number of blocks stored: nonZeroBlocks(), or the distinct ones if shared().
  Index storedBlocks() const { return static_cast<Index>(blocks_.size()); }

  /// Writes blocks of a matrix without returning a shared() matrix to one block per entry: each
  /// value is looked up (bit for bit) among the stored blocks and appended if it is new; on a plain
  /// matrix it is copied. Blocks that no entry uses any more stay stored until the matrix is shared
  /// anew (unshareBlocks(), shareRepeatedBlocks()); storedBlocks() tells when that is worth it. One
  /// writer at a time (it may run inside a parallel region if the calls are serialised), and no
  /// other access to the blocks while it writes.
  class BlockWriter {
  public:
    explicit BlockWriter(BlockSparseMatrix& A);
    void set(Index k, const Block& value);
    /// The number of `value` among the stored blocks of a shared() matrix, appended if it is new.
    std::uint32_t number(const Block& value);

  private:
    BlockSparseMatrix& A_;
    std::vector<std::int64_t> table_;  ///< open addressing over the stored blocks' numbers
  };

  /// Calls f(i, k, B) for every block k of every row i, where B is a modifiable copy of the block
  /// (or the block itself); f returns whether it changed B. A plain matrix is changed in place, rows
  /// on threads() threads; a shared() one stays shared: each chunk of rows collects its changed
  /// entries on the threads with the distinct new values among them, and one thread then looks these
  /// values up among the stored blocks (appending the new ones) in chunk order: the storage of
  /// BlockWriter::set called in the order of k, for any thread count. For changes of some rows and
  /// columns (Dirichlet values, rotations) of a large shared matrix, which would otherwise be stored
  /// one block per entry.
  template <class F>
  void modifyBlocks(F&& f) {
    const Index n = rows();
    if (!shared()) {
      forRanges(n, [&](Index begin, Index end) {
        for (Index i = begin; i < end; ++i)
          for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k) f(i, k, blocks_[k]);
      });
      return;
    }
    std::vector<ChangedBlocks> changed(static_cast<std::size_t>((n + kVectorChunk - 1) / kVectorChunk));
    forRanges(n, [&](Index begin, Index end) {
      ChangedBlocks& list = changed[static_cast<std::size_t>(begin / kVectorChunk)];
      for (Index i = begin; i < end; ++i)
        for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k) {
          Block B = blocks_[blockIndex_[k]];
          if (f(i, k, B)) list.add(k, B);
        }
    });
    writeChanged(changed);
  }

  /// Position of block (i, j) in the storage, or -1 if not in the pattern.
  Index find(Index i, Index j) const {
    const auto b = cols_.begin() + rowStart_[i], e = cols_.begin() + rowStart_[i + 1];
    const auto it = std::lower_bound(b, e, j);
    return (it != e && *it == j) ? static_cast<Index>(it - cols_.begin()) : -1;
  }
  /// Block (i, j); it must be in the pattern.
  Block& operator()(Index i, Index j) {
    const Index k = find(i, j);
    assert(k >= 0);
    return blockAt(k);
  }
  const Block& operator()(Index i, Index j) const {
    const Index k = find(i, j);
    assert(k >= 0);
    return blockAt(k);
  }
  /// Position of the diagonal block of row i.
  Index diagonal(Index i) const { return find(i, i); }

  /// Zeroes every block (on threads() threads for large matrices).
  void setZero();

  /// Removes the off-diagonal blocks of the rows and columns of the vertices with isolated[p] != 0
  /// from the pattern, in place (the storage is compacted; shared blocks stay shared, the sweep
  /// order is recomputed on next use). The caller guarantees that those blocks are zero, as the
  /// rows and columns of fully prescribed vertices are after applyDirichlet(): products and sweeps
  /// then skip them. Returns the number of blocks removed.
  Index isolate(const std::vector<char>& isolated);
  /// The number of blocks isolate(isolated) would remove (a pass over the column indices).
  Index isolatedBlocks(const std::vector<char>& isolated) const;

  /// y = A x for vertex-major vectors (x[v*d + c]); rows on threads() threads (each row's sum in
  /// column order, so the result does not depend on the thread count).
  void multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const;
  /// y1 = A x1 and y2 = A x2 in one pass over the blocks, each bitwise the result of multiply():
  /// a product of a large matrix is bound by streaming its blocks, so two cost little more than one.
  void multiply(const Eigen::VectorXd& x1, Eigen::VectorXd& y1, const Eigen::VectorXd& x2,
                Eigen::VectorXd& y2) const;
  Eigen::VectorXd operator*(const Eigen::VectorXd& x) const {
    Eigen::VectorXd y;
    multiply(x, y);
    return y;
  }

  /// Energy product x' A x.
  double energy(const Eigen::VectorXd& x) const { return x.dot(*this * x); }

  /// The Gauss-Seidel order of this pattern for threads() parts (Parallel.hpp), computed on first
  /// use and shared by copies of the matrix (they have the same pattern).
  const SweepOrder& sweepOrder() const;
  /// Sets the order of sweepOrder() for threads() parts to the order of the partition `part` of
  /// this pattern (one part in [0, threads()) per vertex), instead of METIS' partition of the
  /// pattern itself (LinearMultigrid carries a coarser level's partition to the fine level).
  void setSweepPartition(std::span<const int> part) const;
  /// Whether sweepOrder() for threads() parts is known (computed or set).
  bool hasSweepOrder() const { return order_ && order_->requestedParts() == threads(); }

  std::size_t memoryBytes() const {
    return rowStart_.capacity() * sizeof(Index) + cols_.capacity() * sizeof(Index) +
           blocks_.capacity() * sizeof(Block) + blockIndex_.capacity() * sizeof(std::uint32_t);
  }

  /// The two views of withBlocks().
  struct PlainBlocks {
    const Block* blocks;
    const Block& operator[](Index k) const { return blocks[k]; }
  };
  struct SharedBlocks {
    const Block* blocks;
    const std::uint32_t* index;
    const Block& operator[](Index k) const { return blocks[index[k]]; }
  };

private:
  /// The changed blocks of one chunk of rows in modifyBlocks(): the entries, and for each the number
  /// of its value among the chunk's distinct values (in order of first appearance).
  class ChangedBlocks {
  public:
    void add(Index k, const Block& value);

  private:
    friend class BlockSparseMatrix;
    std::vector<Index> entries_;
    std::vector<std::uint32_t> numbers_;
    std::vector<Block> values_;
    std::vector<std::int64_t> table_;  ///< open addressing over values_
  };
  /// Writes modifyBlocks()' changes to a shared() matrix (the chunks' values looked up in chunk
  /// order, then the entries' numbers on the threads).
  void writeChanged(std::vector<ChangedBlocks>& changed);

  std::vector<Index> rowStart_{0};
  IndexArray cols_;
  /// One block per entry, or (shared()) the distinct blocks; huge pages for large matrices.
  std::vector<Block, LargeArrayAllocator<Block>> blocks_;
  /// Empty, or (shared()) entry k's position in blocks_.
  std::vector<std::uint32_t, LargeArrayAllocator<std::uint32_t>> blockIndex_;
  mutable std::shared_ptr<const SweepOrder> order_;  ///< cache of sweepOrder()
};

extern template class BlockSparseMatrix<2>;
extern template class BlockSparseMatrix<3>;

}  // namespace obs
