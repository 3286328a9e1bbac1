#pragma once
/// \file MultigridHierarchy.hpp
/// The level hierarchy of the geometric multigrid methods (docs/theory.md#multigrid-levels): the
/// spaces of vector-valued P1/Q1 functions on the level views 0 .. L-1 of a Grid and on its leaf
/// view (level L, where the problem lives), the block prolongations P_l = P^s_l (x) I_d from level l
/// to l + 1 (P^s_l the scalar interpolation of Prolongation.hpp), and the Galerkin operators
///   A_l = P_l' A_{l+1} P_l,   l = L-1, ..., 0.
///
/// Finest level: rotations and truncation (docs/theory.md#multigrid-levels). The fine operator is given in
/// the rotated unknowns w_p = Q_p' u_p of the contact problem (A~ = Q'AQ), so the last prolongation
/// is P~ = Q' P_{L-1} (rotations live on the finest level only). A truncation mask marks fine
/// components (Dirichlet components and active bounds, rotated numbering); with T = diag(1 - mask)
///   P~_T = T Q' P_{L-1}   (truncated fine rows zeroed),
///   A~_T = A~ with truncated rows and columns replaced by the identity,
///   A_{L-1} = P~_T' A~_T P~_T = P_{L-1}' B P_{L-1},   B_pq = E_p A~_pq E_q',  E_p = Q_p T_p.
/// Transfers use E_p per fine vertex: restriction r_c = P_{L-1}' (E r), prolongation c += E' P_{L-1} c_c.
/// The coarse operators are recomputed only when the mask changes (coarseUpdates() counts it), and
/// then locally: only the entries (I, J) of A_{L-1} with I or J in the support R of the changed fine
/// vertices change, i.e. the rows of R and of its neighbours; R is the changed set of the next level
/// down. A level whose changed rows exceed a quarter of its rows is recomputed completely.
///
/// Galerkin products: the block pattern of each A_l is computed once per fine operator (symbolic
/// triple product); the full numerical product runs over fine rows, C_p = sum_q B_pq P_q (a sparse
/// accumulator), then A_l(I, J) += P_pI C_pJ; local updates run over the coarse rows to recompute,
/// A_l(I, :) = sum_p P_pI sum_q B_pq P_q. A coarse component whose column of P~_T is zero (all of
/// its fine support truncated) has a zero row and column ("dead"; deadBits(l)). Its diagonal entry
/// is set to the largest live diagonal entry of the level so that the diagonal blocks stay
/// invertible (the restricted defect is zero there), and the component counts as truncated below:
/// the next product is A_{l-1} = P_{l-1}' T_l A_l T_l P_{l-1} and the transfers between levels l-1
/// and l use T_l P_{l-1}, so the patch never acts as stiffness and every A_l is exactly the Galerkin
/// product of the truncated fine problem.
///
/// Several bodies: the hierarchy of several grids is block-stacked, level by level from the finest
/// (the leaf views, numbered in the order of the grids) downwards; a grid with fewer levels keeps its
/// coarsest view (identity prolongation) on the remaining coarse levels.
///
/// Fine basis transformation (two-body contact, ContactProblem.hpp): if the fine unknowns are
/// x = (I - C) u with u the nodal displacements, the last prolongation into the transformed fine
/// space is (I - C) P_{L-1} (Krause 2009): setFineBasis(C) before setFineOperator(); the coarse
/// spaces stay the nodal ones of each body.
///
/// Distributed hierarchy (MultigridHierarchy(const DistributedGrid&); docs/architecture.md#distributed-multigrid):
/// the levels below the partition level L_p are replicated (every rank holds the whole level view;
/// none if L_p = 0),
/// the levels L_p .. L are the rank's parts (DistributedView: owned vertices first, then one layer
/// of ghosts). A rank's prolongation rows are those of its held fine vertices; their coarse parents
/// are held. The restriction and the Galerkin products run over the rank's *owned* fine rows only,
/// so each rank computes its share P' R_r B P of every product (R_r: its owned rows), and the
/// shares are summed: the ghost rows of a distributed level are added to their owners (its owned
/// rows are then complete; its ghost rows are set to identity rows and not used), a
/// replicated level is summed over all ranks (every rank then holds it whole). The dead components
/// of a distributed level are found on the owned rows (the largest live diagonal entry a maximum
/// over the ranks) and given to the ghosts. Vectors of a distributed level are in its local
/// numbering: restrict() returns complete owned entries (ghosts zero); prolongateAdd() needs the
/// coarse ghost entries current and gives complete fine entries, ghosts included. After a
/// truncation change a distributed level is updated locally as serially, the rows next to the
/// changed vertices, by every rank that holds one of them (so that its owner sums fresh shares),
/// unless they are a quarter of the level's rows or more over all ranks; replicated levels are
/// recomputed whole.
///
/// Several distributed bodies (MultigridHierarchy(grids, fineExtras);
/// docs/architecture.md#distributed-two-body-multigrid): stacked level by level as serially, each
/// rank's owned vertices of body 0, 1, ... first, then its ghosts of each body; a body's replicated
/// level inside a distributed stacked level is held whole and owned in consecutive slices. With a
/// fine basis transformation or fine extra ghosts the levels below the fine one grow by extra
/// ghosts in setFineOperator(): the prolongation rows of a level's extra ghosts come from their
/// owners, (I - C) P_{L-1} is formed on the owned fine rows and its other rows come from their
/// owners, and the couplings the pattern join brings to an owner's rows beyond its ghosts become
/// extra ghosts, level by level down to the first replicated one.
///
/// If L = 0 (a grid without refinement) level 0 is the fine level and coarseOperator(0) is the
/// explicit truncated fine matrix A~_T (for the direct coarse solver).
#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/HaloExchange.hpp"

namespace obs {

class DistributedGrid;

/// A local rotation of the fine level: the unknowns of `vertex` are w = Q' u, Q = rotation.
template <int d>
struct VertexRotation {
  Index vertex = -1;
  Eigen::Matrix<double, d, d> rotation;
};

/// The rotations of a contact problem's rotated form (the constraints' Q_p, identities skipped).
template <int d>
std::vector<VertexRotation<d>> problemRotations(const ContactProblem<d>& problem);

template <int d>
class MultigridHierarchy {
public:
  using Mat = Eigen::Matrix<double, d, d>;

  /// The hierarchy of the grid's current state: L = grid.maxLevel(), level views 0 .. L-1 and the
  /// leaf view; builds the scalar prolongations. Throws obs::Error if the grid dimension is not d.
  explicit MultigridHierarchy(const mesh::Grid& grid);
  /// The block-stacked hierarchy of several grids (see the file comment); throws obs::Error if the
  /// list is empty, holds a null grid or grids of another dimension than d.
  explicit MultigridHierarchy(const std::vector<const mesh::Grid*>& grids);

  /// The distributed hierarchy of this rank (see the file comment). Collective. On a communicator
  /// of one (without fine extra ghosts) the serial hierarchy of grid.grid(), for any grid
  /// (docs/architecture.md#one-path). Throws obs::Error if the grid dimension is not d, or, on more
  /// than one rank, if the partition level is 0 and the grid has no refinement.
  /// With partition level 0 the coarsest level is distributed too (no level is replicated; its
  /// solvers use DistributedCoarseSolver).
  explicit MultigridHierarchy(const DistributedGrid& grid);
  /// The block-stacked distributed hierarchy of several bodies (see the file comment), in the
  /// stacked numbering of DistributedMultiBody: on every level a rank's owned vertices of body 0,
  /// 1, ..., then its ghosts of body 0, 1, ...; on the fine level then `fineExtras` (stacked global
  /// indices, DistributedMultiBody's extra ghosts in its order). Collective. Throws obs::Error as
  /// the one-grid constructor, for grids on different numbers of ranks, and for an extra ghost
  /// this rank owns or holds already.
  explicit MultigridHierarchy(const std::vector<const DistributedGrid*>& grids,
                              const std::vector<Index>& fineExtras = {});
  /// Whether the hierarchy is distributed (built from a DistributedGrid on more than one rank).
  bool distributed() const { return !levels_.empty(); }
  /// Vertices of level l owned by this rank: the first ownedVertices(l) of the level's numbering
  /// (all of them in a serial hierarchy and on a replicated level).
  Index ownedVertices(int l) const { return distributed() ? levels_[l].owned : vertices_[l]; }
  /// The halo of a distributed level; nullptr on a replicated level and in a serial hierarchy.
  const HaloExchange* halo(int l) const { return distributed() ? levels_[l].halo.get() : nullptr; }
  /// The ranks of a distributed hierarchy (nullptr: serial).
  const Communicator* communicator() const { return comm_ ? &*comm_ : nullptr; }
  /// Level l's local vertex -> vertex of its view of the rank's grid (empty in a serial hierarchy,
  /// where the numbering is the view's).
  const std::vector<Index>& viewVertices(int l) const;
  /// The global index of each local vertex of a distributed level (owned first; empty on a
  /// replicated level and in a serial hierarchy).
  const std::vector<Index>& globalVertices(int l) const;
  /// The extra ghosts of level l (held for the operators' couplings beyond the ghost layers; the
  /// last ones of the level's numbering): the fine level's given ones, and on the levels below
  /// those setFineOperator() added. 0 on a replicated level and in a serial hierarchy.
  Index extraGhosts(int l) const { return distributedLevel(l) ? vertices_[l] - levels_[l].rows : 0; }

  /// Sets (or with rows == 0 removes) the fine basis transformation C: the last prolongation becomes
  /// (I - C) P_{L-1}. Takes effect at the next setFineOperator(). Throws obs::Error on a wrong size.
  /// Distributed: C in the fine local numbering with its owned rows complete (ContactProblem's
  /// basis transformation on DistributedMultiBody's numbering); a collective call.
  void setFineBasis(const mesh::CsrMatrix& C);

  int maxLevel() const { return static_cast<int>(prolongations_.size()); }
  int numLevels() const { return maxLevel() + 1; }
  Index numVertices(int level) const { return vertices_[level]; }
  /// Scalar prolongation from level l to level l + 1.
  const mesh::CsrMatrix& prolongation(int l) const { return prolongations_[l]; }
  /// For 0 < l < L: one entry per level-l vertex, non-zero where its basis function is new on level l,
  /// i.e. not also a basis function of level l - 1 (docs/theory.md#local-multigrid). A level-l
  /// vertex p keeps the function of a coarse vertex c iff P_{l-1} maps c to p alone with weight 1
  /// (row p of P_{l-1} is e_c and column c is e_p); new vertices and old vertices next to refined
  /// cells are marked. Empty for l = 0 and l = L (the finest level is always smoothed whole).
  const std::vector<char>& newBasis(int l) const { return newBasis_[l]; }

  /// Sets the fine operator (kept by reference, must outlive its use) in the frame given by the
  /// rotations and the initial truncation mask (empty: none; see truncate()), computes the coarse
  /// patterns and operators. Throws obs::Error if A has not numVertices(L) rows.
  void setFineOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>> rotations = {},
                       const std::vector<char>& mask = {});
  bool hasFineOperator() const { return fine_ != nullptr; }
  const BlockSparseMatrix<d>& fineOperator() const { return *fine_; }

  /// Sets the fine truncation mask (one entry per fine component, non-zero = truncated). Returns
  /// the number of components whose truncation changed; if that, or the fine diagonal term below,
  /// changed, the coarse operators are recomputed. changedVertices() lists the fine vertices whose
  /// bits or diagonal term changed.
  Index truncate(const std::vector<char>& mask);
  /// A symmetric positive semidefinite term K added to diagonal blocks of the fine operator, in
  /// its (rotated) frame: the operator of the hierarchy becomes A~ + K, on the finest level (see
  /// fineDiagonal()) and in every Galerkin product, B_pp = E_p (A~_pp + K_p) E_p'. The
  /// curvature of the friction term in the TNNMG correction (docs/theory.md#friction-tnnmg).
  /// The blocks replace the previous ones and take effect at the next truncate(), which recomputes
  /// the coarse operators locally where they changed (one update for both). Throws obs::Error for
  /// a vertex out of range, a repeated vertex, sizes that differ or non-finite entries.
  void setFineDiagonal(std::vector<Index> vertices, std::vector<Mat> blocks);
  /// The diagonal term in force: slot per fine vertex (-1: none) into the blocks, and its vertices.
  const std::vector<Index>& fineDiagonalSlot() const { return diagonalSlot_; }
  const std::vector<Mat>& fineDiagonalBlocks() const { return diagonalBlocks_; }
  const std::vector<Index>& fineDiagonalVertices() const { return diagonalVertices_; }
  /// out += K x on the rows of the diagonal term (x, out: fine vectors).
  void addFineDiagonal(const Eigen::VectorXd& x, Eigen::VectorXd& out) const;
  /// Truncation bits per fine vertex (bit c: component c truncated).
  const std::vector<std::uint8_t>& truncationBits() const { return bits_; }
  const std::vector<Index>& changedVertices() const { return changed_; }
  /// Whether the last truncate() changed bits or the diagonal term anywhere (on any rank of a
  /// distributed hierarchy, where the coarse operators were then recomputed on every rank).
  bool changedAnywhere() const { return changedAnywhere_; }
  /// Components of level l < L without untruncated fine support (bit c: component c), see above.
  const std::vector<std::uint8_t>& deadBits(int l) const { return dead_[l]; }
  Index truncatedComponents() const;

  /// Galerkin operator of level l < L (level 0 if L = 0: the explicit truncated fine operator).
  const BlockSparseMatrix<d>& coarseOperator(int l) const { return coarse_[l]; }
  /// Coarse recomputations since setFineOperator (including the one it does).
  int coarseUpdates() const { return updates_; }
  /// Which rows of coarseOperator(l) the last update recomputed: all (fullUpdate) or updatedRows.
  bool fullUpdate(int l) const { return fullUpdate_[l] != 0; }
  const std::vector<Index>& updatedRows(int l) const { return updatedRows_[l]; }
  /// Coarse block rows recomputed since construction (a measure of the update work).
  long long coarseRowsRecomputed() const { return rowsRecomputed_; }
  /// Time spent in symbolic and numerical Galerkin products since construction.
  double galerkinSeconds() const { return galerkinSeconds_; }

  /// coarse = P~_l' fine: level l + 1 -> level l (truncated and rotated if l + 1 = L).
  void restrict(int l, const Eigen::VectorXd& fine, Eigen::VectorXd& coarse) const;
  /// fine += P~_l coarse: level l -> level l + 1.
  void prolongateAdd(int l, const Eigen::VectorXd& coarse, Eigen::VectorXd& fine) const;

  /// Bytes held by prolongations and coarse operators.
  std::size_t memoryBytes() const;

private:
  /// The serial (block-stacked) hierarchy of the grids (see the one- and several-grid constructors).
  void buildSerial(const std::vector<const mesh::Grid*>& grids);

  /// A level of a distributed hierarchy: owned count, halo (null: replicated), local -> global
  /// index and owner, global -> local of the ghosts, local -> view vertex.
  struct Level {
    Index owned = 0;
    std::shared_ptr<const HaloExchange> halo;
    std::vector<Index> global;
    std::vector<int> owner;
    std::unordered_map<Index, Index> ghostLocal;
    std::vector<Index> viewVertex;
    std::vector<Index> offsets;  ///< the first global index of each rank (+ the total)
    Index base = 0;  ///< held vertices without the extra ghosts the operators' couplings add (widen())
    Index rows = 0;  ///< held vertices whose prolongation rows the rank computes (the others' come from owners)
    Index local(Index g) const;  ///< local index of a global one held here, -1 if not held
    int ownerOf(Index g) const;  ///< the rank owning global index g
  };
  bool distributedLevel(int l) const { return distributed() && levels_[l].halo != nullptr; }
  /// The coarse pattern of level l made whole: a distributed level's ghost rows' columns joined to
  /// their owners' rows; a replicated level below a distributed one joined over all ranks.
  void joinPattern(int l);
  /// The shares of coarse level l summed (as joinPattern), the dead components found. With `rows`
  /// (a distributed level's local update: the rows recomputed on this rank, ascending) only the
  /// ghost rows among them are sent, and the dead components of the owned ones found again;
  /// returns the owned rows outside `rows` whose dead components were patched anew.
  std::vector<Index> sumShares(int l, const std::vector<Index>* rows = nullptr);
  /// The local update of a distributed level l whose finer level changed at the held vertices
  /// `changed` (see computeCoarse); `rows` receives the held rows it recomputed. False, without
  /// changing anything, if it would recompute a quarter of the level's rows or more (over all
  /// ranks).
  bool updateDistributedRows(int l, const std::vector<Index>& changed, const std::vector<Index>* slot,
                             const std::vector<Mat>* E, std::vector<Index>& rows);
  /// Extra ghosts (docs/architecture.md#distributed-two-body-multigrid): with a fine basis
  /// transformation or fine extra ghosts, the levels' held vertices grow below the fine level.
  /// restoreBase() returns to the constructor's levels; widen(l) (before the pattern of level l)
  /// fetches the rows of P_l of level l + 1's extra ghosts from their owners and forms (I - C) P_{L-1};
  /// their coarse columns not held become extra ghosts of level l, as do the columns joinPattern()
  /// brings to the owners' rows; finishLevel(l) renews level l's halo and transposed prolongation.
  void restoreBase();
  void widen(int l);
  void fetchRows(int l, Index first);
  void finishLevel(int l);
  Index addExtra(int l, Index global);
  Index globalOf(int l, Index local) const { return distributedLevel(l) ? levels_[l].global[local] : local; }
  Index localOf(int l, Index global) const { return distributedLevel(l) ? levels_[l].local(global) : global; }
  Index setBits(const std::vector<char>& mask);
  void updateTransforms();
  void computeCoarse(bool local);

  std::vector<Index> vertices_;
  std::vector<std::vector<char>> newBasis_;
  std::vector<mesh::CsrMatrix> prolongations_, transposed_;
  mesh::CsrMatrix plainTop_;  ///< P_{L-1} without the fine basis transformation (if one is set)
  const BlockSparseMatrix<d>* fine_ = nullptr;
  std::vector<BlockSparseMatrix<d>> coarse_;
  std::vector<Mat> rotation_;        ///< per rotated fine vertex
  std::vector<Index> rotationSlot_;  ///< fine vertex -> index into rotation_ or -1
  std::vector<Mat> transform_;       ///< E_p = Q_p T_p per special fine vertex
  std::vector<Index> transformSlot_;  ///< fine vertex -> index into transform_ or -1 (E_p = I)
  std::vector<std::uint8_t> bits_;
  std::vector<std::vector<std::uint8_t>> dead_;  ///< per coarse level: components without fine support
  std::vector<Index> changed_;
  // the fine diagonal term K (setFineDiagonal) in force, and the one set for the next truncate()
  std::vector<Index> diagonalSlot_, diagonalVertices_, pendingVertices_;
  std::vector<Mat> diagonalBlocks_, pendingBlocks_;
  bool pending_ = false;
  std::vector<std::vector<Index>> updatedRows_;
  std::vector<char> fullUpdate_;
  mutable Eigen::VectorXd restrictBuffer_;  ///< the transformed fine defect of a threaded restrict()
  std::vector<Level> levels_;               ///< distributed: per level (empty: serial)
  std::vector<Level> baseLevels_;           ///< distributed: the levels without extra ghosts
  std::vector<mesh::CsrMatrix> baseProlongations_;  ///< distributed: the prolongations of baseLevels_
  mesh::CsrMatrix basis_;                   ///< distributed: the fine basis transformation set
  bool widening_ = false;                   ///< distributed: extra ghosts (fine ones, or a basis) anywhere
  bool changedAnywhere_ = false;
  std::optional<Communicator> comm_;        ///< distributed: the ranks
  long long rowsRecomputed_ = 0;
  int updates_ = 0;
  double galerkinSeconds_ = 0;
};

extern template class MultigridHierarchy<2>;
extern template class MultigridHierarchy<3>;

}  // namespace obs
