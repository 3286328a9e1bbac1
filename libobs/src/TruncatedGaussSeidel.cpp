#include "obs/obs/TruncatedGaussSeidel.hpp"

#include <algorithm>
#include <string>

namespace obs {

template <int d>
void TruncatedGaussSeidel<d>::setMatrix(const BlockSparseMatrix<d>& A, const std::vector<std::uint8_t>* bits,
                                        std::string what) {
  A_ = &A;
  bits_ = bits;
  what_ = std::move(what);
  inverse_.resize(A.rows());
  diagonal_.resize(A.rows());
  for (Index p = 0; p < A.rows(); ++p) {
    diagonal_[p] = A.diagonal(p);
    if (diagonal_[p] < 0) throw Error("Gauss-Seidel smoother: " + what_ + " has no diagonal block in row " + std::to_string(p));
  }
  updateAll();
  buildSubsetOrder();
}

template <int d>
void TruncatedGaussSeidel<d>::setSubset(std::vector<char> member) {
  if (!member.empty() && (!A_ || static_cast<Index>(member.size()) != A_->rows()))
    throw Error("Gauss-Seidel smoother: subset mask of " + std::to_string(member.size()) + " entries for " +
                std::to_string(A_ ? A_->rows() : 0) + " rows");
  if (std::all_of(member.begin(), member.end(), [](char m) { return m != 0; })) member.clear();
  subset_ = std::move(member);
  buildSubsetOrder();
}

template <int d>
void TruncatedGaussSeidel<d>::buildSubsetOrder() {
  if (!subset_.empty() && A_ && static_cast<Index>(subset_.size()) != A_->rows())
    throw Error("Gauss-Seidel smoother: the subset mask does not match the new matrix of " + what_);
  subsetOrder_ = subset_.empty() || !A_ ? SweepOrder() : A_->sweepOrder().subset(subset_);
}

template <int d>
Index TruncatedGaussSeidel<d>::sweptVertices() const {
  if (!A_) return 0;
  if (subset_.empty()) return A_->rows();
  return static_cast<Index>(std::count_if(subset_.begin(), subset_.end(), [](char m) { return m != 0; }));
}

template <int d>
void TruncatedGaussSeidel<d>::updateAll() {
  // update() throws for a bad block: on threads the first failing vertex is found, then reported
  const Index n = A_->rows();
  const int nt = n >= kParallelMinRows ? threads() : 1;
  if (nt == 1) {
    for (Index p = 0; p < n; ++p) update(p);
    return;
  }
  Index failed = n;
#pragma omp parallel for schedule(dynamic, kRowChunk) num_threads(nt) reduction(min : failed)
  for (Index p = 0; p < n; ++p) {
    try {
      update(p);
    } catch (const Error&) {
      failed = std::min(failed, p);
    }
  }
  if (failed < n) update(failed);  // throws the message of that vertex
}

template <int d>
void TruncatedGaussSeidel<d>::sweep(const Eigen::VectorXd& r, Eigen::VectorXd& x, bool backward) const {
  sweep(r, x, order(), backward);
}

template <int d>
void TruncatedGaussSeidel<d>::sweep(const Eigen::VectorXd& r, Eigen::VectorXd& x, const SweepOrder& sweepOrder,
                                    bool backward) const {
  const BlockSparseMatrix<d>& A = *A_;
  A.withBlocks([&](const auto blocks) {
    const auto row = [&](Index p) {
      if (bits_ && (*bits_)[p] == kAll) return;  // fully truncated: x_p = 0
      Vec s = r.template segment<d>(static_cast<Eigen::Index>(p) * d);
      const Index dp = diagonal_[p];
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
        if (k != dp) s.noalias() -= blocks[k] * x.template segment<d>(static_cast<Eigen::Index>(A.column(k)) * d);
      x.template segment<d>(static_cast<Eigen::Index>(p) * d).noalias() = inverse_[p] * s;
    };
    if (backward) sweepOrder.backward(A.rows(), row);
    else sweepOrder.forward(A.rows(), row);
  });
}

template <int d>
void TruncatedGaussSeidel<d>::sweepFromZero(const Eigen::VectorXd& r, Eigen::VectorXd& x) const {
  const BlockSparseMatrix<d>& A = *A_;
  if (!subset_.empty()) x.setZero();  // the vertices outside the subset are not swept
  A.withBlocks([&](const auto blocks) {
    // `full`: read the whole row, else only the blocks left of the diagonal (SweepOrder::forwardFromZero)
    const auto row = [&](Index p, bool full) {
      auto xp = x.template segment<d>(static_cast<Eigen::Index>(p) * d);
      if (bits_ && (*bits_)[p] == kAll) {  // fully truncated: x_p = 0
        xp.setZero();
        return;
      }
      Vec s = r.template segment<d>(static_cast<Eigen::Index>(p) * d);
      const Index dp = diagonal_[p];
      const Index end = full ? A.rowEnd(p) : dp;
      for (Index k = A.rowBegin(p); k < end; ++k)
        if (k != dp) s.noalias() -= blocks[k] * x.template segment<d>(static_cast<Eigen::Index>(A.column(k)) * d);
      xp.noalias() = inverse_[p] * s;
    };
    order().forwardFromZero(A.rows(), row, [&](Index p) {
      x.template segment<d>(static_cast<Eigen::Index>(p) * d).setZero();
    });
  });
}

template class TruncatedGaussSeidel<2>;
template class TruncatedGaussSeidel<3>;

}  // namespace obs
