#include "obs/obs/CholmodSolver.hpp"

#include <cholmod.h>

#include <chrono>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {

struct CholmodSolver::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  Eigen::Index n = 0;
  Index blocks = 0;
  Impl() {
    cholmod_start(&common);
    common.print = 0;
    common.error_handler = nullptr;
    // Always a supernodal LL' factorisation: a simplicial LDL' would silently accept indefinite
    // matrices, and obs wants a clear error for an ill-posed problem.
    common.supernodal = CHOLMOD_SUPERNODAL;
  }
  ~Impl() {
    if (factor) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
};

namespace {

/// The lower triangle of A (compressed rows) as the upper triangle in compressed columns of the
/// symmetric matrix, stype = +1, for CHOLMOD.
template <int d>
cholmod_sparse* toCholmod(const BlockSparseMatrix<d>& A, cholmod_common* common) {
  const Index nb = A.rows();
  const std::size_t n = static_cast<std::size_t>(nb) * d;
  std::size_t nnz = 0;
  for (Index i = 0; i < nb; ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k)
      if (A.column(k) < i) nnz += d * d;
      else if (A.column(k) == i) nnz += d * (d + 1) / 2;
  cholmod_sparse* S = cholmod_allocate_sparse(n, n, nnz, 1, 1, 1, CHOLMOD_REAL, common);
  if (!S) throw Error("CHOLMOD: out of memory allocating a " + std::to_string(n) + "x" +
                      std::to_string(n) + " matrix");
  int* colPtr = static_cast<int*>(S->p);
  int* rowIdx = static_cast<int*>(S->i);
  double* val = static_cast<double*>(S->x);
  std::size_t pos = 0;
  for (Index i = 0; i < nb; ++i)
    for (int a = 0; a < d; ++a) {
      colPtr[i * d + a] = static_cast<int>(pos);
      for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) {
        const Index j = A.column(k);
        if (j > i) break;
        for (int b = 0; b < d; ++b) {
          if (j == i && b > a) break;
          rowIdx[pos] = j * d + b;
          val[pos] = A.blockAt(k)(a, b);
          ++pos;
        }
      }
    }
  colPtr[n] = static_cast<int>(pos);
  return S;
}

}  // namespace

template <int d>
CholmodSolver::CholmodSolver(const BlockSparseMatrix<d>& A) : impl_(std::make_unique<Impl>()) {
  const auto t0 = std::chrono::steady_clock::now();
  impl_->n = static_cast<Eigen::Index>(A.rows()) * d;
  impl_->blocks = A.nonZeroBlocks();
  useBlasThreadsFor(impl_->n);
  cholmod_sparse* S = toCholmod(A, &impl_->common);
  impl_->factor = cholmod_analyze(S, &impl_->common);
  if (!impl_->factor) {
    cholmod_free_sparse(&S, &impl_->common);
    throw Error("CHOLMOD: analysis failed (status " + std::to_string(impl_->common.status) + ")");
  }
  factorize(S);
  factorSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <int d>
void CholmodSolver::refactorize(const BlockSparseMatrix<d>& A) {
  const auto t0 = std::chrono::steady_clock::now();
  if (static_cast<Eigen::Index>(A.rows()) * d != impl_->n || A.nonZeroBlocks() != impl_->blocks)
    throw Error("CholmodSolver::refactorize: the matrix has another size or pattern than the analysed one");
  useBlasThreadsFor(impl_->n);
  factorize(toCholmod(A, &impl_->common));
  factorSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void CholmodSolver::factorize(cholmod_sparse* S) {
  cholmod_factorize(S, impl_->factor, &impl_->common);
  cholmod_free_sparse(&S, &impl_->common);
  if (impl_->common.status == CHOLMOD_NOT_POSDEF || impl_->factor->minor < static_cast<std::size_t>(impl_->n))
    throw Error("CHOLMOD: matrix not positive definite (breakdown at column " +
                std::to_string(impl_->factor->minor) +
                "); are all rigid motions fixed by Dirichlet conditions?");
  if (impl_->common.status < CHOLMOD_OK)
    throw Error("CHOLMOD: factorisation failed (status " + std::to_string(impl_->common.status) +
                ")");
}

CholmodSolver::~CholmodSolver() = default;

Eigen::VectorXd CholmodSolver::solve(const Eigen::VectorXd& b) const {
  Eigen::VectorXd x;
  solve(b, x);
  return x;
}

void CholmodSolver::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
  if (b.size() != impl_->n) throw Error("CholmodSolver::solve: right-hand side of wrong size");
  useBlasThreadsFor(impl_->n);
  cholmod_dense B;
  B.nrow = B.d = static_cast<std::size_t>(b.size());
  B.ncol = 1;
  B.nzmax = B.nrow;
  B.x = const_cast<double*>(b.data());
  B.z = nullptr;
  B.xtype = CHOLMOD_REAL;
  B.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* X = cholmod_solve(CHOLMOD_A, impl_->factor, &B, &impl_->common);
  if (!X) throw Error("CHOLMOD: solve failed");
  x = Eigen::Map<const Eigen::VectorXd>(static_cast<double*>(X->x), b.size());
  cholmod_free_dense(&X, &impl_->common);
}

long long CholmodSolver::factorNonZeros() const {
  const auto* L = impl_->factor;
  if (!L) return 0;
  if (L->is_super) return static_cast<long long>(L->xsize);
  return static_cast<long long>(L->nzmax);
}

template CholmodSolver::CholmodSolver(const BlockSparseMatrix<2>&);
template CholmodSolver::CholmodSolver(const BlockSparseMatrix<3>&);
template void CholmodSolver::refactorize(const BlockSparseMatrix<2>&);
template void CholmodSolver::refactorize(const BlockSparseMatrix<3>&);

}  // namespace obs
