#pragma once
/// \file DistributedMultiBody.hpp
/// Bodies coupled by dual mortar, each a DistributedGrid over all ranks, as one distributed contact
/// problem in the transformed unknowns x = (I - C) u (docs/architecture.md#distributed-two-body).
///
/// Stacked numbering. Rank r owns the vertices its parts of the bodies own, body by body, and
/// numbers them consecutively from its offset (the prefix sums over the ranks of their counts), so
/// each rank's owned vertices are one range of the global numbering, as on one body. Locally: the
/// owned vertices of body 0, 1, ..., then the ghosts of body 0, 1, ..., then the *extra ghosts*:
/// vertices of either body outside both ghost layers that the transformed operator couples to an
/// owned vertex (master vertices of a slave row, and, on a master vertex's row, the neighbours of
/// the slave vertices coupled to it).
///
/// The transformed operator (docs/theory.md#mortar-transformation). With T = I + C acting per
/// component (the Dirichlet components of slave vertices left alone, ContactProblem::basisSkip()),
///   (T'AT)_pq = sum_{r,s} T_rp' A_rs T_sq,   (T'b)_p = sum_r T_rp' b_r.
/// Every rank adds the terms of its owned rows r of each body's stiffness (complete on the rank):
/// T_r needs the row of C at r (the rank's own mortar rows), T_s the rows of C at the slave
/// neighbours s, which a ghost's owner sends once. A term whose row p this rank does not own goes
/// to p's owner (one all-to-all). Two passes over the terms: the pattern (the owned rows'
/// columns; the (p, q) of other ranks' rows sent to their owners), then the blocks, summed as they
/// come into T'AT in place and into one buffer per other rank; an owner adds the other ranks'
/// sums in rank order, so no block is stored twice and its owned rows of T'AT and T'b are complete
/// and the same bits for a fixed number of ranks. The rank's ContactProblem is then built on the local numbering with these rows (the
/// ghost rows are identity rows, never read), the local rows of C at its held slave vertices and
/// the constraints of all held slave vertices (from their owners): the Dirichlet elimination and
/// the rotations act as in one process.
#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <memory>
#include <unordered_map>
#include <vector>

#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/HaloExchange.hpp"
#include "obs/obs/MultiBody.hpp"

namespace obs {

/// One body of a distributed multi-body problem: its distributed view (the leaf view) and its
/// system assembled on the view's local mesh (assembleBody: owned rows complete). The constructor
/// reads the systems; they may be released after it, the views must outlive the problem.
template <int d>
struct DistributedBody {
  const DistributedView* view = nullptr;
  const BodySystem<d>* system = nullptr;
};

template <int d>
class DistributedMultiBody {
public:
  /// Collective. `bodies` in stacking order; `mortar` couples body `slaveBody` (its slave surface)
  /// to body `masterBody`, with the surfaces' globalOffset the serial stacked offsets of these
  /// bodies (the sum of the global vertices of the bodies before each). Throws obs::Error on every
  /// rank for inconsistent sizes, indices out of range, or a Dirichlet component of a slave vertex
  /// that ContactProblem refuses.
  DistributedMultiBody(std::vector<DistributedBody<d>> bodies, const DistributedMortar& mortar, int slaveBody,
                       int masterBody);

  int numBodies() const { return static_cast<int>(bodies_.size()); }
  /// The halo of the stacked local numbering (owned first, then body ghosts, then extra ghosts).
  const HaloExchange& halo() const { return *halo_; }
  const Communicator& communicator() const { return halo_->communicator(); }
  Index numOwned() const { return owned_; }
  Index numLocal() const { return static_cast<Index>(global_.size()); }
  /// Stacked global index of each local vertex.
  const std::vector<Index>& global() const { return global_; }
  Index globalVertices() const { return rankOffset_.back(); }
  /// Extra ghosts on this rank (held for the transformed operator only).
  Index extraGhosts() const { return numLocal() - firstExtra_; }
  /// The stacked global indices of the extra ghosts, in local order (the last extraGhosts() of
  /// global()): the fine extra ghosts of the stacked multigrid hierarchy (LinearMultigrid).
  std::vector<Index> extraGhostGlobals() const { return {global_.begin() + firstExtra_, global_.end()}; }
  /// The stacked local index of body b's vertex v (local numbering of its view's halo).
  Index local(int body, Index v) const;
  /// The stacked global index of body b's vertex with global index g (in its view's numbering).
  Index stackedGlobal(int body, Index g) const;
  /// The rank owning a stacked global index.
  int owner(Index stackedGlobal) const;

  /// The rank's contact problem (transformed; owned rows complete, ghost rows identity rows).
  const ContactProblem<d>& problem() const { return *problem_; }
  /// The same, to set its friction (ContactProblem::setFriction, solveFriction).
  ContactProblem<d>& problem() { return *problem_; }
  /// The terms (d x d blocks) of T'AT this rank received from other ranks (the coupling's traffic).
  Index receivedTerms() const { return receivedTerms_; }

  /// Body b's part of a stacked local vector (`components` per vertex), in its view's local
  /// numbering (owned and ghost vertices).
  Eigen::VectorXd bodyPart(int body, const Eigen::VectorXd& stacked, int components) const;
  /// u = (I + C) x on the held vertices (ContactProblem::toDisplacement; the ghosts of x current).
  Eigen::VectorXd toDisplacement(const Eigen::VectorXd& x) const { return problem_->toDisplacement(x); }

  // --- other operators on the same bodies and pair (time stepping, docs/architecture.md#distributed-dynamics) ---
  /// The slave and master body of the pair.
  int slaveBody() const { return slave_; }
  int masterBody() const { return master_; }
  /// The first extra ghost (local index): the vertices below it are the bodies' owned and ghost
  /// vertices.
  Index firstExtraGhost() const { return firstExtra_; }
  /// The constraints of all held slave vertices (the problem's contact set), the local rows of C
  /// (at the owned and ghost slave vertices; none at extra ghosts) and the Dirichlet data of the
  /// held vertices (from their owners), all in the local numbering.
  const ContactSet& contactSet() const { return problem_->contactSet(); }
  const mesh::CsrMatrix& basis() const { return problem_->basisTransformation(); }
  const DirichletValues& dirichlet() const { return dirichlet_; }
  /// Body matrices (each on its view's local mesh, rows of owned vertices complete) as one matrix
  /// in this local numbering (numLocal() rows; an extra ghost's row one zero diagonal block).
  BlockSparseMatrix<d> stack(const std::vector<const BlockSparseMatrix<d>*>& bodies) const;
  /// Body vectors (`components` values per vertex, each in its view's local numbering) as one
  /// vector in this numbering; the extra ghosts' values from their owners (collective). The inverse
  /// of bodyPart().
  Eigen::VectorXd stack(const std::vector<Eigen::VectorXd>& bodies, int components) const;
  /// The transformed problem of another operator of the bodies (collective): `stacked` in this
  /// numbering with complete owned rows whose columns the constructor's operator also couples
  /// (e.g. a time step's M + c tau^2 A on the stiffness' pattern), `load` likewise, `dirichlet`
  /// in this numbering (e.g. dirichlet() with other values). T'AT and T'b are summed as by the
  /// constructor; the problem has this contact set and C. Throws obs::Error on every rank if a term
  /// couples a vertex this rank does not hold.
  std::unique_ptr<ContactProblem<d>> transformed(const BlockSparseMatrix<d>& stacked, const Eigen::VectorXd& load,
                                                 const DirichletValues& dirichlet) const;
  /// (I + sign C')y of a vector y in this numbering whose owned entries are complete (its ghost
  /// entries are ignored): sign = 1 gives T'y (a load on the transformed unknowns), sign = -1 the
  /// forces (I - C')y on the displacements of forces y on the transformed unknowns. The owned
  /// entries complete, the ghosts' those of their owners (collective).
  Eigen::VectorXd transposedProduct(const Eigen::VectorXd& y, double sign = 1.0) const;

private:
  /// A matrix and load whose owned rows enter T'AT and T'b: a body's (body >= 0, its view's local
  /// numbering) or a stacked one (body = -1, this numbering).
  struct Source {
    const BlockSparseMatrix<d>* matrix = nullptr;
    const Eigen::VectorXd* load = nullptr;
    int body = -1;
  };
  /// T'AT (this rank's owned rows; ghost rows identity rows) and T'b (owned rows) of the sources'
  /// owned rows, summed over the ranks (collective). `localOf` gives the local index of a stacked
  /// global one, -1 if the rank does not hold it (an obs::Error on every rank); the constructor's
  /// makes such columns extra ghosts. `received`: the count of blocks other ranks sent.
  void transform(const std::vector<Source>& sources, const std::function<Index(Index)>& localOf,
                 BlockSparseMatrix<d>& out, Eigen::VectorXd& load, Index* received = nullptr) const;

  std::vector<DistributedBody<d>> bodies_;
  std::vector<Index> rankOffset_;                 ///< first stacked global index per rank (+ total)
  std::vector<std::vector<Index>> ownedCounts_;   ///< per body, per rank
  std::vector<Index> ownedStart_, ghostStart_;    ///< per body: first local owned / ghost index
  Index owned_ = 0, firstExtra_ = 0;
  std::vector<Index> global_;
  std::unordered_map<Index, Index> ghostLocal_;   ///< stacked global -> local, ghosts and extras
  std::unique_ptr<HaloExchange> halo_;
  std::unique_ptr<ContactProblem<d>> problem_;
  Index receivedTerms_ = 0;
  int slave_ = 0, master_ = 1;
  /// rows of C at the held slave vertices (stacked global columns; firstExtra_ rows) and the
  /// components the transformation leaves alone (ContactProblem::basisSkip())
  std::vector<std::vector<std::pair<Index, double>>> crow_;
  std::vector<std::uint8_t> skip_;
  DirichletValues dirichlet_;
};

extern template class DistributedMultiBody<2>;
extern template class DistributedMultiBody<3>;

}  // namespace obs
