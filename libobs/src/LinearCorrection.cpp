#include "obs/obs/LinearCorrection.hpp"

#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/DistributedCoarseSolver.hpp"
#include "obs/obs/HaloExchange.hpp"

namespace obs {

template <int d>
DirectCorrection<d>::DirectCorrection() = default;
template <int d>
DirectCorrection<d>::DirectCorrection(const HaloExchange& halo, const std::vector<Index>& global)
    : halo_(&halo), global_(&global) {
  halo.communicator().collective([&] {
    if (!DistributedCoarseSolver::available())
      throw Error("direct correction: a distributed operator needs hypre (obs is built without it; install "
                  "libhypre-dev and rebuild)");
  });
}
template <int d>
DirectCorrection<d>::~DirectCorrection() = default;

template <int d>
long long DirectCorrection<d>::coarseIterations() const {
  return distributed_ ? distributed_->totalIterations() : 0;
}

template <int d>
void DirectCorrection<d>::setOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>>,
                                      const std::vector<char>& mask) {
  A_ = &A;
  mask_.assign(static_cast<std::size_t>(A.rows()) * d, 0);
  if (!mask.empty()) {
    if (mask.size() != mask_.size()) throw Error("direct correction: truncation mask of wrong size");
    for (std::size_t i = 0; i < mask.size(); ++i) mask_[i] = mask[i] != 0;
  }
  solver_.reset();
  distributed_.reset();
  updates_ = 0;
  termVertices_.clear();
  termBlocks_.clear();
  pending_ = false;
  factorize();
}

template <int d>
bool DirectCorrection<d>::setDiagonalTerm(std::vector<Index> vertices, std::vector<Eigen::Matrix<double, d, d>> blocks) {
  if (!A_) throw Error("direct correction: setDiagonalTerm() before setOperator()");
  if (vertices.size() != blocks.size()) throw Error("direct correction: diagonal term with vertices and blocks of different sizes");
  for (Index p : vertices)
    if (p < 0 || p >= A_->rows()) throw Error("direct correction: diagonal term at a vertex out of range");
  pendingVertices_ = std::move(vertices);
  pendingBlocks_ = std::move(blocks);
  pending_ = true;
  return true;
}

template <int d>
Index DirectCorrection<d>::truncate(const std::vector<char>& mask) {
  if (!A_) throw Error("direct correction: truncate() before setOperator()");
  if (mask.size() != mask_.size()) throw Error("direct correction: truncation mask of wrong size");
  Index changes = 0;
  for (std::size_t i = 0; i < mask.size(); ++i) changes += (mask[i] != 0) != (mask_[i] != 0);
  bool term = false;
  if (pending_) {
    pending_ = false;
    term = pendingVertices_ != termVertices_ || pendingBlocks_ != termBlocks_;
    termVertices_.swap(pendingVertices_);
    termBlocks_.swap(pendingBlocks_);
  }
  bool update = changes > 0 || term;
  // distributed: hypre's setup is collective, so every rank refactorises if one has to
  if (halo_) update = halo_->communicator().max(update ? 1.0 : 0.0) > 0;
  if (update) {
    for (std::size_t i = 0; i < mask.size(); ++i) mask_[i] = mask[i] != 0;
    factorize();
  }
  return changes;
}

template <int d>
void DirectCorrection<d>::factorize() {
  truncated_ = *A_;
  for (std::size_t i = 0; i < termVertices_.size(); ++i)
    truncated_.blockAt(truncated_.diagonal(termVertices_[i])) += termBlocks_[i];
  for (Index p = 0; p < truncated_.rows(); ++p)
    for (Index k = truncated_.rowBegin(p); k < truncated_.rowEnd(p); ++k) {
      const Index q = truncated_.column(k);
      auto& B = truncated_.blockAt(k);
      for (int c = 0; c < d; ++c) {
        if (mask_[static_cast<std::size_t>(p) * d + c]) B.row(c).setZero();
        if (mask_[static_cast<std::size_t>(q) * d + c]) B.col(c).setZero();
        if (p == q && mask_[static_cast<std::size_t>(p) * d + c]) B(c, c) = 1;
      }
    }
  if (halo_) {
    if (distributed_) distributed_->refactorize(truncated_);
    else distributed_ = std::make_unique<DistributedCoarseSolver>(truncated_, *global_, *halo_);
  } else if (solver_) {
    solver_->refactorize(truncated_);
  } else {
    solver_ = std::make_unique<CholmodSolver>(truncated_);
  }
  ++updates_;
}

template <int d>
void DirectCorrection<d>::apply(const Eigen::VectorXd& r, Eigen::VectorXd& c) {
  Eigen::VectorXd rt = r;
  for (std::size_t i = 0; i < mask_.size(); ++i)
    if (mask_[i]) rt[static_cast<Eigen::Index>(i)] = 0;
  if (distributed_) distributed_->solve(rt, c);
  else solver_->solve(rt, c);
  for (std::size_t i = 0; i < mask_.size(); ++i)
    if (mask_[i]) c[static_cast<Eigen::Index>(i)] = 0;
}

template class DirectCorrection<2>;
template class DirectCorrection<3>;

}  // namespace obs
