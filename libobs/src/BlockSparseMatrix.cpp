#include "obs/obs/BlockSparseMatrix.hpp"

#include <omp.h>

#include <array>
#include <atomic>
#include <bit>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
BlockSparseMatrix<d> BlockSparseMatrix<d>::withMeshPattern(const mesh::Mesh& mesh) {
  return BlockSparseMatrix(meshPattern(mesh, mesh::vertexCells(mesh)));
}

template <int d>
typename BlockSparseMatrix<d>::Pattern BlockSparseMatrix<d>::meshPattern(const mesh::Mesh& mesh,
                                                                         const mesh::VertexCells& cells) {
  const Index n = mesh.numVertices();
  // neighbours of each vertex: union of the vertices of its cells, sorted; two passes over the rows
  // (count, then fill) so that rows can be built on threads() threads. A vertex is taken once per
  // row by marking it with the row (mark[w] == v), so only the distinct neighbours are sorted.
  const int nt = n >= kParallelMinRows ? threads() : 1;
  const auto neighbours = [&](Index v, std::vector<Index>& mark, Index* row) {
    Index count = 0;
    for (Index c : cells.cellsOf(v))
      for (Index w : mesh.cellVertices(c))
        if (mark[w] != v) {
          mark[w] = v;
          if (row) row[count] = w;
          ++count;
        }
    if (count == 0) {  // isolated vertex keeps its diagonal
      if (row) row[0] = v;
      count = 1;
    }
    if (row) std::sort(row, row + count);
    return count;
  };
  Pattern p;
  p.rowStart.assign(static_cast<std::size_t>(n) + 1, 0);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    std::vector<Index> mark(static_cast<std::size_t>(n), -1);
#pragma omp for schedule(dynamic, kRowChunk)
    for (Index v = 0; v < n; ++v) p.rowStart[v + 1] = neighbours(v, mark, nullptr);
  }
  for (Index v = 0; v < n; ++v) p.rowStart[v + 1] += p.rowStart[v];
  p.columns.resize(static_cast<std::size_t>(p.rowStart[n]));
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    std::vector<Index> mark(static_cast<std::size_t>(n), -1);
#pragma omp for schedule(dynamic, kRowChunk)
    for (Index v = 0; v < n; ++v) neighbours(v, mark, p.columns.data() + p.rowStart[v]);
  }
  return p;
}

template <int d>
BlockSparseMatrix<d>::BlockSparseMatrix(std::vector<Index> rowStart, const std::vector<Index>& columns)
    : BlockSparseMatrix(Pattern{std::move(rowStart), IndexArray(columns.begin(), columns.end())}) {}

template <int d>
BlockSparseMatrix<d>::BlockSparseMatrix(Pattern pattern)
    : rowStart_(std::move(pattern.rowStart)), cols_(std::move(pattern.columns)), blocks_(cols_.size()) {
  setZero();  // the blocks are left unset on allocation: zeroed here, by the threads that will use them
}

template <int d>
void BlockSparseMatrix<d>::setZero() {
  if (shared()) {  // one block per entry again, zeroed below
    blockIndex_ = {};
    blocks_ = decltype(blocks_)(cols_.size());
  }
  const Index n = rows();
  const int nt = n >= kParallelMinRows ? threads() : 1;
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (Index i = 0; i < n; ++i)
    for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k) blocks_[k].setZero();
}

template <int d>
void BlockSparseMatrix<d>::multiply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
  const Index n = rows();
  y.resize(static_cast<Eigen::Index>(n) * d);
  const int nt = n >= kParallelMinRows ? threads() : 1;
  withBlocks([&](const auto blocks) {
#pragma omp parallel for schedule(dynamic, kRowChunk) num_threads(nt) if (nt > 1)
    for (Index i = 0; i < n; ++i) {
      Eigen::Matrix<double, d, 1> s = Eigen::Matrix<double, d, 1>::Zero();
      for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k)
        s.noalias() += blocks[k] * x.template segment<d>(static_cast<Eigen::Index>(cols_[k]) * d);
      y.template segment<d>(static_cast<Eigen::Index>(i) * d) = s;
    }
  });
}

template <int d>
void BlockSparseMatrix<d>::multiply(const Eigen::VectorXd& x1, Eigen::VectorXd& y1, const Eigen::VectorXd& x2,
                                    Eigen::VectorXd& y2) const {
  const Index n = rows();
  y1.resize(static_cast<Eigen::Index>(n) * d);
  y2.resize(static_cast<Eigen::Index>(n) * d);
  const int nt = n >= kParallelMinRows ? threads() : 1;
  withBlocks([&](const auto blocks) {
#pragma omp parallel for schedule(dynamic, kRowChunk) num_threads(nt) if (nt > 1)
    for (Index i = 0; i < n; ++i) {
      Eigen::Matrix<double, d, 1> s1 = Eigen::Matrix<double, d, 1>::Zero(), s2 = Eigen::Matrix<double, d, 1>::Zero();
      for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k) {
        const auto j = static_cast<Eigen::Index>(cols_[k]) * d;
        s1.noalias() += blocks[k] * x1.template segment<d>(j);
        s2.noalias() += blocks[k] * x2.template segment<d>(j);
      }
      y1.template segment<d>(static_cast<Eigen::Index>(i) * d) = s1;
      y2.template segment<d>(static_cast<Eigen::Index>(i) * d) = s2;
    }
  });
}

namespace {

/// The bits of a block as 64-bit words.
template <class Block>
std::array<std::uint64_t, Block::SizeAtCompileTime> blockBits(const Block& B) {
  std::array<std::uint64_t, Block::SizeAtCompileTime> w;
  std::memcpy(w.data(), B.data(), sizeof w);
  return w;
}

/// Hash of a block's bits: the words rotated by different amounts and xored (independent
/// operations), then one multiplicative mix.
template <class Block>
std::uint64_t blockHash(const Block& B) {
  const auto w = blockBits(B);
  std::uint64_t h = 0;
  for (std::size_t i = 0; i < w.size(); ++i) h ^= std::rotl(w[i], static_cast<int>(7 * i));
  h *= 0x9E3779B97F4A7C15ull;
  return h ^ (h >> 32);
}

/// Whether two blocks have the same bits (inline, without a call of memcmp).
template <class Block>
bool sameBits(const Block& A, const Block& B) {
  const auto a = blockBits(A), b = blockBits(B);
  std::uint64_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ |= a[i] ^ b[i];
  return differ == 0;
}

/// Block numbers in an open-addressing table (-1: empty; load at most 1/2): the number of a block
/// with the bits of b, or -1. blockOf(u) is block number u; the blocks live elsewhere.
template <class Block, class BlockOf>
std::int64_t findNumber(const std::vector<std::int64_t>& table, const Block& b, const BlockOf& blockOf) {
  const std::size_t mask = table.size() - 1;
  for (std::size_t slot = blockHash(b) & mask; table[slot] >= 0; slot = (slot + 1) & mask)
    if (sameBits(blockOf(table[slot]), b)) return table[slot];
  return -1;
}

/// Enters number count - 1, the newest of `count` numbers; when the table would be more than half
/// full, it doubles and takes all numbers anew.
template <class BlockOf>
void addNumber(std::vector<std::int64_t>& table, std::size_t count, const BlockOf& blockOf) {
  const auto put = [&](std::size_t u) {
    const std::size_t mask = table.size() - 1;
    std::size_t slot = blockHash(blockOf(static_cast<std::int64_t>(u))) & mask;
    while (table[slot] >= 0) slot = (slot + 1) & mask;
    table[slot] = static_cast<std::int64_t>(u);
  };
  if (2 * count <= table.size()) {
    put(count - 1);
    return;
  }
  table.assign(2 * table.size(), -1);
  for (std::size_t u = 0; u < count; ++u) put(u);
}

/// The distinct blocks of a sequence, numbered in order of first appearance (findNumber over the
/// positions of their first appearances). Blocks compare bitwise (-0.0 and 0.0 differ), so every
/// value is kept exactly.
template <class Block>
class DistinctBlocks {
public:
  explicit DistinctBlocks(const Block* blocks) : blocks_(blocks) {}

  /// Number of the block at position k (new if it is new); -1 if it would be number `limit`.
  std::int64_t number(std::size_t k, std::size_t limit) {
    const auto blockOf = [this](std::int64_t u) -> const Block& { return blocks_[first_[static_cast<std::size_t>(u)]]; };
    if (const std::int64_t id = findNumber(table_, blocks_[k], blockOf); id >= 0) return id;
    if (first_.size() >= limit) return -1;
    first_.push_back(k);
    addNumber(table_, first_.size(), blockOf);
    return static_cast<std::int64_t>(first_.size()) - 1;
  }
  /// Position of the first appearance of each distinct block, by number.
  const std::vector<std::size_t>& first() const { return first_; }

private:
  const Block* blocks_;
  std::vector<std::size_t> first_;
  std::vector<std::int64_t> table_ = std::vector<std::int64_t>(1024, -1);
};

}  // namespace

template <int d>
BlockSparseMatrix<d> BlockSparseMatrix<d>::fromRowRanges(Pattern pattern, const RowRangeFill& fill) {
  BlockSparseMatrix A;
  A.rowStart_ = std::move(pattern.rowStart);
  A.cols_ = std::move(pattern.columns);
  A.fillByRowRanges(fill);
  return A;
}

template <int d>
void BlockSparseMatrix<d>::fillByRowRanges(const RowRangeFill& fill) {
  BlockSparseMatrix& A = *this;
  A.blocks_ = {};  // the old blocks go first: never two storages at once
  A.blockIndex_ = {};
  const Index n = A.rows();
  const std::size_t nnz = A.cols_.size();
  // ranges of whole rows of about kRange blocks (a row longer than that is a range of its own)
  constexpr Index kRange = Index{1} << 16;
  std::vector<Index> first{0};
  while (first.back() < n) {
    const Index from = first.back();
    Index to = from + 1;
    while (to < n && A.rowStart_[to + 1] - A.rowStart_[from] <= kRange) ++to;
    first.push_back(to);
  }
  const auto ranges = static_cast<long long>(first.size()) - 1;
  // The ranges are filled on the threads; in range order (omp ordered) each range's distinct
  // blocks are merged into the matrix's, numbered in order of first appearance as by
  // shareRepeatedBlocks(), and the prefix rule is checked. Until it fails, a range is filled into a
  // scratch array of its thread and only its block numbers are kept; the range that fails it
  // allocates one block per entry, and the ranges filled from then on write there directly. The
  // shared ranges before it are expanded at the end.
  using Blocks = decltype(A.blocks_);
  std::atomic<bool> sharing{nnz / 4 > 0};
  if (!sharing) A.blocks_ = Blocks(nnz);
  long long plainFrom = 0;  // the first range not kept shared, once sharing stops
  std::vector<std::uint32_t, LargeArrayAllocator<std::uint32_t>> index(sharing ? nnz : 0);
  Blocks distinct;
  std::vector<std::int64_t> table(1024, -1);  // over distinct
  const auto distinctBlock = [&](std::int64_t u) -> const Block& { return distinct[static_cast<std::size_t>(u)]; };
  std::size_t seen = 0;  // blocks of the ranges merged
  std::exception_ptr error;
  const int nt = ranges > 1 ? threads() : 1;
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    std::vector<Block> scratch;
    std::vector<std::uint32_t> toMatrix;  // a range's local block numbers -> the matrix's
#pragma omp for schedule(dynamic, 1) ordered
    for (long long r = 0; r < ranges; ++r) {
      const Index rowFrom = first[static_cast<std::size_t>(r)], rowTo = first[static_cast<std::size_t>(r) + 1];
      const Index base = A.rowStart_[rowFrom];
      const auto size = static_cast<std::size_t>(A.rowStart_[rowTo] - base);
      const bool direct = !sharing.load(std::memory_order_acquire);
      if (!direct && scratch.size() < size) scratch.resize(size);
      Block* out = direct ? A.blocks_.data() + base : scratch.data();
      for (std::size_t k = 0; k < size; ++k) out[k].setZero();
      std::exception_ptr failed;
      try {
        fill(rowFrom, rowTo, out);
      } catch (...) {
        failed = std::current_exception();
      }
      std::optional<DistinctBlocks<Block>> local;
      if (!direct && !failed) {
        local.emplace(scratch.data());
        for (std::size_t k = 0; k < size; ++k)
          index[base + k] = static_cast<std::uint32_t>(local->number(k, size));
      }
      bool merged = false, copy = false;
#pragma omp ordered
      {
        if (failed) {
          if (!error) error = failed;  // the lowest range's: the ordered regions run in range order
        } else if (!direct) {
          if (sharing.load(std::memory_order_relaxed)) {
            toMatrix.clear();
            for (const std::size_t k : local->first()) {
              std::int64_t id = findNumber(table, scratch[k], distinctBlock);
              if (id < 0) {
                distinct.push_back(scratch[k]);
                addNumber(table, distinct.size(), distinctBlock);
                id = static_cast<std::int64_t>(distinct.size()) - 1;
              }
              toMatrix.push_back(static_cast<std::uint32_t>(id));
            }
            seen += size;
            merged = distinct.size() <= seen / 4;
            if (!merged) {
              A.blocks_ = Blocks(nnz);  // not touched here: each range's thread writes its part
              plainFrom = r;
              sharing.store(false, std::memory_order_release);
            }
          }
          copy = !merged;
        }
      }
      if (merged)
        for (std::size_t k = 0; k < size; ++k) index[base + k] = toMatrix[index[base + k]];
      if (copy) std::copy(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(size), A.blocks_.begin() + base);
    }
  }
  if (error) {  // the pattern stays, with zero blocks
    A.blocks_ = {};
    A.blockIndex_ = {};
    A.blocks_ = Blocks(nnz);
    A.setZero();
    std::rethrow_exception(error);
  }
  if (sharing) {
    A.blocks_ = std::move(distinct);
    A.blockIndex_ = std::move(index);
  } else if (plainFrom > 0) {  // the ranges kept shared before sharing stopped
    const Index end = A.rowStart_[first[static_cast<std::size_t>(plainFrom)]];
    forRanges(end, [&](Index begin, Index stop) {
      for (Index k = begin; k < stop; ++k) A.blocks_[k] = distinct[index[k]];
    });
  }
}

template <int d>
bool BlockSparseMatrix<d>::shareRepeatedBlocks() {
  if (shared()) return true;
  const std::size_t nnz = blocks_.size();
  const std::size_t limit = nnz / 4;  // at most a quarter distinct, else one block per entry stays
  if (limit == 0) return false;
  // Chunks of a fixed size are numbered on the threads, each on its own (local numbers in order of
  // first appearance within the chunk); then one thread merges the chunks' distinct blocks in
  // chunk order, which numbers them in order of first appearance in the whole matrix, and the
  // threads translate local numbers into these. The result does not depend on the thread count.
  constexpr std::size_t kChunk = std::size_t{1} << 16;
  const std::size_t chunks = (nnz + kChunk - 1) / kChunk;
  std::vector<std::uint32_t, LargeArrayAllocator<std::uint32_t>> index(nnz);
  std::vector<std::vector<std::size_t>> chunkFirst(chunks);  // first appearances of each chunk's blocks
  const auto count = static_cast<long long>(chunks);
  const int nt = chunks > 1 ? threads() : 1;
  int tooMany = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt) reduction(max : tooMany) if (nt > 1)
  for (long long c = 0; c < count; ++c) {
    const auto u = static_cast<std::size_t>(c);
    DistinctBlocks<Block> local(blocks_.data());
    for (std::size_t k = u * kChunk; k < std::min(nnz, (u + 1) * kChunk); ++k) {
      const std::int64_t id = local.number(k, limit);
      if (id < 0) {  // more than `limit` in this chunk alone
        tooMany = 1;
        break;
      }
      index[k] = static_cast<std::uint32_t>(id);
    }
    chunkFirst[u] = local.first();
  }
  if (tooMany != 0) return false;
  DistinctBlocks<Block> all(blocks_.data());
  std::vector<std::vector<std::uint32_t>> toGlobal(chunks);
  for (std::size_t c = 0; c < chunks; ++c) {
    toGlobal[c].reserve(chunkFirst[c].size());
    for (const std::size_t k : chunkFirst[c]) {
      const std::int64_t id = all.number(k, limit);
      if (id < 0) return false;
      toGlobal[c].push_back(static_cast<std::uint32_t>(id));
    }
  }
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (long long c = 0; c < count; ++c) {
    const auto u = static_cast<std::size_t>(c);
    const std::vector<std::uint32_t>& map = toGlobal[u];
    for (std::size_t k = u * kChunk; k < std::min(nnz, (u + 1) * kChunk); ++k) index[k] = map[index[k]];
  }
  decltype(blocks_) distinct(all.first().size());
  for (std::size_t u = 0; u < distinct.size(); ++u) distinct[u] = blocks_[all.first()[u]];
  blocks_ = std::move(distinct);
  blockIndex_ = std::move(index);
  return true;
}

template <int d>
Index BlockSparseMatrix<d>::isolatedBlocks(const std::vector<char>& isolated) const {
  const Index n = rows();
  Index count = 0;
  for (Index i = 0; i < n; ++i)
    for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k)
      count += cols_[k] != i && (isolated[i] || isolated[cols_[k]]);
  return count;
}

template <int d>
Index BlockSparseMatrix<d>::isolate(const std::vector<char>& isolated) {
  if (static_cast<Index>(isolated.size()) != rows())
    throw Error("BlockSparseMatrix::isolate: " + std::to_string(isolated.size()) + " flags for " +
                std::to_string(rows()) + " rows");
  const Index n = rows();
  Index out = 0;
  for (Index i = 0; i < n; ++i) {
    const Index begin = rowStart_[i], end = rowStart_[i + 1];
    rowStart_[i] = out;
    for (Index k = begin; k < end; ++k) {
      const Index j = cols_[k];
      if (j != i && (isolated[i] || isolated[j])) continue;
      cols_[out] = j;
      if (shared()) blockIndex_[out] = blockIndex_[k];
      else blocks_[out] = blocks_[k];
      ++out;
    }
  }
  const Index removed = rowStart_[n] - out;
  rowStart_[n] = out;
  cols_.resize(static_cast<std::size_t>(out));
  if (shared()) blockIndex_.resize(static_cast<std::size_t>(out));
  else blocks_.resize(static_cast<std::size_t>(out));
  order_.reset();
  return removed;
}

template <int d>
void BlockSparseMatrix<d>::unshareBlocks() {
  if (!shared()) return;
  if (omp_in_parallel()) {  // the other threads would write to the blocks being replaced
    std::fprintf(stderr, "obs: BlockSparseMatrix: a write to a matrix with shared blocks inside a parallel region; "
                         "call unshareBlocks() before the loop\n");
    std::abort();
  }
  decltype(blocks_) all(cols_.size());
  for (std::size_t k = 0; k < all.size(); ++k) all[k] = blocks_[blockIndex_[k]];
  blocks_ = std::move(all);
  blockIndex_ = {};
}

template <int d>
BlockSparseMatrix<d>::BlockWriter::BlockWriter(BlockSparseMatrix& A) : A_(A) {
  if (!A_.shared()) return;
  std::size_t size = 1024;
  while (size < 2 * A_.blocks_.size()) size *= 2;
  table_.assign(size, -1);
  const auto blockOf = [this](std::int64_t u) -> const Block& { return A_.blocks_[static_cast<std::size_t>(u)]; };
  for (std::size_t u = 0; u < A_.blocks_.size(); ++u) addNumber(table_, u + 1, blockOf);
}

template <int d>
void BlockSparseMatrix<d>::BlockWriter::set(Index k, const Block& value) {
  if (!A_.shared()) {
    A_.blocks_[static_cast<std::size_t>(k)] = value;
    return;
  }
  A_.blockIndex_[static_cast<std::size_t>(k)] = number(value);
}

template <int d>
std::uint32_t BlockSparseMatrix<d>::BlockWriter::number(const Block& value) {
  const auto blockOf = [this](std::int64_t u) -> const Block& { return A_.blocks_[static_cast<std::size_t>(u)]; };
  std::int64_t id = findNumber(table_, value, blockOf);
  if (id < 0) {  // a new block: appended
    A_.blocks_.push_back(value);
    addNumber(table_, A_.blocks_.size(), blockOf);
    id = static_cast<std::int64_t>(A_.blocks_.size()) - 1;
  }
  return static_cast<std::uint32_t>(id);
}

template <int d>
void BlockSparseMatrix<d>::ChangedBlocks::add(Index k, const Block& value) {
  if (table_.empty()) table_.assign(64, -1);
  const auto valueOf = [this](std::int64_t u) -> const Block& { return values_[static_cast<std::size_t>(u)]; };
  std::int64_t id = findNumber(table_, value, valueOf);
  if (id < 0) {
    values_.push_back(value);
    addNumber(table_, values_.size(), valueOf);
    id = static_cast<std::int64_t>(values_.size()) - 1;
  }
  entries_.push_back(k);
  numbers_.push_back(static_cast<std::uint32_t>(id));
}

template <int d>
void BlockSparseMatrix<d>::writeChanged(std::vector<ChangedBlocks>& changed) {
  // a value's first appearance in the order of k is its first appearance in the first chunk that
  // has it: looking the chunks' distinct values up chunk by chunk appends the new ones in the order
  // of BlockWriter::set called entry by entry
  BlockWriter writer(*this);
  std::vector<std::vector<std::uint32_t>> toMatrix(changed.size());
  for (std::size_t c = 0; c < changed.size(); ++c) {
    toMatrix[c].reserve(changed[c].values_.size());
    for (const Block& value : changed[c].values_) toMatrix[c].push_back(writer.number(value));
  }
  const auto chunks = static_cast<long long>(changed.size());
  const int nt = chunks > 1 ? threads() : 1;
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (long long c = 0; c < chunks; ++c) {
    const ChangedBlocks& list = changed[static_cast<std::size_t>(c)];
    const std::vector<std::uint32_t>& map = toMatrix[static_cast<std::size_t>(c)];
    for (std::size_t i = 0; i < list.entries_.size(); ++i)
      blockIndex_[static_cast<std::size_t>(list.entries_[i])] = map[list.numbers_[i]];
  }
}

template <int d>
const SweepOrder& BlockSparseMatrix<d>::sweepOrder() const {
  const int parts = threads();
  if (!order_ || order_->requestedParts() != parts)
    order_ = std::make_shared<const SweepOrder>(rowStart_, cols_, parts);
  return *order_;
}

template <int d>
void BlockSparseMatrix<d>::setSweepPartition(std::span<const int> part) const {
  order_ = std::make_shared<const SweepOrder>(rowStart_, cols_, threads(), part);
}

template class BlockSparseMatrix<2>;
template class BlockSparseMatrix<3>;

}  // namespace obs
