#pragma once
/// \file VertexPatchSmoother.hpp
/// Overlapping multiplicative Schwarz smoother on vertex patches for A_T x = r, an alternative to
/// TruncatedGaussSeidel in the linear multigrid V-cycle for nearly incompressible materials
/// (docs/theory.md#vertex-patch-smoother). The patch of vertex v is v and every vertex coupled to v in
/// the matrix graph (on a hexahedral grid: the 27 vertices of the 8 cells around an interior v, 81
/// unknowns in 3D); on Galerkin coarse levels the graph plays the role of the grid (rows longer than
/// kMaxPatch vertices get the one-vertex patch, a point block step). One patch step
/// solves the patch block of A_T exactly:
///   x_P += W_P (r - A x)_P,   W_P = T_P (T_P A_PP T_P + I - T_P)^{-1} T_P,
/// with T_P = diag(1 - truncation bits) on the patch's unknowns, so truncated components stay zero
/// and the right-hand side there is ignored, as in TruncatedGaussSeidel. A sweep visits the
/// patches in vertex order (forward) or in reverse order (backward), so forward pre- and backward
/// post-smoothing keep the V-cycle symmetric. Each step minimises the energy of the error over the
/// patch's unknowns, so the A-norm of the error never increases.
///
/// The W_P are precomputed as dense symmetric matrices (the inverse from a Cholesky factorisation,
/// a pseudo-inverse if the patch block is only semidefinite, as truncated coarse operators can be),
/// stored packed (the lower triangle by columns), and recomputed only for the patches that contain
/// a vertex whose truncation bits (or matrix rows) changed. Memory: sum over patches of
/// m (m + 1) / 2 doubles, m = d |P| (about 27 KB per interior vertex of a hexahedral grid in 3D,
/// memoryBytes()); a sweep costs about 2 m^2 + 2 d^2 |P| nnz(row) flops per patch and reads every
/// W_P once, which makes it memory-bound and some 30 times a point Gauss-Seidel sweep (Hertz scene, 16^3 hexahedra). A sweep does
/// no allocation.
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"

namespace obs {

template <int d>
class VertexPatchSmoother {
public:
  using Vec = Eigen::Matrix<double, d, 1>;

  /// Longest patch (in vertices): a vertex whose matrix row is longer (the slave rows of a mortar
  /// basis transformation, couplings across hanging levels) gets the patch {v}, a point block step,
  /// so that no patch costs more than (d kMaxPatch)^3 to factorise.
  static constexpr Index kMaxPatch = d == 3 ? 54 : 18;

  VertexPatchSmoother() = default;

  /// Smoother for A (kept by reference) with the per-vertex truncation bits (nullptr: none; kept by
  /// pointer, must outlive the smoother). Throws obs::Error if a patch block is not positive
  /// semidefinite or a row has no diagonal block; `what` names the matrix in the message.
  void setMatrix(const BlockSparseMatrix<d>& A, const std::vector<std::uint8_t>* bits = nullptr,
                 std::string what = "matrix") {
    A_ = &A;
    bits_ = bits;
    what_ = std::move(what);
    const Index n = A.rows();
    local_.assign(static_cast<std::size_t>(n), -1);
    offset_.assign(static_cast<std::size_t>(n) + 1, 0);
    patchStart_.assign(static_cast<std::size_t>(n) + 1, 0);
    patchVertices_.clear();
    std::size_t maxPatch = 0;
    for (Index p = 0; p < n; ++p) {
      if (A.diagonal(p) < 0)
        throw Error("vertex-patch smoother: " + what_ + " has no diagonal block in row " + std::to_string(p));
      // the row's vertices, or the vertex alone if the row is longer than kMaxPatch
      if (A.rowEnd(p) - A.rowBegin(p) <= kMaxPatch)
        for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k) patchVertices_.push_back(A.column(k));
      else
        patchVertices_.push_back(p);
      patchStart_[p + 1] = static_cast<Index>(patchVertices_.size());
      const auto m = static_cast<std::size_t>(patchStart_[p + 1] - patchStart_[p]) * d;
      maxPatch = std::max(maxPatch, m);
      offset_[p + 1] = offset_[p] + m * (m + 1) / 2;
    }
    inverse_.assign(offset_[n], 0.0);
    local_residual_.resize(static_cast<Eigen::Index>(maxPatch));
    local_correction_.resize(static_cast<Eigen::Index>(maxPatch));
    for (Index p = 0; p < n; ++p) factor(p);
  }
  bool hasMatrix() const { return A_ != nullptr; }

  /// Recomputes W_P for every patch that contains one of the vertices (their truncation bits or
  /// matrix rows changed): the patches of the vertices coupled to them (a superset).
  void updateVertices(std::span<const Index> vertices) {
    const BlockSparseMatrix<d>& A = *A_;
    stamp_.resize(static_cast<std::size_t>(A.rows()), 0);
    ++generation_;
    for (Index v : vertices)
      for (Index k = A.rowBegin(v); k < A.rowEnd(v); ++k) {
        const Index p = A.column(k);
        if (stamp_[p] == generation_) continue;
        stamp_[p] = generation_;
        factor(p);
      }
  }

  /// One sweep over all patches on A_T x = r in place (forward, or backward if `backward`).
  void sweep(const Eigen::VectorXd& r, Eigen::VectorXd& x, bool backward = false) const {
    const BlockSparseMatrix<d>& A = *A_;
    const Index n = A.rows();
    for (Index step = 0; step < n; ++step) {
      const Index v = backward ? n - 1 - step : step;
      const Index b = patchStart_[v], e = patchStart_[v + 1];
      const auto m = static_cast<Eigen::Index>(e - b) * d;
      // patch residual (r - A x)_P, row by row over the patch's vertices
      for (Index i = 0; i < e - b; ++i) {
        const Index p = patchVertices_[b + i];
        Vec s = r.template segment<d>(static_cast<Eigen::Index>(p) * d);
        for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k)
          s.noalias() -= A.blockAt(k) * x.template segment<d>(static_cast<Eigen::Index>(A.column(k)) * d);
        local_residual_.template segment<d>(static_cast<Eigen::Index>(i) * d) = s;
      }
      // c = W s with W packed: column j holds W(j..m-1, j)
      const double* w = inverse_.data() + offset_[v];
      auto& c = local_correction_;
      const auto& s = local_residual_;
      c.head(m).setZero();
      for (Eigen::Index j = 0; j < m; ++j) {
        const Eigen::Index len = m - j - 1;
        const Eigen::Map<const Eigen::VectorXd> col(w + 1, len);
        c[j] += w[0] * s[j] + col.dot(s.segment(j + 1, len));
        c.segment(j + 1, len) += s[j] * col;
        w += len + 1;
      }
      for (Index i = 0; i < e - b; ++i)
        x.template segment<d>(static_cast<Eigen::Index>(patchVertices_[b + i]) * d) +=
            local_correction_.template segment<d>(static_cast<Eigen::Index>(i) * d);
    }
  }
  /// The first forward sweep from x = 0 (x resized and overwritten).
  void sweepFromZero(const Eigen::VectorXd& r, Eigen::VectorXd& x) const {
    x.setZero(r.size());
    sweep(r, x, false);
  }

  /// Bytes held by the patch inverses and index arrays.
  std::size_t memoryBytes() const {
    return inverse_.capacity() * sizeof(double) + offset_.capacity() * sizeof(std::size_t) +
           local_.capacity() * sizeof(Index) + stamp_.capacity() * sizeof(std::uint64_t) +
           (patchStart_.capacity() + patchVertices_.capacity()) * sizeof(Index);
  }

private:
  /// W_P of the patch of vertex v.
  void factor(Index v) {
    const BlockSparseMatrix<d>& A = *A_;
    const Index b = patchStart_[v], e = patchStart_[v + 1], size = e - b;
    const auto m = static_cast<Eigen::Index>(size) * d;
    for (Index i = 0; i < size; ++i) local_[patchVertices_[b + i]] = i;
    Eigen::MatrixXd M = Eigen::MatrixXd::Zero(m, m);
    for (Index i = 0; i < size; ++i) {
      const Index p = patchVertices_[b + i];
      for (Index k = A.rowBegin(p); k < A.rowEnd(p); ++k) {
        const Index j = local_[A.column(k)];
        if (j >= 0) M.template block<d, d>(i * d, j * d) = A.blockAt(k);
      }
    }
    for (Index i = 0; i < size; ++i) local_[patchVertices_[b + i]] = -1;
    // truncated components: identity rows and columns
    std::vector<char> truncated(static_cast<std::size_t>(m), 0);
    if (bits_)
      for (Index i = 0; i < size; ++i) {
        const std::uint8_t bits = (*bits_)[patchVertices_[b + i]];
        for (int c = 0; c < d; ++c)
          if (bits & (1u << c)) {
            const Eigen::Index q = i * d + c;
            truncated[q] = 1;
            M.row(q).setZero();
            M.col(q).setZero();
            M(q, q) = 1;
          }
      }
    Eigen::MatrixXd W(m, m);
    const double top = M.diagonal().maxCoeff();
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    // a pivot far below the largest diagonal entry: the block is (numerically) semidefinite
    const bool definite = llt.info() == Eigen::Success && top > 0 &&
                          llt.matrixLLT().diagonal().minCoeff() > 1e-7 * std::sqrt(top);
    if (definite) {
      W = llt.solve(Eigen::MatrixXd::Identity(m, m));
    } else {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(M);
      const double largest = eig.eigenvalues().cwiseAbs().maxCoeff();
      if (!(largest > 0) || eig.eigenvalues().minCoeff() < -1e-10 * largest)
        throw Error("vertex-patch smoother: the patch block of vertex " + std::to_string(v) + " of " + what_ +
                    " is not positive semidefinite");
      W.setZero();
      for (Eigen::Index c = 0; c < m; ++c)
        if (eig.eigenvalues()[c] > 1e-12 * largest)
          W += eig.eigenvectors().col(c) * eig.eigenvectors().col(c).transpose() / eig.eigenvalues()[c];
    }
    for (Eigen::Index q = 0; q < m; ++q)
      if (truncated[q]) {
        W.row(q).setZero();
        W.col(q).setZero();
      }
    // packed lower triangle (symmetric by construction: the V-cycle stays symmetric)
    double* w = inverse_.data() + offset_[v];
    for (Eigen::Index j = 0; j < m; ++j)
      for (Eigen::Index i = j; i < m; ++i) *w++ = 0.5 * (W(i, j) + W(j, i));
  }

  const BlockSparseMatrix<d>* A_ = nullptr;
  const std::vector<std::uint8_t>* bits_ = nullptr;
  std::string what_;
  std::vector<Index> patchStart_, patchVertices_;  ///< patch of v: patchVertices_[patchStart_[v] ..]
  std::vector<std::size_t> offset_;  ///< start of W_P of vertex v in inverse_
  std::vector<double> inverse_;      ///< the W_P, packed lower triangles, one after the other
  std::vector<Index> local_;         ///< work: vertex -> index in the patch being factorised, or -1
  std::vector<std::uint64_t> stamp_;  ///< work of updateVertices
  std::uint64_t generation_ = 0;
  mutable Eigen::VectorXd local_residual_, local_correction_;
};

}  // namespace obs
