#include "obs/obs/BlockSparseMatrix.hpp"

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
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (Index i = 0; i < n; ++i) {
    Eigen::Matrix<double, d, 1> s = Eigen::Matrix<double, d, 1>::Zero();
    for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k)
      s.noalias() += blocks_[k] * x.template segment<d>(static_cast<Eigen::Index>(cols_[k]) * d);
    y.template segment<d>(static_cast<Eigen::Index>(i) * d) = s;
  }
}

template <int d>
void BlockSparseMatrix<d>::multiply(const Eigen::VectorXd& x1, Eigen::VectorXd& y1, const Eigen::VectorXd& x2,
                                    Eigen::VectorXd& y2) const {
  const Index n = rows();
  y1.resize(static_cast<Eigen::Index>(n) * d);
  y2.resize(static_cast<Eigen::Index>(n) * d);
  const int nt = n >= kParallelMinRows ? threads() : 1;
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (Index i = 0; i < n; ++i) {
    Eigen::Matrix<double, d, 1> s1 = Eigen::Matrix<double, d, 1>::Zero(), s2 = Eigen::Matrix<double, d, 1>::Zero();
    for (Index k = rowStart_[i]; k < rowStart_[i + 1]; ++k) {
      const auto j = static_cast<Eigen::Index>(cols_[k]) * d;
      s1.noalias() += blocks_[k] * x1.template segment<d>(j);
      s2.noalias() += blocks_[k] * x2.template segment<d>(j);
    }
    y1.template segment<d>(static_cast<Eigen::Index>(i) * d) = s1;
    y2.template segment<d>(static_cast<Eigen::Index>(i) * d) = s2;
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
