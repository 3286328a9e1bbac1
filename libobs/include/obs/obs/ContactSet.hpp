#pragma once
/// \file ContactSet.hpp
/// The potential contact nodes N^C of a one-body Signorini problem (docs/theory.md#signorini, thesis Sec.
/// 2.1): the vertices of the boundary faces with one boundary id (Gamma_C), with per node p
///   nu_p   constraint direction, nu_p = obstacle.direction(x_p) normalised;
///   g_p    gap, g_p = obstacle.gap(x_p) (negative: penetration, valid; +infinity: unconstrained);
///   Q_p    local rotation, an orthogonal (Householder) matrix with Q_p e_1 = nu_p, so that in rotated
///          unknowns u~_p = Q_p' u_p the constraint nu_p' u_p <= g_p is the bound u~_{p,1} <= g_p;
///   m_p^C  lumped boundary mass m_p^C = int_{Gamma_C} phi_p (face quadrature of the P1/Q1 traces),
///          which turns the nodal contact force into the discrete pressure s_p = mu_p / m_p^C.
/// The contact faces (with their measures) are kept for contact areas and boundary integrals.
///
/// A ContactSet is geometry only; ContactProblem combines it with the Dirichlet data.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs {

using mesh::Index;

class ContactSet {
public:
  /// A boundary face of Gamma_C: its contact nodes (indices into this set) and its measure.
  struct Face {
    std::vector<Index> nodes;
    double measure = 0;
  };

  /// Potential contact boundary = the vertices of the boundary faces with id `boundaryId` and the
  /// mesh's boundary vertices with that id (Mesh::addBoundaryVertex; boundary mass 0). Throws obs::Error if no
  /// face has this id, if the obstacle is made for another dimension than the mesh, or if the
  /// obstacle returns a NaN or -infinity gap or a zero / non-finite direction at a contact vertex.
  /// Throws obs::Error if no boundary face has the id, unless `allowEmpty` (a rank's local mesh of a
  /// distributed grid may have none; the caller checks the set over all ranks).
  ContactSet(const mesh::Mesh& mesh, int boundaryId, const Obstacle& obstacle, bool allowEmpty = false);
  /// The same for a named boundary; throws obs::Error if the mesh has no boundary of that name.
  ContactSet(const mesh::Mesh& mesh, const std::string& boundaryName, const Obstacle& obstacle);

  /// The data of a set built elsewhere (e.g. the slave nodes of a mortar coupling, over the stacked
  /// vertices of several bodies). Rotations are computed from the directions.
  struct Data {
    int dimension = 0;
    std::string label, obstacleName;
    Index numMeshVertices = 0;
    std::vector<Index> vertices;  ///< increasing
    std::vector<Point> positions, directions;
    std::vector<double> gaps, masses;
    std::vector<Face> faces;
  };
  /// Throws obs::Error on inconsistent sizes, unsorted or out-of-range vertices, non-unit or
  /// non-finite directions, NaN gaps or non-positive masses.
  explicit ContactSet(Data data);

  int dimension() const { return dim_; }
  int boundaryId() const { return boundaryId_; }
  /// Boundary name (from the mesh) or "id <n>", for messages.
  const std::string& boundaryLabel() const { return label_; }
  const std::string& obstacleName() const { return obstacleName_; }

  /// Number of potential contact nodes.
  Index size() const { return static_cast<Index>(vertices_.size()); }
  /// Mesh vertex of contact node k (nodes are in increasing vertex order).
  Index vertex(Index k) const { return vertices_[k]; }
  const std::vector<Index>& vertices() const { return vertices_; }
  /// Contact node of mesh vertex v, or -1.
  Index nodeOf(Index v) const { return v < static_cast<Index>(nodeOf_.size()) ? nodeOf_[v] : -1; }
  /// Number of mesh vertices this set was built for.
  Index numMeshVertices() const { return static_cast<Index>(nodeOf_.size()); }

  const Point& position(Index k) const { return positions_[k]; }
  /// Unit constraint direction nu_p (z = 0 in 2D).
  const Point& direction(Index k) const { return directions_[k]; }
  double gap(Index k) const { return gaps_[k]; }
  /// Lumped boundary mass m_p^C.
  double boundaryMass(Index k) const { return masses_[k]; }
  /// Householder rotation Q_p (3 x 3; in 2D the top-left 2 x 2 block, Q_p e_3 = e_3).
  const Eigen::Matrix3d& rotation(Index k) const { return rotations_[k]; }

  const std::vector<Face>& faces() const { return faces_; }
  /// Measure of Gamma_C (sum of the face measures = sum of the m_p^C).
  double measure() const;

private:
  void build(const mesh::Mesh& mesh, const Obstacle& obstacle, bool allowEmpty);

  int dim_ = 0;
  int boundaryId_ = 0;
  std::string label_, obstacleName_;
  std::vector<Index> vertices_, nodeOf_;
  std::vector<Point> positions_, directions_;
  std::vector<double> gaps_, masses_;
  std::vector<Eigen::Matrix3d> rotations_;
  std::vector<Face> faces_;
};

/// Orthogonal Q with Q e_1 = nu for a unit vector nu (a Householder reflection; for nu_1 > 0 the
/// reflection about e_1 + nu with its first column negated, for stability). In 2D pass nu with z = 0;
/// then Q e_3 = e_3.
Eigen::Matrix3d householderRotation(const Point& nu);

}  // namespace obs
