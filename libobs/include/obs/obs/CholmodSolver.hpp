#pragma once
/// \file CholmodSolver.hpp
/// Sparse Cholesky factorisation of a symmetric positive definite block matrix with SuiteSparse
/// CHOLMOD (supernodal, METIS/AMD ordering chosen by CHOLMOD). Factorise once, solve many times;
/// refactorize() reuses the ordering and symbolic analysis for new values on the same pattern (the
/// coarse-grid solver of the multigrid methods, whose Galerkin operators change with the truncation).
#include <Eigen/Core>

#include <memory>

struct cholmod_sparse_struct;

#include "obs/obs/BlockSparseMatrix.hpp"

namespace obs {

class CholmodSolver {
public:
  /// Analyses and factorises A; throws obs::Error if A is not positive definite (reporting the
  /// column where the factorisation broke down) or if CHOLMOD fails.
  template <int d>
  explicit CholmodSolver(const BlockSparseMatrix<d>& A);
  ~CholmodSolver();
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  /// Numerical factorisation of a matrix with the same block pattern (and size) as the one given to
  /// the constructor, reusing its analysis. Throws obs::Error like the constructor, or if the size
  /// or the number of stored blocks differs.
  template <int d>
  void refactorize(const BlockSparseMatrix<d>& A);

  /// x = A^{-1} b.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;
  /// x = A^{-1} b into a vector of the right size (no allocation by the caller's vector).
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const;

  long long factorNonZeros() const;
  double factorSeconds() const { return factorSeconds_; }

private:
  struct Impl;
  void factorize(cholmod_sparse_struct* S);  ///< numerical factorisation; frees S
  std::unique_ptr<Impl> impl_;
  double factorSeconds_ = 0;
};

}  // namespace obs
