#pragma once
/// \file LinearCorrection.hpp
/// The linear correction of TNNMG (docs/theory.md#tnnmg-correction) as an exchangeable part (dune-tnnmg
/// style): an approximate solver for the truncated defect problem A_T c = r, where A_T is the fine operator
/// with the truncated components replaced by identity rows and columns, r is zero there and the
/// correction c must be zero there. Implementations: LinearMultigrid (V-cycles on the grid
/// hierarchy, the TNNMG default) and DirectCorrection (CHOLMOD on A_T: an exact truncated Newton
/// step, for tests and small problems).
#include <Eigen/Core>

#include <memory>
#include <vector>

#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/MultigridHierarchy.hpp"

namespace obs {

class CholmodSolver;
class DistributedCoarseSolver;
class HaloExchange;

template <int d>
class LinearCorrection {
public:
  virtual ~LinearCorrection() = default;
  /// The fine operator (kept by reference, must outlive its use) in the frame of the rotations
  /// (vertex unknowns w = Q'u), with an initial truncation mask (empty: none).
  virtual void setOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>> rotations,
                           const std::vector<char>& mask) = 0;
  /// The fine basis transformation C of a two-body problem (ContactProblem::basisTransformation();
  /// rows == 0: none), set before setOperator(). Corrections that work on the fine operator alone
  /// ignore it; multigrid prolongates into the transformed space with (I - C) P.
  virtual void setFineBasis(const mesh::CsrMatrix& /*C*/) {}
  /// Truncation mask, one entry per component (non-zero = truncated). Returns the number of
  /// components whose truncation changed (the operators are updated only then, or when the
  /// diagonal term below changed).
  virtual Index truncate(const std::vector<char>& mask) = 0;
  /// A symmetric positive semidefinite d x d block K_p per listed vertex, added to the operator's
  /// diagonal (in the frame of the operator): the correction then approximates (A + K)_T^{-1}. It
  /// replaces the previous term and takes effect at the next truncate(). TNNMG passes the
  /// curvature of the friction term at slipping vertices (docs/theory.md#friction-tnnmg). Returns
  /// false if this correction ignores the term (the default; it then keeps A).
  virtual bool setDiagonalTerm(std::vector<Index> /*vertices*/, std::vector<Eigen::Matrix<double, d, d>> /*blocks*/) {
    return false;
  }
  /// c ~= A_T^{-1} r (c resized; zero at truncated components).
  virtual void apply(const Eigen::VectorXd& r, Eigen::VectorXd& c) = 0;
  /// Number of operator updates (factorisations / coarse recomputations) since setOperator.
  virtual int operatorUpdates() const = 0;
  /// Preconditioner applications (multigrid: V-cycles) since construction; 0 for direct solves.
  virtual long long cycles() const { return 0; }
  /// Iterations of an iterative coarse solve since construction (multigrid with a distributed
  /// coarse level: hypre's CG iterations); 0 for direct coarse solves.
  virtual long long coarseIterations() const { return 0; }
};

/// Exact correction c = A_T^{-1} r with CHOLMOD (refactorised with the same pattern when the
/// truncation changes). Rotations are irrelevant: A_T is formed in the frame of A.
///
/// Distributed (the constructor with a halo): A is a rank's part of a distributed operator (owned
/// rows first and complete, the ghost rows not read), and A_T is solved by hypre
/// (DistributedCoarseSolver: CG with BoomerAMG to a relative residual of 1e-12, so "exact" up to
/// that), the ghosts of c then current. For problems whose operator reaches beyond the multigrid
/// hierarchy's ghost layers (two bodies on ranks, DistributedMultiBody.hpp).
template <int d>
class DirectCorrection : public LinearCorrection<d> {
public:
  DirectCorrection();
  /// Distributed: `global` the global index of each local vertex of the halo's numbering (kept by
  /// reference with the halo; both must outlive the correction).
  DirectCorrection(const HaloExchange& halo, const std::vector<Index>& global);
  ~DirectCorrection() override;
  void setOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>> rotations,
                   const std::vector<char>& mask) override;
  Index truncate(const std::vector<char>& mask) override;
  bool setDiagonalTerm(std::vector<Index> vertices, std::vector<Eigen::Matrix<double, d, d>> blocks) override;
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd& c) override;
  int operatorUpdates() const override { return updates_; }
  /// hypre's CG iterations (distributed), 0 with CHOLMOD.
  long long coarseIterations() const override;

private:
  void factorize();
  const HaloExchange* halo_ = nullptr;        ///< distributed: the operator's halo
  const std::vector<Index>* global_ = nullptr;
  std::unique_ptr<DistributedCoarseSolver> distributed_;
  const BlockSparseMatrix<d>* A_ = nullptr;
  BlockSparseMatrix<d> truncated_;
  std::vector<char> mask_;
  std::vector<Index> termVertices_;  ///< the diagonal term in force (setDiagonalTerm)
  std::vector<Eigen::Matrix<double, d, d>> termBlocks_;
  std::vector<Index> pendingVertices_;  ///< set, effective at the next truncate()
  std::vector<Eigen::Matrix<double, d, d>> pendingBlocks_;
  bool pending_ = false;
  std::unique_ptr<CholmodSolver> solver_;
  int updates_ = 0;
};

extern template class DirectCorrection<2>;
extern template class DirectCorrection<3>;

}  // namespace obs
