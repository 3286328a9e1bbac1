#pragma once
/// \file TNNMG.hpp
/// Truncated nonsmooth Newton multigrid (Graeser, Sack, Sander 2009; docs/theory.md#tnnmg) for the contact
/// problem min 1/2 w'Aw - b'w s.t. w_{p,1} <= g_p in the rotated unknowns of a ContactProblem.
/// One iteration from w^k, composed of the parts of dune-tnnmg:
///   1. pre-smoothing: nu1 nonsmooth block Gauss-Seidel sweeps (BlockGaussSeidelSweep with the exact
///      local solver BlockLocalSolver) -> w^{k+1/2};
///   2. truncated linearization at w^{k+1/2} (TruncatedLinearization): mask = Dirichlet components
///      and active bounds, defect r = b - A w^{k+1/2} zeroed there;
///   3. linear correction c ~= A_T^{-1} r (LinearCorrection: one V-cycle of LinearMultigrid on the
///      grid hierarchy with truncated transfers, P~ = T Q' P on the finest level; coarse operators
///      recomputed only when the mask, or with friction in 3D the curvature term, changed);
///   4. defect projection: c_{p,1} <- min(c_{p,1}, g_p - w_{p,1}) (projectCorrection);
///   5. exact line search alpha = min(alpha_max, c'r / c'Ac) (exactLineSearch, alpha_max >= 1);
///      w^{k+1} = w^{k+1/2} + alpha c; optional nu2 post-smoothing sweeps.
/// Every part minimises J exactly in a subspace or along a line inside the admissible set, so the
/// energy never increases (checked each iteration by IterationMonitor::requireMonotone). Stopping:
/// ||w^{k+1} - w^k||_A / ||w^{k+1}||_A < tolerance (ContactSolverOptions), or, if the problem declares
/// a diagonal lower bound of A (time steps with a lumped mass), the a posteriori error bound
/// RotatedProblem::errorBound(w^{k+1}) / ||w^{k+1}||_A < tolerance (docs/theory.md#tnnmg-error-bound);
/// either way the KKT residual of the iterate must pass as well (docs/theory.md#tnnmg-stopping).
/// History records energy, correction, active-set size and the number of components whose
/// truncation changed.
///
/// Tresca friction (ContactProblem::setFriction; docs/theory.md#friction-tnnmg) runs through the same
/// steps: the smoother solves the friction block exactly, the truncation adds the tangential
/// components of sticking vertices, the defect carries the friction gradient of slipping ones, the
/// correction sees the curvature of the friction term at slipping ones (3D), the line search minimises the exact nonquadratic energy (frictionLineSearch), and the monitored energy
/// includes the friction term. The error-bound stopping test is off with friction.
///
/// The solver is built for one grid, or for the grids of several bodies (their hierarchies block-
/// stacked, MultigridHierarchy): the problem must be assembled on the leaf views, stacked in the same
/// order (the vertex count is checked; obs::Error otherwise). After a grid is adapted, build a new
/// TNNMG. A two-body problem with a basis transformation (ContactProblem.hpp) is solved in its
/// transformed unknowns; the multigrid correction prolongates with (I - C) P on the finest level.
///
/// Operator reuse: the rotated matrix and the linear correction's operators (multigrid hierarchy,
/// coarse patterns and Galerkin products) are kept after a solve. A following solve of a problem
/// with the same ContactProblem::operatorId() (the same problem, a copy, or one changed only by
/// setLoad()/setGaps(), as in time stepping) only rebuilds the right-hand side and the bounds; the
/// truncation of the previous solve is the starting point of the operator updates; the smoother's
/// inverted diagonal blocks are kept as well (only the bounds are replaced).
#include <Eigen/Core>

#include <cstdint>
#include <memory>

#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactSolver.hpp"
#include "obs/obs/DistributedSweep.hpp"
#include "obs/obs/LinearCorrection.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"

namespace obs {

template <int d>
class TNNMG : public ContactSolver<d> {
public:
  struct Options : ContactSolverOptions {
    int preSmoothing = 3;   ///< nu1 nonsmooth Gauss-Seidel sweeps before the correction
    int postSmoothing = 0;  ///< nu2 nonsmooth sweeps after the line search (backward)
    LinearMultigridOptions multigrid;  ///< the V-cycle of the linear correction
    /// Tresca friction in 3D: the linear correction sees the curvature s_p (P_T - e e')/|t_p| of the
    /// friction term at slipping vertices (LinearCorrection::setDiagonalTerm;
    /// docs/theory.md#friction-tnnmg). false: A alone (the line search still minimises the exact
    /// energy). No effect without friction or in 2D, where the curvature is zero.
    bool frictionCurvature = true;
  };
  /// Where the time of the last solve went, and how often the linear operators were updated.
  struct Statistics {
    int operatorUpdates = 0;      ///< coarse-operator recomputations (truncation changed)
    Index truncationChanges = 0;  ///< total number of components whose truncation changed
    double setupSeconds = 0;      ///< rotated problem, smoother, hierarchy patterns
    double smoothingSeconds = 0;  ///< nonsmooth Gauss-Seidel
    double updateSeconds = 0;     ///< truncation: Galerkin products, coarse factorisation
    double correctionSeconds = 0; ///< V-cycles
    double otherSeconds = 0;      ///< residuals, projection, line search, norms
    long long vcycles = 0;        ///< V-cycles of the linear corrections (LinearCorrection::cycles())
    long long coarseIterations = 0;  ///< CG iterations of a distributed coarse level (hypre), else 0
  };

  /// TNNMG with the multigrid correction on the grid's hierarchy.
  explicit TNNMG(const mesh::Grid& grid, const Options& options = {});
  /// TNNMG on the block-stacked hierarchy of several bodies' grids.
  explicit TNNMG(const std::vector<const mesh::Grid*>& grids, const Options& options = {});
  /// Distributed TNNMG on a DistributedGrid (collective; docs/architecture.md#distributed-tnnmg): the
  /// problem assembled on the rank's local mesh of the leaf view (DistributedView::local: owned
  /// vertices first, their rows complete), u in that numbering with its ghosts current on entry
  /// (and on return). Sweeps in DistributedSweep's order, the distributed V-cycle, sums and the
  /// step bound reduced over the ranks: every rank takes the same steps and stops together.
  /// With friction the friction energy and the friction line search's slope are summed over the
  /// owned friction vertices and the ranks (Coulomb: solveFriction with the rank's halo). Two-body
  /// contact is refused (obs::Error: the distributed hierarchy has no fine basis transformation yet).
  explicit TNNMG(const DistributedGrid& grid, const Options& options = {});
  /// TNNMG with another linear correction (e.g. DirectCorrection).
  TNNMG(const mesh::Grid& grid, const Options& options, std::unique_ptr<LinearCorrection<d>> correction);
  /// The same for the stacked leaf views of several bodies' grids.
  TNNMG(const std::vector<const mesh::Grid*>& grids, const Options& options,
        std::unique_ptr<LinearCorrection<d>> correction);
  /// Distributed TNNMG on any distributed numbering with another linear correction (collective): the
  /// problem in the halo's local numbering (owned vertices first, their rows complete), u with its
  /// ghosts current; the sweeps in DistributedSweep's order on the problem's own pattern. The
  /// two-body problem of DistributedMultiBody with the distributed DirectCorrection
  /// (docs/architecture.md#distributed-two-body). The halo must outlive the solver.
  TNNMG(const HaloExchange& halo, const Options& options, std::unique_ptr<LinearCorrection<d>> correction);

  std::string name() const override { return "tnnmg"; }
  ContactResult solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) override;

  const Statistics& statistics() const { return statistics_; }
  const Options& options() const { return options_; }
  /// Changes the stopping tolerance of the following solves (everything else is kept; time stepping
  /// with inexact solves, docs/theory.md#dynamic-inexact-solves).
  void setTolerance(double tolerance) { options_.tolerance = tolerance; }

private:
  Options options_;
  Index fineVertices_ = 0;
  std::unique_ptr<LinearCorrection<d>> correction_;
  std::unique_ptr<RotatedProblem<d>> rotated_;  ///< operator of the last solve (see "Operator reuse")
  std::unique_ptr<BlockGaussSeidelSweep<d>> smoother_;  ///< nonsmooth sweep on rotated_->matrix()
  std::uint64_t operatorId_ = 0;                ///< its ContactProblem::operatorId(), 0: none
  bool diagonalTerm_ = false;  ///< the correction holds a friction curvature term (to be cleared)
  double rowSumBound_ = 0;  ///< max_p sum_q ||A~_pq||_F >= ||A~||_2 (round-off scale of w'A~w)
  // distributed (null/-1: serial): the fine level's halo, the ranks, owned vertices, the sweep
  const HaloExchange* halo_ = nullptr;
  const Communicator* comm_ = nullptr;
  Index owned_ = -1;
  DistributedSweep fineSweep_;
  Statistics statistics_;
};

extern template class TNNMG<2>;
extern template class TNNMG<3>;

}  // namespace obs
