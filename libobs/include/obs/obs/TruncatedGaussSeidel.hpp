#pragma once
/// \file TruncatedGaussSeidel.hpp
/// Linear block Gauss-Seidel for A_T x = r, the smoother of the linear multigrid V-cycle
/// (docs/theory.md#tnnmg-correction). A_T is the matrix A with the *truncated* components (a bit mask per
/// vertex: Dirichlet
/// components and active bounds on the finest level, nothing on coarse levels) replaced by identity
/// rows and columns, without forming it: with T_p = diag(1 - bit_c) and D_p = A_pp the block step is
///   x_p = W_p (r_p - sum_{q != p} A_pq x_q),   W_p = T_p (T_p D_p T_p + I - T_p)^{-1} T_p,
/// so truncated components stay exactly zero and the right-hand side there is ignored (the
/// solution of the truncated defect problem is zero at truncated components).
/// The W_p are precomputed (Cholesky of the free part; a pseudo-inverse if the block is only
/// semidefinite, as truncated coarse operators can be) and recomputed only for vertices whose mask
/// changed; a sweep does no allocation.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Core>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"

namespace obs {

template <int d>
class TruncatedGaussSeidel {
public:
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;
  static constexpr std::uint8_t kAll = (1u << d) - 1;

  TruncatedGaussSeidel() = default;

  /// Smoother for A (kept by reference) with the per-vertex truncation bits (nullptr: none; kept by
  /// pointer, must outlive the smoother). Throws obs::Error if a free part of a diagonal block is
  /// zero or not positive semidefinite; `what` names the matrix in the message.
  void setMatrix(const BlockSparseMatrix<d>& A, const std::vector<std::uint8_t>* bits = nullptr,
                 std::string what = "matrix");
  bool hasMatrix() const { return A_ != nullptr; }
  /// Smooths A + K instead of A, K_p = blocks[slot[p]] added to the diagonal block of vertex p
  /// where slot[p] >= 0 (both kept by pointer; nullptr: none). Only the W_p change, so the
  /// vertices whose K_p changes must be passed to updateVertices().
  void setDiagonalTerm(const std::vector<Index>* slot, const std::vector<Mat>* blocks) {
    addSlot_ = slot;
    addBlocks_ = blocks;
  }
  /// Recomputes W_p for vertices whose truncation bits (or diagonal blocks) changed.
  void updateVertices(std::span<const Index> vertices) {
    for (Index p : vertices) update(p);
  }
  /// The same for every vertex (on threads() threads).
  void updateAll();
  /// Restricts the sweeps to the vertices p with member[p] != 0 (one entry per row; local smoothing
  /// on adaptive hierarchies, docs/theory.md#local-multigrid): the others are neither read as rows
  /// nor written, sweepFromZero() sets them to zero. A full mask (or an empty one) sweeps every
  /// vertex. Kept across setMatrix() (matrices of the same size). Throws obs::Error on a wrong size.
  void setSubset(std::vector<char> member);
  /// Number of vertices a sweep visits.
  Index sweptVertices() const;

  /// nu sweeps on A_T x = r in place (forward, or backward if `backward`), in the matrix's sweep
  /// order (Parallel.hpp: the natural order on one thread).
  void sweep(const Eigen::VectorXd& r, Eigen::VectorXd& x, bool backward = false) const;
  /// One sweep in a given order of the matrix's vertices (a SweepOrder of its pattern or a subset:
  /// DistributedSweep's interior or interface); the subset of setSubset() does not apply.
  void sweep(const Eigen::VectorXd& r, Eigen::VectorXd& x, const SweepOrder& order, bool backward) const;
  /// The first forward sweep from x = 0, in place on x of the right size (it overwrites every entry):
  /// the same result as x.setZero(); sweep(r, x), but rows swept before all their neighbours read
  /// only the blocks left of the diagonal (columns are sorted; the others multiply zeros), which
  /// halves the matrix traffic of this sweep.
  void sweepFromZero(const Eigen::VectorXd& r, Eigen::VectorXd& x) const;

private:
  void update(Index p) {
    const std::uint8_t bits = bits_ ? (*bits_)[p] : 0;
    Mat D = A_->blockAt(diagonal_[p]);
    if (addSlot_ && (*addSlot_)[p] >= 0) D += (*addBlocks_)[(*addSlot_)[p]];
    if (bits) {
      for (int c = 0; c < d; ++c)
        if (bits & (1u << c)) {
          D.row(c).setZero();
          D.col(c).setZero();
          D(c, c) = 1;
        }
    }
    Mat W;
    const Eigen::LLT<Mat> llt(D);
    bool regular = llt.info() == Eigen::Success && D.diagonal().minCoeff() > 0;
    if (regular) {
      W = llt.solve(Mat::Identity());
      // A block that is singular in exact arithmetic often passes the factorisation with a pivot of
      // round-off size (eigenvalues 1e-17 of the largest, seen on the truncated coarse levels of
      // two-body problems); its inverse would amplify the round-off of every sweep by 1e17 and make
      // the iterates depend on the last bits of the input (on the BLAS kernel of the coarse solve).
      // ||D||_F ||W||_F >= cond_2(D): up to 1e12 every eigenvalue is above the cut of the
      // pseudo-inverse below, which then equals the inverse, so the inverse is kept as it is.
      regular = D.norm() * W.norm() <= 1e12;
    }
    if (!regular) {
      // a positive semidefinite block (possible on truncated coarse levels: a combination of the
      // vertex's components with a zero fine prolongation): pseudo-inverse
      const Eigen::SelfAdjointEigenSolver<Mat> eig(D);
      const double top = eig.eigenvalues().cwiseAbs().maxCoeff();
      if (!(top > 0) || eig.eigenvalues().minCoeff() < -1e-10 * top)
        throw Error("Gauss-Seidel smoother: the diagonal block of vertex " + std::to_string(p) + " of " + what_ +
                    " is not positive semidefinite");
      W.setZero();
      for (int c = 0; c < d; ++c)
        if (eig.eigenvalues()[c] > 1e-12 * top)
          W += eig.eigenvectors().col(c) * eig.eigenvectors().col(c).transpose() / eig.eigenvalues()[c];
    }
    for (int c = 0; c < d; ++c)
      if (bits & (1u << c)) {
        W.row(c).setZero();
        W.col(c).setZero();
      }
    inverse_[p] = W;
  }

  const SweepOrder& order() const { return subset_.empty() ? A_->sweepOrder() : subsetOrder_; }
  void buildSubsetOrder();

  const BlockSparseMatrix<d>* A_ = nullptr;
  std::vector<char> subset_;  ///< empty: every vertex
  SweepOrder subsetOrder_;
  const std::vector<std::uint8_t>* bits_ = nullptr;
  const std::vector<Index>* addSlot_ = nullptr;
  const std::vector<Mat>* addBlocks_ = nullptr;
  std::string what_;
  std::vector<Mat> inverse_;
  std::vector<Index> diagonal_;
};

extern template class TruncatedGaussSeidel<2>;
extern template class TruncatedGaussSeidel<3>;

}  // namespace obs
