#pragma once
/// \file ContactModel.hpp
/// One description of a contact problem for every runner (docs/architecture.md, "Many bodies"):
/// bodies (mesh, material, boundary conditions) and couplings, each either a body against a rigid
/// obstacle (a ContactSet on that body's mesh) or a dual-mortar pair (slave boundary of one body,
/// master boundary of another; MortarCoupling.hpp). assemble() stacks the bodies (MultiBody.hpp),
/// merges the couplings' constraints into one ContactSet over the stacked vertices and builds the
/// ContactProblem with the mortar basis transformation (none if there is no mortar pair), so TNNMG,
/// PDAS and PGS solve every model alike; NewmarkFamily (Newmark.hpp) builds its step problems
/// from assembleParts(). A one-body Signorini problem is the model with one body
/// and one obstacle coupling, and gives the same ContactProblem as ContactProblem(mesh, material,
/// bc, contactSet).
#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/FrictionLaw.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs {

template <int d>
class ContactModel {
public:
  struct Body {
    std::string name;
    const mesh::Mesh* mesh = nullptr;  ///< kept by pointer: must outlive assemble()
    Material material;
    BoundaryConditions bc;
    Index offset = 0;  ///< first stacked vertex (set by assemble())
  };
  struct Coupling {
    std::string label;
    bool mortar = false;
    int body = -1;                     ///< obstacle couplings: the body
    int slave = -1, master = -1;       ///< mortar pairs: the bodies
    int slaveId = 0, masterId = 0;     ///< mortar pairs: boundary ids on the bodies' meshes
    MortarOptions options;
    std::unique_ptr<ContactSet> obstacleSet;  ///< obstacle couplings (on the body's mesh)
    std::unique_ptr<MortarCoupling> coupling; ///< mortar pairs (built by assemble())
    std::vector<Index> nodes;  ///< this coupling's nodes in the merged ContactSet (assemble())
    FrictionLaw friction;      ///< setFriction (default: frictionless)
  };

  /// Adds a body; returns its index.
  int addBody(std::string name, const mesh::Mesh& mesh, const Material& material, BoundaryConditions bc);
  /// A rigid obstacle for body `body`: `set` was built on that body's mesh.
  void addObstacleContact(int body, ContactSet set, std::string label);
  /// A dual-mortar pair between boundary `slaveId` of body `slave` and `masterId` of body `master`.
  void addMortarPair(int slave, int slaveId, int master, int masterId, std::string label,
                     const MortarOptions& options = {});

  /// The friction law of coupling `coupling` (index in couplings()). Throws obs::Error for an
  /// invalid index or a negative or non-finite value.
  void setFriction(int coupling, const FrictionLaw& law);
  /// True if some coupling has friction with a positive value.
  bool frictional() const;

  /// The pieces of the problem before the ContactProblem is formed: the stacked system of the
  /// bodies (stiffness, load, Dirichlet data of the displacements u), the couplings' constraints
  /// merged into one ContactSet over the stacked vertices, and the basis transformation C of the
  /// mortar pairs (rows() == 0 without mortar pairs). The dynamic runner (Newmark.hpp) builds its
  /// step problems from these with its own matrices.
  struct Parts {
    BodySystem<d> system;
    ContactSet contact;
    mesh::CsrMatrix basis;
  };
  /// Stacks the bodies and builds the couplings (sets Body::offset, Coupling::coupling/nodes).
  /// With `skipPrescribedBodies`, a body whose every vertex and component is prescribed (a meshed
  /// rigid or driven body) gets zero diagonal blocks instead of its stiffness: its rows are Dirichlet
  /// rows of the problem, so the solution is the same, and its cells cost nothing (the stiffness is
  /// then not that body's, e.g. for an elastic energy). Throws obs::Error on invalid indices, a vertex
  /// constrained by two couplings, and every error of the parts (MortarCoupling).
  Parts assembleParts(bool skipPrescribedBodies = false);
  /// The constraints of the couplings without the bodies' stiffness: the merged ContactSet over
  /// the stacked vertices and the basis transformation C (the parts of assembleParts() that name
  /// the contact nodes, e.g. for a runner that tracks them before it builds its time stepper).
  /// Sets Body::offset and Coupling::coupling/nodes; throws what assembleParts() throws for them.
  struct Constraints {
    ContactSet contact;
    mesh::CsrMatrix basis;
  };
  Constraints constraints();
  /// assembleParts(true) made into the ContactProblem. Throws what assembleParts() and the
  /// ContactProblem constructor throw.
  ContactProblem<d> assemble();

  const std::vector<Body>& bodies() const { return bodies_; }
  const std::vector<Coupling>& couplings() const { return couplings_; }
  Index numVertices() const { return numVertices_; }

private:
  /// The stacked numbering (Body::offset, numVertices_) and the checks of the bodies' materials and
  /// dimensions.
  void stackBodies();

  std::vector<Body> bodies_;
  std::vector<Coupling> couplings_;
  Index numVertices_ = 0;
};

/// A contact model without meshes: the bodies (name, material, boundary conditions) and the
/// couplings by boundary id, valid on every refinement of the bodies' grids (refinement keeps the
/// boundary ids). makeContactModel builds the ContactModel on the bodies' current meshes; the
/// adaptive loop keeps a specification and builds the model once per step's leaf views, the
/// drivers once per scene (docs/architecture.md#multi-body). Materials, boundary conditions and
/// obstacles are held by pointer and must outlive the specification's use.
struct ContactModelSpec {
  struct Body {
    std::string name;
    const Material* material = nullptr;
    const BoundaryConditions* bc = nullptr;
  };
  struct Coupling {
    std::string label;
    bool mortar = false;
    int body = -1;       ///< obstacle: the body; mortar: the slave body
    int boundaryId = 0;  ///< obstacle: the contact boundary; mortar: the slave boundary
    const Obstacle* obstacle = nullptr;  ///< obstacle couplings
    /// Obstacle couplings: makes the ContactSet on the body's mesh (unset: ContactSet(mesh,
    /// boundaryId, *obstacle); a driver sets it to add the checks and messages of its input).
    std::function<ContactSet(const mesh::Mesh&)> contactSet;
    int master = -1, masterId = 0;  ///< mortar pairs: the master body and boundary
    MortarOptions options;          ///< mortar pairs
    FrictionLaw friction;           ///< frictionless by default

    /// Body `body` against a rigid obstacle on its boundary `boundaryId`.
    static Coupling obstacleContact(int body, const Obstacle& obstacle, int boundaryId, std::string label = {});
    /// A dual-mortar pair between boundary `slaveId` of body `slave` and `masterId` of body `master`.
    static Coupling mortarPair(int slave, int slaveId, int master, int masterId, std::string label,
                               const MortarOptions& options = {});
  };
  std::vector<Body> bodies;
  std::vector<Coupling> couplings;

  /// Adds a body; returns its index.
  int addBody(std::string name, const Material& material, const BoundaryConditions& bc);
  /// Body `body` against a rigid obstacle on its boundary `boundaryId`.
  void addObstacleContact(int body, const Obstacle& obstacle, int boundaryId, std::string label = {});
  /// A dual-mortar pair between boundary `slaveId` of body `slave` and `masterId` of body `master`.
  void addMortarPair(int slave, int slaveId, int master, int masterId, std::string label,
                     const MortarOptions& options = {});
};

/// The ContactModel of `spec` on the bodies' meshes (meshes[i] of spec.bodies[i]; they must outlive
/// the model). An obstacle coupling without label is named by its contact set (boundaryLabel()).
template <int d>
ContactModel<d> makeContactModel(const ContactModelSpec& spec, const std::vector<const mesh::Mesh*>& meshes);

/// The figures of one coupling of a solved model (an obstacle on a body's boundary or a mortar pair),
/// reported per pair by every runner (couplingRecords).
struct CouplingRecord {
  std::string label;                ///< as given to addObstacleContact / addMortarContact
  bool mortar = false;
  int slaveBody = -1;               ///< the constrained body (the obstacle's body for obstacles)
  int masterBody = -1;              ///< -1 for obstacles
  Index slaveVertices = 0;          ///< vertices of the constrained boundary
  Index potentialVertices = 0;      ///< constrained nodes (finite gap, covered by the master)
  Index actualVertices = 0;         ///< in actual contact
  Eigen::Vector3d forceSlave = Eigen::Vector3d::Zero();   ///< total force on the constrained body
  Eigen::Vector3d forceMaster = Eigen::Vector3d::Zero();  ///< on the master body (the obstacle's reaction)
  /// The tangential (friction) force on the constrained body, -sum f_T (ContactOutputs::tangential),
  /// and its contact nodes in stick and in slip (ContactOutputs::state).
  Eigen::Vector3d tangentialSlave = Eigen::Vector3d::Zero();
  Index stickVertices = 0, slipVertices = 0;
  double stickArea = 0;  ///< measure of the faces all of whose nodes stick
  double load = 0;                  ///< sum of the multipliers mu_p
  double pressureMin = 0, pressureMax = 0;  ///< over the actual contact nodes (0 without contact)
  double area = 0;                  ///< measure of the faces with all nodes in contact
  double maxViolation = 0;          ///< max (nu_p'x_p - g_p)^+ of the problem unknowns x
  Index segments = 0, uncovered = 0;  ///< mortar statistics (MortarCoupling::Statistics; segments -1: not counted, as on ranks)
  double mortarSeconds = 0;
};

/// The CouplingRecord of every coupling of `model` (after assemble()/assembleParts()) for the problem
/// unknowns x of the assembled problem and their contact outputs (computeContactOutputs): nodes,
/// forces on both sides (the master's from MortarCoupling::masterForces, equal and opposite), the
/// sum of the multipliers, pressure range and area over the actual contact nodes, mortar statistics.
template <int d>
std::vector<CouplingRecord> couplingRecords(const ContactModel<d>& model, const ContactProblem<d>& problem,
                                            const Eigen::VectorXd& x, const ContactOutputs& outputs);

extern template class ContactModel<2>;
extern template class ContactModel<3>;

}  // namespace obs
