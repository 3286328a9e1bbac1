#pragma once
/// \file LinearMultigrid.hpp
/// Geometric multigrid V-cycle for A_T x = r on a MultigridHierarchy (docs/theory.md#tnnmg-correction):
/// symmetric block Gauss-Seidel smoothing (nu1 forward sweeps before, nu2 backward sweeps after the
/// coarse correction, TruncatedGaussSeidel; or the vertex-patch Schwarz smoother VertexPatchSmoother,
/// Options::smoother), Galerkin coarse operators with truncated and rotated
/// transfers on the finest level, and CHOLMOD on level 0 (factorised once per coarse-operator
/// update, refactorised with the same pattern; truncated coarse operators can be singular, see
/// below); a distributed level 0 (partition level 0) by hypre's conjugate gradients with BoomerAMG
/// to a relative residual of 1e-12 (DistributedCoarseSolver). One cycle from x = 0 on level l:
///   x = S_l^{nu1}(0; r);  d = r - A_l x;  x += P_{l-1} V_{l-1}(P_{l-1}' d);  x = S'_l^{nu2}(x; r)
/// with V_0 = A_0^{-1}. With nu1 = nu2 the cycle is a symmetric positive definite operator.
///
/// Singular coarse operators. The truncated prolongation P~_T = T Q' P need not have full column
/// rank (e.g. a coarse function that vanishes at every untruncated fine vertex), so the Galerkin
/// operators are only positive semidefinite. Their null space is prolongated to zero and the
/// restricted defects are orthogonal to it, so any solution of the coarse problem gives the same
/// correction: level 0 is factorised with a relative diagonal shift, A_0 + 1e-10 diag(A_0) (when
/// L > 0), and the smoothers use pseudo-inverses of semidefinite diagonal blocks.
///
/// Two uses:
///  - the linear correction inside TNNMG (LinearCorrection: `cycles` V-cycles per apply());
///  - a solver for linear problems: setOperator(A) with A after applyDirichlet, truncate(mask of the
///    Dirichlet components), solve(b, x): V-cycle iteration x += V(b - A x) until the relative
///    energy-norm correction ||x^{k+1} - x^k||_A / ||x^{k+1}||_A < tolerance, returning a result
///    value (iterations, rate, residual reduction) instead of printing. Truncated components keep
///    their start values (a start of the wrong size is zero with x_i = b_i on truncated components,
///    the Dirichlet values of an applyDirichlet system).
#include <Eigen/Core>

#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/DistributedSweep.hpp"
#include "obs/obs/LinearCorrection.hpp"
#include "obs/obs/MultigridHierarchy.hpp"
#include "obs/obs/TruncatedGaussSeidel.hpp"
#include "obs/obs/VertexPatchSmoother.hpp"

namespace obs {

class DistributedCoarseSolver;

/// The smoother of every level above level 0 (docs/theory.md#vertex-patch-smoother).
enum class LinearSmoother {
  GaussSeidel,  ///< point-block Gauss-Seidel (TruncatedGaussSeidel), the default
  VertexPatch,  ///< multiplicative Schwarz on vertex patches (VertexPatchSmoother), for nu -> 1/2
};

struct LinearMultigridOptions {
  LinearSmoother smoother = LinearSmoother::GaussSeidel;
  int preSmoothing = 3;      ///< nu1 forward smoothing sweeps
  int postSmoothing = 3;     ///< nu2 backward smoothing sweeps
  int cycles = 1;            ///< V-cycles per apply() (the TNNMG correction)
  /// > 0: apply() runs this many steps of conjugate gradients on A_T c = r from c = 0, preconditioned
  /// by one V-cycle each (cycles must then be 1; nu1 = nu2 keeps the preconditioner symmetric), and
  /// each iteration of solve() is one such apply(). 0: plain V-cycles.
  int krylovSteps = 0;
  int cycleIndex = 1;        ///< coarse corrections per level: 1 = V-cycle, 2 = W-cycle
  /// Local smoothing (docs/theory.md#local-multigrid): on the levels 0 < l < L the Gauss-Seidel
  /// smoother sweeps only the vertices whose basis function is new on level l
  /// (MultigridHierarchy::newBasis), and the defect after pre-smoothing is recomputed only on their
  /// rows and their neighbours'. Identical to whole-level smoothing on uniformly refined hierarchies
  /// (every basis function is new); the vertex-patch smoother always sweeps whole levels.
  bool localSmoothing = true;
  double tolerance = 1e-10;  ///< solve(): relative energy-norm correction
  int maxIterations = 100;   ///< solve(): iteration cap (converged = false when reached)
  bool operator==(const LinearMultigridOptions&) const = default;
};

/// Result of LinearMultigrid::solve (cf. DUNE's InverseOperatorResult).
struct LinearSolverResult {
  int iterations = 0;
  bool converged = false;
  double seconds = 0;
  double correction = 0;         ///< last ||x^{k+1} - x^k||_A / ||x^{k+1}||_A
  double convergenceRate = 0;    ///< geometric mean of the ratios of successive corrections
  double residualReduction = 0;  ///< ||r_k||_2 / ||r_0||_2 (truncated residuals)
  std::vector<double> history;   ///< relative corrections per iteration
};

/// Sets the Gauss-Seidel orders (Parallel.hpp) on threads() > 1 threads of the fine operator A and of
/// the coarse operators above the *base* level from one METIS partition of the base level instead
/// of METIS on every level's graph (docs/performance.md#serial-work). The base is the lowest level
/// with at least kParallelMinRows rows, at most L - 1 (in 3D it has about 64 times fewer vertices
/// than the fine level at L - 2). Every vertex of a finer level goes to the part of its parent, the
/// coarser vertex of its largest prolongation weight (the first on ties); the base vertices weigh
/// as many as their fine descendants, so that the fine parts are balanced. Any partition gives a
/// valid sweep order, and these depend on the hierarchy and the thread count only. A level whose
/// order is known already (the fine operator's, say, set by another smoother) keeps it. Returns
/// false, and sets nothing, on one thread, below kParallelMinRows fine rows, if a vertex has no
/// parent or if METIS fails. LinearMultigrid::setOperator calls it.
template <int d>
bool carrySweepPartition(const MultigridHierarchy<d>& hierarchy, const BlockSparseMatrix<d>& A);

template <int d>
class LinearMultigrid : public LinearCorrection<d> {
public:
  using Options = LinearMultigridOptions;

  /// Hierarchy of the grid's current state (the operator must live on grid.leafView().mesh).
  /// Throws obs::Error on negative smoothing counts or cycles < 1.
  explicit LinearMultigrid(const mesh::Grid& grid, const Options& options = {});
  /// The block-stacked hierarchy of several bodies' grids (MultigridHierarchy).
  explicit LinearMultigrid(const std::vector<const mesh::Grid*>& grids, const Options& options = {});
  /// The distributed hierarchy of a DistributedGrid (collective; docs/architecture.md#distributed-multigrid):
  /// vectors in the fine level's local numbering (owned vertices, then ghosts). The smoothers sweep
  /// the owned vertices in the order of DistributedSweep on the distributed levels; the coarse
  /// level is replicated and solved on every rank. apply() and vcycle() read the owned entries of
  /// the right-hand side and return a correction whose ghost entries are current; solve() needs
  /// the ghosts of x current. krylovSteps > 0 runs the conjugate gradients with their dot products
  /// over the owned entries. Throws obs::Error for the vertex-patch smoother (not distributed yet).
  /// Local smoothing does not apply (uniform hierarchies).
  explicit LinearMultigrid(const DistributedGrid& grid, const Options& options = {});
  /// The block-stacked distributed hierarchy of several bodies in DistributedMultiBody's numbering
  /// (MultigridHierarchy; `fineExtras` its extra ghosts), otherwise as the one-grid constructor.
  LinearMultigrid(const std::vector<const DistributedGrid*>& grids, const std::vector<Index>& fineExtras,
                  const Options& options = {});
  ~LinearMultigrid() override;

  void setOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>> rotations = {},
                   const std::vector<char>& mask = {}) override;
  void setFineBasis(const mesh::CsrMatrix& C) override { hierarchy_.setFineBasis(C); }
  Index truncate(const std::vector<char>& mask) override;
  /// The diagonal term enters the finest level (smoother, defects, conjugate gradients) and the
  /// Galerkin products (MultigridHierarchy::setFineDiagonal). The vertex-patch smoother ignores it
  /// (returns false).
  bool setDiagonalTerm(std::vector<Index> vertices, std::vector<Eigen::Matrix<double, d, d>> blocks) override;
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd& c) override;
  int operatorUpdates() const override { return hierarchy_.coarseUpdates(); }
  long long cycles() const override { return vcycles_; }

  /// One V-cycle from zero: c = V r (c zero at truncated components).
  /// (apply(): `cycles` V-cycles, or krylovSteps preconditioned CG steps, see Options.)
  void vcycle(const Eigen::VectorXd& r, Eigen::VectorXd& c);
  /// Iterates V-cycles on A_T x = b (see the file comment).
  LinearSolverResult solve(const Eigen::VectorXd& b, Eigen::VectorXd& x);

  const MultigridHierarchy<d>& hierarchy() const { return hierarchy_; }
  const Options& options() const { return options_; }
  /// Seconds spent in coarse-grid factorisations since construction.
  double coarseFactorSeconds() const { return factorSeconds_; }
  /// Bytes held by the smoothers of all levels (the vertex-patch inverses dominate).
  std::size_t smootherMemoryBytes() const;
  /// V-cycles run since construction (apply() and solve() count each cycle).
  long long vcycles() const { return vcycles_; }
  /// Whether level 0 is distributed (a distributed hierarchy with partition level 0): it is then
  /// solved by hypre's conjugate gradients with BoomerAMG (DistributedCoarseSolver) instead of
  /// CHOLMOD, and coarseIterations() counts their iterations since construction.
  bool distributedCoarseLevel() const { return hierarchy_.halo(0) != nullptr; }
  long long coarseIterations() const override;
  /// Wall seconds of the V-cycles' phases on one level, summed over the cycles since construction
  /// (or the last resetLevelSeconds()). Level 0 has only the coarse solve; the transfers of level l
  /// are those between l and l - 1.
  struct LevelSeconds {
    double smoothing = 0;    ///< pre- and post-smoothing sweeps
    double defect = 0;       ///< r - A_l x before the restriction
    double restriction = 0;  ///< the defect to level l - 1
    double prolongation = 0; ///< the coarse correction added on level l
    double coarseSolve = 0;  ///< level 0: the direct solve
  };
  /// One entry per level 0 .. maxLevel (bench/threads reports them per thread count).
  const std::vector<LevelSeconds>& levelSeconds() const { return levelSeconds_; }
  void resetLevelSeconds() { levelSeconds_.assign(levelSeconds_.size(), LevelSeconds{}); }
  /// Vertices one V-cycle's smoother visits per sweep, summed over the levels 1 .. L (local
  /// smoothing makes it smaller than the sum of the level sizes).
  Index smoothedVerticesPerSweep() const;

private:
  void cycle(int level, const Eigen::VectorXd& r, Eigen::VectorXd& x);
  void conjugateGradients(const Eigen::VectorXd& r, Eigen::VectorXd& c);
  void truncateFine(Eigen::VectorXd& v) const;
  Eigen::VectorXd cgResidual_, cgPreconditioned_, cgDirection_, cgProduct_;
  void updateCoarse();
  const BlockSparseMatrix<d>& levelOperator(int l) const {
    return l == hierarchy_.maxLevel() ? hierarchy_.fineOperator() : hierarchy_.coarseOperator(l);
  }
  /// Defect out = r - A_l x (on the finest level x is zero at truncated components, so this is
  /// r - A_T x off the truncated rows; those are removed by the restriction).
  void defect(int level, const Eigen::VectorXd& r, const Eigen::VectorXd& x, Eigen::VectorXd& out) const;
  /// The same for an x that is zero outside the local smoothing set of the level: out = r except on
  /// localRows_[level] (the set and its neighbours).
  void localDefect(int level, const Eigen::VectorXd& r, const Eigen::VectorXd& x, Eigen::VectorXd& out) const;
  void setLocalSmoothing();
  std::vector<char> local_;                    ///< per level: smoothed locally
  std::vector<std::vector<Index>> localRows_;  ///< per local level: the rows localDefect() recomputes

  Options options_;
  MultigridHierarchy<d> hierarchy_;
  // the smoother of level l: one of the two, by options_.smoother
  bool smootherReady(int l) const;
  void setSmootherMatrix(int l, const BlockSparseMatrix<d>& A, const std::vector<std::uint8_t>* bits, std::string what);
  void updateSmoother(int l, std::span<const Index> vertices);
  void smoothFromZero(int l, const Eigen::VectorXd& r, Eigen::VectorXd& x) const;
  void smooth(int l, const Eigen::VectorXd& r, Eigen::VectorXd& x, bool backward) const;

  std::vector<TruncatedGaussSeidel<d>> smoothers_;
  std::vector<DistributedSweep> schedules_;  ///< per distributed level (empty: serial)
  /// work() on this rank; distributed, through Communicator::collective (an error on one rank
  /// reaches every rank).
  void everywhere(const std::function<void()>& work) const;
  /// x'y over the fine level's owned entries, summed over the ranks (x'y in a serial hierarchy).
  double fineDot(const Eigen::VectorXd& x, const Eigen::VectorXd& y) const;
  std::vector<VertexPatchSmoother<d>> patchSmoothers_;
  long long vcycles_ = 0;
  std::vector<LevelSeconds> levelSeconds_;
  std::vector<Eigen::VectorXd> rhs_, sol_, work_;  ///< per level
  static constexpr double kCoarseShift = 1e-10;  ///< relative diagonal shift of A_0 (L > 0)
  BlockSparseMatrix<d> shifted_;
  std::unique_ptr<CholmodSolver> coarseSolver_;                 ///< level 0 held whole (serial, replicated)
  std::unique_ptr<DistributedCoarseSolver> distributedCoarse_;  ///< level 0 distributed (partition level 0)
  double factorSeconds_ = 0;
};

extern template class LinearMultigrid<2>;
extern template class LinearMultigrid<3>;

}  // namespace obs
