#include "obs/estimators/AdaptiveLoop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>

#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Marking.hpp"
#include "BodyEstimation.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/SurfaceObstacle.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::estimators {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

const EstimatorRegistry& registryOf(const AdaptiveLoopOptions& o) {
  return o.registry ? *o.registry : EstimatorRegistry::global();
}

/// Interpolates a vertex-major vector with `components` per vertex by the transfer matrix T.
Eigen::VectorXd transfer(const mesh::CsrMatrix& T, const Eigen::VectorXd& u, int components) {
  Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(T.rows) * components);
  for (Index i = 0; i < T.rows; ++i)
    for (Index k = T.rowStart[i]; k < T.rowStart[i + 1]; ++k)
      r.segment(static_cast<Eigen::Index>(i) * components, components) +=
          T.values[k] * u.segment(static_cast<Eigen::Index>(T.columns[k]) * components, components);
  return r;
}

}  // namespace

double experimentalOrder(double eta0, double n0, double eta1, double n1) {
  if (!(eta0 > 0) || !(eta1 > 0) || !(n0 > 0) || !(n1 > n0)) return std::numeric_limits<double>::quiet_NaN();
  return (std::log(eta0) - std::log(eta1)) / (std::log(n1) - std::log(n0));
}

namespace {

/// A process's part of the reference errors: the L2 sums over the boundary faces it counts, the
/// contact radius over its nodes, and its node nearest to the centre.
struct ReferencePart {
  double err2 = 0, norm2 = 0, radius = 0;
  double nearest = std::numeric_limits<double>::infinity();
  Index nearestNode = -1;
};

/// The part of the faces with counted[f] != 0 (all if counted is empty) and the nodes on vertices
/// below `ownedVertices`; the nearest node to the centre by distance, ties by position (so the
/// choice does not depend on the vertex numbering).
ReferencePart referencePart(const mesh::Mesh& mesh, const ContactSet& set, const ContactOutputs& outputs,
                            const ContactReference& reference, double load, std::span<const char> counted,
                            Index ownedVertices) {
  if (!reference.pressure) throw Error("contact reference: no pressure function given");
  if (set.numMeshVertices() != mesh.numVertices() || outputs.pressure.size() != static_cast<std::size_t>(set.size()))
    throw Error("contact reference: contact set, outputs and mesh do not belong together");
  ReferencePart part;
  // relative L2 error of s_m on Gamma_C
  double shape[4], grad[8];
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    if (mesh.boundaryFaceId(f) != set.boundaryId() || (!counted.empty() && !counted[f])) continue;
    const auto fv = mesh.boundaryFaceVertices(f);
    const mesh::CellType ft = mesh::faceTypeFromVertexCount(static_cast<int>(fv.size()));
    const auto& ref = mesh::referenceElement(ft);
    const auto& rule = mesh::quadratureRule(ft, reference.quadratureDegree);
    for (std::size_t q = 0; q < rule.size(); ++q) {
      ref.values(rule.points[q], std::span<double>(shape, fv.size()));
      ref.gradients(rule.points[q], std::span<double>(grad, fv.size() * ref.dim));
      Point x = Point::Zero(), ds = Point::Zero(), dt = Point::Zero();
      double sm = 0;
      for (std::size_t i = 0; i < fv.size(); ++i) {
        x += shape[i] * mesh.vertex(fv[i]);
        ds += grad[i * ref.dim] * mesh.vertex(fv[i]);
        if (ref.dim == 2) dt += grad[i * ref.dim + 1] * mesh.vertex(fv[i]);
        sm += shape[i] * outputs.pressure[static_cast<std::size_t>(set.nodeOf(fv[i]))];
      }
      const double w = rule.weights[q] * (ref.dim == 1 ? ds.norm() : ds.cross(dt).norm());
      const double p = reference.pressure(x, load);
      part.err2 += w * (sm - p) * (sm - p);
      part.norm2 += w * p * p;
    }
  }
  // contact radius and centre node
  for (Index k = 0; k < set.size(); ++k) {
    if (set.vertex(k) >= ownedVertices) continue;
    const double dist = (set.position(k) - reference.centre).norm();
    if (outputs.inContact[static_cast<std::size_t>(k)]) part.radius = std::max(part.radius, dist);
    const auto before = [&](Index a, Index b) {
      const Point& xa = set.position(a);
      const Point& xb = set.position(b);
      return std::lexicographical_compare(xa.data(), xa.data() + 3, xb.data(), xb.data() + 3);
    };
    if (dist < part.nearest || (dist == part.nearest && before(k, part.nearestNode))) {
      part.nearest = dist;
      part.nearestNode = k;
    }
  }
  return part;
}

/// The errors from the (summed) part, the centre node's pressure and position.
ReferenceErrors finishReference(const ReferencePart& part, double load, double centrePressure, const Point& centre,
                                const ContactReference& reference) {
  ReferenceErrors r;
  r.load = load;
  r.pressureError = part.norm2 > 0 ? std::sqrt(part.err2 / part.norm2) : std::numeric_limits<double>::quiet_NaN();
  r.radius = part.radius;
  r.centrePressure = centrePressure;
  r.exactCentrePressure = reference.pressure(centre, load);
  r.exactRadius = reference.radius ? reference.radius(load) : std::numeric_limits<double>::quiet_NaN();
  r.radiusError = std::abs(r.radius - r.exactRadius) / r.exactRadius;
  r.centreError = std::abs(r.centrePressure - r.exactCentrePressure) / std::abs(r.exactCentrePressure);
  return r;
}

}  // namespace

ReferenceErrors referenceErrors(const mesh::Mesh& mesh, const ContactSet& set, const ContactOutputs& outputs,
                                const ContactReference& reference) {
  double load = 0;
  for (double mu : outputs.multiplier) load += mu;
  const ReferencePart part = referencePart(mesh, set, outputs, reference, load, {}, mesh.numVertices());
  if (part.nearestNode < 0) return finishReference(part, load, std::numeric_limits<double>::quiet_NaN(), reference.centre, reference);
  const auto k = static_cast<std::size_t>(part.nearestNode);
  ReferenceErrors r = finishReference(part, load, outputs.pressure[k], set.position(part.nearestNode), reference);
  r.centreVertex = set.vertex(part.nearestNode);
  return r;
}

ReferenceErrors referenceErrors(const mesh::Mesh& mesh, const ContactSet& set, const ContactOutputs& outputs,
                                const ContactReference& reference, Index ownedVertices,
                                std::span<const char> countedFaces, const Communicator& comm) {
  ReferencePart part;
  double load = 0;
  comm.collective([&] {
    for (Index k = 0; k < set.size(); ++k)
      if (set.vertex(k) < ownedVertices) load += outputs.multiplier[static_cast<std::size_t>(k)];
  });
  load = comm.sum(load);
  comm.collective([&] { part = referencePart(mesh, set, outputs, reference, load, countedFaces, ownedVertices); });
  std::vector<double> sums = {part.err2, part.norm2};
  comm.sum(sums);
  part.err2 = sums[0];
  part.norm2 = sums[1];
  part.radius = comm.max(part.radius);
  // the nearest node over the ranks (ties by position): every rank's candidate, the best taken
  const std::vector<double> mine = part.nearestNode < 0
                                       ? std::vector<double>{part.nearest, 0, 0, 0, 0}
                                       : std::vector<double>{part.nearest, set.position(part.nearestNode)[0],
                                                             set.position(part.nearestNode)[1],
                                                             set.position(part.nearestNode)[2],
                                                             outputs.pressure[static_cast<std::size_t>(part.nearestNode)]};
  std::vector<double> all(mine.size() * static_cast<std::size_t>(comm.size()), 0.0);
  std::copy(mine.begin(), mine.end(), all.begin() + static_cast<std::ptrdiff_t>(mine.size() * comm.rank()));
  comm.sum(all);  // each rank's five numbers in its own slot
  int best = -1;
  for (int q = 0; q < comm.size(); ++q) {
    const double* c = all.data() + 5 * q;
    if (!std::isfinite(c[0])) continue;
    if (best < 0) {
      best = q;
      continue;
    }
    const double* b = all.data() + 5 * best;
    if (c[0] < b[0] || (c[0] == b[0] && std::lexicographical_compare(c + 1, c + 4, b + 1, b + 4))) best = q;
  }
  if (best < 0) return finishReference(part, load, std::numeric_limits<double>::quiet_NaN(), reference.centre, reference);
  const double* b = all.data() + 5 * best;
  ReferenceErrors r = finishReference(part, load, b[4], Point(b[1], b[2], b[3]), reference);
  r.centreVertex = best == comm.rank() ? set.vertex(part.nearestNode) : -1;
  return r;
}

AdaptiveLoop::AdaptiveLoop(mesh::Grid& grid, const Material& material, const BoundaryConditions& bc,
                           AdaptiveLoopOptions options)
    : AdaptiveLoop(std::vector<AdaptiveBody>{AdaptiveBody{"body", &grid, &material, &bc}}, std::move(options)) {}

AdaptiveLoop::AdaptiveLoop(std::vector<AdaptiveBody> bodies, AdaptiveLoopOptions options)
    : bodies_(std::move(bodies)), options_(std::move(options)) {
  if (bodies_.empty()) throw Error("adaptive loop: no body");
  for (const AdaptiveBody& b : bodies_) {
    if (!b.grid || !b.material || !b.bc)
      throw Error("adaptive loop: body '" + b.name + "' lacks its grid, material or boundary conditions");
    if (b.grid->dimension() != bodies_.front().grid->dimension())
      throw Error("adaptive loop: body '" + b.name + "' has dimension " + std::to_string(b.grid->dimension()) +
                  ", body '" + bodies_.front().name + "' " + std::to_string(bodies_.front().grid->dimension()));
  }
  if (options_.maxSteps < 1)
    throw Error("adaptive loop: maxSteps must be at least 1, got " + std::to_string(options_.maxSteps));
  for (const AdaptiveBody& b : bodies_) {
    b.material->validate();
    model_.addBody(b.name, *b.material, *b.bc);
  }
  const bool needEstimator = options_.mode == RefinementMode::Adaptive || options_.estimateUniform;
  if (needEstimator) registryOf(options_).description(options_.estimator);  // throws, listing the names
  if (options_.mode == RefinementMode::Adaptive) MarkingStrategy(options_.marking, options_.markingParameter);
}

void AdaptiveLoop::checkBody(int body, const std::string& what) const {
  if (body < 0 || body >= static_cast<int>(bodies_.size()))
    throw Error("adaptive loop: " + what + " names body " + std::to_string(body) + " (the loop has " +
                std::to_string(bodies_.size()) + ")");
}

void AdaptiveLoop::setContact(const Obstacle& obstacle, int boundaryId) {
  model_.couplings.clear();
  addObstacleContact(0, obstacle, boundaryId);
}

void AdaptiveLoop::addObstacleContact(int body, const Obstacle& obstacle, int boundaryId, std::string label) {
  addCoupling(ContactModelSpec::Coupling::obstacleContact(body, obstacle, boundaryId, std::move(label)));
}

void AdaptiveLoop::addMortarContact(int slave, int slaveId, int master, int masterId, std::string label,
                                    const MortarOptions& options) {
  addCoupling(ContactModelSpec::Coupling::mortarPair(slave, slaveId, master, masterId, std::move(label), options));
}

void AdaptiveLoop::addCoupling(ContactModelSpec::Coupling c) {
  if (c.mortar) {
    checkBody(c.body, "mortar pair '" + c.label + "'");
    checkBody(c.master, "mortar pair '" + c.label + "'");
    if (c.body == c.master)
      throw Error("adaptive loop: mortar pair '" + c.label + "': slave and master belong to the same body");
  } else {
    checkBody(c.body, "obstacle contact '" + c.label + "'");
    if (!c.obstacle) throw Error("adaptive loop: obstacle contact '" + c.label + "' without obstacle");
  }
  model_.couplings.push_back(std::move(c));
}

void AdaptiveLoop::setReference(ContactReference reference) { reference_ = std::move(reference); }

void AdaptiveLoop::setCallback(Callback callback) { callback_ = std::move(callback); }

void AdaptiveLoop::setStateHook(StateHook hook) { stateHook_ = std::move(hook); }

void AdaptiveLoop::restore(AdaptiveLoopState state) {
  const std::size_t nb = bodies_.size();
  const int k = state.nextStep;
  if (k < 1 || k >= options_.maxSteps)
    throw Error("adaptive loop: cannot continue with step " + std::to_string(k) + " (the loop has steps 0 to " +
                std::to_string(options_.maxSteps - 1) + ")");
  if (state.steps.size() != static_cast<std::size_t>(k) || state.refinements.size() != static_cast<std::size_t>(k))
    throw Error("adaptive loop: a state before step " + std::to_string(k) + " needs " + std::to_string(k) +
                " step records and refinements, it has " + std::to_string(state.steps.size()) + " and " +
                std::to_string(state.refinements.size()));
  for (int j = 0; j < k; ++j) {
    const std::size_t sj = static_cast<std::size_t>(j);
    if (state.refinements[sj].size() != nb || state.steps[sj].bodies.size() != nb)
      throw Error("adaptive loop: the state of step " + std::to_string(j) + " has " +
                  std::to_string(state.refinements[sj].size()) + " bodies, the loop " + std::to_string(nb));
  }
  // replay the refinements: the grids of step k, as the interrupted loop refined them
  for (int j = 0; j < k; ++j)
    for (std::size_t i = 0; i < nb; ++i) {
      mesh::Grid& grid = *bodies_[i].grid;
      if (options_.mode == RefinementMode::Uniform) {
        grid.refineUniformly(threads());
        continue;
      }
      const std::vector<Index>& marked = state.refinements[static_cast<std::size_t>(j)][i];
      if (marked.empty()) continue;
      const mesh::GridView view = grid.leafView();
      if (view.mesh.numCells() != state.steps[static_cast<std::size_t>(j)].bodies[i].cells)
        throw Error("adaptive loop: replaying the refinement after step " + std::to_string(j) + ": body '" +
                    bodies_[i].name + "' has " + std::to_string(view.mesh.numCells()) + " leaf cells, the record " +
                    std::to_string(state.steps[static_cast<std::size_t>(j)].bodies[i].cells));
      for (Index c : marked) {
        if (c < 0 || c >= view.mesh.numCells())
          throw Error("adaptive loop: replaying the refinement after step " + std::to_string(j) + ": body '" +
                      bodies_[i].name + "' has no leaf cell " + std::to_string(c));
        grid.mark(view.elements[static_cast<std::size_t>(c)]);
      }
      grid.setClosureRule(options_.closure);
      grid.adapt(threads());
    }
  resume_ = std::move(state);
}

std::vector<AdaptiveStep> AdaptiveLoop::run() {
  return bodies_.front().grid->dimension() == 2 ? runDim<2>() : runDim<3>();
}

namespace {

/// sqrt(sum over free components i of u_i (A u)_i): the energy norm TNNMG's relative stopping
/// test divides by (prescribed rows of A are identity rows, left out).
template <int d>
double freeEnergyNorm(const ContactProblem<d>& problem, const Eigen::VectorXd& u, const DirichletValues& dirichlet) {
  Eigen::VectorXd Au;
  problem.multiply(u, Au);
  double s = 0;
  for (Eigen::Index i = 0; i < u.size(); ++i)
    if (!dirichlet.constrained[static_cast<std::size_t>(i)]) s += u[i] * Au[i];
  return std::sqrt(std::max(0.0, s));
}

}  // namespace

double AdaptiveLoop::inexactTolerance(const std::vector<AdaptiveStep>& steps, const AdaptiveStep& rec, int d) const {
  const double base = options_.solver.tolerance;
  if (!(options_.inexactFraction > 0) || steps.empty()) return base;
  const bool knownLast = rec.step + 1 == options_.maxSteps ||
                         (options_.targetVertices > 0 && rec.vertices >= options_.targetVertices);
  const AdaptiveStep& previous = steps.back();
  if (knownLast || !(previous.eta > 0) || !(lastEnergyNorm_ > 0)) return base;
  // predicted eta of this step: eta ~ N^(-eoc), eoc of the last step (1/d, the optimal order for
  // first-order elements, until there is one), clamped to [0, 1]
  const double eoc = std::isfinite(previous.eoc) ? std::clamp(previous.eoc, 0.0, 1.0) : 1.0 / d;
  const double predicted = previous.eta * std::pow(static_cast<double>(previous.vertices) / rec.vertices, eoc);
  // algebraic error ~ rho / (1 - rho) * last correction (geometric convergence with rate rho)
  const double rho = std::clamp(lastRate_, 0.05, 0.9);
  const double tolerance = options_.inexactFraction * predicted / lastEnergyNorm_ * (1 - rho) / rho;
  return std::clamp(tolerance, base, 1e-2);
}

namespace {

/// The smallest gap of several obstacles (a body with more than one constrained boundary: at each
/// point the nearest obstacle along its direction constrains).
class MinimumGapObstacle : public Obstacle {
public:
  explicit MinimumGapObstacle(std::vector<const Obstacle*> parts) : parts_(std::move(parts)) {}
  double gap(const Point& x) const override {
    double g = std::numeric_limits<double>::infinity();
    for (const Obstacle* o : parts_) g = std::min(g, o->gap(x));
    return g;
  }
  Point direction(const Point& x) const override {
    const Obstacle* best = parts_.front();
    for (const Obstacle* o : parts_)
      if (o->gap(x) < best->gap(x)) best = o;
    return best->direction(x);
  }
  std::string name() const override { return "several"; }

private:
  std::vector<const Obstacle*> parts_;
};

/// What the loop keeps of one body in a step.
struct BodyState {
  Index offset = 0;                     ///< first stacked vertex
  Eigen::VectorXd u;                    ///< displacement on the leaf view
  std::vector<int> contactIds;          ///< obstacle and slave boundaries (node classes)
  std::vector<int> estimatorIds;        ///< ... and master boundaries (EstimatorInput)
  std::optional<ContactSet> ownSet;     ///< restricted set (several couplings or mortar)
  const ContactSet* set = nullptr;      ///< the body's constrained nodes (ownSet or an obstacle set)
  std::vector<Index> stackedNodes;      ///< node k of set -> node of the stacked problem
  std::optional<ContactOutputs> outputs;
  std::vector<const Obstacle*> obstacles;
  std::vector<std::unique_ptr<Obstacle>> ownObstacles;  ///< mortar gaps, minimum
  const Obstacle* gap = nullptr;        ///< the exact gap for the estimator
  Eigen::VectorXd traction;             ///< master sides: mortar traction by vertex (empty: none)
  bool friction = false;                ///< the model has friction (ContactData::friction)
  std::vector<int> masterIds;
  ContactNodeClasses classes;
  std::optional<EstimatorResult> estimate;
  std::vector<Index> marked;
};

/// Fills the contact data of every body (BodyState: its constrained nodes as a ContactSet on its
/// mesh, their outputs, the exact gap, the master traction; docs/theory.md#two-body-estimator) from
/// the solution (u displacements, x problem unknowns) of the model's problem. `obstacles` holds the
/// obstacle of each coupling (null for mortar pairs).
template <int d>
void bodyContactData(const ContactModel<d>& model, const ContactProblem<d>& problem, const Eigen::VectorXd& u,
                     const Eigen::VectorXd& x, const ContactOutputs& out, const std::vector<const Obstacle*>& obstacles,
                     const std::vector<mesh::GridView>& views, std::vector<BodyState>& body) {
  const auto& couplings = model.couplings();
  const ContactSet& cs = problem.contactSet();
  for (std::size_t i = 0; i < body.size(); ++i) {
    BodyState& b = body[i];
    const mesh::Mesh& m = views[i].mesh;
    const Index n = m.numVertices();
    b.friction = model.frictional();
    std::vector<std::size_t> constrained;
    for (std::size_t j = 0; j < couplings.size(); ++j) {
      const auto& c = couplings[j];
      if (c.mortar && c.master == static_cast<int>(i)) {
        b.estimatorIds.push_back(c.masterId);
        b.masterIds.push_back(c.masterId);
        Eigen::VectorXd force;
        if (model.frictional()) {  // the slave's nodal forces mu_p n_p + f_T,p, friction included
          std::vector<Point> f(c.nodes.size(), Point::Zero());
          for (std::size_t k = 0; k < c.nodes.size(); ++k)
            if (problem.constraint(c.nodes[k]).bounded())
              f[k] = out.multiplier[c.nodes[k]] * cs.direction(c.nodes[k]) + out.tangential[c.nodes[k]];
          force = c.coupling->masterForces(f);
        } else {
          Eigen::VectorXd mu = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(c.nodes.size()));
          for (std::size_t k = 0; k < c.nodes.size(); ++k)
            if (problem.constraint(c.nodes[k]).bounded()) mu[static_cast<Eigen::Index>(k)] = out.multiplier[c.nodes[k]];
          force = c.coupling->masterForces(mu);
        }
        const std::vector<double> mass = boundaryLumpedMass(m, c.masterId);
        if (b.traction.size() == 0) b.traction = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * d);
        for (Index q = 0; q < n; ++q)
          if (mass[static_cast<std::size_t>(q)] > 0)
            b.traction.template segment<d>(static_cast<Eigen::Index>(q) * d) +=
                force.template segment<d>(static_cast<Eigen::Index>(b.offset + q) * d) / mass[static_cast<std::size_t>(q)];
      }
      if ((c.mortar ? c.slave : c.body) != static_cast<int>(i)) continue;
      constrained.push_back(j);
      if (c.mortar) {
        b.contactIds.push_back(c.slaveId);
        const auto& master = model.bodies()[c.master];
        const Eigen::VectorXd um =
            u.segment(static_cast<Eigen::Index>(master.offset) * d, static_cast<Eigen::Index>(master.mesh->numVertices()) * d);
        try {
          const ContactSet probe = c.coupling->contactSet();
          if (probe.size() == 0) throw Error("no constrained slave node");
          std::vector<Index> masterVertex;
          mesh::SurfaceMesh masterSurface =
              boundarySurface(*master.mesh, c.masterId, "the master surface of '" + c.label + "'", &masterVertex);
          std::vector<Point> masterDisplacement;
          for (Index v : masterVertex) {
            Point w = Point::Zero();
            w.head<d>() = um.template segment<d>(static_cast<Eigen::Index>(v) * d);
            masterDisplacement.push_back(w);
          }
          b.ownObstacles.push_back(std::make_unique<MortarGapObstacle>(
              boundarySurface(m, c.slaveId, "the slave surface of '" + c.label + "'"), masterSurface,
              std::move(masterDisplacement), probe.position(0), probe.direction(0)));
        } catch (const Error& e) {
          throw Error("adaptive loop: the exact gap of mortar pair '" + c.label + "' (the distance along the "
                      "slave normals to the master surface) cannot be built: " + e.what());
        }
        b.obstacles.push_back(b.ownObstacles.back().get());
      } else {
        b.contactIds.push_back(c.obstacleSet->boundaryId());
        b.obstacles.push_back(obstacles[j]);
      }
    }
    b.estimatorIds.insert(b.estimatorIds.end(), b.contactIds.begin(), b.contactIds.end());
    if (constrained.empty()) continue;
    if (b.obstacles.size() == 1) {
      b.gap = b.obstacles.front();
    } else {
      b.ownObstacles.push_back(std::make_unique<MinimumGapObstacle>(b.obstacles));
      b.gap = b.ownObstacles.back().get();
    }
    if (body.size() == 1 && constrained.size() == 1 && !couplings[constrained[0]].mortar) {
      // one body, one obstacle: the set and outputs of the problem itself
      b.set = couplings[constrained[0]].obstacleSet.get();
      b.stackedNodes = couplings[constrained[0]].nodes;
      b.outputs = out;
      continue;
    }
    // the stacked nodes on this body's vertices, with the gaps relative to the displaced master
    ContactSet::Data data;
    data.dimension = d;
    data.numMeshVertices = n;
    for (std::size_t j : constrained) data.label += (data.label.empty() ? "" : ", ") + couplings[j].label;
    data.obstacleName = b.obstacles.size() == 1 && !couplings[constrained[0]].mortar
                            ? couplings[constrained[0]].obstacleSet->obstacleName()
                            : (b.obstacles.size() == 1 ? "mortar" : "several");
    std::vector<Index> local(static_cast<std::size_t>(cs.size()), -1);
    for (Index node = 0; node < cs.size(); ++node) {
      const Index v = cs.vertex(node) - b.offset;
      if (v < 0 || v >= n) continue;
      local[static_cast<std::size_t>(node)] = static_cast<Index>(data.vertices.size());
      b.stackedNodes.push_back(node);
      const Point& nu = cs.direction(node);
      const auto at = static_cast<Eigen::Index>(cs.vertex(node)) * d;
      data.vertices.push_back(v);
      data.positions.push_back(cs.position(node));
      data.directions.push_back(nu);
      data.gaps.push_back(cs.gap(node) + nu.template head<d>().dot(u.template segment<d>(at) - x.template segment<d>(at)));
      data.masses.push_back(cs.boundaryMass(node));
    }
    for (const ContactSet::Face& f : cs.faces()) {
      ContactSet::Face g{{}, f.measure};
      for (Index node : f.nodes) g.nodes.push_back(local[static_cast<std::size_t>(node)]);
      if (std::all_of(g.nodes.begin(), g.nodes.end(), [](Index k) { return k >= 0; })) data.faces.push_back(std::move(g));
    }
    b.ownSet.emplace(std::move(data));
    b.set = &*b.ownSet;
    ContactOutputs o;
    for (Index node : b.stackedNodes) {
      const auto s = static_cast<std::size_t>(node);
      o.inContact.push_back(out.inContact[s]);
      o.multiplier.push_back(out.multiplier[s]);
      o.pressure.push_back(out.pressure[s]);
      o.tangential.push_back(out.tangential[s]);
      o.slip.push_back(out.slip[s]);
      o.state.push_back(out.state[s]);
      o.contactNodes += out.inContact[s] ? 1 : 0;
      o.force += out.multiplier[s] * cs.direction(node);
    }
    for (const ContactSet::Face& f : b.set->faces())
      if (std::all_of(f.nodes.begin(), f.nodes.end(), [&](Index k) { return o.inContact[static_cast<std::size_t>(k)] != 0; }))
        o.contactArea += f.measure;
    o.contactRadius = d == 3 ? std::sqrt(o.contactArea / std::numbers::pi) : o.contactArea / 2;
    b.outputs = std::move(o);
  }
}

/// The contact figures of a step from the solution of the model's problem: per coupling
/// (couplingRecords), per body (its constrained nodes, outputs, exact gap and master traction:
/// bodyContactData; then the node classes of every body), the total load, and the reference errors
/// of one body against one obstacle.
template <int d>
void contactFigures(const std::optional<ContactModel<d>>& model, const std::optional<ContactProblem<d>>& problem,
                    const Eigen::VectorXd& u, const Eigen::VectorXd& x, const std::vector<const Obstacle*>& couplingObstacles,
                    const std::vector<mesh::GridView>& views, double contactTolerance,
                    const std::optional<ContactReference>& reference, bool oneObstacle, AdaptiveStep& rec,
                    std::vector<BodyState>& body) {
  std::optional<ContactOutputs> outputs;
  if (problem) {
    outputs = computeContactOutputs(*problem, x, contactTolerance);
    rec.couplings = couplingRecords(*model, *problem, x, *outputs);
    bodyContactData(*model, *problem, u, x, *outputs, couplingObstacles, views, body);
  }
  for (std::size_t i = 0; i < body.size(); ++i) {
    BodyState& b = body[i];
    b.classes = classifyContactNodes(views[i].mesh, b.contactIds, b.set, b.u, contactTolerance);
    rec.potentialContact += b.classes.potential;
    rec.actualContact += b.classes.actual;
    rec.semiContact += b.classes.semi;
    rec.fullContact += b.classes.full;
  }
  if (outputs)
    for (double mu : outputs->multiplier) rec.load += mu;
  if (reference && body.size() == 1 && oneObstacle)
    rec.reference = referenceErrors(views[0].mesh, *body[0].set, *body[0].outputs, *reference);
}

/// The estimate of every body on its own contact data, eta = (sum_i eta_i^2)^1/2 and the
/// contributions summed the same way, and the eoc against the previous step.
void estimateStep(Estimator& estimator, const std::vector<AdaptiveBody>& bodies, const std::vector<mesh::GridView>& views,
                  int k, const std::vector<AdaptiveStep>& steps, AdaptiveStep& rec, std::vector<BodyState>& body) {
  const auto t = Clock::now();
  std::vector<const EstimatorResult*> estimates;
  for (std::size_t i = 0; i < body.size(); ++i) {
    BodyState& b = body[i];
    EstimatorInput in(views[i].mesh, *bodies[i].material, *bodies[i].bc, b.u);
    in.meshRevision = static_cast<std::uint64_t>(k);
    in.contactBoundaryIds = b.estimatorIds;
    ContactData data;
    if (b.set || b.traction.size() > 0) {
      data = ContactData{b.set, b.outputs ? &*b.outputs : nullptr, b.gap, b.traction.size() > 0 ? &b.traction : nullptr,
                         b.masterIds};
      data.friction = b.friction;
      in.contact = &data;
    }
    b.estimate = estimator.estimate(in);
    rec.bodies[i].eta = b.estimate->total;
    estimates.push_back(&*b.estimate);
  }
  rec.estimatorSeconds = since(t);
  CombinedEstimate all = combineEstimates(estimates);
  rec.eta = all.total;
  rec.contributions = std::move(all.contributions);
  if (!steps.empty())
    rec.eoc = experimentalOrder(steps.back().eta, static_cast<double>(steps.back().vertices), rec.eta,
                                static_cast<double>(rec.vertices));
}

/// Marks among the cells of all bodies (their indicators in body order) and hands each body its
/// cells; returns the seconds taken. No marked cell makes the step the last.
double markStep(const MarkingStrategy& marking, AdaptiveStep& rec, std::vector<BodyState>& body, bool& last) {
  const auto t = Clock::now();
  std::vector<double> indicators;
  for (const BodyState& b : body)
    indicators.insert(indicators.end(), b.estimate->indicators.begin(), b.estimate->indicators.end());
  std::vector<Index> cells = marking.mark(indicators);
  std::sort(cells.begin(), cells.end());
  std::size_t i = 0;
  Index first = 0;
  for (Index c : cells) {
    while (c >= first + rec.bodies[i].cells) first += rec.bodies[i++].cells;
    body[i].marked.push_back(c - first);
  }
  rec.marked = static_cast<Index>(cells.size());
  for (std::size_t j = 0; j < body.size(); ++j) rec.bodies[j].marked = static_cast<Index>(body[j].marked.size());
  if (cells.empty()) last = true;
  return since(t);
}

/// Refines every body's grid: its marked cells (adaptive; the closure rule set first) or all of
/// them (uniform); records the marked cells per body in `refinement` and the counts in rec.
void refineGrids(const std::vector<AdaptiveBody>& bodies, const std::vector<mesh::GridView>& views,
                 const std::vector<BodyState>& body, bool adaptive, mesh::ClosureRule closure,
                 std::vector<std::vector<Index>>& refinement, AdaptiveStep& rec) {
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    mesh::Grid& grid = *bodies[i].grid;
    if (!adaptive) {
      grid.refineUniformly(threads());
      continue;
    }
    refinement[i] = body[i].marked;
    if (body[i].marked.empty()) continue;
    for (Index c : body[i].marked) grid.mark(views[i].elements[c]);
    grid.setClosureRule(closure);
    const mesh::AdaptResult r = grid.adapt(threads());
    rec.refinedRed += r.redRefined;
    rec.closureRed += r.propagated;
    rec.greenClosed += r.greenClosed;
  }
}

/// The start vector on the new leaf views `next`: each body's solution transferred from `views`
/// (Prolongation.hpp), stacked; empty without warm starts.
Eigen::VectorXd transferStart(const std::vector<AdaptiveBody>& bodies, const std::vector<mesh::GridView>& views,
                              const std::vector<mesh::GridView>& next, const std::vector<BodyState>& body, int d) {
  std::vector<Eigen::VectorXd> parts;
  Index total = 0;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    total += next[i].mesh.numVertices();
    parts.push_back(transfer(mesh::transferMatrix(*bodies[i].grid, views[i], next[i]), body[i].u, d));
  }
  if (parts.size() == 1) return std::move(parts.front());
  Eigen::VectorXd start(static_cast<Eigen::Index>(total) * d);
  Eigen::Index at = 0;
  for (const Eigen::VectorXd& p : parts) {
    start.segment(at, p.size()) = p;
    at += p.size();
  }
  return start;
}

}  // namespace

template <int d>
void AdaptiveLoop::solveStep(const std::vector<mesh::GridView>& views, const std::vector<const mesh::Grid*>& grids,
                             const Eigen::VectorXd& start, const std::vector<AdaptiveStep>& steps, AdaptiveStep& rec,
                             std::optional<ContactModel<d>>& model, std::optional<ContactProblem<d>>& problem,
                             Eigen::VectorXd& u, Eigen::VectorXd& x) {
  auto t = Clock::now();
  if (model_.couplings.empty()) {  // linear elasticity: the stacked bodies, CHOLMOD
    std::vector<const mesh::Mesh*> meshes;
    std::vector<const Material*> materials;
    std::vector<const BoundaryConditions*> conditions;
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
      meshes.push_back(&views[i].mesh);
      materials.push_back(bodies_[i].material);
      conditions.push_back(bodies_[i].bc);
    }
    BodySystem<d> sys = assembleBodies<d>(meshes, materials, conditions);
    applyDirichlet(sys.stiffness, sys.load, sys.dirichlet);
    rec.assemblySeconds = since(t);
    t = Clock::now();
    const CholmodSolver cholmod(sys.stiffness);
    u = cholmod.solve(sys.load);
    rec.solverSeconds = since(t);
    rec.solver = "cholmod";
    rec.solverIterations = 1;
    rec.converged = u.allFinite();
    if (!rec.converged) throw Error("adaptive loop, step " + std::to_string(rec.step) + ": the direct solve gave NaN");
    return;
  }
  std::vector<const mesh::Mesh*> meshes;
  for (const mesh::GridView& v : views) meshes.push_back(&v.mesh);
  model.emplace(makeContactModel<d>(model_, meshes));  // the contact model, as in static and dynamic runs
  problem.emplace(model->assemble());
  rec.assemblySeconds = since(t);
  const bool warm = options_.warmStart && start.size() == rec.unknowns;
  x = warm ? problem->fromDisplacement(start) : Eigen::VectorXd::Zero(rec.unknowns);
  t = Clock::now();
  SolverConfig config = options_.solver;
  if (config.kind == ContactSolverKind::TNNMG) config.tolerance = inexactTolerance(steps, rec, d);
  rec.solverTolerance = config.tolerance;
  const auto solver = makeContactSolver<d>(config, grids, {}, false);
  ContactResult result;
  if (model->frictional()) {  // Tresca: one solve; Coulomb: the fixed point over Tresca solves
    CoulombOptions options;
    options.tolerance = std::max(options.tolerance, 10 * config.tolerance);
    const CoulombResult fr = solveFriction(*problem, *solver, x, nodalFriction(*model, problem->contactSet()), options);
    result = fr.last;
    result.iterations = static_cast<int>(fr.innerIterations);
    result.converged = fr.converged && fr.last.converged;
  } else {
    result = solver->solve(*problem, x);
  }
  rec.solverSeconds = since(t);
  rec.solver = result.solver;
  rec.solverIterations = result.iterations;
  rec.converged = result.converged;
  rec.kkt = result.kkt.max();
  if (options_.inexactFraction > 0) {  // inputs of the next step's tolerance (inexactTolerance)
    lastRate_ = result.convergenceRate;
    lastEnergyNorm_ = freeEnergyNorm<d>(*problem, x, problem->dirichlet());
  }
  u = problem->toDisplacement(x);
}

template <int d>
std::vector<AdaptiveStep> AdaptiveLoop::runDim() {
  const bool adaptive = options_.mode == RefinementMode::Adaptive;
  const bool estimate = adaptive || options_.estimateUniform;
  std::unique_ptr<Estimator> estimator;
  if (estimate) estimator = registryOf(options_).create(options_.estimator);
  std::optional<MarkingStrategy> marking;
  if (adaptive) marking.emplace(options_.marking, options_.markingParameter);
  const std::size_t nb = bodies_.size();
  std::vector<const mesh::Grid*> grids;
  for (const AdaptiveBody& b : bodies_) grids.push_back(b.grid);
  std::vector<const Obstacle*> couplingObstacles;  // per coupling, null for mortar pairs
  for (const ContactModelSpec::Coupling& c : model_.couplings) couplingObstacles.push_back(c.mortar ? nullptr : c.obstacle);
  const bool oneObstacle = model_.couplings.size() == 1 && !model_.couplings[0].mortar;

  std::vector<AdaptiveStep> steps;
  lastRate_ = lastEnergyNorm_ = 0;
  std::vector<mesh::GridView> views;
  for (const AdaptiveBody& b : bodies_) views.push_back(b.grid->leafView());
  Eigen::VectorXd start;  // stacked displacements; empty: cold start
  double transferSeconds = 0;
  std::vector<std::vector<std::vector<Index>>> refinements;  // [step][body]: marked leaf cells
  int firstStep = 0;
  if (resume_) {  // restore(): the grids are those of step nextStep already
    firstStep = resume_->nextStep;
    steps = std::move(resume_->steps);
    refinements = std::move(resume_->refinements);
    start = std::move(resume_->start);
    transferSeconds = resume_->transferSeconds;
    lastRate_ = resume_->lastRate;
    lastEnergyNorm_ = resume_->lastEnergyNorm;
    resume_.reset();
    Index total = 0;
    for (const mesh::GridView& v : views) total += v.mesh.numVertices();
    if (start.size() != 0 && start.size() != static_cast<Eigen::Index>(total) * d)
      throw Error("adaptive loop: the restored start vector has " + std::to_string(start.size()) +
                  " entries, the leaf views of step " + std::to_string(firstStep) + " " + std::to_string(total * d) +
                  " unknowns");
  }
  for (int k = firstStep; k < options_.maxSteps; ++k) {
    AdaptiveStep rec;
    rec.step = k;
    rec.transferSeconds = transferSeconds;
    std::vector<BodyState> body(nb);
    for (std::size_t i = 0; i < nb; ++i) {
      const mesh::Mesh& m = views[i].mesh;
      body[i].offset = rec.vertices;
      rec.cells += m.numCells();
      rec.vertices += m.numVertices();
      rec.bodies.push_back(BodyRecord{m.numCells(), m.numVertices()});
    }
    rec.unknowns = rec.vertices * d;

    // solve, then the contact figures of the couplings and of every body
    std::optional<ContactModel<d>> model;
    std::optional<ContactProblem<d>> problem;
    Eigen::VectorXd u, x;
    solveStep<d>(views, grids, start, steps, rec, model, problem, u, x);
    for (std::size_t i = 0; i < nb; ++i)
      body[i].u = u.segment(static_cast<Eigen::Index>(body[i].offset) * d, views[i].mesh.numVertices() * d);
    contactFigures<d>(model, problem, u, x, couplingObstacles, views, options_.contactTolerance, reference_, oneObstacle,
                      rec, body);

    // estimate (not on an unconverged solution: its residual is the solver's, not the
    // discretisation's, and marking on it would refine the wrong cells; the loop stops there)
    if (estimator && rec.converged) estimateStep(*estimator, bodies_, views, k, steps, rec, body);

    // stop? marking among the cells of all bodies (the refinement itself follows the callback, so
    // that it sees the grids of the step)
    bool last = !rec.converged || k + 1 == options_.maxSteps ||
                (options_.targetVertices > 0 && rec.vertices >= options_.targetVertices) ||
                (options_.etaTolerance > 0 && body[0].estimate && rec.eta <= options_.etaTolerance);
    double markSeconds = 0;
    if (!last && adaptive) {
      markSeconds = markStep(*marking, rec, body, last);
    } else if (!last) {
      rec.marked = rec.cells;
      for (BodyRecord& br : rec.bodies) br.marked = br.cells;
    }

    steps.push_back(rec);
    if (callback_) {
      std::vector<AdaptiveBodyView> bodyViews;
      for (std::size_t i = 0; i < nb; ++i) {
        const BodyState& b = body[i];
        bodyViews.push_back(AdaptiveBodyView{*bodies_[i].grid, views[i], b.u, b.set, b.outputs ? &*b.outputs : nullptr,
                                             b.classes, b.estimate ? &*b.estimate : nullptr, b.marked});
      }
      const BodyState& b0 = body[0];
      callback_(AdaptiveStepView{steps.back(), *bodies_[0].grid, views[0], b0.u, b0.set,
                                 b0.outputs ? &*b0.outputs : nullptr, b0.classes,
                                 b0.estimate ? &*b0.estimate : nullptr, bodyViews});
    }
    if (last) {
      u_ = std::move(u);
      break;
    }

    // refine, then the next leaf views and the start vector on them
    auto t = Clock::now();
    refinements.emplace_back(nb);
    refineGrids(bodies_, views, body, adaptive, options_.closure, refinements.back(), steps.back());
    steps.back().refinementSeconds = markSeconds + since(t);
    t = Clock::now();
    std::vector<mesh::GridView> next;
    for (const AdaptiveBody& b : bodies_) next.push_back(b.grid->leafView());
    start = options_.warmStart ? transferStart(bodies_, views, next, body, d) : Eigen::VectorXd();
    transferSeconds = since(t);
    views = std::move(next);
    u_ = std::move(u);
    if (stateHook_) {
      AdaptiveLoopState state;
      state.nextStep = k + 1;
      state.steps = steps;
      state.refinements = refinements;
      state.start = start;
      state.transferSeconds = transferSeconds;
      state.lastRate = lastRate_;
      state.lastEnergyNorm = lastEnergyNorm_;
      stateHook_(state);
    }
  }
  return steps;
}

template std::vector<AdaptiveStep> AdaptiveLoop::runDim<2>();
template std::vector<AdaptiveStep> AdaptiveLoop::runDim<3>();

}  // namespace obs::estimators
