#pragma once
/// \file CholmodSolver.hpp
/// Sparse Cholesky factorisation of a symmetric positive definite block matrix with SuiteSparse
/// CHOLMOD (supernodal, METIS/AMD ordering chosen by CHOLMOD). Factorise once, solve many times.
#include <Eigen/Core>

#include <memory>

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

  /// x = A^{-1} b.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;

  long long factorNonZeros() const;
  double factorSeconds() const { return factorSeconds_; }

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double factorSeconds_ = 0;
};

}  // namespace obs
