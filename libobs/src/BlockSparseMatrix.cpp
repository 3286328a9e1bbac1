#include "obs/obs/BlockSparseMatrix.hpp"

#include <omp.h>

#include <array>
#include <bit>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace obs {

template <int d>
BlockSparseMatrix<d> BlockSparseMatrix<d>::withMeshPattern(const mesh::Mesh& mesh) {
  const Index n = mesh.numVertices();
  // vertex -> cells (compressed)
  std::vector<Index> start(n + 1, 0);
  for (Index c = 0; c < mesh.numCells(); ++c)
    for (Index v : mesh.cellVertices(c)) ++start[v + 1];
  for (Index v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<Index> cellsOf(start[n]);
  {
    std::vector<Index> pos(start.begin(), start.end() - 1);
    for (Index c = 0; c < mesh.numCells(); ++c)
      for (Index v : mesh.cellVertices(c)) cellsOf[pos[v]++] = c;
  }
  // neighbours of each vertex: union of the vertices of its cells, sorted; two passes over the rows
  // (count, then fill) so that rows can be built on threads() threads. A vertex is taken once per
  // row by marking it with the row (mark[w] == v), so only the distinct neighbours are sorted.
  const int nt = n >= kParallelMinRows ? threads() : 1;
  const auto neighbours = [&](Index v, std::vector<Index>& mark, Index* row) {
    Index count = 0;
    for (Index k = start[v]; k < start[v + 1]; ++k)
      for (Index w : mesh.cellVertices(cellsOf[k]))
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
  std::vector<Index> rowStart(n + 1, 0);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    std::vector<Index> mark(static_cast<std::size_t>(n), -1);
#pragma omp for schedule(static)
    for (Index v = 0; v < n; ++v) rowStart[v + 1] = neighbours(v, mark, nullptr);
  }
  for (Index v = 0; v < n; ++v) rowStart[v + 1] += rowStart[v];
  std::vector<Index> cols(static_cast<std::size_t>(rowStart[n]));
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    std::vector<Index> mark(static_cast<std::size_t>(n), -1);
#pragma omp for schedule(static)
    for (Index v = 0; v < n; ++v) neighbours(v, mark, cols.data() + rowStart[v]);
  }
  return BlockSparseMatrix(std::move(rowStart), std::move(cols));
}

template <int d>
BlockSparseMatrix<d>::BlockSparseMatrix(std::vector<Index> rowStart, std::vector<Index> columns)
    : rowStart_(std::move(rowStart)), cols_(std::move(columns)), blocks_(cols_.size()) {
  setZero();  // Eigen leaves the blocks uninitialised: zeroed here, by the threads that will use them
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
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
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
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
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

}  // namespace

template <int d>
bool BlockSparseMatrix<d>::shareRepeatedBlocks() {
  if (shared()) return true;
  const std::size_t nnz = blocks_.size();
  const std::size_t limit = nnz / 4;  // at most a quarter distinct, else one block per entry stays
  if (limit == 0) return false;
  // The distinct blocks in order of first appearance (their positions in blocks_), found through an
  // open-addressing table of distinct numbers; blocks compare bitwise (-0.0 and 0.0 differ), so
  // every value is kept exactly.
  std::vector<std::uint32_t> first;
  std::vector<std::int64_t> table(1024, -1);  // distinct number, -1 = empty; load at most 1/2
  const auto mask = [&] { return table.size() - 1; };
  // distinct number of block k, a new one if it is new; -1 if there would be more than `limit`
  const auto distinctNumber = [&](std::size_t k) -> std::int64_t {
    const std::uint64_t h = blockHash(blocks_[k]);
    std::size_t slot = h & mask();
    for (; table[slot] >= 0; slot = (slot + 1) & mask())
      if (sameBits(blocks_[first[static_cast<std::size_t>(table[slot])]], blocks_[k])) return table[slot];
    if (first.size() >= limit) return -1;
    const auto id = static_cast<std::int64_t>(first.size());
    first.push_back(static_cast<std::uint32_t>(k));
    table[slot] = id;
    if (2 * first.size() > table.size()) {
      table.assign(2 * table.size(), -1);
      for (std::size_t u = 0; u < first.size(); ++u) {
        std::size_t s = blockHash(blocks_[first[u]]) & mask();
        while (table[s] >= 0) s = (s + 1) & mask();
        table[s] = static_cast<std::int64_t>(u);
      }
    }
    return id;
  };
  std::vector<std::uint32_t, LargeArrayAllocator<std::uint32_t>> index(nnz);
  for (std::size_t k = 0; k < nnz; ++k) {
    const std::int64_t id = distinctNumber(k);
    if (id < 0) return false;
    index[k] = static_cast<std::uint32_t>(id);
  }
  decltype(blocks_) distinct(first.size());
  for (std::size_t u = 0; u < first.size(); ++u) distinct[u] = blocks_[first[u]];
  blocks_ = std::move(distinct);
  blockIndex_ = std::move(index);
  return true;
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
