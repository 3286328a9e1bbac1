#include "obs/estimators/DistributedAdaptiveLoop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/estimators/DistributedEstimation.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Marking.hpp"
#include "BodyEstimation.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedMortar.hpp"
#include "obs/obs/DistributedMultiBody.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultiBody.hpp"
#include "obs/obs/SolverConfig.hpp"
#include "obs/obs/TNNMG.hpp"

namespace obs::estimators {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// This rank's part of the scales of computeContactOutputs' rule (to be maximised over the ranks):
/// U = max(|u|, finite gaps), F = max(|b_i|, |(A u)_i|) over the free components of the owned
/// vertices (their rows are complete).
template <int d>
std::vector<double> contactScales(const ContactProblem<d>& problem, const Eigen::VectorXd& x, Index owned) {
  const ContactSet& cs = problem.contactSet();
  const Eigen::Index n = static_cast<Eigen::Index>(owned) * d;
  std::vector<double> scales = {n > 0 ? x.head(n).lpNorm<Eigen::Infinity>() : 0.0, 0.0};
  for (Index k = 0; k < cs.size(); ++k)
    if (cs.vertex(k) < owned && std::isfinite(cs.gap(k))) scales[0] = std::max(scales[0], std::abs(cs.gap(k)));
  Eigen::VectorXd Ax;
  problem.multiply(x, Ax);
  const auto& prescribed = problem.dirichlet().constrained;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!prescribed[static_cast<std::size_t>(i)])
      scales[1] = std::max({scales[1], std::abs(problem.rhs()[i]), std::abs(Ax[i])});
  return scales;
}

/// True if this rank counts the face with these local vertices of a view: it owns the face's vertex
/// of smallest global index, so that sums over faces count each face on one rank.
bool countsFace(const DistributedView& view, std::span<const Index> vertices) {
  const auto& held = view.halo.viewVertices();
  Index first = -1, firstGlobal = std::numeric_limits<Index>::max();
  for (Index v : vertices)
    if (const Index g = view.numbering.global[held[v]]; g < firstGlobal) {
      firstGlobal = g;
      first = v;
    }
  return first >= 0 && first < view.halo.numOwned();
}

/// countsFace of every boundary face of a view's local mesh (1: counted here).
std::vector<char> countedFaces(const DistributedView& view) {
  std::vector<char> counted(static_cast<std::size_t>(view.local.numBoundaryFaces()), 0);
  for (Index f = 0; f < view.local.numBoundaryFaces(); ++f) counted[f] = countsFace(view, view.local.boundaryFaceVertices(f));
  return counted;
}

/// The boundary faces with id `id` of all ranks as one surface (each face from the rank counting
/// it; vertices merged by position, which is the same bits on every rank that holds a vertex), and
/// with `values` (d per local vertex; null: none) the value at each surface vertex. Collective.
mesh::SurfaceMesh gatherSurface(const DistributedView& view, int id, const Eigen::VectorXd* values, int d,
                                const std::string& label, std::vector<Point>* gathered) {
  const Communicator& comm = view.halo.communicator();
  std::vector<double> mine;  // per face: its vertex count, then per vertex x (3) and the value (3)
  comm.collective([&] {
    const std::vector<char> counted = countedFaces(view);
    for (Index f = 0; f < view.local.numBoundaryFaces(); ++f) {
      if (!counted[f] || view.local.boundaryFaceId(f) != id) continue;
      const auto fv = view.local.boundaryFaceVertices(f);
      mine.push_back(static_cast<double>(fv.size()));
      for (Index v : fv) {
        const Point& x = view.local.vertex(v);
        mine.insert(mine.end(), {x[0], x[1], x[2]});
        Point u = Point::Zero();
        if (values) u.head(d) = values->segment(static_cast<Eigen::Index>(v) * d, d);
        mine.insert(mine.end(), {u[0], u[1], u[2]});
      }
    }
  });
  const std::vector<std::vector<double>> all = comm.allGather(mine);
  mesh::SurfaceMesh s;
  s.dimension = d;
  s.source = label;
  std::map<std::array<double, 3>, Index> vertexAt;
  for (const std::vector<double>& part : all)
    for (std::size_t i = 0; i < part.size();) {
      const auto n = static_cast<std::size_t>(part[i++]);
      std::array<Index, 4> face{};
      for (std::size_t k = 0; k < n; ++k, i += 6) {
        const std::array<double, 3> x{part[i], part[i + 1], part[i + 2]};
        auto [it, added] = vertexAt.emplace(x, static_cast<Index>(s.vertices.size()));
        if (added) {
          s.vertices.push_back(Point(x[0], x[1], x[2]));
          if (gathered) gathered->push_back(Point(part[i + 3], part[i + 4], part[i + 5]));
        }
        face[k] = it->second;
      }
      s.types.push_back(mesh::faceTypeFromVertexCount(static_cast<int>(n)));
      s.faces.push_back(face);
    }
  return s;
}

/// The key of a cell of body b among the cells of all bodies (marking ties): the grid's cell key,
/// mixed with the body index (the first body's keys unchanged).
std::uint64_t bodyCellKey(std::uint64_t key, std::size_t body) {
  return key ^ (0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(body));
}

/// What the loop keeps of one body in a step.
struct BodyStep {
  Eigen::VectorXd u;                     ///< displacement on the local mesh
  std::vector<int> contactIds;           ///< obstacle or slave boundary (node classes)
  std::vector<int> estimatorIds;         ///< ... or the master boundary (EstimatorInput)
  std::vector<int> masterIds;
  std::optional<ContactSet> ownSet;      ///< the slave nodes on the body's local mesh
  const ContactSet* set = nullptr;
  std::optional<ContactOutputs> ownOutputs;
  const ContactOutputs* outputs = nullptr;
  std::unique_ptr<Obstacle> ownGap;      ///< the mortar exact gap
  const Obstacle* gap = nullptr;
  Eigen::VectorXd traction;              ///< master side: the mortar traction by vertex
  double scale = 0;                      ///< U of the node classes, over all ranks
  ContactNodeClasses classes;
  std::optional<EstimatorResult> estimate;
  std::vector<Index> marked;
  RebalanceReport balance;
};

}  // namespace

DistributedAdaptiveLoop::DistributedAdaptiveLoop(DistributedGrid& grid, const Material& material,
                                                 const BoundaryConditions& bc, const Obstacle& obstacle,
                                                 int boundaryId, AdaptiveLoopOptions options)
    : DistributedAdaptiveLoop(std::vector<DistributedAdaptiveBody>{{"", &grid, &material, &bc}}, std::move(options)) {
  obstacle_ = &obstacle;
  boundaryId_ = boundaryId;
}

DistributedAdaptiveLoop::DistributedAdaptiveLoop(std::vector<DistributedAdaptiveBody> bodies, AdaptiveLoopOptions options)
    : bodies_(std::move(bodies)), options_(std::move(options)) {
  if (bodies_.empty() || !bodies_.front().grid) throw Error("adaptive loop on ranks: no bodies");
  communicator().collective([&] {
    for (const DistributedAdaptiveBody& b : bodies_) {
      if (!b.grid || !b.material || !b.bc) throw Error("adaptive loop on ranks: body '" + b.name + "' without grid, material or conditions");
      if (b.grid->grid().dimension() != bodies_.front().grid->grid().dimension())
        throw Error("adaptive loop on ranks: the bodies' grids have different dimensions");
    }
    if (options_.maxSteps < 1) throw Error("adaptive loop: maxSteps = " + std::to_string(options_.maxSteps) + " (>= 1)");
    if (options_.solver.kind != ContactSolverKind::TNNMG)
      throw Error("adaptive loop on ranks: the contact problems are solved by TNNMG only");
    if (options_.inexactFraction > 0) throw Error("adaptive loop on ranks: inexact solves are not distributed yet");
    // the names, checked as AdaptiveLoop checks them
    const EstimatorRegistry& registry = options_.registry ? *options_.registry : EstimatorRegistry::global();
    (void)registry.create(options_.estimator);
    if (options_.mode == RefinementMode::Adaptive) (void)MarkingStrategy(options_.marking, options_.markingParameter);
  });
}

void DistributedAdaptiveLoop::addMortarContact(int slave, int slaveId, int master, int masterId, std::string label,
                                               const MortarOptions& options) {
  communicator().collective([&] {
    const int n = static_cast<int>(bodies_.size());
    if (slave < 0 || slave >= n || master < 0 || master >= n || slave == master)
      throw Error("adaptive loop on ranks: mortar pair '" + label + "' between bodies " + std::to_string(slave) + " and " +
                  std::to_string(master) + " of " + std::to_string(n));
    if (n != 2 || pair_ || obstacle_)
      throw Error("adaptive loop on ranks: two bodies with one mortar pair only (pair '" + label + "')");
  });
  pair_ = Pair{slave, slaveId, master, masterId, std::move(label), options};
}

void DistributedAdaptiveLoop::setImbalanceTolerance(double tolerance) {
  if (!(tolerance >= 1.0))
    throw Error("adaptive loop on ranks: imbalance tolerance " + std::to_string(tolerance) + " (at least 1)");
  imbalanceTolerance_ = tolerance;
}

std::vector<AdaptiveStep> DistributedAdaptiveLoop::run() {
  communicator().collective([&] {
    if (!obstacle_ && !pair_) throw Error("adaptive loop on ranks: no contact (an obstacle, or a mortar pair of two bodies)");
    if (pair_ && bodies_.size() != 2) throw Error("adaptive loop on ranks: a mortar pair needs two bodies");
  });
  return bodies_.front().grid->grid().dimension() == 2 ? runDim<2>() : runDim<3>();
}

template <int d>
std::vector<AdaptiveStep> DistributedAdaptiveLoop::runDim() {
  const Communicator& comm = communicator();
  const std::size_t nb = bodies_.size();
  const bool adaptive = options_.mode == RefinementMode::Adaptive;
  const bool estimate = adaptive || options_.estimateUniform;
  const EstimatorRegistry& registry = options_.registry ? *options_.registry : EstimatorRegistry::global();
  std::unique_ptr<Estimator> estimator;
  if (estimate) estimator = registry.create(options_.estimator);
  std::optional<MarkingStrategy> marking;
  if (adaptive) marking.emplace(options_.marking, options_.markingParameter);
  for (const DistributedAdaptiveBody& b : bodies_) b.grid->setClosureRule(options_.closure);

  std::vector<AdaptiveStep> steps;
  // per body: d values per vertex of its leaf view (warm start); empty: cold
  std::vector<std::vector<double>> start(nb);
  double transferSeconds = 0;
  // the balancing after the refinement that made the step's grids (step 0: measured only)
  std::vector<RebalanceReport> balance(nb);
  double balanceSeconds = 0;
  std::vector<std::vector<std::vector<std::uint64_t>>> markedKeys;  // for the state hook
  int first = 0;
  if (resume_) {  // restore(): the grids rebuilt, the records and the starts of the interrupted run
    steps = resume_->steps;
    markedKeys = resume_->marked;
    transferSeconds = resume_->transferSeconds;
    first = resume_->nextStep;
    start = std::move(resumeStart_);
    balance = resumeBalance_;
    balanceSeconds = resumeBalanceSeconds_;
    resume_.reset();
  } else {
    for (std::size_t b = 0; b < nb; ++b) balance[b] = bodies_[b].grid->rebalance(std::numeric_limits<double>::infinity());
  }
  for (int k = first; k < options_.maxSteps; ++k) {
    AdaptiveStep rec;
    rec.step = k;
    rec.transferSeconds = transferSeconds;
    std::vector<DistributedView> leaves;
    for (std::size_t b = 0; b < nb; ++b) {
      const DistributedView& leaf = leaves.emplace_back(bodies_[b].grid->view());
      const auto cells = static_cast<Index>(bodies_[b].grid->globalLeaves());
      rec.bodies.push_back(BodyRecord{cells, leaf.globalVertices()});
      rec.cells += cells;
      rec.vertices += leaf.globalVertices();
    }
    rec.unknowns = rec.vertices * d;

    // the problem on the local meshes, the start, the solve
    auto t = Clock::now();
    std::vector<BodyStep> body(nb);
    std::optional<ContactSet> obstacleSet;
    std::optional<ContactProblem<d>> obstacleProblem;
    std::optional<DistributedMortar> mortar;
    std::optional<DistributedMultiBody<d>> multi;
    std::vector<Eigen::VectorXd> u0(nb);
    comm.collective([&] {
      for (std::size_t b = 0; b < nb; ++b) {
        const DistributedView& leaf = leaves[b];
        u0[b] = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(leaf.local.numVertices()) * d);
        if (start[b].empty()) continue;  // else on the leaf view's vertices
        const auto& held = leaf.halo.viewVertices();
        for (Index i = 0; i < leaf.local.numVertices(); ++i)
          for (int c = 0; c < d; ++c)
            u0[b][static_cast<Eigen::Index>(i) * d + c] = start[b][static_cast<std::size_t>(held[i]) * d + c];
      }
    });
    // the starts' ghost entries from their owners: an owned vertex lies in old owned or ghost cells
    // only, whose vertices were all held, but a ghost may have been located in an old cell beyond
    for (std::size_t b = 0; b < nb; ++b) leaves[b].halo.update(u0[b], d);
    double mortarSeconds = 0;
    Eigen::VectorXd x;
    if (!pair_) {
      comm.collective([&] {
        obstacleSet.emplace(leaves[0].local, boundaryId_, *obstacle_, true);
        obstacleProblem.emplace(leaves[0].local, *bodies_[0].material, *bodies_[0].bc, *obstacleSet);
        x = obstacleProblem->fromDisplacement(u0[0]);
      });
    } else {  // the pair on this step's leaf views, the bodies' systems, the transformed problem
      const auto tm = Clock::now();
      const Index offsets[2] = {0, leaves[0].globalVertices()};
      const Pair& p = *pair_;
      mortar.emplace(DistributedMortarSurface{&leaves[p.slave], p.slaveId, offsets[p.slave], p.label + " (slave)"},
                     DistributedMortarSurface{&leaves[p.master], p.masterId, offsets[p.master], p.label + " (master)"},
                     p.options);
      mortarSeconds = comm.max(since(tm));
      std::vector<BodySystem<d>> systems(nb);
      comm.collective([&] {
        for (std::size_t b = 0; b < nb; ++b)
          systems[b] = assembleBody<d>(leaves[b].local, *bodies_[b].material, *bodies_[b].bc);
      });
      multi.emplace(std::vector<DistributedBody<d>>{{&leaves[0], &systems[0]}, {&leaves[1], &systems[1]}}, *mortar,
                    p.slave, p.master);
      systems.clear();  // in T'AT now
      const Eigen::VectorXd stacked = multi->stack(u0, d);
      comm.collective([&] { x = multi->problem().fromDisplacement(stacked); });
      multi->halo().update(x, d);
    }
    ContactProblem<d>& problem = multi ? multi->problem() : *obstacleProblem;
    const HaloExchange& halo = multi ? multi->halo() : leaves[0].halo;
    const Index owned = halo.numOwned();
    rec.assemblySeconds = comm.max(since(t));
    t = Clock::now();
    typename TNNMG<d>::Options so = tnnmgOptions<d>(options_.solver);
    std::optional<TNNMG<d>> solver;
    if (multi) {
      std::vector<const DistributedGrid*> grids;
      for (const DistributedAdaptiveBody& b : bodies_) grids.push_back(b.grid);
      solver.emplace(multi->halo(), so, std::make_unique<LinearMultigrid<d>>(grids, multi->extraGhostGlobals(), so.multigrid));
    } else {
      solver.emplace(*bodies_[0].grid, so);
    }
    const ContactResult result = solver->solve(problem, x);
    solver.reset();
    rec.solverSeconds = comm.max(since(t));
    rec.solver = result.solver;
    rec.solverIterations = result.iterations;
    rec.solverTolerance = options_.solver.tolerance;
    rec.converged = result.converged;
    rec.kkt = result.kkt.max();
    const Eigen::VectorXd u = problem.toDisplacement(x);
    for (std::size_t b = 0; b < nb; ++b) body[b].u = multi ? multi->bodyPart(static_cast<int>(b), u, d) : u;

    // contact outputs over the owned vertices (local work in collective(), the exchanges between:
    // a rank that fails must not leave the others waiting in an exchange)
    const ContactSet& cs = problem.contactSet();
    std::optional<ContactOutputs> outputs;
    std::vector<double> scales;
    comm.collective([&] { scales = contactScales<d>(problem, x, owned); });
    comm.max(scales);
    // a ghost's own row is incomplete away from the owned cells: its outputs come from the owner
    Eigen::VectorXd flat = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(halo.numLocal()) * 3);
    comm.collective([&] {
      outputs = computeContactOutputs(problem, x, options_.contactTolerance, scales[0] > 0 ? scales[0] : 1.0, scales[1]);
      for (Index q = 0; q < cs.size(); ++q) {
        const auto k = static_cast<std::size_t>(q);
        const Eigen::Index at = static_cast<Eigen::Index>(cs.vertex(q)) * 3;
        flat.segment<3>(at) << outputs->pressure[k], outputs->multiplier[k], outputs->inContact[k];
      }
    });
    halo.update(flat, 3);
    comm.collective([&] {
      for (Index q = 0; q < cs.size(); ++q)
        if (const Index v = cs.vertex(q); v >= owned) {
          const auto k = static_cast<std::size_t>(q);
          outputs->pressure[k] = flat[v * 3];
          outputs->multiplier[k] = flat[v * 3 + 1];
          outputs->inContact[k] = static_cast<char>(flat[v * 3 + 2] != 0);
        }
    });

    // every body's contact data (docs/theory.md#two-body-estimator)
    Eigen::VectorXd masterForce;  // a pair's C'(mu n), complete at the master's owned vertices
    if (!pair_) {
      BodyStep& b = body[0];
      b.contactIds = b.estimatorIds = {boundaryId_};
      b.set = &*obstacleSet;
      b.outputs = &*outputs;
      b.gap = obstacle_;
    } else {
      const Pair& p = *pair_;
      BodyStep& sb = body[static_cast<std::size_t>(p.slave)];
      BodyStep& mb = body[static_cast<std::size_t>(p.master)];
      const DistributedView& sv = leaves[static_cast<std::size_t>(p.slave)];
      const DistributedView& mv = leaves[static_cast<std::size_t>(p.master)];
      sb.contactIds = sb.estimatorIds = {p.slaveId};
      mb.estimatorIds = mb.masterIds = {p.masterId};
      // the slave nodes on the slave body's local mesh, the gaps relative to the displaced master
      Eigen::VectorXd y = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(mortar->rows().size()) * d);
      std::vector<double> probe(1 + 6, std::numeric_limits<double>::infinity());  // global index, x, n
      comm.collective([&] {
        ContactSet::Data data;
        data.dimension = d;
        data.numMeshVertices = sv.local.numVertices();
        data.label = p.label;
        data.obstacleName = "mortar";
        ContactOutputs o;
        for (Index v = 0; v < sv.local.numVertices(); ++v) {
          const Index l = multi->local(p.slave, v);
          const Index node = cs.nodeOf(l);
          if (node < 0) continue;
          const auto n = static_cast<std::size_t>(node);
          const Point& nu = cs.direction(node);
          const auto at = static_cast<Eigen::Index>(l) * d;
          data.vertices.push_back(v);
          data.positions.push_back(cs.position(node));
          data.directions.push_back(nu);
          data.gaps.push_back(cs.gap(node) + nu.template head<d>().dot(u.template segment<d>(at) - x.template segment<d>(at)));
          data.masses.push_back(cs.boundaryMass(node));
          o.inContact.push_back(outputs->inContact[n]);
          o.multiplier.push_back(outputs->multiplier[n]);
          o.pressure.push_back(outputs->pressure[n]);
          o.tangential.push_back(outputs->tangential[n]);
          o.slip.push_back(outputs->slip[n]);
          o.state.push_back(outputs->state[n]);
          o.contactNodes += outputs->inContact[n] ? 1 : 0;
          o.force += outputs->multiplier[n] * nu;
        }
        sb.ownSet.emplace(std::move(data));
        sb.set = &*sb.ownSet;
        sb.ownOutputs = std::move(o);
        sb.outputs = &*sb.ownOutputs;
        // the master forces C'(mu n) of the owned rows; the probe orienting the slave face normals
        for (std::size_t j = 0; j < mortar->rows().size(); ++j) {
          const DistributedMortar::Row& row = mortar->rows()[j];
          const Index node = cs.nodeOf(multi->local(p.slave, row.local));
          if (node < 0 || !problem.constraint(node).bounded()) continue;
          y.segment<d>(static_cast<Eigen::Index>(j) * d) = outputs->multiplier[node] * cs.direction(node).template head<d>();
          if (static_cast<double>(row.global) < probe[0]) {
            probe[0] = static_cast<double>(row.global);
            for (int a = 0; a < 3; ++a) {
              probe[1 + a] = cs.position(node)[a];
              probe[4 + a] = cs.direction(node)[a];
            }
          }
        }
      });
      // the exact gap: both surfaces whole on every rank, the master's with its displacement
      std::vector<Point> masterDisplacement;
      const mesh::SurfaceMesh slaveSurface = gatherSurface(sv, p.slaveId, nullptr, d, "the slave surface of '" + p.label + "'", nullptr);
      const mesh::SurfaceMesh masterSurface = gatherSurface(mv, p.masterId, &body[static_cast<std::size_t>(p.master)].u, d,
                                                            "the master surface of '" + p.label + "'", &masterDisplacement);
      const std::vector<std::vector<double>> probes = comm.allGather(probe);
      for (const std::vector<double>& q : probes)
        if (q[0] < probe[0]) probe = q;
      comm.collective([&] {
        if (!std::isfinite(probe[0]))
          throw Error("adaptive loop on ranks: the exact gap of mortar pair '" + p.label + "' cannot be built: no constrained slave node");
        try {
          sb.ownGap = std::make_unique<MortarGapObstacle>(slaveSurface, masterSurface, std::move(masterDisplacement),
                                                         Point(probe[1], probe[2], probe[3]), Point(probe[4], probe[5], probe[6]));
        } catch (const Error& e) {
          throw Error("adaptive loop on ranks: the exact gap of mortar pair '" + p.label + "' (the distance along the "
                      "slave normals to the master surface) cannot be built: " + e.what());
        }
        sb.gap = sb.ownGap.get();
      });
      // the master traction: the forces summed at their owners over the lumped boundary mass
      Eigen::VectorXd force = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(mv.halo.numLocal()) * d);
      mortar->addTransposedTransformation(y, force, d);
      mb.traction = Eigen::VectorXd::Zero(force.size());
      comm.collective([&] {
        const std::vector<double> mass = boundaryLumpedMass(mv.local, p.masterId);
        for (Index q = 0; q < mv.halo.numOwned(); ++q)
          if (mass[static_cast<std::size_t>(q)] > 0)
            mb.traction.template segment<d>(static_cast<Eigen::Index>(q) * d) =
                force.template segment<d>(static_cast<Eigen::Index>(q) * d) / mass[static_cast<std::size_t>(q)];
      });
      mv.halo.update(mb.traction, d);
      masterForce = std::move(force);
    }

    // the coupling's record over all ranks (as couplingRecords): its owned constrained nodes; the
    // faces with all nodes in contact, each counted on one rank; the mortar segments not counted (-1)
    {
      CouplingRecord& cr = rec.couplings.emplace_back();
      cr.mortar = pair_.has_value();
      cr.label = pair_ ? pair_->label : obstacleSet->boundaryLabel();
      cr.slaveBody = pair_ ? pair_->slave : 0;
      cr.masterBody = pair_ ? pair_->master : -1;
      cr.mortarSeconds = mortarSeconds;
      const std::size_t sb = static_cast<std::size_t>(cr.slaveBody);
      const DistributedView& sv = leaves[sb];
      const ContactSet& set = *body[sb].set;
      const ContactOutputs& out = *body[sb].outputs;
      // the constrained boundary's vertices, potential, actual; force on the slave (3), on the
      // master (3); load, contact area; max violation, max pressure, -min pressure
      std::vector<double> sums(11, 0.0), maxima(3, -std::numeric_limits<double>::infinity());
      comm.collective([&] {
        const Index sOwned = sv.halo.numOwned();
        const auto inContact = [&](Index v) {
          const Index node = set.nodeOf(v);
          return node >= 0 && out.inContact[static_cast<std::size_t>(node)] != 0;
        };
        if (pair_) {  // the slave faces (measures as MortarCoupling's)
          std::vector<char> onBoundary(static_cast<std::size_t>(sOwned), 0);
          for (Index f = 0; f < sv.local.numBoundaryFaces(); ++f) {
            if (sv.local.boundaryFaceId(f) != pair_->slaveId) continue;
            const auto fv = sv.local.boundaryFaceVertices(f);
            for (Index v : fv)
              if (v < sOwned) onBoundary[static_cast<std::size_t>(v)] = 1;
            if (!countsFace(sv, fv) || !std::all_of(fv.begin(), fv.end(), inContact)) continue;
            const auto x = [&](std::size_t i) { return sv.local.vertex(fv[i]); };
            sums[10] += d == 2 ? (x(1) - x(0)).norm()
                              : 0.5 * (fv.size() == 3 ? (x(1) - x(0)).cross(x(2) - x(0)) : (x(2) - x(0)).cross(x(3) - x(1))).norm();
          }
          for (char c : onBoundary) sums[0] += c;
        } else {  // the obstacle set's faces
          for (Index q = 0; q < set.size(); ++q) sums[0] += set.vertex(q) < sOwned ? 1 : 0;
          for (const ContactSet::Face& f : set.faces()) {
            std::vector<Index> fv;
            for (Index node : f.nodes) fv.push_back(set.vertex(node));
            if (countsFace(sv, fv) && std::all_of(fv.begin(), fv.end(), inContact)) sums[10] += f.measure;
          }
        }
        for (Index node = 0; node < cs.size(); ++node) {
          const Index l = cs.vertex(node);
          if (l >= owned || !problem.constraint(node).bounded()) continue;
          const auto n = static_cast<std::size_t>(node);
          const Point& nu = cs.direction(node);
          const double mu = outputs->multiplier[n];
          sums[1] += 1;
          sums[9] += mu;
          for (int a = 0; a < d; ++a) sums[static_cast<std::size_t>(3 + a)] -= mu * nu[a];
          const double xn = nu.template head<d>().dot(x.template segment<d>(static_cast<Eigen::Index>(l) * d));
          maxima[0] = std::max(maxima[0], xn - cs.gap(node));
          if (outputs->inContact[n]) {
            sums[2] += 1;
            maxima[1] = std::max(maxima[1], outputs->pressure[n]);
            maxima[2] = std::max(maxima[2], -outputs->pressure[n]);
          }
        }
        if (pair_) {
          const DistributedView& mv = leaves[static_cast<std::size_t>(pair_->master)];
          for (Index q = 0; q < mv.halo.numOwned(); ++q)
            for (int a = 0; a < d; ++a) sums[static_cast<std::size_t>(6 + a)] += masterForce[static_cast<Eigen::Index>(q) * d + a];
        }
      });
      comm.sum(sums);
      comm.max(maxima);
      cr.slaveVertices = static_cast<Index>(sums[0]);
      cr.potentialVertices = static_cast<Index>(sums[1]);
      cr.actualVertices = static_cast<Index>(sums[2]);
      for (int a = 0; a < d; ++a) {
        cr.forceSlave[a] = sums[static_cast<std::size_t>(3 + a)];
        cr.forceMaster[a] = pair_ ? sums[static_cast<std::size_t>(6 + a)] : -cr.forceSlave[a];  // an obstacle takes the reaction
      }
      if (pair_) {
        cr.uncovered = cr.slaveVertices - static_cast<Index>(mortar->globalSize());
        cr.segments = -1;  // not counted: the ranks' local couplings share the faces at their boundaries
      }
      cr.load = sums[9];
      cr.area = sums[10];
      cr.maxViolation = std::max(0.0, maxima[0]);
      cr.pressureMax = cr.actualVertices > 0 ? maxima[1] : 0.0;
      cr.pressureMin = cr.actualVertices > 0 ? -maxima[2] : 0.0;
    }

    // node classes per body at the body's scale over all ranks (max |u| and the finite gaps), as
    // one process's; counted over the owned vertices
    std::vector<double> bodyScales(nb, 0.0), sums(5, 0.0);  // potential, actual, semi, full, load
    comm.collective([&] {
      for (std::size_t b = 0; b < nb; ++b) {
        const Index ownedB = leaves[b].halo.numOwned();
        const Eigen::Index n = static_cast<Eigen::Index>(ownedB) * d;
        double U = n > 0 ? body[b].u.head(n).lpNorm<Eigen::Infinity>() : 0.0;
        if (const ContactSet* set = body[b].set)
          for (Index q = 0; q < set->size(); ++q)
            if (set->vertex(q) < ownedB && std::isfinite(set->gap(q))) U = std::max(U, std::abs(set->gap(q)));
        bodyScales[b] = U;
      }
    });
    comm.max(bodyScales);
    comm.collective([&] {
      for (std::size_t b = 0; b < nb; ++b) {
        BodyStep& bs = body[b];
        bs.scale = bodyScales[b];
        bs.classes = classifyContactNodes(leaves[b].local, bs.contactIds, bs.set, bs.u, options_.contactTolerance, bs.scale);
        for (Index v = 0; v < leaves[b].halo.numOwned(); ++v) {
          const NodeClass c = bs.classes.ofVertex[v];
          sums[0] += c != NodeClass::None;
          sums[1] += c == NodeClass::Semi || c == NodeClass::Full;
          sums[2] += c == NodeClass::Semi;
          sums[3] += c == NodeClass::Full;
        }
      }
      for (Index q = 0; q < cs.size(); ++q)
        if (cs.vertex(q) < owned) sums[4] += outputs->multiplier[q];
    });
    comm.sum(sums);
    rec.potentialContact = static_cast<Index>(sums[0]);
    rec.actualContact = static_cast<Index>(sums[1]);
    rec.semiContact = static_cast<Index>(sums[2]);
    rec.fullContact = static_cast<Index>(sums[3]);
    rec.load = sums[4];
    if (reference_ && !pair_)  // each contact face counted by the owner of its vertex of smallest global index
      rec.reference = referenceErrors(leaves[0].local, *obstacleSet, *outputs, *reference_, owned, countedFaces(leaves[0]), comm);

    // estimate (not on an unconverged solution, as serially): every body's owned cells
    if (estimator && rec.converged) {
      t = Clock::now();
      std::vector<const EstimatorResult*> estimates;
      for (std::size_t b = 0; b < nb; ++b) {
        BodyStep& bs = body[b];
        EstimatorInput in(leaves[b].local, *bodies_[b].material, *bodies_[b].bc, bs.u);
        in.meshRevision = static_cast<std::uint64_t>(k);
        in.contactBoundaryIds = bs.estimatorIds;
        ContactData data;
        if (bs.set || bs.traction.size() > 0) {
          data = ContactData{bs.set, bs.outputs, bs.gap, bs.traction.size() > 0 ? &bs.traction : nullptr, bs.masterIds};
          data.contactScale = bs.scale;  // the classes of one process
          in.contact = &data;
        }
        bs.estimate = estimateOwned(*estimator, in, static_cast<Index>(leaves[b].part.owned.size()), comm);
        rec.bodies[b].eta = bs.estimate->total;
        estimates.push_back(&*bs.estimate);
      }
      rec.estimatorSeconds = comm.max(since(t));
      CombinedEstimate all = combineEstimates(estimates);  // (over the bodies; each over the ranks)
      rec.eta = all.total;
      rec.contributions = std::move(all.contributions);
      if (!steps.empty())
        rec.eoc = experimentalOrder(steps.back().eta, static_cast<double>(steps.back().vertices), rec.eta,
                                    static_cast<double>(rec.vertices));
    }

    // stop? mark with global thresholds among the cells of all bodies, ties by the cells' keys
    bool last = !rec.converged || k + 1 == options_.maxSteps ||
                (options_.targetVertices > 0 && rec.vertices >= options_.targetVertices) ||
                (options_.etaTolerance > 0 && body[0].estimate && rec.eta <= options_.etaTolerance);
    const auto ownedCellsOf = [&](std::size_t b) { return static_cast<Index>(leaves[b].part.owned.size()); };
    const auto keyOf = [&](std::size_t b, Index c) {
      return bodies_[b].grid->cellKey(leaves[b].view.elements[leaves[b].part.owned[c]]);
    };
    t = Clock::now();
    if (!last && adaptive) {
      std::vector<double> indicators;
      std::vector<std::uint64_t> keys;
      for (std::size_t b = 0; b < nb; ++b) {
        const auto& ind = body[b].estimate->indicators;
        indicators.insert(indicators.end(), ind.begin(), ind.begin() + ownedCellsOf(b));
        for (Index c = 0; c < ownedCellsOf(b); ++c) keys.push_back(bodyCellKey(keyOf(b, c), b));
      }
      const std::vector<Index> marked = markOwned(*marking, indicators, keys, comm);
      std::size_t b = 0;
      Index offset = 0;
      for (Index c : marked) {  // (ascending)
        while (c >= offset + ownedCellsOf(b)) offset += ownedCellsOf(b++);
        body[b].marked.push_back(c - offset);
      }
    } else if (!last) {
      for (std::size_t b = 0; b < nb; ++b)
        for (Index c = 0; c < ownedCellsOf(b); ++c) body[b].marked.push_back(c);
    }
    if (!last) {
      std::vector<double> counts(nb);
      for (std::size_t b = 0; b < nb; ++b) counts[b] = static_cast<double>(body[b].marked.size());
      comm.sum(counts);
      for (std::size_t b = 0; b < nb; ++b) {
        rec.bodies[b].marked = static_cast<Index>(counts[b]);
        rec.marked += rec.bodies[b].marked;
      }
      if (rec.marked == 0) last = true;
    }
    if (hook_ && !last) {  // the marks by cell key, of every rank (a restart replays them on any partition)
      std::vector<std::vector<std::uint64_t>>& stepKeys = markedKeys.emplace_back(nb);
      for (std::size_t b = 0; b < nb; ++b) {
        std::vector<std::uint64_t> mine;
        for (Index c : body[b].marked) mine.push_back(keyOf(b, c));
        for (const auto& part : comm.allGather(mine)) stepKeys[b].insert(stepKeys[b].end(), part.begin(), part.end());
        std::sort(stepKeys[b].begin(), stepKeys[b].end());
      }
    }
    const double markSeconds = since(t);
    steps.push_back(rec);
    if (callback_) {
      std::vector<DistributedAdaptiveBodyView> views;
      for (std::size_t b = 0; b < nb; ++b) {
        const BodyStep& bs = body[b];
        views.push_back(DistributedAdaptiveBodyView{*bodies_[b].grid, leaves[b], bs.u, bs.set, bs.outputs,
                                                    bs.estimate ? &*bs.estimate : nullptr, bs.marked, balance[b]});
      }
      callback_(DistributedAdaptiveStepView{steps.back(), views, balanceSeconds});
    }
    if (last) break;

    // refine; each body's solution on its held grid vertices, interpolated to the new ones
    t = Clock::now();
    AdaptiveStep& done = steps.back();
    std::vector<mesh::GridView> before;  // the leaf views the solutions live on
    for (std::size_t b = 0; b < nb; ++b) {
      std::vector<Index> elements;
      elements.reserve(body[b].marked.size());
      for (Index c : body[b].marked) elements.push_back(leaves[b].view.elements[leaves[b].part.owned[c]]);
      const mesh::AdaptResult ar = bodies_[b].grid->adapt(elements);
      done.refinedRed += ar.redRefined;
      done.closureRed += ar.propagated;
      done.greenClosed += ar.greenClosed;
    }
    done.refinementSeconds = comm.max(markSeconds + since(t));
    t = Clock::now();
    if (options_.warmStart) {  // the old leaf function on the new leaf view, as serially (transferMatrix)
      comm.collective([&] {
        for (std::size_t b = 0; b < nb; ++b) {
          const mesh::Grid& grid = bodies_[b].grid->grid();
          const DistributedView& leaf = leaves[b];
          const mesh::GridView next = grid.leafView();
          const mesh::CsrMatrix T = mesh::transferMatrix(grid, leaf.view, next);
          const auto& held = leaf.halo.viewVertices();
          std::vector<double> component(leaf.view.vertices.size(), 0.0), values;
          start[b].assign(next.vertices.size() * d, 0.0);
          for (int c = 0; c < d; ++c) {  // new held vertices lie in old owned and ghost cells: values known
            for (Index i = 0; i < leaf.local.numVertices(); ++i)
              component[held[i]] = body[b].u[static_cast<Eigen::Index>(i) * d + c];
            values = T * std::span<const double>(component);
            for (std::size_t v = 0; v < values.size(); ++v) start[b][v * d + c] = values[v];
          }
        }
      });
    }
    transferSeconds = comm.max(since(t));
    // the parts balanced again if refinement unbalanced them; the starts move with their vertices
    t = Clock::now();
    for (std::size_t b = 0; b < nb; ++b)
      balance[b] = bodies_[b].grid->rebalance(imbalanceTolerance_, options_.warmStart ? &start[b] : nullptr, d);
    balanceSeconds = comm.max(since(t));
    if (hook_) {  // the state after step k: the records, the marks, the starts on the new leaf views
      DistributedAdaptiveLoopState state{k + 1, steps, markedKeys, transferSeconds};
      std::vector<DistributedView> next;
      std::vector<Eigen::VectorXd> local(nb);
      for (std::size_t b = 0; b < nb; ++b) {
        const DistributedView& view = next.emplace_back(bodies_[b].grid->view());
        if (start[b].empty()) continue;
        local[b].resize(static_cast<Eigen::Index>(view.local.numVertices()) * d);
        const auto& held = view.halo.viewVertices();
        for (Index i = 0; i < view.local.numVertices(); ++i)
          for (int c = 0; c < d; ++c)
            local[b][static_cast<Eigen::Index>(i) * d + c] = start[b][static_cast<std::size_t>(held[i]) * d + c];
      }
      hook_(state, next, local);
    }
  }
  return steps;
}

void DistributedAdaptiveLoop::restore(DistributedAdaptiveLoopState state, const StartFunction& start) {
  const Communicator& comm = communicator();
  const std::size_t nb = bodies_.size();
  const int d = bodies_.front().grid->grid().dimension();
  comm.collective([&] {
    const auto n = static_cast<std::size_t>(std::max(state.nextStep, 0));
    if (state.nextStep < 1 || state.steps.size() != n || state.marked.size() != n)
      throw Error("adaptive loop on ranks: a state at step " + std::to_string(state.nextStep) + " with " +
                  std::to_string(state.steps.size()) + " records and the marks of " + std::to_string(state.marked.size()) +
                  " steps");
    for (const auto& step : state.marked)
      if (step.size() != nb)
        throw Error("adaptive loop on ranks: a state with the marks of " + std::to_string(step.size()) + " bodies for " +
                    std::to_string(nb) + " bodies");
    if (state.nextStep >= options_.maxSteps)
      throw Error("adaptive loop on ranks: a state at step " + std::to_string(state.nextStep) + " of a loop of " +
                  std::to_string(options_.maxSteps) + " steps");
  });
  // the refinements of the interrupted run, each followed by its load balancing
  for (const DistributedAdaptiveBody& b : bodies_) b.grid->setClosureRule(options_.closure);
  std::vector<RebalanceReport> balance(nb);
  double seconds = 0;
  for (auto& step : state.marked) {
    for (std::size_t b = 0; b < nb; ++b) {
      DistributedGrid& grid = *bodies_[b].grid;
      std::vector<std::uint64_t>& keys = step[b];
      std::sort(keys.begin(), keys.end());
      const DistributedView leaf = grid.view();
      std::vector<Index> elements;
      for (Index c : leaf.part.owned) {
        const Index e = leaf.view.elements[c];
        if (std::binary_search(keys.begin(), keys.end(), grid.cellKey(e))) elements.push_back(e);
      }
      grid.adapt(elements);
    }
    seconds = 0;
    for (std::size_t b = 0; b < nb; ++b) {
      const auto tb = Clock::now();
      balance[b] = bodies_[b].grid->rebalance(imbalanceTolerance_);
      seconds += since(tb);
    }
    seconds = comm.max(seconds);
  }
  std::vector<DistributedView> next;
  for (const DistributedAdaptiveBody& b : bodies_) next.push_back(b.grid->view());
  const std::vector<Eigen::VectorXd> local = start(next);
  std::vector<std::vector<double>> values(nb);  // on the grids' leaf views, as run() keeps its starts
  comm.collective([&] {
    if (local.size() != nb)
      throw Error("adaptive loop on ranks: starts of " + std::to_string(local.size()) + " bodies for " + std::to_string(nb));
    for (std::size_t b = 0; b < nb; ++b) {
      const DistributedView& view = next[b];
      if (local[b].size() != 0 && local[b].size() != static_cast<Eigen::Index>(view.local.numVertices()) * d)
        throw Error("adaptive loop on ranks: a start of " + std::to_string(local[b].size()) + " values for " +
                    std::to_string(view.local.numVertices()) + " vertices");
      if (local[b].size() == 0) continue;
      values[b].assign(bodies_[b].grid->grid().leafView().vertices.size() * static_cast<std::size_t>(d), 0.0);
      const auto& held = view.halo.viewVertices();
      for (Index i = 0; i < view.local.numVertices(); ++i)
        for (int c = 0; c < d; ++c)
          values[b][static_cast<std::size_t>(held[i]) * d + c] = local[b][static_cast<Eigen::Index>(i) * d + c];
    }
  });
  resume_ = std::move(state);
  resumeStart_ = std::move(values);
  resumeBalance_ = balance;
  resumeBalanceSeconds_ = seconds;
}

template std::vector<AdaptiveStep> DistributedAdaptiveLoop::runDim<2>();
template std::vector<AdaptiveStep> DistributedAdaptiveLoop::runDim<3>();

}  // namespace obs::estimators
