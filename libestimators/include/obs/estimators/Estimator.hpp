#pragma once
/// \file Estimator.hpp
/// The interface of a posteriori error estimators (docs/architecture.md#libestimators,
/// in the spirit of MFEM's `ErrorEstimator`): from the discrete problem and its solution an
/// estimator computes one non-negative indicator eta_e per cell with
///     eta^2 = sum_e eta_e^2 = sum_k eta_k^2,
/// the named contributions eta_k (e.g. eta_1 ... eta_5 of the residual estimator,
/// docs/theory.md#contact-estimator), and
/// per-vertex / per-cell fields for visualisation. The result records which mesh it was computed
/// for (a MeshStamp), so a result that is used after the mesh changed is detected.
///
/// Sample use:
///   auto estimator = obs::estimators::EstimatorRegistry::global().create("residual");
///   obs::estimators::EstimatorInput in(mesh, material, bc, solution.displacement);
///   const auto result = estimator->estimate(in);
///   const auto marked = obs::estimators::markMeanValue(result.indicators, 1.1);
#include <Eigen/Core>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Material.hpp"

namespace obs {
class ContactSet;
struct ContactOutputs;
class Obstacle;
}  // namespace obs

namespace obs::estimators {

using mesh::Index;

/// Identifies one state of a mesh: its sizes, a 64-bit hash (FNV-1a over values) of dimension, cell
/// types, connectivity, boundary faces and vertex coordinates, and an optional revision number given
/// by the caller (e.g. a grid's refinement counter; 0 = none).
struct MeshStamp {
  int dimension = 0;         ///< of the mesh
  Index numVertices = 0;     ///< of the mesh
  Index numCells = 0;        ///< of the mesh
  std::uint64_t hash = 0;    ///< FNV-1a (over values) of the mesh content
  std::uint64_t revision = 0;  ///< the caller's revision number (0: none)

  /// Same mesh content (sizes and hash); the revision is not compared.
  bool sameMesh(const MeshStamp& other) const {
    return dimension == other.dimension && numVertices == other.numVertices &&
           numCells == other.numCells && hash == other.hash;
  }
  /// Same content and revision.
  bool operator==(const MeshStamp&) const = default;
};

/// The stamp of a mesh (linear in the mesh size).
MeshStamp meshStamp(const mesh::Mesh& mesh, std::uint64_t revision = 0);

/// Contact data of a Signorini solution, for contact estimators (docs/theory.md#estimator-contributions). The
/// pointers are not owned; any of them may be null. `residual` uses only `set` (its boundary id is
/// treated as potential contact boundary, its directions nu_p split sigma n into eta_4 / eta_5);
/// `contact-residual` (ContactResidualEstimator.hpp) also the pressures s_p of `outputs` (required
/// once a node is in actual contact) and the exact gap of `obstacle` (eta_7, eta_8; required with a
/// set).
///
/// Two-body contact (docs/theory.md#two-body-estimator): on the slave side of a mortar pair, `set`
/// holds the slave nodes with their mortar normals, the gaps relative to the displaced master
/// (g_p + n_p'(C u)_p) and D_pp, `outputs` the dual-mortar pressures lambda_p, and `obstacle` the
/// pointwise gap of the linearised constraint (distance along the slave face normal to the master
/// faces plus the master displacement there). On the master side, `masterTraction` is the
/// contact traction the mortar coupling exerts on the body, by vertex (vertex-major, d entries per
/// vertex: nodal force / int phi_q), on the boundary faces with an id in `masterBoundaryIds`;
/// `contact-residual` measures sigma(u_h) n against it there, `residual` ignores it.
struct ContactData {
  const ContactSet* set = nullptr;          ///< potential contact nodes N^C, nu_p, g_p, m_p^C
  const ContactOutputs* outputs = nullptr;  ///< actual contact, multipliers, pressures s_p
  const Obstacle* obstacle = nullptr;       ///< the exact gap g (eta_7, eta_8)
  const Eigen::VectorXd* masterTraction = nullptr;  ///< master side of mortar pairs (see above)
  std::vector<int> masterBoundaryIds{};             ///< the faces masterTraction acts on
  /// True if the contact has friction: outputs->tangential are then friction forces, and
  /// `contact-residual` measures the tangential boundary stress against their traction instead of
  /// against zero (docs/theory.md#friction-estimators).
  bool friction = false;
  /// The scale U of the relative contact tolerance (classifyContactNodes); 0: from the input's
  /// displacement and the set's gaps. A distributed run gives the scale over all ranks, so that a
  /// rank classifies its nodes as one process does.
  double contactScale = 0;
};

/// What an estimator needs: the problem (mesh, material, boundary conditions) and the discrete
/// displacement u_h (vertex-major, u[v*d + c]). The members are references: the objects must
/// outlive the input.
struct EstimatorInput {
  /// The four required inputs; the optional members below keep their defaults.
  EstimatorInput(const mesh::Mesh& mesh, const Material& material, const BoundaryConditions& bc,
                 const Eigen::VectorXd& displacement)
      : mesh(mesh), material(material), boundaryConditions(bc), displacement(displacement) {}

  const mesh::Mesh& mesh;                        ///< the mesh of the solution
  const Material& material;                      ///< Lame parameters of sigma(u_h)
  const BoundaryConditions& boundaryConditions;  ///< f, Neumann data (J^N), Dirichlet faces
  const Eigen::VectorXd& displacement;           ///< u_h, vertex-major

  /// Boundary ids of the potential contact boundary Gamma_C. `residual` treats these faces as a
  /// traction-free Neumann boundary (docs/theory.md#residual-estimator, thesis remark after (3.14)); any
  /// Neumann or Dirichlet data on them is ignored except Dirichlet-fixed components. The id of contact->set
  /// is added automatically.
  std::vector<int> contactBoundaryIds;
  /// Optional contact data (see ContactData).
  const ContactData* contact = nullptr;
  /// Recorded in the result's stamp (0 = none).
  std::uint64_t meshRevision = 0;
};

/// A named contribution eta_k and its value.
struct Contribution {
  std::string name;  ///< e.g. "eta_1"
  double value = 0;  ///< eta_k = (sum_p eta_{k,p}^2)^{1/2}
};

/// The output of an estimator.
struct EstimatorResult {
  std::string estimator;            ///< name of the estimator that computed it
  MeshStamp stamp;                  ///< the mesh it belongs to
  std::vector<double> indicators;   ///< eta_e >= 0 per cell
  double total = 0;                 ///< eta = (sum_e eta_e^2)^{1/2}
  std::vector<Contribution> contributions;  ///< eta_k, in the estimator's order
  /// Per-cell values eta_{k,e} of each contribution (sum_k eta_{k,e}^2 = eta_e^2), by name.
  std::map<std::string, std::vector<double>> cellFields;
  /// Per-vertex fields for visualisation (size numVertices each), e.g. the patch values eta_{k,p}.
  std::map<std::string, Eigen::VectorXd> vertexFields;

  /// True if this result was computed for `mesh` (same sizes and content hash).
  bool validFor(const mesh::Mesh& mesh) const;
  /// ... and for the given revision number.
  bool validFor(const mesh::Mesh& mesh, std::uint64_t revision) const;
  /// Throws obs::Error (naming the mesh sizes) unless validFor(mesh).
  void requireValidFor(const mesh::Mesh& mesh) const;
  /// Value of a named contribution; throws obs::Error listing the names when unknown.
  double contribution(const std::string& name) const;
};

/// An a posteriori error estimator. Implementations are stateless with respect to the problem:
/// estimate() may be called for any number of inputs.
class Estimator {
public:
  virtual ~Estimator() = default;
  /// Registry name, e.g. "residual".
  virtual std::string name() const = 0;
  /// One line for `obs estimators`.
  virtual std::string description() const = 0;
  /// Computes indicators and contributions; throws obs::Error on inconsistent input.
  virtual EstimatorResult estimate(const EstimatorInput& input) const = 0;
};

/// Checks what every estimator needs: displacement size = numVertices * dimension, finite values,
/// a valid material. Throws obs::Error saying what is wrong.
void validateInput(const EstimatorInput& input, const std::string& estimatorName);

}  // namespace obs::estimators
