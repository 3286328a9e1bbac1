#include "obs/obs/DistributedCoarseSolver.hpp"

#include <chrono>
#include <string>

#include "obs/mesh/Error.hpp"

#ifdef OBS_HAVE_HYPRE
#include <mpi.h>

#include <HYPRE.h>
#include <HYPRE_IJ_mv.h>
#include <HYPRE_krylov.h>
#include <HYPRE_parcsr_ls.h>
#endif

namespace obs {

#ifdef OBS_HAVE_HYPRE

namespace {

/// HYPRE_Init once per process (after MPI_Init, which MpiSession does before any solver exists).
void initialiseHypre() {
  static const bool done = [] {
    HYPRE_Init();
    return true;
  }();
  (void)done;
}

}  // namespace

struct DistributedCoarseSolver::Impl {
  const HaloExchange* halo = nullptr;
  int d = 0;
  Index owned = 0;
  HYPRE_BigInt lower = 0, upper = -1;  ///< this rank's rows (inclusive)
  std::vector<HYPRE_BigInt> columnOf;  ///< per local vertex: its global index times d
  Options options;
  HYPRE_IJMatrix A = nullptr;
  HYPRE_IJVector b = nullptr, x = nullptr;
  HYPRE_Solver pcg = nullptr, amg = nullptr;
  // scratch of the row-wise matrix upload
  std::vector<HYPRE_Int> counts;
  std::vector<HYPRE_BigInt> rows, columns, indices;
  std::vector<double> values, zeros;

  ~Impl() { release(); }
  void release() {
    if (pcg) HYPRE_ParCSRPCGDestroy(pcg);
    if (amg) HYPRE_BoomerAMGDestroy(amg);
    if (A) HYPRE_IJMatrixDestroy(A);
    if (b) HYPRE_IJVectorDestroy(b);
    if (x) HYPRE_IJVectorDestroy(x);
    pcg = amg = nullptr;
    A = nullptr;
    b = x = nullptr;
  }

  template <int dd>
  void upload(const BlockSparseMatrix<dd>& M) {
    release();
    counts.clear();
    rows.clear();
    columns.clear();
    values.clear();
    for (Index I = 0; I < owned; ++I)
      for (int a = 0; a < dd; ++a) {
        rows.push_back(columnOf[static_cast<std::size_t>(I)] + a);
        counts.push_back(static_cast<HYPRE_Int>((M.rowEnd(I) - M.rowBegin(I)) * dd));
        for (Index k = M.rowBegin(I); k < M.rowEnd(I); ++k) {
          const auto& B = M.blockAt(k);
          for (int c = 0; c < dd; ++c) {
            columns.push_back(columnOf[static_cast<std::size_t>(M.column(k))] + c);
            values.push_back(B(a, c));
          }
        }
      }
    HYPRE_IJMatrixCreate(MPI_COMM_WORLD, lower, upper, lower, upper, &A);
    HYPRE_IJMatrixSetObjectType(A, HYPRE_PARCSR);
    HYPRE_IJMatrixSetRowSizes(A, counts.data());
    HYPRE_IJMatrixInitialize(A);
    if (!rows.empty())
      HYPRE_IJMatrixSetValues(A, static_cast<HYPRE_Int>(rows.size()), counts.data(), rows.data(), columns.data(),
                              values.data());
    HYPRE_IJMatrixAssemble(A);
    for (HYPRE_IJVector* v : {&b, &x}) {
      HYPRE_IJVectorCreate(MPI_COMM_WORLD, lower, upper, v);
      HYPRE_IJVectorSetObjectType(*v, HYPRE_PARCSR);
      HYPRE_IJVectorInitialize(*v);
      HYPRE_IJVectorAssemble(*v);
    }
    indices.resize(rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) indices[i] = lower + static_cast<HYPRE_BigInt>(i);

    HYPRE_BoomerAMGCreate(&amg);
    HYPRE_BoomerAMGSetNumFunctions(amg, dd);  // systems AMG: unknown c of a vertex couples with unknowns c
    HYPRE_BoomerAMGSetCoarsenType(amg, 10);   // HMIS
    HYPRE_BoomerAMGSetInterpType(amg, 6);     // extended+i
    HYPRE_BoomerAMGSetPMaxElmts(amg, 4);
    HYPRE_BoomerAMGSetStrongThreshold(amg, dd == 3 ? 0.5 : 0.25);
    HYPRE_BoomerAMGSetRelaxType(amg, 8);      // l1-scaled symmetric Gauss-Seidel: a symmetric preconditioner
    HYPRE_BoomerAMGSetMaxIter(amg, 1);
    HYPRE_BoomerAMGSetTol(amg, 0.0);
    HYPRE_BoomerAMGSetPrintLevel(amg, 0);
    HYPRE_ParCSRPCGCreate(MPI_COMM_WORLD, &pcg);
    HYPRE_PCGSetTol(pcg, options.relativeTolerance);
    HYPRE_PCGSetAbsoluteTol(pcg, 0.0);
    HYPRE_PCGSetMaxIter(pcg, options.maxIterations);
    HYPRE_PCGSetTwoNorm(pcg, 1);
    HYPRE_PCGSetPrintLevel(pcg, 0);
    HYPRE_PCGSetPrecond(pcg, reinterpret_cast<HYPRE_PtrToSolverFcn>(HYPRE_BoomerAMGSolve),
                        reinterpret_cast<HYPRE_PtrToSolverFcn>(HYPRE_BoomerAMGSetup), amg);
    HYPRE_ParCSRMatrix parA;
    HYPRE_ParVector parb, parx;
    HYPRE_IJMatrixGetObject(A, reinterpret_cast<void**>(&parA));
    HYPRE_IJVectorGetObject(b, reinterpret_cast<void**>(&parb));
    HYPRE_IJVectorGetObject(x, reinterpret_cast<void**>(&parx));
    HYPRE_ParCSRPCGSetup(pcg, parA, parb, parx);
  }
};

bool DistributedCoarseSolver::available() { return true; }

template <int d>
DistributedCoarseSolver::DistributedCoarseSolver(const BlockSparseMatrix<d>& A, const std::vector<Index>& global,
                                                 const HaloExchange& halo, const Options& options)
    : impl_(std::make_unique<Impl>()) {
  halo.communicator().collective([&] {
    if (static_cast<Index>(global.size()) != A.rows() || A.rows() != halo.numLocal())
      throw Error("distributed coarse solver: a matrix of " + std::to_string(A.rows()) + " rows, " +
                  std::to_string(global.size()) + " global indices and " + std::to_string(halo.numLocal()) +
                  " local vertices");
  });
  initialiseHypre();
  Impl& m = *impl_;
  m.halo = &halo;
  m.d = d;
  m.owned = halo.numOwned();
  m.options = options;
  m.columnOf.resize(global.size());
  for (std::size_t i = 0; i < global.size(); ++i) m.columnOf[i] = static_cast<HYPRE_BigInt>(global[i]) * d;
  // the parts' vertices are numbered part by part (numberView): the rank's rows are one range after
  // those of the ranks before it (empty if it owns no vertex)
  const std::vector<long long> counts = halo.communicator().allGather(static_cast<long long>(m.owned));
  long long first = 0;
  for (int r = 0; r < halo.communicator().rank(); ++r) first += counts[static_cast<std::size_t>(r)];
  halo.communicator().collective([&] {
    if (m.owned > 0 && first != static_cast<long long>(global[0]))
      throw Error("distributed coarse solver: the owned vertices are not numbered part by part");
  });
  m.lower = static_cast<HYPRE_BigInt>(first) * d;
  m.upper = m.lower + static_cast<HYPRE_BigInt>(m.owned) * d - 1;
  refactorize(A);
}

template <int d>
void DistributedCoarseSolver::refactorize(const BlockSparseMatrix<d>& A) {
  const auto t0 = std::chrono::steady_clock::now();
  if (impl_->d != d || A.rows() != impl_->halo->numLocal())
    throw Error("distributed coarse solver: refactorize with a matrix of another size");
  HYPRE_ClearAllErrors();
  impl_->upload(A);
  const HYPRE_Int failed = HYPRE_GetError();
  HYPRE_ClearAllErrors();
  impl_->halo->communicator().collective([&] {  // a failure on one rank stops every rank
    if (failed) throw Error("distributed coarse solver: hypre failed to set up the matrix or BoomerAMG (error " +
                            std::to_string(failed) + ")");
  });
  setupSeconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void DistributedCoarseSolver::solve(const Eigen::VectorXd& rhs, Eigen::VectorXd& out) const {
  Impl& m = *impl_;
  const auto n = static_cast<HYPRE_Int>(m.indices.size());
  if (rhs.size() != static_cast<Eigen::Index>(m.halo->numLocal()) * m.d)
    throw Error("distributed coarse solver: a right-hand side of " + std::to_string(rhs.size()) + " entries");
  HYPRE_IJVectorInitialize(m.b);
  HYPRE_IJVectorInitialize(m.x);
  if (n > 0) {
    HYPRE_IJVectorSetValues(m.b, n, m.indices.data(), rhs.data());
    m.zeros.assign(static_cast<std::size_t>(n), 0.0);  // CG starts from zero
    HYPRE_IJVectorSetValues(m.x, n, m.indices.data(), m.zeros.data());
  }
  HYPRE_IJVectorAssemble(m.b);
  HYPRE_IJVectorAssemble(m.x);
  HYPRE_ParCSRMatrix parA;
  HYPRE_ParVector parb, parx;
  HYPRE_IJMatrixGetObject(m.A, reinterpret_cast<void**>(&parA));
  HYPRE_IJVectorGetObject(m.b, reinterpret_cast<void**>(&parb));
  HYPRE_IJVectorGetObject(m.x, reinterpret_cast<void**>(&parx));
  HYPRE_ParCSRPCGSolve(m.pcg, parA, parb, parx);
  HYPRE_Int iterations = 0;
  double residual = 0;
  HYPRE_PCGGetNumIterations(m.pcg, &iterations);
  HYPRE_PCGGetFinalRelativeResidualNorm(m.pcg, &residual);
  HYPRE_ClearAllErrors();  // a solve stopped at maxIterations is still a correction; reported by its residual
  lastIterations_ = iterations;
  totalIterations_ += iterations;
  lastResidual_ = residual;
  out.setZero(rhs.size());
  if (n > 0) HYPRE_IJVectorGetValues(m.x, n, m.indices.data(), out.data());
  m.halo->update(out, m.d);
}

#else  // without hypre

struct DistributedCoarseSolver::Impl {};

bool DistributedCoarseSolver::available() { return false; }

template <int d>
DistributedCoarseSolver::DistributedCoarseSolver(const BlockSparseMatrix<d>&, const std::vector<Index>&,
                                                 const HaloExchange& halo, const Options&) {
  halo.communicator().collective([] {
    throw Error("distributed coarse solver: obs is built without hypre (install libhypre-dev and rebuild; or keep the "
                "coarse level replicated, partition level >= 1)");
  });
}

template <int d>
void DistributedCoarseSolver::refactorize(const BlockSparseMatrix<d>&) {}

void DistributedCoarseSolver::solve(const Eigen::VectorXd&, Eigen::VectorXd&) const {}

#endif

DistributedCoarseSolver::~DistributedCoarseSolver() = default;

template DistributedCoarseSolver::DistributedCoarseSolver(const BlockSparseMatrix<2>&, const std::vector<Index>&,
                                                          const HaloExchange&, const Options&);
template DistributedCoarseSolver::DistributedCoarseSolver(const BlockSparseMatrix<3>&, const std::vector<Index>&,
                                                          const HaloExchange&, const Options&);
template void DistributedCoarseSolver::refactorize(const BlockSparseMatrix<2>&);
template void DistributedCoarseSolver::refactorize(const BlockSparseMatrix<3>&);

}  // namespace obs
