#pragma once
/// \file DistributedCoarseSolver.hpp
/// The coarse problem of a distributed multigrid hierarchy whose coarsest level is distributed as
/// well (partition level 0, docs/architecture.md#distributed-coarse-solve), solved by hypre: the
/// conjugate gradient method preconditioned by one BoomerAMG V-cycle (systems AMG with d unknowns
/// per vertex, HMIS coarsening, l1 symmetric Gauss-Seidel), to a relative residual. Replicated
/// coarse levels (partition level >= 1) are factorised by CHOLMOD on every rank instead; with a
/// coarse mesh that grows with the ranks their size grows with the ranks, this solver's does not.
///
/// The operator is the level's matrix in its local numbering (HaloExchange: owned vertices first,
/// their rows complete; ghost rows are not read), unknown c of the vertex with global index g is
/// row g d + c of the distributed hypre matrix. Available where obs is built with MPI and hypre
/// (available()); elsewhere the constructor throws obs::Error.
#include <Eigen/Core>

#include <memory>
#include <vector>

#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/HaloExchange.hpp"

namespace obs {

class DistributedCoarseSolver {
public:
  struct Options {
    double relativeTolerance = 1e-12;  ///< of the residual's 2-norm
    int maxIterations = 200;
  };
  /// True if obs is built with hypre (and MPI).
  static bool available();

  /// Sets up the hypre matrix and the AMG preconditioner of A (collective). `global`: the global
  /// vertex index of each local vertex of A (the owned ones consecutive, first). Throws obs::Error
  /// (on every rank) without hypre, on inconsistent sizes, or if hypre fails.
  template <int d>
  DistributedCoarseSolver(const BlockSparseMatrix<d>& A, const std::vector<Index>& global, const HaloExchange& halo,
                          const Options& options);
  template <int d>
  DistributedCoarseSolver(const BlockSparseMatrix<d>& A, const std::vector<Index>& global, const HaloExchange& halo)
      : DistributedCoarseSolver(A, global, halo, Options{}) {}
  ~DistributedCoarseSolver();
  DistributedCoarseSolver(const DistributedCoarseSolver&) = delete;
  DistributedCoarseSolver& operator=(const DistributedCoarseSolver&) = delete;

  /// New values on the same block pattern: the matrix and the AMG setup are rebuilt (collective).
  template <int d>
  void refactorize(const BlockSparseMatrix<d>& A);

  /// x = A^{-1} b to the tolerance on the owned entries of b (local numbering, the ghost entries are
  /// not read); x's ghost entries are then the owners' values. Collective.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const;

  /// CG iterations of the last solve, over all solves, and the relative residual of the last one.
  int lastIterations() const { return lastIterations_; }
  long long totalIterations() const { return totalIterations_; }
  double lastRelativeResidual() const { return lastResidual_; }
  double setupSeconds() const { return setupSeconds_; }

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  mutable int lastIterations_ = 0;
  mutable long long totalIterations_ = 0;
  mutable double lastResidual_ = 0;
  double setupSeconds_ = 0;
};

}  // namespace obs
