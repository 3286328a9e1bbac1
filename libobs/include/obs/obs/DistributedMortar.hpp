#pragma once
/// \file DistributedMortar.hpp
/// The dual-mortar coupling of two bodies whose grids are distributed over the ranks of a run
/// (docs/architecture.md#distributed-mortar): every rank computes the rows of D, M and the weighted
/// gaps of the slave nodes it owns, the same rows one process computes (MortarCoupling.hpp) up to
/// the order of the sums.
///
/// Construction (collective):
///  1. Slave side. A rank owns a slave node p if it owns the vertex; every cell around an owned
///     vertex is held (owned or ghost), so the slave faces around p, its nodal normal, its face
///     masses and its dual basis functions are all on the rank. The rank's slave surface is the set
///     of slave faces with an owned vertex.
///  2. Extents by reduction: the slave surface's bounding box and largest face (the default search
///     distance, defaultMortarSearchDistance) and the largest coordinate of both surfaces (the gap
///     rounding, MortarOptions::coordinateScale), so that every rank pairs and rounds as one
///     process would.
///  3. Bounding-box search across ranks. Every rank sends its slave surface's box (enlarged by the
///     search distance) to every rank (one all-gather of six numbers), and each master face goes,
///     with its cell, from the rank owning the cell to every rank whose box it meets (one
///     all-to-all). A master face that one process pairs with a face of p meets that face's box
///     enlarged by the search distance, hence the box of the rank owning p.
///  4. Each rank couples its slave surface with the master faces it received (MortarCoupling on
///     the two local meshes) and keeps the rows of its owned slave nodes, their master columns in
///     the global stacked numbering.
///  5. The columns of a rank's rows (masterVertices()) are global indices of master vertices it
///     need not hold. Each column's owner (from the master view's offsets) learns once which of its
///     vertices the rank needs; gatherMaster() then brings their values and addToMaster() sends
///     values back to be added (one message to and from each rank involved).
#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/MortarCoupling.hpp"

namespace obs {

/// One side of a distributed mortar pair: a boundary of one body's distributed view (usually the
/// leaf view) and the offset of that body's global vertices in the global stacked numbering.
struct DistributedMortarSurface {
  const DistributedView* view = nullptr;
  int boundaryId = 0;
  Index globalOffset = 0;
  std::string label;
};

class DistributedMortar {
public:
  /// The row of one owned, constrained slave node.
  struct Row {
    Index local = -1;   ///< the slave vertex in the slave view's local numbering (an owned vertex)
    Index global = -1;  ///< its global stacked index (slave globalOffset + global vertex index)
    Point position, normal;
    double D = 0;         ///< D_pp = sum_q M_pq
    double mass = 0;      ///< int_S phi_p over the whole slave surface
    double gap = 0;       ///< weighted gap
    std::vector<MortarCoupling::Entry> entries;  ///< M_pq, q global stacked master indices, ascending
  };

  /// Collective. Throws obs::Error on every rank if a surface has no face on any rank, the dimensions
  /// differ, or no slave node is covered on any rank (the message gives the distance of the
  /// surfaces' boxes); and with the message of MortarCoupling for a degenerate face or a
  /// non-finite coordinate on any rank.
  DistributedMortar(const DistributedMortarSurface& slave, const DistributedMortarSurface& master,
                    const MortarOptions& options = {});

  /// The owned constrained slave nodes, in ascending local (hence global) order.
  const std::vector<Row>& rows() const { return rows_; }
  /// Constrained slave nodes over all ranks (what one process's MortarCoupling::size() gives).
  long long globalSize() const { return globalSize_; }
  /// The master columns of this rank's rows (global stacked indices, ascending) and their positions.
  const std::vector<Index>& masterVertices() const { return masterVertices_; }
  const std::vector<Point>& masterPositions() const { return masterPositions_; }
  /// Values at the master columns: (masterVertices().size() x components) values of a vector of
  /// the master body in its view's local numbering (`components` per vertex; owned entries used),
  /// from the ranks that own them. Collective (one message to and from each rank involved).
  Eigen::VectorXd gatherMaster(const Eigen::VectorXd& masterLocal, int components) const;
  /// The reverse: adds values at the master columns to their owners' entries of a master-body
  /// vector (local numbering; owned entries changed). Collective.
  void addToMaster(const Eigen::VectorXd& columnValues, Eigen::VectorXd& masterLocal, int components) const;
  /// (C x)_p = sum_q M_pq x_q / D_pp per row (rows().size() x components) of the master values x
  /// (a master-body vector in local numbering): the slave rows of u = (I + C) x. Collective.
  Eigen::VectorXd applyTransformation(const Eigen::VectorXd& masterLocal, int components) const;
  /// masterLocal += C' y, y given per row (rows().size() x components): the master rows of
  /// (I + C)' y. With y_p = mu_p n_p (mu_p the multiplier of row p's bound) these are the forces on
  /// the master body, MortarCoupling::masterForces. Collective.
  void addTransposedTransformation(const Eigen::VectorXd& rowValues, Eigen::VectorXd& masterLocal,
                                   int components) const;
  /// The search distance used (the option's, or the default from the whole slave surface).
  double searchDistance() const { return search_; }
  /// Master faces this rank received (its candidates; a master face can go to several ranks).
  Index receivedMasterFaces() const { return receivedMasterFaces_; }
  /// This rank's local coupling (its slave surface against the master faces it received).
  const MortarCoupling::Statistics& localStatistics() const { return stats_; }

private:
  /// One round of the master-column exchange: owners to the ranks that asked (gatherMaster), or
  /// towardOwners (addToMaster). pack(r) is the message for rank r; use(r, message) takes what came
  /// from rank r, in rank order with this rank's own part in its place.
  void exchangeColumns(bool towardOwners, int components, const std::function<std::vector<double>(std::size_t)>& pack,
                       const std::function<void(std::size_t, const std::vector<double>&)>& use) const;
  /// Throws obs::Error if v does not have the expected size.
  void checkSize(const Eigen::VectorXd& v, Eigen::Index expected, const char* what) const;

  Communicator comm_;
  std::vector<Row> rows_;
  /// The master-column exchange: per rank r, the columns (indices into masterVertices_) that r
  /// owns, and the owned master vertices (local) that r asks for, in r's order.
  std::vector<std::vector<Index>> askedColumns_, sentOwned_;
  Index masterLocalSize_ = 0;
  long long globalSize_ = 0;
  std::vector<Index> masterVertices_;
  std::vector<Point> masterPositions_;
  double search_ = 0;
  Index receivedMasterFaces_ = 0;
  MortarCoupling::Statistics stats_;
};

}  // namespace obs
