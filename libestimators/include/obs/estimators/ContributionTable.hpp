#pragma once
/// \file ContributionTable.hpp
/// Bookkeeping of patch-based estimators (docs/theory.md#element-indicators, thesis Sec. 4.1.1).
///
/// The thesis estimator is defined on vertex patches: eta_k^2 = sum_p eta_{k,p}^2. Every
/// eta_{k,p}^2 is a sum of pieces that each come from one cell e of the patch (an element
/// integral weighted with h_p^2, a face integral weighted with h_p and split between the cells of
/// the face, a node term split over the contact faces at p). The table stores each piece twice,
/// once under its cell and once under its vertex:
///     cell[k][e]   = sum of the pieces of contribution k that come from e  = eta_{k,e}^2
///     vertex[k][p] = sum of the pieces of contribution k at vertex p       = eta_{k,p}^2
/// so that, exactly up to summation order,
///     sum_e eta_e^2 = sum_e sum_k cell[k][e] = sum_k eta_k^2 = sum_k sum_p vertex[k][p].
#include <string>
#include <vector>

#include "obs/estimators/Estimator.hpp"

namespace obs::estimators {

class ContributionTable {
public:
  /// Contributions named `names` (in result order) on a mesh with the given sizes.
  ContributionTable(std::vector<std::string> names, Index numCells, Index numVertices);

  int numContributions() const { return static_cast<int>(names_.size()); }
  const std::vector<std::string>& names() const { return names_; }
  /// Index of a contribution by name; throws obs::Error when unknown.
  int index(const std::string& name) const;

  /// Adds the piece `squared` (>= 0) of eta_{k,vertex}^2 that comes from `cell`.
  void add(int k, Index vertex, Index cell, double squared) {
    cell_[k][cell] += squared;
    vertex_[k][vertex] += squared;
  }
  /// eta_{k,e}^2 and eta_{k,p}^2 accumulated so far.
  double cellSquared(int k, Index cell) const { return cell_[k][cell]; }
  double vertexSquared(int k, Index vertex) const { return vertex_[k][vertex]; }

  /// The result: indicators eta_e = (sum_k cell[k][e])^{1/2}, contributions eta_k, total eta,
  /// cell fields "eta_k" = eta_{k,e}, vertex fields "eta_k" = eta_{k,p} and "eta" = (sum_k
  /// eta_{k,p}^2)^{1/2}. Throws obs::Error if any entry is negative or not finite.
  EstimatorResult result(const std::string& estimator, const MeshStamp& stamp) const;

private:
  std::vector<std::string> names_;
  std::vector<std::vector<double>> cell_;
  std::vector<std::vector<double>> vertex_;
};

}  // namespace obs::estimators
