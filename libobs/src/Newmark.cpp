#include "obs/obs/Newmark.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultiBody.hpp"

namespace obs {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

double seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

bool hasPredictorInDisplacement(NewmarkScheme s) {  // alpha + beta = 1
  return s == NewmarkScheme::ContactStabilized || s == NewmarkScheme::ImprovedContactStabilized ||
         s == NewmarkScheme::AlphaHalf || s == NewmarkScheme::AlphaOneZero;
}

/// Block-diagonal stacking of scalar matrices (one per body), body i's vertex v at index
/// vertices[i][v] (one matrix in its own numbering: itself).
ScalarSparseMatrix stackScalar(const std::vector<ScalarSparseMatrix>& parts, const std::vector<std::vector<Index>>& vertices,
                               Index size) {
  if (parts.size() == 1 && parts.front().rows() == size) return parts.front();
  std::vector<Eigen::Triplet<double>> t;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::vector<Index>& at = vertices[i];
    for (Eigen::Index r = 0; r < parts[i].outerSize(); ++r)
      for (ScalarSparseMatrix::InnerIterator it(parts[i], r); it; ++it)
        t.emplace_back(at[static_cast<std::size_t>(it.row())], at[static_cast<std::size_t>(it.col())], it.value());
  }
  ScalarSparseMatrix m(size, size);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

}  // namespace

const std::vector<NewmarkScheme>& allNewmarkSchemes() {
  static const std::vector<NewmarkScheme> all{
      NewmarkScheme::Classical,          NewmarkScheme::ContactImplicit,
      NewmarkScheme::ContactStabilized,  NewmarkScheme::ImprovedContactStabilized,
      NewmarkScheme::AlphaHalf,          NewmarkScheme::AlphaOneZero,
      NewmarkScheme::LaursenChawla,      NewmarkScheme::KhenousLabordeRenard,
      NewmarkScheme::HagerHuebnerWohlmuth, NewmarkScheme::HagerHuebnerWohlmuthNonPenetration};
  return all;
}

std::string_view name(NewmarkScheme scheme) {
  switch (scheme) {
    case NewmarkScheme::Classical: return "classical";
    case NewmarkScheme::ContactImplicit: return "contact-implicit";
    case NewmarkScheme::ContactStabilized: return "contact-stabilized";
    case NewmarkScheme::ImprovedContactStabilized: return "improved-contact-stabilized";
    case NewmarkScheme::AlphaHalf: return "alpha-half";
    case NewmarkScheme::AlphaOneZero: return "alpha-one-zero";
    case NewmarkScheme::LaursenChawla: return "laursen-chawla";
    case NewmarkScheme::KhenousLabordeRenard: return "khenous-laborde-renard";
    case NewmarkScheme::HagerHuebnerWohlmuth: return "hager-huebner-wohlmuth";
    case NewmarkScheme::HagerHuebnerWohlmuthNonPenetration: return "hager-huebner-wohlmuth-nonpenetration";
  }
  return "?";
}

NewmarkScheme newmarkSchemeFromName(std::string_view n) {
  std::string valid;
  for (NewmarkScheme s : allNewmarkSchemes()) {
    if (name(s) == n) return s;
    valid += (valid.empty() ? "" : ", ") + std::string(name(s));
  }
  throw Error("unknown time stepping scheme '" + std::string(n) + "' (valid: " + valid + ")");
}

std::string_view name(NewmarkStart start) {
  switch (start) {
    case NewmarkStart::Predictor: return "predictor";
    case NewmarkStart::PreviousIncrement: return "previous-increment";
  }
  return "?";
}

NewmarkStart newmarkStartFromName(std::string_view n) {
  for (NewmarkStart s : {NewmarkStart::Predictor, NewmarkStart::PreviousIncrement})
    if (name(s) == n) return s;
  throw Error("unknown warm start '" + std::string(n) + "' (valid: predictor, previous-increment)");
}

bool usesRedistributedMass(NewmarkScheme s) {
  return s == NewmarkScheme::KhenousLabordeRenard || s == NewmarkScheme::HagerHuebnerWohlmuth ||
         s == NewmarkScheme::HagerHuebnerWohlmuthNonPenetration;
}

bool usesPersistency(NewmarkScheme s) {
  return s == NewmarkScheme::LaursenChawla || s == NewmarkScheme::HagerHuebnerWohlmuth;
}

// --- NewmarkFamily -------------------------------------------------------------------------------

template <int d>
struct NewmarkFamily<d>::Predictor {
  std::vector<char> active;     ///< per contact node
  std::vector<double> tauStar;  ///< local impact time
  std::vector<double> delta;    ///< (tau* - tau) nu'v^n = normal predictor correction (<= 0)
  std::vector<double> mu;       ///< mortar: multipliers of the projection (>= 0)
  std::vector<double> rowMu;    ///< mortar: the same per row of PredictorRows (every rank's)
};

/// The constraint rows of B (mortar) of every rank, in rank order and, on a rank, in the order of
/// its owned bounded constraints (serial: all, in constraint order): row k is nu_p'x_p with
/// x_p = u_p - sum_j C_pj u_j, i.e. the entries (p, 1) and (j, -C_pj), all along nu_p. The vertices
/// of the rows are numbered compactly (every rank the same numbering), so that every rank runs the
/// serial Hildreth iteration over all rows (the rows share master vertices across ranks).
template <int d>
struct NewmarkFamily<d>::PredictorRows {
  struct Row {
    Eigen::Matrix<double, d, 1> direction;
    double diagonal = 0;  ///< (B M^{-1} B')_kk over the free components
    std::vector<std::pair<Index, double>> entries;  ///< (compact vertex, coefficient)
  };
  std::vector<Row> rows;
  std::vector<double> mass;          ///< per compact vertex: its lumped mass
  std::vector<std::uint8_t> fixed;   ///< per compact vertex: its Dirichlet components (bit a)
  std::vector<Index> local;          ///< per compact vertex: the stepper's index (-1: not held)
  std::vector<std::size_t> own;      ///< the constraint of each of this rank's rows
  std::size_t first = 0;             ///< the index of this rank's first row
};

template <int d>
NewmarkFamily<d>::NewmarkFamily(const mesh::Grid& grid, const Material& material, const BoundaryConditions& bc,
                                const ContactSet& contact, const NewmarkOptions& options)
    : options_(options) {
  if (grid.dimension() != d)
    throw Error("time stepping: the grid has dimension " + std::to_string(grid.dimension()) + ", the stepper " +
                std::to_string(d));
  const mesh::Mesh mesh = grid.leafView().mesh;
  if (contact.dimension() != d || contact.numMeshVertices() != mesh.numVertices())
    throw Error("time stepping: the contact set " + contact.boundaryLabel() + " was built for another mesh (" +
                std::to_string(contact.numMeshVertices()) + " vertices; the leaf mesh of the grid has " +
                std::to_string(mesh.numVertices()) + ")");
  // one body against an obstacle: the contact model with one body and one obstacle coupling
  ContactModel<d> model;
  model.addBody("body", mesh, material, bc);
  model.addObstacleContact(0, contact, contact.boundaryLabel());
  init({&grid}, model);
}

template <int d>
NewmarkFamily<d>::NewmarkFamily(const std::vector<const mesh::Grid*>& grids, ContactModel<d>& model,
                                const NewmarkOptions& options)
    : options_(options) {
  init(grids, model);
}

template <int d>
NewmarkFamily<d>::NewmarkFamily(const DistributedGrid& grid, const DistributedView& leaf, ContactModel<d>& model,
                                const NewmarkOptions& options)
    : NewmarkFamily(std::vector<const DistributedGrid*>{&grid}, std::vector<const DistributedView*>{&leaf}, model,
                    options) {}

template <int d>
NewmarkFamily<d>::NewmarkFamily(const std::vector<const DistributedGrid*>& grids,
                                const std::vector<const DistributedView*>& leaves, ContactModel<d>& model,
                                const NewmarkOptions& options, const DistributedMultiBody<d>* coupled)
    : options_(options), multi_(coupled) {
  if (grids.empty() || !grids.front()) throw Error("time stepping: no distributed grid");
  comm_ = &grids.front()->communicator();
  comm_->collective([&] {
    const auto& bodies = model.bodies();
    if (grids.size() != bodies.size() || leaves.size() != bodies.size())
      throw Error("time stepping: " + std::to_string(grids.size()) + " distributed grids and " +
                  std::to_string(leaves.size()) + " views for a contact model of " + std::to_string(bodies.size()) +
                  " bodies");
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      if (!grids[i] || !leaves[i]) throw Error("time stepping: the grid or view of body " + std::to_string(i) + " is not given");
      if (grids[i]->grid().dimension() != d)
        throw Error("time stepping: the grid has dimension " + std::to_string(grids[i]->grid().dimension()) +
                    ", the stepper " + std::to_string(d));
      if (bodies[i].mesh->numVertices() != leaves[i]->local.numVertices())
        throw Error("time stepping: body '" + bodies[i].name + "' of the distributed contact model is not on the rank's "
                    "local mesh (" + std::to_string(bodies[i].mesh->numVertices()) + " vertices, the local mesh has " +
                    std::to_string(leaves[i]->local.numVertices()) + ")");
    }
    std::size_t pairs = 0;
    for (const auto& c : model.couplings()) pairs += c.mortar ? 1 : 0;
    if (!coupled) {
      if (bodies.size() != 1 || pairs > 0)
        throw Error("time stepping: a distributed contact model of " + std::to_string(bodies.size()) + " bodies and " +
                    std::to_string(pairs) + " mortar pairs needs their DistributedMultiBody (one body: obstacles only)");
      return;
    }
    const auto& cs = model.couplings();
    if (bodies.size() != 2 || cs.size() != 1 || !cs.front().mortar || coupled->numBodies() != 2 ||
        cs.front().slave != coupled->slaveBody() || cs.front().master != coupled->masterBody())
      throw Error("time stepping: distributed bodies are two bodies with one mortar pair, the pair of their "
                  "DistributedMultiBody (got " + std::to_string(bodies.size()) + " bodies, " + std::to_string(cs.size()) +
                  " couplings)");
    if (model.frictional())
      throw Error("time stepping: friction on a mortar pair is not distributed yet (run it without mpirun)");
  });
  halo_ = multi_ ? &multi_->halo() : &leaves.front()->halo;
  owned_ = halo_->numOwned();
  std::vector<const mesh::Grid*> serial;
  for (const DistributedGrid* g : grids) serial.push_back(&g->grid());
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    std::vector<Index> at(static_cast<std::size_t>(leaves[i]->halo.numLocal()));
    for (Index v = 0; v < static_cast<Index>(at.size()); ++v) at[v] = multi_ ? multi_->local(static_cast<int>(i), v) : v;
    bodyVertices_.push_back(std::move(at));
    bodyOwned_.push_back(leaves[i]->halo.numOwned());
  }
  init(serial, model, grids);
}

template <int d>
void NewmarkFamily<d>::init(const std::vector<const mesh::Grid*>& grids, ContactModel<d>& model,
                            const std::vector<const DistributedGrid*>& distributed) {
  std::optional<typename ContactModel<d>::Parts> assembled;
  std::vector<BodySystem<d>> systems;  // distributed bodies coupled by mortar: each on its local mesh
  collective([&] {
    checkInputs(grids, model);
    if (multi_) {
      // the bodies' systems on their local meshes, stacked below in the coupling's numbering (its
      // constraints and C are those of the pair: assembleParts() would couple the local meshes)
      for (const auto& b : model.bodies()) systems.push_back(assembleBody<d>(*b.mesh, b.material, b.bc));
      numVertices_ = multi_->numLocal();
    } else {
      assembled.emplace(model.assembleParts());
      numVertices_ = assembled->system.numVertices();
    }
    if (!comm_) {
      owned_ = numVertices_;
      for (const auto& b : model.bodies()) {
        std::vector<Index> at(static_cast<std::size_t>(b.mesh->numVertices()));
        for (Index v = 0; v < static_cast<Index>(at.size()); ++v) at[v] = b.offset + v;
        bodyVertices_.push_back(std::move(at));
        bodyOwned_.push_back(-1);
      }
    }
    for (Index v : options_.trackedVertices)
      if (v < (comm_ ? -1 : 0) || v >= owned_)
        throw Error("time stepping: tracked vertex " + std::to_string(v) + " is not " +
                    (comm_ ? "-1 or an owned vertex of the rank (0.." : "a vertex of the mesh (0..") +
                    std::to_string(owned_ - 1) + ")");
  });
  if (multi_) {  // collective (the extra ghosts' loads from their owners)
    A_ = multi_->stack({&systems[0].stiffness, &systems[1].stiffness});
    f_ = multi_->stack({systems[0].load, systems[1].load}, d);
    systems.clear();
    dirichlet_ = multi_->dirichlet();
    basis_ = multi_->basis();
  } else {
    typename ContactModel<d>::Parts& parts = *assembled;
    A_ = std::move(parts.system.stiffness);
    f_ = std::move(parts.system.load);
    dirichlet_ = std::move(parts.system.dirichlet);
    basis_ = std::move(parts.basis);
  }
  const ContactSet& contact = multi_ ? multi_->contactSet() : assembled->contact;
  assembleMasses(model, contact);  // collective with redistribution
  BlockSparseMatrix<d> S;
  collective([&] {
    S = stepMatrix(contact);
    contact_ = std::make_unique<ContactSet>(contact);
    friction_ = nodalFriction(model, contact);
    // the model's couplings decide, the same on every rank (a rank may hold no contact node)
    frictional_ = model.frictional() && !friction_.bound.empty();
    S_ = S;
    // From here on the matrices are only read: on grids of repeated cells their products (S base and
    // A u^{n+1} in every step) read a block number per entry instead of a block (the same values and
    // bits, docs/performance.md#shared-blocks)
    for (BlockSparseMatrix<d>* m : {&A_, &M_, &Mr_, &S_}) m->shareRepeatedBlocks();
  });
  setupStepProblem(std::move(S));  // collective
  frictional_ = anyRank(frictional_);
  typename TNNMG<d>::Options so = tnnmgOptions<d>(options_.solver);
  so.recordHistory = false;
  if (multi_)  // the stacked distributed hierarchy with the coupling's extra ghosts (collective)
    solver_ = std::make_unique<TNNMG<d>>(
        multi_->halo(), so, std::make_unique<LinearMultigrid<d>>(distributed, multi_->extraGhostGlobals(), so.multigrid));
  else if (!distributed.empty())
    solver_ = std::make_unique<TNNMG<d>>(*distributed.front(), so);  // collective
  else
    solver_ = grids.size() == 1 ? std::make_unique<TNNMG<d>>(*grids.front(), so) : std::make_unique<TNNMG<d>>(grids, so);
}

template <int d>
void NewmarkFamily<d>::collective(const std::function<void()>& work) const {
  if (comm_)
    comm_->collective(work);
  else
    work();
}

template <int d>
void NewmarkFamily<d>::sum(std::vector<double>& x) const {
  if (comm_) comm_->sum(x);
}

template <int d>
double NewmarkFamily<d>::maximum(double x) const {
  return comm_ ? comm_->max(x) : x;
}

template <int d>
bool NewmarkFamily<d>::anyRank(bool flag) const {
  return comm_ ? comm_->max(flag ? 1.0 : 0.0) > 0 : flag;
}

template <int d>
double NewmarkFamily<d>::dot(const Eigen::VectorXd& x, const Eigen::VectorXd& y) const {
  const Eigen::Index n = static_cast<Eigen::Index>(owned_) * d;
  const double local = x.head(n).dot(y.head(n));
  return comm_ ? comm_->sum(local) : local;
}

template <int d>
void NewmarkFamily<d>::updateGhosts(Eigen::VectorXd& x) const {
  if (halo_ && x.size() == static_cast<Eigen::Index>(numVertices_) * d) halo_->update(x, d);
}

template <int d>
void NewmarkFamily<d>::checkInputs(const std::vector<const mesh::Grid*>& grids, const ContactModel<d>& model) const {
  const NewmarkOptions& options = options_;
  const double tau = options.timeStep;
  if (!std::isfinite(tau) || tau <= 0)
    throw Error("time stepping: the time step tau must be positive and finite, got " + num(tau));
  const auto& bodies = model.bodies();
  if (bodies.empty() || grids.size() != bodies.size())
    throw Error("time stepping: " + std::to_string(grids.size()) + " grids for a contact model of " +
                std::to_string(bodies.size()) + " bodies");
  for (const auto& b : bodies) b.material.validate();
  for (std::size_t i = 0; i < grids.size(); ++i) {
    if (!grids[i] || grids[i]->dimension() != d)
      throw Error("time stepping: the grid of body '" + bodies[i].name + "' has dimension " +
                  std::to_string(grids[i] ? grids[i]->dimension() : 0) + ", the stepper " + std::to_string(d));
    if (!comm_ && grids[i]->leafView().mesh.numVertices() != bodies[i].mesh->numVertices())
      throw Error("time stepping: the grid of body '" + bodies[i].name + "' does not carry the body's mesh (" +
                  std::to_string(grids[i]->leafView().mesh.numVertices()) + " leaf vertices, the mesh has " +
                  std::to_string(bodies[i].mesh->numVertices()) + ")");
  }
  const NewmarkScheme scheme = options.scheme;
  if (options.mass == MassKind::Consistent && hasPredictorInDisplacement(scheme))
    throw Error("time stepping: scheme '" + std::string(obs::name(scheme)) +
                "' needs the lumped mass matrix (its predictor is a node-wise projection); use mass = lumped");
  if (options.activeTolerance < 0 || !std::isfinite(options.activeTolerance))
    throw Error("time stepping: active tolerance must be non-negative and finite");
  if (!(options.predictorTolerance > 0) || options.maxPredictorSweeps < 1)
    throw Error("time stepping: the predictor tolerance must be positive and the sweep cap at least 1");
  if (options.solver.kind != ContactSolverKind::TNNMG)
    throw Error("time stepping: the step solver is TNNMG, got " + std::string(obs::name(options.solver.kind)));
  if (!(options.inexactFraction >= 0 && options.inexactFraction < 1))
    throw Error("time stepping: the inexact fraction must lie in [0, 1), got " + num(options.inexactFraction));
}

template <int d>
void NewmarkFamily<d>::assembleMasses(const ContactModel<d>& model, const ContactSet& contact) {
  const auto& bodies = model.bodies();
  const bool redistributed = usesRedistributedMass(options_.scheme);
  const bool needConsistent = options_.mass == MassKind::Consistent || redistributed;
  // masses body by body, stacked like the stiffness (one body: the body's matrices as they are)
  std::vector<ScalarSparseMatrix> consistentPerBody;
  lumped_ = Eigen::VectorXd::Zero(numVertices_);
  collective([&] {
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      const Eigen::VectorXd m = assembleLumpedMass(*bodies[i].mesh, bodies[i].material);
      for (Index v = 0; v < static_cast<Index>(m.size()); ++v) lumped_[bodyVertices_[i][v]] = m[v];
      if (needConsistent) consistentPerBody.push_back(assembleConsistentMass(*bodies[i].mesh, bodies[i].material));
    }
  });
  // distributed bodies coupled by mortar: the masses of the extra ghosts (the predictor's rows reach
  // them) and of the body ghosts from their owners
  if (multi_) halo_->update(lumped_, 1);
  collective([&] {
    ScalarSparseMatrix consistent;
    if (needConsistent) consistent = stackScalar(consistentPerBody, bodyVertices_, numVertices_);
    M_ = options_.mass == MassKind::Lumped ? expandLumpedMass<d>(lumped_, A_) : expandMass<d>(consistent, A_);
  });
  if (redistributed) redistributeMasses(model, consistentPerBody, contact);
}

template <int d>
void NewmarkFamily<d>::redistributeMasses(const ContactModel<d>& model,
                                          const std::vector<ScalarSparseMatrix>& consistentPerBody,
                                          const ContactSet& contact) {
  const auto& bodies = model.bodies();
  // massless: the contact vertices, and for mortar pairs the master vertices coupled to them
  std::vector<char> massless(static_cast<std::size_t>(numVertices_), 0);
  for (Index v : contact.vertices()) massless[static_cast<std::size_t>(v)] = 1;
  for (std::size_t k = 0; k < basis_.columns.size(); ++k)
    if (basis_.values[k] != 0) massless[static_cast<std::size_t>(basis_.columns[k])] = 1;
  if (multi_) {
    // a master vertex is coupled by the C rows of its slave vertices, which other ranks may hold:
    // the flags summed at the owners and sent back to every rank that holds the vertex
    Eigen::VectorXd flags(numVertices_);
    for (Index v = 0; v < numVertices_; ++v) flags[v] = massless[static_cast<std::size_t>(v)];
    halo_->accumulate(flags, 1);
    halo_->update(flags, 1);
    for (Index v = 0; v < numVertices_; ++v) massless[static_cast<std::size_t>(v)] = flags[v] > 0 ? 1 : 0;
  }
  // each body keeps its own mass, centre of gravity and second moments
  std::vector<ScalarSparseMatrix> tilde;
  auto stacked = std::make_unique<RedistributedMass>();
  stacked->massless = massless;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const std::vector<Index>& at = bodyVertices_[i];
    std::vector<char> local(at.size());
    for (std::size_t v = 0; v < at.size(); ++v) local[v] = massless[static_cast<std::size_t>(at[v])];
    if (!anyRank(std::find(local.begin(), local.end(), 1) != local.end())) {
      tilde.push_back(consistentPerBody[i]);  // no contact vertex: nothing to redistribute
      continue;
    }
    // distributed: global multipliers from the rank's owned rows of the body (collective)
    RedistributedMass r = redistributeMass(consistentPerBody[i], bodies[i].mesh->vertices(), d, local,
                                           options_.redistribution, bodyOwned_[i], comm_);
    tilde.push_back(std::move(r.matrix));
    const Eigen::Index m = stacked->multipliers.size();
    stacked->multipliers.conservativeResize(m + r.multipliers.size());
    stacked->multipliers.tail(r.multipliers.size()) = r.multipliers;
    stacked->iterations = std::max(stacked->iterations, r.iterations);
    stacked->residual = std::max(stacked->residual, r.residual);
    stacked->movedMass += r.movedMass;
    stacked->boundedEntries += r.boundedEntries;
    stacked->minimumFactor = std::min(stacked->minimumFactor, r.minimumFactor);
  }
  stacked->matrix = stackScalar(tilde, bodyVertices_, numVertices_);
  redistributed_ = std::move(stacked);
  Mr_ = expandMass<d>(redistributed_->matrix, A_);
  const ScalarSparseMatrix& Mt = redistributed_->matrix;
  const auto checkDiagonal = [&] {  // the owned rows (distributed: the others are partial sums)
    for (Eigen::Index i = 0; i < owned_; ++i) {
      if (massless[static_cast<std::size_t>(i)]) continue;
      if (!(Mt.coeff(i, i) > 0))
        throw Error("time stepping: the redistributed mass matrix has the non-positive diagonal entry " +
                    num(Mt.coeff(i, i)) + " at vertex " + std::to_string(i) +
                    " (too much mass on the contact boundary: refine the mesh near it)");
    }
  };
  if (comm_) {
    collective(checkDiagonal);
    // the inertia check factorises the whole M~, which no rank holds: not done on ranks
    redistributedCheck_.positiveDefinite = true;
    redistributedCheck_.checked = false;
    return;
  }
  checkDiagonal();
  // An indefinite M~ gives modes with x'M~x < 0 < x'Ax, which grow (weakly for large tau^2 A);
  // checked once on the vertices that keep mass and are not fully Dirichlet-constrained (one scalar
  // sparse LDL'). If it is indefinite, S = M~ + c tau^2 A is checked by stepMatrix.
  std::vector<char> mask = massless;
  for (Index v = 0; v < numVertices_; ++v) {
    bool fixed = true;
    for (int a = 0; a < d; ++a) fixed = fixed && dirichlet_.constrained[static_cast<std::size_t>(v) * d + a];
    if (fixed) mask[static_cast<std::size_t>(v)] = 1;
  }
  if (std::find(mask.begin(), mask.end(), 0) != mask.end())
    redistributedCheck_ = checkPositiveDefinite(Mt, mask);
  else
    redistributedCheck_.positiveDefinite = true;
}

template <int d>
BlockSparseMatrix<d> NewmarkFamily<d>::stepMatrix(const ContactSet& contact) const {
  // system matrix S = M_s + c tau^2 A (same block pattern)
  const NewmarkScheme scheme = options_.scheme;
  const bool redistributed = usesRedistributedMass(scheme);
  const double tau = options_.timeStep;
  const double c = scheme == NewmarkScheme::KhenousLabordeRenard ? 0.5 : 0.25;
  BlockSparseMatrix<d> S = A_;
  const BlockSparseMatrix<d>& Ms = redistributed ? Mr_ : M_;
  for (Index k = 0; k < S.nonZeroBlocks(); ++k) S.blockAt(k) = Ms.blockAt(k) + c * tau * tau * std::as_const(A_).blockAt(k);
  if (redistributed && !redistributedCheck_.positiveDefinite) {
    // M~ indefinite: the step problem is well posed only if S is positive definite on the free
    // components; an indefinite S would surface as a CHOLMOD error of TNNMG's coarse solve
    // (supernodal CHOLMOD on S with the Dirichlet components replaced by identity rows/columns)
    BlockSparseMatrix<d> Sfree = S;
    for (Index i = 0; i < Sfree.rows(); ++i)
      for (Index k = Sfree.rowBegin(i); k < Sfree.rowEnd(i); ++k)
        for (int a = 0; a < d; ++a)
          for (int b = 0; b < d; ++b) {
            const bool ci = dirichlet_.constrained[static_cast<std::size_t>(i) * d + a];
            const bool cj = dirichlet_.constrained[static_cast<std::size_t>(Sfree.column(k)) * d + b];
            if (ci || cj) Sfree.blockAt(k)(a, b) = (ci && cj && i == Sfree.column(k) && a == b) ? 1.0 : 0.0;
          }
    try {
      CholmodSolver check(Sfree);
    } catch (const Error& e) {
      throw Error("time stepping: scheme '" + std::string(obs::name(scheme)) + "': the step matrix S = M~ + " + num(c) +
                  " tau^2 A is not positive definite (" + e.what() + "), because the redistributed mass matrix M~ is "
                  "indefinite on the vertices that keep mass (" + std::to_string(redistributedCheck_.nonPositivePivots) +
                  " negative eigenvalues): the contact boundary " + contact.boundaryLabel() +
                  " carries too much of the mass of this mesh. Refine the mesh near the contact boundary (several "
                  "cells across the body), or use a scheme without mass redistribution (e.g. improved-contact-stabilized)");
    }
  }
  return S;
}

template <int d>
void NewmarkFamily<d>::setupStepProblem(BlockSparseMatrix<d> S) {
  // the step problem is posed for the increment u^{n+1} - base (base = u^n + tau v^n, see step()):
  // its Dirichlet values are zero
  DirichletValues zero = dirichlet_;
  zero.values.setZero();
  if (multi_)  // T'ST summed over the ranks (collective)
    problem_ = multi_->transformed(S, Eigen::VectorXd::Zero(numVertices_ * d), zero);
  else
    collective([&] {
      problem_ = std::make_unique<ContactProblem<d>>(std::move(S), Eigen::VectorXd::Zero(numVertices_ * d), zero,
                                                     *contact_, basis_);
    });
  collective([&] { setupConstraints(); });
  if (basis_.rows > 0) setupPredictorRows();  // collective
}

template <int d>
void NewmarkFamily<d>::setupConstraints() {
  const NewmarkScheme scheme = options_.scheme;
  const ContactSet& contact = *contact_;
  // S = M + c tau^2 A with the lumped (diagonal) M and A positive semidefinite: S - M >= 0, so the
  // lumped masses bound S from below and TNNMG can stop on an a posteriori bound of the error
  // (docs/theory.md#tnnmg-error-bound); not for M~ or the consistent M (not diagonal), nor in mortar
  // unknowns (T'ST)
  if (options_.mass == MassKind::Lumped && !usesRedistributedMass(scheme) && !problem_->transformed())
    problem_->setDiagonalLowerBound(std::vector<double>(lumped_.data(), lumped_.data() + lumped_.size()));
  constraints_ = problem_->constraints();
  for (auto& c : constraints_) {  // effective constraints for u (the problem's are for increments)
    if (!c.bounded()) continue;
    const Index k = contact_->nodeOf(c.vertex);
    double shift = 0;
    for (int a = 0; a < d; ++a) {
      const std::size_t i = static_cast<std::size_t>(c.vertex) * d + a;
      if (dirichlet_.constrained[i]) shift += contact_->direction(k)[a] * dirichlet_.values[static_cast<Eigen::Index>(i)];
    }
    c.shift = shift;
    c.gap = (contact_->gap(k) - shift) / c.scale;
  }
  gaps_.resize(static_cast<std::size_t>(contact.size()));
  for (Index k = 0; k < contact.size(); ++k) gaps_[static_cast<std::size_t>(k)] = contact.gap(k);
  multiplierFactor_ = scheme == NewmarkScheme::Classical ? 0.25 : 0.5;
}

template <int d>
std::vector<double> NewmarkFamily<d>::gatherRows(const std::vector<double>& own, int width) const {
  if (!comm_) return own;
  const std::vector<std::vector<double>> got = comm_->allGather(own);
  std::vector<double> all;
  all.reserve(rows_ ? rows_->rows.size() * static_cast<std::size_t>(width) : own.size());
  for (const auto& part : got) all.insert(all.end(), part.begin(), part.end());
  return all;
}

template <int d>
void NewmarkFamily<d>::setupPredictorRows() {
  // mortar: the rows of B for the predictor (a Dirichlet component of a slave vertex is orthogonal
  // to its direction, ContactProblem::basisSkip(), so it adds nothing to the row). Each rank packs
  // the rows of its owned bounded constraints: direction, diagonal (from its held masses), and per
  // entry the global vertex, coefficient, lumped mass and Dirichlet components; every rank gets all
  auto rows = std::make_unique<PredictorRows>();
  std::vector<double> pack;
  std::vector<Index> global;  // the stepper's global index of a local vertex
  collective([&] {
    for (std::size_t k = 0; k < constraints_.size(); ++k) {
      const auto& cn = constraints_[k];
      if (!cn.bounded() || cn.vertex >= owned_) continue;
      rows->own.push_back(k);
      std::vector<std::pair<Index, double>> entries{{cn.vertex, 1.0}};
      for (Index m = basis_.rowStart[cn.vertex]; m < basis_.rowStart[cn.vertex + 1]; ++m)
        if (basis_.values[m] != 0) entries.emplace_back(basis_.columns[m], -basis_.values[m]);
      double diagonal = 0;
      for (const auto& [v, coef] : entries)
        for (int a = 0; a < d; ++a)
          if (!dirichlet_.constrained[static_cast<std::size_t>(v) * d + a])
            diagonal += coef * coef * cn.direction[a] * cn.direction[a] / lumped_[v];
      for (int a = 0; a < d; ++a) pack.push_back(cn.direction[a]);
      pack.push_back(diagonal);
      pack.push_back(static_cast<double>(entries.size()));
      for (const auto& [v, coef] : entries) {
        unsigned fixed = 0;
        for (int a = 0; a < d; ++a)
          if (dirichlet_.constrained[static_cast<std::size_t>(v) * d + a]) fixed |= 1u << a;
        pack.push_back(static_cast<double>(multi_ ? multi_->global()[v] : v));
        pack.push_back(coef);
        pack.push_back(lumped_[v]);
        pack.push_back(static_cast<double>(fixed));
      }
    }
  });
  std::vector<std::vector<double>> all;
  if (comm_) {
    all = comm_->allGather(pack);
  } else {
    all.push_back(std::move(pack));
  }
  collective([&] {
    std::unordered_map<Index, Index> compact;  // global vertex -> compact index
    std::unordered_map<Index, Index> held;     // global vertex -> the stepper's index
    if (multi_)
      for (Index v = 0; v < numVertices_; ++v) held.emplace(multi_->global()[v], v);
    for (std::size_t r = 0; r < all.size(); ++r) {
      if (comm_ && static_cast<int>(r) == comm_->rank()) rows->first = rows->rows.size();
      const std::vector<double>& x = all[r];
      for (std::size_t i = 0; i < x.size();) {
        typename PredictorRows::Row row;
        for (int a = 0; a < d; ++a) row.direction[a] = x[i++];
        row.diagonal = x[i++];
        const auto count = static_cast<std::size_t>(x[i++]);
        for (std::size_t e = 0; e < count; ++e, i += 4) {
          const auto g = static_cast<Index>(x[i]);
          const auto [it, added] = compact.try_emplace(g, static_cast<Index>(rows->mass.size()));
          if (added) {
            rows->mass.push_back(x[i + 2]);
            rows->fixed.push_back(static_cast<std::uint8_t>(x[i + 3]));
            const auto h = multi_ ? held.find(g) : held.end();
            rows->local.push_back(!multi_ ? g : h != held.end() ? h->second : -1);
          }
          row.entries.emplace_back(it->second, x[i + 1]);
        }
        rows->rows.push_back(std::move(row));
      }
    }
  });
  rows_ = std::move(rows);
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::relative(const Eigen::VectorXd& u) const {
  return basis_.rows > 0 ? problem_->fromDisplacement(u) : u;
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::physicalForce(const Eigen::VectorXd& y) const {
  // distributed bodies: the slave rows' parts summed at the masters' owners (collective)
  return multi_ ? multi_->transposedProduct(y, -1.0) : problem_->applyInverseTransposedBasis(y);
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::predictorCorrection(const Predictor& P, const std::vector<double>& weight) const {
  Eigen::VectorXd z = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(numVertices_) * d);
  if (basis_.rows == 0) {
    for (std::size_t k = 0; k < constraints_.size(); ++k) {
      if (!P.active[k] || weight[k] == 0) continue;
      const auto& c = constraints_[k];
      z.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d) += weight[k] * P.delta[k] * c.direction;
    }
    return z;
  }
  // mortar: -M^{-1} B'(w mu) over the rows of every rank (the weights of the others' rows gathered),
  // in row order on the rows' vertices, then at the vertices this rank holds
  const PredictorRows& R = *rows_;
  std::vector<double> own(R.own.size());
  for (std::size_t j = 0; j < R.own.size(); ++j) own[j] = P.active[R.own[j]] ? weight[R.own[j]] : 0.0;
  const std::vector<double> w = gatherRows(own, 1);  // collective
  Eigen::VectorXd y = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(R.mass.size()) * d);
  for (std::size_t j = 0; j < R.rows.size(); ++j) {
    if (P.rowMu[j] <= 0 || w[j] == 0) continue;
    const auto& row = R.rows[j];
    for (const auto& [v, coef] : row.entries)
      for (int a = 0; a < d; ++a)
        if (!(R.fixed[static_cast<std::size_t>(v)] & (1u << a)))
          y[static_cast<Eigen::Index>(v) * d + a] -= w[j] * P.rowMu[j] * coef * row.direction[a] / R.mass[static_cast<std::size_t>(v)];
  }
  for (std::size_t v = 0; v < R.local.size(); ++v)
    if (R.local[v] >= 0)
      z.template segment<d>(static_cast<Eigen::Index>(R.local[v]) * d) = y.template segment<d>(static_cast<Eigen::Index>(v) * d);
  return z;
}

template <int d>
NewmarkFamily<d>::~NewmarkFamily() = default;

template <int d>
const RedistributedMass& NewmarkFamily<d>::redistributedMass() const {
  if (!redistributed_)
    throw Error("time stepping: scheme '" + std::string(obs::name(options_.scheme)) + "' has no redistributed mass");
  return *redistributed_;
}

template <int d>
const DefinitenessCheck& NewmarkFamily<d>::redistributedMassDefiniteness() const {
  redistributedMass();  // throws for the schemes without M~
  return redistributedCheck_;
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::applyMass(const Eigen::VectorXd& x, bool redistributed) const {
  if (redistributed) return Mr_ * x;
  if (options_.mass == MassKind::Consistent) return M_ * x;
  Eigen::VectorXd y(x.size());
  for (Index p = 0; p < numVertices_; ++p)
    y.template segment<d>(static_cast<Eigen::Index>(p) * d) = lumped_[p] * x.template segment<d>(static_cast<Eigen::Index>(p) * d);
  return y;
}

template <int d>
double NewmarkFamily<d>::energy(const Eigen::VectorXd& u, const Eigen::VectorXd& v) const {
  if (!comm_) return 0.5 * v.dot(applyMass(v, false)) + 0.5 * A_.energy(u) - f_.dot(u);
  Eigen::VectorXd Au;
  A_.multiply(u, Au);
  return 0.5 * dot(v, applyMass(v, false)) + 0.5 * dot(u, Au) - dot(f_, u);
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::contactForces() const {
  checkInitialized();
  const double tau = options_.timeStep;
  return (basis_.rows > 0 ? physicalForce(multiplier_) : multiplier_) / (multiplierFactor_ * tau * tau);
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::nodalContactForces() const {
  checkInitialized();
  const double tau = options_.timeStep;
  return multiplier_ / (multiplierFactor_ * tau * tau);
}

template <int d>
double NewmarkFamily<d>::activeTolerance(const Eigen::VectorXd& u) const {
  double U = u.size() ? u.template lpNorm<Eigen::Infinity>() : 0.0;
  for (double g : gaps_)
    if (std::isfinite(g)) U = std::max(U, std::abs(g));
  return options_.activeTolerance * std::max(maximum(U), 1e-300);  // the same scale on every rank
}

template <int d>
double NewmarkFamily<d>::inexactTolerance(double timeError, double incrementNorm, double rate) const {
  const double base = options_.solver.tolerance;
  const double ratio = timeError / incrementNorm;
  if (!(options_.inexactFraction > 0) || !(timeError > 0) || !(incrementNorm > 0) || !std::isfinite(ratio)) return base;
  // algebraic error ~ rho / (1 - rho) * last correction (geometric convergence with rate rho), as in
  // the adaptive loop (docs/estimators.md#inexact-solves). Where TNNMG also stops on its error bound
  // (lumped mass, docs/theory.md#tnnmg-error-bound) the tolerance bounds the error itself, so it is
  // not widened by (1 - rho) / rho
  const double rho = std::clamp(rate, 0.05, 0.9);
  const double widening = problem_->diagonalLowerBound().empty() ? (1 - rho) / rho : std::min(1.0, (1 - rho) / rho);
  const double tolerance = options_.inexactFraction * ratio * widening;
  return std::max(base, std::min(tolerance, 1e-2));
}

template <int d>
void NewmarkFamily<d>::checkInitialized() const {
  if (!initialized_) throw Error("time stepping: step() before initialize() (no initial state)");
}

template <int d>
void NewmarkFamily<d>::initialize(const Eigen::VectorXd& u0, const Eigen::VectorXd& v0) {
  const Eigen::Index n = static_cast<Eigen::Index>(numVertices_) * d;
  collective([&] {
    if (u0.size() != n || v0.size() != n)
      throw Error("time stepping: initial state with " + std::to_string(u0.size()) + " / " +
                  std::to_string(v0.size()) + " entries, the problem has " + std::to_string(n) + " unknowns");
  });
  Eigen::VectorXd u = u0, v = v0;
  if (multi_) {  // the extra ghosts' values from their owners
    updateGhosts(u);
    updateGhosts(v);
  }
  collective([&] { checkInitialState(u, v); });
  const double tol = activeTolerance(u);  // collective
  collective([&] { checkInitialContact(u, tol); });
  state_ = DynamicState{0, 0.0, u, v, Eigen::VectorXd()};
  frictionDissipation_ = 0;
  previousMultiplier_ = Eigen::VectorXd::Zero(n);
  multiplier_ = Eigen::VectorXd::Zero(n);
  previousVelocity_.resize(0);
  nextTolerance_ = 0;
  previousIncrement_.resize(0);
  if (options_.scheme == NewmarkScheme::KhenousLabordeRenard) state_.a = initialAcceleration(u);
  initialized_ = true;
  A_.multiply(state_.u, Au_);
  last_ = makeRecord();
}

template <int d>
void NewmarkFamily<d>::checkInitialState(const Eigen::VectorXd& u0, const Eigen::VectorXd& v0) const {
  const Eigen::Index n = static_cast<Eigen::Index>(numVertices_) * d;
  if (u0.size() != n || v0.size() != n)
    throw Error("time stepping: initial state with " + std::to_string(u0.size()) + " / " + std::to_string(v0.size()) +
                " entries, the problem has " + std::to_string(n) + " unknowns");
  if (!u0.allFinite() || !v0.allFinite()) throw Error("time stepping: the initial state has non-finite values");
  const double vs = std::max(1.0, v0.template lpNorm<Eigen::Infinity>());
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!dirichlet_.constrained[static_cast<std::size_t>(i)]) continue;
    const double g = dirichlet_.values[i];
    if (std::abs(u0[i] - g) > 1e-12 * std::max(1.0, std::abs(g)) || std::abs(v0[i]) > 1e-14 * vs)
      throw Error("time stepping: the initial state at vertex " + std::to_string(i / d) + ", component " +
                  std::to_string(i % d) + " does not match the Dirichlet condition (u = " + num(u0[i]) +
                  ", prescribed " + num(g) + "; v = " + num(v0[i]) + ", must be 0)");
  }
}

template <int d>
void NewmarkFamily<d>::checkInitialContact(const Eigen::VectorXd& u0, double tol) const {
  const Eigen::VectorXd x0 = relative(u0);
  for (Index k = 0; k < contact_->size(); ++k) {
    const double g = gaps_[static_cast<std::size_t>(k)];
    if (!std::isfinite(g)) continue;
    const Index p = contact_->vertex(k);
    if (p >= owned_) continue;  // distributed: a ghost, checked by its owner
    const double un = contact_->direction(k).template head<d>().dot(x0.template segment<d>(static_cast<Eigen::Index>(p) * d));
    if (un - g > tol) {
      const Point& x = contact_->position(k);
      throw Error("time stepping: the initial displacement violates the contact constraint at vertex " +
                  std::to_string(p) + " (" + num(x[0]) + ", " + num(x[1]) + (d == 3 ? ", " + num(x[2]) : "") +
                  "): nu.u = " + num(un) + " > gap " + num(g));
    }
  }
}

template <int d>
Eigen::VectorXd NewmarkFamily<d>::initialAcceleration(const Eigen::VectorXd& u0) const {
  // a^0: M~ a^0 = f - A u^0 on the vertices with mass, per component (Dirichlet components and
  // massless vertices 0), by conjugate gradients preconditioned with the diagonal of M~; the sums
  // run over the owned vertices (and the ranks), the ghosts of the search direction come from their
  // owners before every product
  const Eigen::Index n = static_cast<Eigen::Index>(numVertices_) * d;
  Eigen::VectorXd a = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd Au;
  A_.multiply(u0, Au);
  const Eigen::VectorXd r0 = f_ - Au;
  const ScalarSparseMatrix& Mt = redistributed_->matrix;
  std::vector<char> fixed(static_cast<std::size_t>(n), 0);  // per component: a = 0
  for (Eigen::Index i = 0; i < n; ++i)
    fixed[static_cast<std::size_t>(i)] = redistributed_->massless[static_cast<std::size_t>(i / d)] ||
                                         dirichlet_.constrained[static_cast<std::size_t>(i)];
  // y = K x on the owned rows (all rows serially): K = M~ on the free components of each component
  const auto apply = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    y.setZero(n);
    for (Index i = 0; i < owned_; ++i)
      for (int c = 0; c < d; ++c) {
        const Eigen::Index row = static_cast<Eigen::Index>(i) * d + c;
        if (fixed[static_cast<std::size_t>(row)]) continue;
        double s = 0;
        for (ScalarSparseMatrix::InnerIterator it(Mt, i); it; ++it) {
          const Eigen::Index col = static_cast<Eigen::Index>(it.col()) * d + c;
          if (!fixed[static_cast<std::size_t>(col)]) s += it.value() * x[col];
        }
        y[row] = s;
      }
  };
  Eigen::VectorXd diagonal = Eigen::VectorXd::Ones(n);
  Eigen::VectorXd r = Eigen::VectorXd::Zero(n);
  for (Index i = 0; i < owned_; ++i)
    for (int c = 0; c < d; ++c) {
      const Eigen::Index row = static_cast<Eigen::Index>(i) * d + c;
      if (fixed[static_cast<std::size_t>(row)]) continue;
      diagonal[row] = Mt.coeff(i, i);
      r[row] = r0[row];
    }
  const double bnorm = std::sqrt(dot(r, r));
  if (!std::isfinite(bnorm))
    throw Error("time stepping: the initial acceleration (M~ a = f - A u^0) has a non-finite right-hand side");
  Eigen::VectorXd z = r.cwiseQuotient(diagonal), p = z, q;
  double rz = dot(r, z);
  const double cap = maximum(10.0 * static_cast<double>(numVertices_) + 100);  // the same on every rank
  bool converged = bnorm == 0;
  for (double it = 0; it < cap && !converged; ++it) {
    updateGhosts(p);
    apply(p, q);
    const double pq = dot(p, q);
    if (!(pq > 0)) break;  // M~ not positive on this direction: reported below
    const double alpha = rz / pq;
    a += alpha * p;
    r -= alpha * q;
    if (std::sqrt(dot(r, r)) <= 1e-14 * bnorm) {
      converged = true;
      break;
    }
    z = r.cwiseQuotient(diagonal);
    const double rzNext = dot(r, z);
    p = z + (rzNext / rz) * p;
    rz = rzNext;
  }
  if (!converged || anyRank(!a.allFinite()))
    throw Error("time stepping: the initial acceleration (M~ a = f - A u^0) could not be computed (conjugate "
                "gradients did not converge on the redistributed mass matrix)");
  for (Eigen::Index i = 0; i < n; ++i)  // the ghosts from their owners; a = 0 where fixed
    if (fixed[static_cast<std::size_t>(i)]) a[i] = 0;
  updateGhosts(a);
  return a;
}

template <int d>
void NewmarkFamily<d>::computePredictor(Predictor& P) const {
  const double tau = options_.timeStep;
  const auto nc = constraints_.size();
  P.active.assign(nc, 0);
  P.tauStar.assign(nc, tau);
  P.delta.assign(nc, 0.0);
  const Eigen::VectorXd x = relative(state_.u), w = relative(state_.v);
  if (basis_.rows == 0) {
    // rigid obstacles: B is diagonal, the lumped-mass projection is node-wise. A node is active for the
    // predictor if the projected predictor lies on the obstacle (thesis Sec. 5.3.1: u_pred(p) = g(p)),
    // i.e. also if u^n + tau v^n touches it without penetrating (a node resting on it with v = 0), with
    // the tolerance of the solution's active set; only a penetrating predictor is moved (delta < 0).
    const double touch = activeTolerance(state_.u + tau * state_.v);
    for (std::size_t k = 0; k < nc; ++k) {
      const auto& c = constraints_[k];
      if (!c.bounded()) continue;
      const auto i = static_cast<Eigen::Index>(c.vertex) * d;
      const double un = c.direction.dot(x.template segment<d>(i));
      const double vn = c.direction.dot(w.template segment<d>(i));
      const double excess = un + tau * vn - c.gap;
      if (excess < -touch) continue;
      P.active[k] = 1;
      if (excess <= 0) continue;  // touching: delta = 0, tau* = tau (no impact inside the step)
      P.delta[k] = -excess;  // = (tau* - tau) vn
      P.tauStar[k] = vn > 0 ? std::clamp(tau - excess / vn, 0.0, tau) : 0.0;
    }
    return;
  }
  // mortar: min 1/2 |z|_M^2 subject to B(y + z) <= g, y = u^n + tau v^n, by projected Gauss-Seidel on
  // the multipliers (Hildreth): z = -M^{-1} B'mu, mu_k <- max(0, mu_k + (B(y + z) - g)_k / G_kk).
  // The rows of every rank (PredictorRows), their r and vn from the ranks that own them: every rank
  // runs the same iteration on the same values (serial: the constraints' rows in their order)
  P.mu.assign(nc, 0.0);
  const PredictorRows& R = *rows_;
  std::vector<double> own(3 * R.own.size());  // r_k = g_k - (B y)_k, vn_k, g_k
  for (std::size_t j = 0; j < R.own.size(); ++j) {
    const auto& c = constraints_[R.own[j]];
    const auto i = static_cast<Eigen::Index>(c.vertex) * d;
    own[3 * j + 1] = c.direction.dot(w.template segment<d>(i));
    own[3 * j] = c.gap - c.direction.dot(x.template segment<d>(i)) - tau * own[3 * j + 1];
    own[3 * j + 2] = c.gap;
  }
  const std::vector<double> rv = gatherRows(own, 3);  // collective
  const std::size_t nr = R.rows.size();
  P.rowMu.assign(nr, 0.0);
  double scale = 0, worst = 0;
  for (std::size_t j = 0; j < nr; ++j) {
    scale = std::max({scale, std::abs(rv[3 * j + 2]), std::abs(tau * rv[3 * j + 1])});
    worst = std::max(worst, -rv[3 * j]);
  }
  const double tol = options_.predictorTolerance * std::max(scale, 1e-300);
  const double touch = activeTolerance(state_.u + tau * state_.v);  // collective
  Eigen::VectorXd z = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(R.mass.size()) * d);
  auto rowValue = [&](std::size_t j) {  // (B z)_j
    double s = 0;
    for (const auto& [v, coef] : R.rows[j].entries)
      s += coef * R.rows[j].direction.dot(z.template segment<d>(static_cast<Eigen::Index>(v) * d));
    return s;
  };
  std::vector<double>& mu = P.rowMu;
  // y admissible up to the iteration's tolerance: z = 0 (a violation of round-off size would give
  // multipliers of round-off size, whose support depends on the order of the rows)
  for (int sweep = 0; worst > tol; ++sweep) {
    if (sweep >= options_.maxPredictorSweeps)
      throw Error("time stepping: step " + std::to_string(state_.step + 1) + ": the contact predictor did not converge in " +
                  std::to_string(sweep) + " sweeps (constraint residual " + num(worst) + ")");
    double change = 0;
    for (std::size_t j = 0; j < nr; ++j) {
      const auto& row = R.rows[j];
      if (row.diagonal <= 0) continue;
      const double violation = rowValue(j) - rv[3 * j];  // (B(y + z) - g)_j
      const double next = std::max(0.0, mu[j] + violation / row.diagonal);
      const double dmu = next - mu[j];
      if (dmu == 0) continue;
      mu[j] = next;
      change = std::max(change, std::abs(dmu) * row.diagonal);
      for (const auto& [v, coef] : row.entries)
        for (int a = 0; a < d; ++a)
          if (!(R.fixed[static_cast<std::size_t>(v)] & (1u << a)))
            z[static_cast<Eigen::Index>(v) * d + a] -= dmu * coef * row.direction[a] / R.mass[static_cast<std::size_t>(v)];
    }
    worst = change;
    if (change <= tol) break;
  }
  // a row is active for the predictor if the projected predictor lies on its constraint, with the
  // tolerance of the solution's active set (as for obstacles: also a row that y touches without a
  // multiplier; not the sign of a multiplier, which is round-off for rows the projection barely moves)
  for (std::size_t j = 0; j < R.own.size(); ++j) {
    const std::size_t k = R.own[j], row = R.first + j;
    const double moved = rowValue(row);  // (B z)_k: the change of the normal jump
    if (rv[3 * row] - moved > touch) continue;  // g - B(y + z) > 0: apart
    P.mu[k] = mu[row];
    P.active[k] = 1;
    if (moved >= 0) continue;  // touching: delta = 0, tau* = tau (no impact inside the step)
    P.delta[k] = moved;  // = (tau* - tau) [v]_nu
    const double vn = own[3 * j + 1];
    P.tauStar[k] = vn > 0 ? std::clamp(tau + moved / vn, 0.0, tau) : 0.0;
  }
}

template <int d>
StepRecord NewmarkFamily<d>::step() {
  checkInitialized();
  const auto start = Clock::now();
  const double tau = options_.timeStep;
  const NewmarkScheme scheme = options_.scheme;
  const bool redistributed = usesRedistributedMass(scheme);
  const Eigen::VectorXd& u = state_.u;
  const Eigen::VectorXd& v = state_.v;
  const Eigen::Index n = u.size();

  Predictor P;
  computePredictor(P);

  // right-hand side
  Eigen::VectorXd base = u + tau * v;
  if (hasPredictorInDisplacement(scheme)) {
    if (basis_.rows == 0) {
      for (std::size_t k = 0; k < constraints_.size(); ++k)
        if (P.active[k])
          base.template segment<d>(static_cast<Eigen::Index>(constraints_[k].vertex) * d) += P.delta[k] * constraints_[k].direction;
    } else {
      base += predictorCorrection(P, std::vector<double>(constraints_.size(), 1.0));  // the projection onto K
    }
  }
  updateGhosts(base);  // distributed: the owners' base (a ghost's constraint is its owner's business)
  Eigen::VectorXd rhs = applyMass(base, redistributed) + (0.5 * tau * tau) * f_;
  if (scheme != NewmarkScheme::KhenousLabordeRenard) rhs -= (0.25 * tau * tau) * Au_;  // Au_ = A u^n
  // classical (5.21): + tau^2/4 M F_con^n, the reaction of the obstacle at t^n. The solver's multiplier
  // lambda = (b - S w) along nu is the force on the obstacle (S w = b - lambda), i.e. minus the reaction:
  // the previous step's lambda enters with the sign of the new one (S u^{n+1} = ... - lambda^n - lambda^{n+1})
  if (scheme == NewmarkScheme::Classical) rhs -= basis_.rows > 0 ? physicalForce(previousMultiplier_) : previousMultiplier_;

  // The variational inequality is solved for the increment w = u^{n+1} - base (S w = rhs - S base,
  // bounds shifted by nu'base): the iterate and the energy are small, which keeps the solver's
  // round-off small also for very stiff S (large E tau^2).
  // Bounds: non-penetration nu'u^{n+1} <= g, or persistency nu'u^{n+1} <= nu'u^n at the nodes in
  // contact or penetrated at t^n (no bound elsewhere).
  {
    const double tol = activeTolerance(u);
    const bool persistency = usesPersistency(scheme);
    const Eigen::VectorXd xu = relative(u), xb = relative(base);
    std::vector<double> g(gaps_.size(), kInf);
    for (Index k = 0; k < contact_->size(); ++k) {
      const double gk = gaps_[static_cast<std::size_t>(k)];
      if (!std::isfinite(gk)) continue;
      const auto i = static_cast<Eigen::Index>(contact_->vertex(k)) * d;
      const auto nu = contact_->direction(k).template head<d>();
      const double un = nu.dot(xu.template segment<d>(i)), bn = nu.dot(xb.template segment<d>(i));
      if (!persistency)
        g[static_cast<std::size_t>(k)] = gk - bn;
      else if (un >= gk - tol)
        g[static_cast<std::size_t>(k)] = un - bn;
    }
    if (multi_) {
      // (I - C) is exact at the owned vertices only (an extra ghost has no row of C): the ghosts'
      // bounds from their owners (the solver projects every held vertex onto its bound)
      Eigen::VectorXd at = Eigen::VectorXd::Zero(numVertices_);
      for (Index k = 0; k < contact_->size(); ++k)
        if (contact_->vertex(k) < owned_) at[contact_->vertex(k)] = g[static_cast<std::size_t>(k)];
      halo_->update(at, 1);
      for (Index k = 0; k < contact_->size(); ++k) g[static_cast<std::size_t>(k)] = at[contact_->vertex(k)];
    }
    collective([&] { problem_->setGaps(g); });
  }
  // T'(rhs - S base): distributed bodies sum the slave rows' parts at the masters' owners
  if (multi_)
    problem_->setLoad(multi_->transposedProduct(rhs - S_ * base), typename ContactProblem<d>::Transformed{});
  else
    problem_->setLoad(rhs - S_ * base);

  // inexact solves: the tolerance predicted from the previous step (docs/theory.md#dynamic-inexact-solves)
  const bool inexact = options_.inexactFraction > 0;
  const double tolerance = inexact && nextTolerance_ > 0 ? nextTolerance_ : options_.solver.tolerance;
  if (inexact) solver_->setTolerance(tolerance);
  // initial iterate (NewmarkStart): zero, or the previous step's increment (projected by the solver)
  const bool fromPrevious = options_.start == NewmarkStart::PreviousIncrement && previousIncrement_.size() == n;
  Eigen::VectorXd increment = fromPrevious ? previousIncrement_ : Eigen::VectorXd::Zero(n);  // problem unknowns
  // friction (docs/theory.md#friction-dynamics): on the slip of the step, u^{n+1} - u^n, i.e. in the
  // increment w = u^{n+1} - base from the origin u^n - base; the bounds in the units of the step's
  // multipliers (c' tau^2 times forces): Coulomb's mu lambda as it is, Tresca's bound scaled
  ContactResult result;
  int frictionSolves = 0;
  Eigen::VectorXd slipOrigin;
  if (!frictional_) {
    result = solver_->solve(*problem_, increment);
  } else {
    NodalFriction f = friction_;
    for (double& b : f.bound) b *= multiplierFactor_ * tau * tau;
    slipOrigin = basis_.rows > 0 ? problem_->fromDisplacement(u - base) : Eigen::VectorXd(u - base);
    CoulombOptions co;
    co.tolerance = std::max(co.tolerance, 10 * tolerance);
    const CoulombResult fr = solveFriction(*problem_, *solver_, increment, f, co, slipOrigin, halo_);
    result = fr.last;
    result.iterations = static_cast<int>(fr.innerIterations);
    frictionSolves = fr.iterations;
    if (!fr.converged && result.converged)
      throw Error("time stepping: step " + std::to_string(state_.step + 1) + " (t = " + num(state_.time + tau) +
                  "): the Coulomb fixed point did not converge in " + std::to_string(fr.iterations) +
                  " Tresca solves (last relative change of the slip bounds " + num(fr.changes.back()) +
                  (fr.contracting ? "" : "; the iteration did not contract: mu may be too large") + ")");
  }
  Eigen::VectorXd unew = base + (basis_.rows > 0 ? problem_->toDisplacement(increment) : increment);
  if (multi_) updateGhosts(unew);  // an extra ghost has no row of C
  if (!result.converged)
    throw Error("time stepping: step " + std::to_string(state_.step + 1) + " (t = " + num(state_.time + tau) +
                "): TNNMG did not converge in " + std::to_string(result.iterations) + " iterations (correction " +
                num(result.correction) + ")");
  if (anyRank(!unew.allFinite()))
    throw Error("time stepping: step " + std::to_string(state_.step + 1) + ": non-finite displacement");

  // nodal multipliers lambda = c' tau^2 M F_con
  const Eigen::VectorXd mu = problem_->multipliers(increment);
  multiplier_.setZero(n);
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    const auto& c = problem_->constraint(static_cast<Index>(k));
    if (c.bounded())
      multiplier_.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d) += mu[static_cast<Eigen::Index>(k)] * c.direction;
  }
  updateGhosts(multiplier_);  // distributed: the owned rows are complete, a ghost's are not

  // velocity
  Eigen::VectorXd vnew;
  Eigen::VectorXd anew;
  const double solTol = activeTolerance(unew);
  std::vector<char> solActive(constraints_.size(), 0);
  {
    const Eigen::VectorXd xnew = relative(unew);
    for (std::size_t k = 0; k < constraints_.size(); ++k) {
      const auto& c = constraints_[k];
      if (!c.bounded()) continue;
      solActive[k] = c.gap - c.direction.dot(xnew.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d)) <= solTol;
    }
  }
  if (scheme == NewmarkScheme::KhenousLabordeRenard) {
    anew = (2 / (tau * tau)) * (unew - u - tau * v);
    vnew = v + (0.5 * tau) * (state_.a + anew);
  } else {
    vnew = (2 / tau) * (unew - u) - v;
    if (hasPredictorInDisplacement(scheme)) {
      std::vector<double> betas(constraints_.size(), 0.0);
      for (std::size_t k = 0; k < constraints_.size(); ++k) {
        if (!P.active[k]) continue;
        double beta = 1;
        if (scheme == NewmarkScheme::AlphaHalf) {
          beta = 0.5;
        } else if (solActive[k] && scheme == NewmarkScheme::ImprovedContactStabilized) {
          const double ts = P.tauStar[k];
          const double alpha = ts <= 0.5 * tau ? tau / (2 * (tau - ts)) : 1.0;
          beta = 1 - alpha;
        } else if (solActive[k] && scheme == NewmarkScheme::AlphaOneZero) {
          beta = 0;
        }
        betas[k] = beta;
        if (basis_.rows == 0)
          vnew.template segment<d>(static_cast<Eigen::Index>(constraints_[k].vertex) * d) -=
              (2 / tau) * beta * P.delta[k] * constraints_[k].direction;
      }
      // mortar: the beta-weighted part of the predictor's force pairs (momentum neutral)
      if (basis_.rows > 0) vnew -= (2 / tau) * predictorCorrection(P, betas);
    }
  }
  updateGhosts(vnew);  // distributed: a ghost's predictor terms are its owner's
  if (scheme == NewmarkScheme::KhenousLabordeRenard) updateGhosts(anew);
  if (anyRank(!vnew.allFinite()))
    throw Error("time stepping: step " + std::to_string(state_.step + 1) + ": non-finite velocity");
  if (scheme == NewmarkScheme::Classical) previousMultiplier_ = multiplier_;

  // inexact solves: local time-error estimate of this step (Zienkiewicz-Xie, accelerations from
  // velocity differences) and the tolerance of the next one, both in the S-norm of TNNMG's test
  double timeError = std::numeric_limits<double>::quiet_NaN();
  if (inexact) {
    auto normS = [&](const Eigen::VectorXd& x) { return std::sqrt(std::max(0.0, dot(x, S_ * x))); };
    if (previousVelocity_.size() == n) {
      const double c = scheme == NewmarkScheme::KhenousLabordeRenard ? 1.0 / 3.0 : 1.0 / 12.0;  // |beta - 1/6|
      timeError = c * tau * normS(vnew - 2 * v + previousVelocity_);
    }
    nextTolerance_ = inexactTolerance(timeError, normS(unew - base), result.convergenceRate);
    previousVelocity_ = v;  // v^n (v refers to state_.v, replaced below)
  }

  // friction: the friction force of the step and the energy it dissipates, |F_T| |(u^{n+1} - u^n)_T|,
  // and the step's node counts, summed over the owned nodes (and the ranks) in one reduction:
  // dissipation, friction force (3), stick, slip, active predictor, predictor only, solution only
  std::vector<double> sums(9, 0.0);
  if (frictional_) {
    // the scales of computeContactOutputs over the owned vertices and the ranks (the same thresholds
    // of contact and stick on every rank)
    const Eigen::Index ownedDofs = static_cast<Eigen::Index>(owned_) * d;
    double U = increment.head(ownedDofs).template lpNorm<Eigen::Infinity>(), F = 0;
    for (Index k = 0; k < contact_->size(); ++k)
      if (contact_->vertex(k) < owned_ && std::isfinite(contact_->gap(k))) U = std::max(U, std::abs(contact_->gap(k)));
    Eigen::VectorXd Aw;
    problem_->multiply(increment, Aw);
    for (Eigen::Index i = 0; i < ownedDofs; ++i)
      if (!problem_->dirichlet().constrained[static_cast<std::size_t>(i)])
        F = std::max({F, std::abs(problem_->rhs()[i]), std::abs(Aw[i])});
    U = maximum(U);
    const ContactOutputs out = computeContactOutputs(*problem_, increment, 1e-8, U > 0 ? U : 1, maximum(F));
    const double factor = multiplierFactor_ * tau * tau;
    frictionForces_.setZero(n);
    for (Index k = 0; k < contact_->size(); ++k) {
      frictionForces_.template segment<d>(static_cast<Eigen::Index>(contact_->vertex(k)) * d) +=
          out.tangential[k].template head<d>() / factor;
      if (contact_->vertex(k) >= owned_) continue;  // a ghost: its owner's
      sums[0] += out.tangential[k].norm() / factor * out.slip[k];
      for (int a = 0; a < 3; ++a) sums[1 + a] += out.tangential[k][a] / factor;
      sums[4] += out.state[static_cast<std::size_t>(k)] == 1;
      sums[5] += out.state[static_cast<std::size_t>(k)] == 2;
    }
    frictionStates_ = out.state;
  }
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    if (constraints_[k].vertex >= owned_) continue;
    sums[6] += P.active[k];
    sums[7] += P.active[k] && !solActive[k];
    sums[8] += !P.active[k] && solActive[k];
  }
  sum(sums);
  frictionDissipation_ += sums[0];
  if (options_.start == NewmarkStart::PreviousIncrement) previousIncrement_ = increment;
  state_.u = unew;
  A_.multiply(state_.u, Au_);
  state_.v = vnew;
  if (scheme == NewmarkScheme::KhenousLabordeRenard) state_.a = anew;
  state_.step += 1;
  state_.time += tau;

  StepRecord r = makeRecord();
  r.activePredictor = static_cast<Index>(sums[6]);
  r.predictorOnly = static_cast<Index>(sums[7]);
  r.solutionOnly = static_cast<Index>(sums[8]);
  r.solverIterations = result.iterations;
  r.solverRate = result.iterations >= 2 ? result.convergenceRate : std::numeric_limits<double>::quiet_NaN();
  // distributed: the slowest rank's times, so that every rank holds the same record
  std::vector<double> times{result.seconds, seconds(start)};
  if (comm_) comm_->max(times);
  r.solverSeconds = times[0];
  r.solverTolerance = tolerance;
  r.solverKkt = result.kkt.max();
  r.solverErrorBound = result.errorBound;
  r.timeError = timeError;
  r.frictionForce = Eigen::Vector3d(sums[1], sums[2], sums[3]);
  r.stickNodes = static_cast<Index>(sums[4]);
  r.slipNodes = static_cast<Index>(sums[5]);
  r.frictionSolves = frictionSolves;
  r.stepSeconds = comm_ ? times[1] : seconds(start);
  last_ = r;
  return r;
}

template <int d>
NewmarkSchemeState NewmarkFamily<d>::schemeState() const {
  checkInitialized();
  NewmarkSchemeState s;
  s.scheme = std::string(obs::name(options_.scheme));
  s.state = state_;
  s.multiplier = multiplier_;
  s.previousMultiplier = previousMultiplier_;
  s.activePredictor = last_.activePredictor;
  s.predictorOnly = last_.predictorOnly;
  s.solutionOnly = last_.solutionOnly;
  s.solverIterations = last_.solverIterations;
  s.previousVelocity = previousVelocity_;
  s.nextSolverTolerance = nextTolerance_;
  s.previousIncrement = previousIncrement_;
  s.frictionDissipation = frictionDissipation_;
  return s;
}

template <int d>
void NewmarkFamily<d>::setSchemeState(const NewmarkSchemeState& s) {
  if (s.scheme != obs::name(options_.scheme))
    throw Error("time stepping: a state of scheme '" + s.scheme + "' cannot continue scheme '" +
                std::string(obs::name(options_.scheme)) + "'");
  const Eigen::Index n = static_cast<Eigen::Index>(numVertices_) * d;
  const bool withAcceleration = options_.scheme == NewmarkScheme::KhenousLabordeRenard;
  auto check = [&](const Eigen::VectorXd& x, Eigen::Index size, const char* what) {
    if (x.size() != size)
      throw Error(std::string("time stepping: state vector ") + what + " has " + std::to_string(x.size()) +
                  " entries, the problem has " + std::to_string(size));
    if (!x.allFinite()) throw Error(std::string("time stepping: state vector ") + what + " has non-finite values");
  };
  check(s.state.u, n, "u");
  check(s.state.v, n, "v");
  check(s.state.a, withAcceleration ? n : 0, "a");
  check(s.multiplier, n, "multiplier");
  check(s.previousMultiplier, n, "previous multiplier");
  if (s.previousVelocity.size() != 0) check(s.previousVelocity, n, "previous velocity");
  if (s.previousIncrement.size() != 0) check(s.previousIncrement, n, "previous increment");
  if (!(s.nextSolverTolerance >= 0) || !std::isfinite(s.nextSolverTolerance))
    throw Error("time stepping: state with the next solver tolerance " + num(s.nextSolverTolerance));
  if (s.state.step < 0 || !std::isfinite(s.state.time))
    throw Error("time stepping: state with step " + std::to_string(s.state.step) + ", time " + num(s.state.time));
  state_ = s.state;
  multiplier_ = s.multiplier;
  previousMultiplier_ = s.previousMultiplier;
  previousVelocity_ = s.previousVelocity;
  nextTolerance_ = s.nextSolverTolerance;
  previousIncrement_ = options_.start == NewmarkStart::PreviousIncrement ? s.previousIncrement : Eigen::VectorXd();
  if (!(s.frictionDissipation >= 0) || !std::isfinite(s.frictionDissipation))
    throw Error("time stepping: state with the friction dissipation " + num(s.frictionDissipation));
  frictionDissipation_ = s.frictionDissipation;
  A_.multiply(state_.u, Au_);
  initialized_ = true;
  last_ = makeRecord();
  last_.activePredictor = s.activePredictor;
  last_.predictorOnly = s.predictorOnly;
  last_.solutionOnly = s.solutionOnly;
  last_.solverIterations = s.solverIterations;
}

template <int d>
StepRecord NewmarkFamily<d>::record() const {
  checkInitialized();
  return last_;
}

template <int d>
StepRecord NewmarkFamily<d>::makeRecord() const {
  const Eigen::VectorXd& u = state_.u;
  const Eigen::VectorXd& v = state_.v;
  const double tau = options_.timeStep;
  StepRecord r;
  r.step = state_.step;
  r.time = state_.time;
  r.frictionDissipation = frictionDissipation_;
  // the sums over the owned vertices (every vertex serially), added over the ranks in one reduction:
  // 0 kinetic, 1 elastic, 2 load potential, 3-5 momentum, 6 kinetic (M~), 7-9 momentum (M~),
  // 10 acceleration energy, 11-13 contact force, 14 active nodes, then per tracked vertex 10 values
  const Eigen::Index ownedDofs = static_cast<Eigen::Index>(owned_) * d;
  const std::size_t base = 15;
  std::vector<double> sums(base + 10 * options_.trackedVertices.size(), 0.0);
  const Eigen::VectorXd Mv = applyMass(v, false);
  sums[0] = 0.5 * v.head(ownedDofs).dot(Mv.head(ownedDofs));
  sums[1] = 0.5 * u.head(ownedDofs).dot(Au_.head(ownedDofs));  // = A_.energy(u): Au_ is A u of the state
  sums[2] = -f_.head(ownedDofs).dot(u.head(ownedDofs));
  for (Index p = 0; p < owned_; ++p)
    for (int a = 0; a < d; ++a) sums[3 + a] += Mv[static_cast<Eigen::Index>(p) * d + a];
  if (redistributed_) {
    const Eigen::VectorXd Mrv = Mr_ * v;
    sums[6] = 0.5 * v.head(ownedDofs).dot(Mrv.head(ownedDofs));
    for (Index p = 0; p < owned_; ++p)
      for (int a = 0; a < d; ++a) sums[7 + a] += Mrv[static_cast<Eigen::Index>(p) * d + a];
  }
  const bool acceleration = options_.scheme == NewmarkScheme::KhenousLabordeRenard && state_.a.size() == v.size();
  if (acceleration) {
    const Eigen::VectorXd Ma = Mr_ * state_.a;
    sums[10] = 0.125 * tau * tau * state_.a.head(ownedDofs).dot(Ma.head(ownedDofs));
  }
  for (Index p = 0; p < owned_; ++p)
    for (int a = 0; a < d; ++a) sums[11 + a] += multiplier_[static_cast<Eigen::Index>(p) * d + a];

  const double tol = activeTolerance(u);  // collective
  double penetration = 0;
  const Eigen::VectorXd x = relative(u), w = basis_.rows > 0 ? relative(v) : v;
  for (Index k = 0; k < contact_->size(); ++k) {
    const double g = gaps_[static_cast<std::size_t>(k)];
    if (!std::isfinite(g) || contact_->vertex(k) >= owned_) continue;
    const double un = contact_->direction(k).template head<d>().dot(
        x.template segment<d>(static_cast<Eigen::Index>(contact_->vertex(k)) * d));
    sums[14] += g - un <= tol;
    penetration = std::max(penetration, un - g);
  }
  // tracked vertices: on the rank that holds them (distributed: owns them; -1 elsewhere)
  for (std::size_t j = 0; j < options_.trackedVertices.size(); ++j) {
    const Index vtx = options_.trackedVertices[j];
    if (vtx < 0) continue;
    double* t = &sums[base + 10 * j];
    const auto i = static_cast<Eigen::Index>(vtx) * d;
    for (int a = 0; a < d; ++a) {
      t[a] = u[i + a];
      t[3 + a] = v[i + a];
    }
    const Index k = contact_->nodeOf(vtx);
    if (k >= 0) {
      t[6] = 1;
      const Point& nu = contact_->direction(k);
      Eigen::Vector3d xr = Eigen::Vector3d::Zero(), wr = Eigen::Vector3d::Zero();
      xr.template head<d>() = x.template segment<d>(i);
      wr.template head<d>() = w.template segment<d>(i);
      t[7] = nu.dot(xr);
      t[8] = nu.dot(wr);
      t[9] = gaps_[static_cast<std::size_t>(k)] - t[7];
    }
  }
  sum(sums);
  r.maxPenetration = maximum(penetration);

  r.kineticEnergy = sums[0];
  r.elasticEnergy = sums[1];
  r.loadPotential = sums[2];
  r.energy = r.kineticEnergy + r.elasticEnergy + r.loadPotential;
  r.momentum = Eigen::Vector3d(sums[3], sums[4], sums[5]);
  if (redistributed_) {
    r.hasRedistributed = true;
    r.kineticEnergyRedistributed = sums[6];
    r.energyRedistributed = r.kineticEnergyRedistributed + r.elasticEnergy + r.loadPotential;
    r.momentumRedistributed = Eigen::Vector3d(sums[7], sums[8], sums[9]);
  }
  if (acceleration) {
    r.hasAcceleration = true;
    r.accelerationEnergy = sums[10];
    r.energyModified = r.energyRedistributed + r.accelerationEnergy;
  }
  r.contactForce = Eigen::Vector3d(sums[11], sums[12], sums[13]) / (multiplierFactor_ * tau * tau);
  r.activeSolution = static_cast<Index>(sums[14]);
  for (std::size_t j = 0; j < options_.trackedVertices.size(); ++j) {
    const double* t = &sums[base + 10 * j];
    TrackedVertex tv;
    tv.vertex = options_.trackedVertices[j];
    tv.displacement = Eigen::Vector3d(t[0], t[1], t[2]);
    tv.velocity = Eigen::Vector3d(t[3], t[4], t[5]);
    tv.contactNode = t[6] > 0;
    tv.normalDisplacement = t[7];
    tv.normalVelocity = t[8];
    tv.gap = t[9];
    r.tracked.push_back(tv);
  }
  return r;
}

template <int d>
std::unique_ptr<TimeStepper<d>> makeTimeStepper(const mesh::Grid& grid, const Material& material,
                                                const BoundaryConditions& bc, const ContactSet& contact,
                                                const NewmarkOptions& options) {
  return std::make_unique<NewmarkFamily<d>>(grid, material, bc, contact, options);
}

template <int d>
std::unique_ptr<TimeStepper<d>> makeTimeStepper(const std::vector<const mesh::Grid*>& grids, ContactModel<d>& model,
                                                const NewmarkOptions& options) {
  return std::make_unique<NewmarkFamily<d>>(grids, model, options);
}

template class NewmarkFamily<2>;
template class NewmarkFamily<3>;
template std::unique_ptr<TimeStepper<2>> makeTimeStepper<2>(const mesh::Grid&, const Material&,
                                                            const BoundaryConditions&, const ContactSet&,
                                                            const NewmarkOptions&);
template std::unique_ptr<TimeStepper<3>> makeTimeStepper<3>(const mesh::Grid&, const Material&,
                                                            const BoundaryConditions&, const ContactSet&,
                                                            const NewmarkOptions&);
template std::unique_ptr<TimeStepper<2>> makeTimeStepper<2>(const std::vector<const mesh::Grid*>&, ContactModel<2>&,
                                                            const NewmarkOptions&);
template std::unique_ptr<TimeStepper<3>> makeTimeStepper<3>(const std::vector<const mesh::Grid*>&, ContactModel<3>&,
                                                            const NewmarkOptions&);

}  // namespace obs
