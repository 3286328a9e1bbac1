#pragma once
/// \file ProjectedGaussSeidel.hpp
/// Nonsmooth block Gauss-Seidel for the rotated contact problem (docs/theory.md#tnnmg-smoother; Graeser,
/// Sack, Sander 2009; Kornhuber 1997):  min 1/2 w'Aw - b'w  s.t.  w_{p,1} <= upper_p.
///
/// Two reusable parts (the TNNMG smoother is exactly this sweep):
///  - BlockLocalSolver<d>: exact minimisation of the energy in one block p with the others fixed,
///      minimise 1/2 v'A_pp v - r'v  s.t. v_1 <= upper_p,   r = b_p - sum_{q != p} A_pq w_q:
///    v = A_pp^{-1} r; if v_1 > upper_p, fix v_1 = upper_p and solve the trailing (d-1) x (d-1) system
///      A_pp[2:d, 2:d] v[2:d] = r[2:d] - A_pp[2:d, 1] upper_p.
///    (A strictly convex function of v restricted to v_1 = upper is minimised there, and because the
///    unconstrained minimiser violates the bound, the constrained minimiser lies on it.)
///    With Tresca friction (RotatedProblem::frictionVertices, setFriction) a friction vertex solves
///      minimise 1/2 v'A_pp v - r'v + s_p |(v - o_p)_T|  s.t. v_1 <= upper_p
///    exactly by solveFrictionBlock (FrictionBlock.hpp) on its free components; the others as above.
///  - BlockGaussSeidelSweep<d>: one sweep over the vertices in order (forward or backward) with the
///    local solver. Each local step minimises exactly, so the energy never increases.
/// ProjectedGaussSeidel<d> iterates sweeps from the projected start as a ContactSolver.
#include <Eigen/Core>

#include <vector>

#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSolver.hpp"

namespace obs {

/// Exact local block solves, with the inverses of the diagonal blocks and of their trailing
/// (d-1) x (d-1) parts computed once per matrix (the bounds can be replaced, setUpper).
template <int d>
class BlockLocalSolver {
public:
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;
  using Tail = Eigen::Matrix<double, d - 1, d - 1>;

  BlockLocalSolver() = default;
  /// Throws obs::Error if a diagonal block is not symmetric positive definite (e.g. a vertex without
  /// cells, or a zero block). upper has one entry per vertex (+inf: no bound).
  BlockLocalSolver(const BlockSparseMatrix<d>& A, std::vector<double> upper);
  /// Replaces the bounds (same matrix; the inverses are kept, the trailing ones are computed for every
  /// vertex). Throws obs::Error for a wrong number of entries.
  void setUpper(std::vector<double> upper);
  /// The friction vertices, bounds and origin of `problem` (whose matrix must be A of the
  /// constructor); replaces those of an earlier call. Without friction: the frictionless solver.
  void setFriction(const BlockSparseMatrix<d>& A, const RotatedProblem<d>& problem);

  /// argmin of 1/2 v'A_pp v - r'v (+ s_p |(v - o_p)_T| at a friction vertex) subject to v_1 <= upper_p.
  Vec solve(Index p, const Vec& r) const {
    if (!slot_.empty() && slot_[p] >= 0) return solveFriction(slot_[p], r, upper_[p]);
    Vec v = inverse_[p] * r;
    if (v[0] > upper_[p]) {
      v[0] = upper_[p];
      v.template tail<d - 1>() = tail_[p] * (r.template tail<d - 1>() - coupling_[p] * upper_[p]);
    }
    return v;
  }
  double upper(Index p) const { return upper_[p]; }

private:
  /// The data of a friction vertex: its diagonal block, bound, origin (normal and prescribed
  /// components zero) and free tangential components (bit a-1: component a).
  struct Friction {
    Mat D;
    Vec origin;
    double slip = 0;
    unsigned freeTangential = 0;
  };
  Vec solveFriction(int f, const Vec& r, double upper) const;

  std::vector<int> slot_;           ///< per vertex: index into friction_, -1 (empty: no friction)
  std::vector<Friction> friction_;
  std::vector<Mat> inverse_;
  std::vector<Tail> tail_;                              ///< (A_pp[2:d,2:d])^{-1}
  std::vector<Eigen::Matrix<double, d - 1, 1>> coupling_;  ///< A_pp[2:d, 1]
  std::vector<double> upper_;
};

/// One nonsmooth block Gauss-Seidel sweep, w <- S(w), for the matrix and bounds the local solver was
/// built for. Works in place on w; `backward` visits the vertices in reverse order. Keeps a reference
/// to A, which must outlive the sweep object.
template <int d>
class BlockGaussSeidelSweep {
public:
  BlockGaussSeidelSweep(const BlockSparseMatrix<d>& A, std::vector<double> upper)
      : A_(A), local_(A, std::move(upper)) {}
  /// New bounds for the same matrix (TNNMG reuses the sweep across solves of one operator).
  void setUpper(std::vector<double> upper) { local_.setUpper(std::move(upper)); }
  /// The friction data of `problem` (built on the same matrix), see BlockLocalSolver::setFriction.
  void setFriction(const RotatedProblem<d>& problem) { local_.setFriction(A_, problem); }
  void sweep(const Eigen::VectorXd& b, Eigen::VectorXd& w, bool backward = false) const;
  /// The same in a given order of the matrix's vertices (a SweepOrder of its pattern or a subset:
  /// DistributedSweep's interior or interface).
  void sweep(const Eigen::VectorXd& b, Eigen::VectorXd& w, const SweepOrder& order, bool backward) const;
  /// A forward sweep on w = 0 (w of the right size, overwritten): the same result as w.setZero();
  /// sweep(b, w), reading only the blocks left of the diagonal (columns are sorted; the others
  /// multiply zeros).
  void sweepFromZero(const Eigen::VectorXd& b, Eigen::VectorXd& w) const;
  const BlockLocalSolver<d>& localSolver() const { return local_; }

private:
  const BlockSparseMatrix<d>& A_;
  BlockLocalSolver<d> local_;
};

/// Projected (nonsmooth block) Gauss-Seidel as a contact solver. One iteration = one forward sweep
/// (or a forward + backward sweep if `symmetric`). Slow (the rate tends to 1 like 1 - c h^2) but
/// robust and monotone; the baseline and the smoother of TNNMG.
template <int d>
class ProjectedGaussSeidel : public ContactSolver<d> {
public:
  struct Options : ContactSolverOptions {
    bool symmetric = false;
  };
  ProjectedGaussSeidel() = default;
  explicit ProjectedGaussSeidel(const Options& options) : options_(options) {}
  std::string name() const override { return "projected-gauss-seidel"; }
  ContactResult solve(const ContactProblem<d>& problem, Eigen::VectorXd& u) override;

private:
  Options options_;
};

extern template class BlockLocalSolver<2>;
extern template class BlockLocalSolver<3>;
extern template class BlockGaussSeidelSweep<2>;
extern template class BlockGaussSeidelSweep<3>;
extern template class ProjectedGaussSeidel<2>;
extern template class ProjectedGaussSeidel<3>;

}  // namespace obs
