#include "obs/obs/ContactModel.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
int ContactModel<d>::addBody(std::string name, const mesh::Mesh& mesh, const Material& material,
                             BoundaryConditions bc) {
  bodies_.push_back({std::move(name), &mesh, material, std::move(bc), 0});
  return static_cast<int>(bodies_.size()) - 1;
}

template <int d>
void ContactModel<d>::addObstacleContact(int body, ContactSet set, std::string label) {
  if (body < 0 || body >= static_cast<int>(bodies_.size()))
    throw Error("contact model: obstacle contact '" + label + "' for body " + std::to_string(body) + " (no such body)");
  Coupling c;
  c.label = std::move(label);
  c.body = body;
  c.obstacleSet = std::make_unique<ContactSet>(std::move(set));
  couplings_.push_back(std::move(c));
}

template <int d>
void ContactModel<d>::addMortarPair(int slave, int slaveId, int master, int masterId, std::string label,
                                    const MortarOptions& options) {
  const int n = static_cast<int>(bodies_.size());
  if (slave < 0 || slave >= n || master < 0 || master >= n)
    throw Error("contact model: mortar pair '" + label + "' names a body that does not exist");
  if (slave == master)
    throw Error("contact model: mortar pair '" + label + "': slave and master belong to the same body");
  Coupling c;
  c.label = std::move(label);
  c.mortar = true;
  c.slave = slave;
  c.master = master;
  c.slaveId = slaveId;
  c.masterId = masterId;
  c.options = options;
  couplings_.push_back(std::move(c));
}

int ContactModelSpec::addBody(std::string name, const Material& material, const BoundaryConditions& bc) {
  bodies.push_back(Body{std::move(name), &material, &bc});
  return static_cast<int>(bodies.size()) - 1;
}

ContactModelSpec::Coupling ContactModelSpec::Coupling::obstacleContact(int body, const Obstacle& obstacle,
                                                                     int boundaryId, std::string label) {
  Coupling c;
  c.label = std::move(label);
  c.body = body;
  c.boundaryId = boundaryId;
  c.obstacle = &obstacle;
  return c;
}

ContactModelSpec::Coupling ContactModelSpec::Coupling::mortarPair(int slave, int slaveId, int master, int masterId,
                                                                std::string label, const MortarOptions& options) {
  Coupling c;
  c.label = std::move(label);
  c.mortar = true;
  c.body = slave;
  c.boundaryId = slaveId;
  c.master = master;
  c.masterId = masterId;
  c.options = options;
  return c;
}

void ContactModelSpec::addObstacleContact(int body, const Obstacle& obstacle, int boundaryId, std::string label) {
  couplings.push_back(Coupling::obstacleContact(body, obstacle, boundaryId, std::move(label)));
}

void ContactModelSpec::addMortarPair(int slave, int slaveId, int master, int masterId, std::string label,
                                     const MortarOptions& options) {
  couplings.push_back(Coupling::mortarPair(slave, slaveId, master, masterId, std::move(label), options));
}

template <int d>
void ContactModel<d>::setFriction(int coupling, const FrictionLaw& law) {
  if (coupling < 0 || coupling >= static_cast<int>(couplings_.size()))
    throw Error("contact model: friction for coupling " + std::to_string(coupling) + " (no such coupling)");
  if (!(law.value >= 0) || !std::isfinite(law.value))
    throw Error("contact model: coupling '" + couplings_[static_cast<std::size_t>(coupling)].label +
                "': the friction " + (law.type == FrictionLaw::Type::Coulomb ? "coefficient" : "slip bound") +
                " must be finite and >= 0");
  couplings_[static_cast<std::size_t>(coupling)].friction = law;
}

template <int d>
bool ContactModel<d>::frictional() const {
  return std::any_of(couplings_.begin(), couplings_.end(),
                     [](const Coupling& c) { return c.friction.type != FrictionLaw::Type::None && c.friction.value > 0; });
}

template <int d>
ContactModel<d> makeContactModel(const ContactModelSpec& spec, const std::vector<const mesh::Mesh*>& meshes) {
  if (meshes.size() != spec.bodies.size())
    throw Error("contact model: " + std::to_string(meshes.size()) + " meshes for " +
                std::to_string(spec.bodies.size()) + " bodies");
  ContactModel<d> model;
  for (std::size_t i = 0; i < spec.bodies.size(); ++i)
    model.addBody(spec.bodies[i].name, *meshes[i], *spec.bodies[i].material, *spec.bodies[i].bc);
  for (const ContactModelSpec::Coupling& c : spec.couplings) {
    if (c.mortar) {
      model.addMortarPair(c.body, c.boundaryId, c.master, c.masterId, c.label, c.options);
      model.setFriction(static_cast<int>(model.couplings().size()) - 1, c.friction);
      continue;
    }
    if (c.body < 0 || c.body >= static_cast<int>(meshes.size()))
      throw Error("contact model: obstacle contact '" + c.label + "' for body " + std::to_string(c.body) +
                  " (no such body)");
    if (!c.obstacle && !c.contactSet) throw Error("contact model: obstacle contact '" + c.label + "' without obstacle");
    ContactSet set = c.contactSet ? c.contactSet(*meshes[c.body]) : ContactSet(*meshes[c.body], c.boundaryId, *c.obstacle);
    std::string label = c.label.empty() ? set.boundaryLabel() : c.label;
    model.addObstacleContact(c.body, std::move(set), std::move(label));
    model.setFriction(static_cast<int>(model.couplings().size()) - 1, c.friction);
  }
  return model;
}

template <int d>
ContactProblem<d> ContactModel<d>::assemble() {
  Parts p = assembleParts(true);
  return ContactProblem<d>(std::move(p.system.stiffness), std::move(p.system.load), std::move(p.system.dirichlet),
                           p.contact, std::move(p.basis));
}

template <int d>
void ContactModel<d>::stackBodies() {
  if (bodies_.empty()) throw Error("contact model: no body");
  // the stacked numbering (vertex v of body i is offset_i + v), known from the meshes
  numVertices_ = 0;
  for (Body& b : bodies_) {
    b.offset = numVertices_;
    numVertices_ += b.mesh->numVertices();
  }
  for (const Body& b : bodies_) {
    b.material.validate();  // before the couplings look at the meshes (assembleBodies checks again)
    if (b.mesh->dimension() != d)
      throw Error("body '" + b.name + "': the mesh has dimension " + std::to_string(b.mesh->dimension()) +
                  ", the problem " + std::to_string(d));
  }
}

template <int d>
typename ContactModel<d>::Parts ContactModel<d>::assembleParts(bool skipPrescribedBodies) {
  Constraints k = constraints();
  std::vector<const mesh::Mesh*> meshes;
  std::vector<const Material*> materials;
  std::vector<const BoundaryConditions*> conditions;
  for (const Body& b : bodies_) {
    meshes.push_back(b.mesh);
    materials.push_back(&b.material);
    conditions.push_back(&b.bc);
  }
  // the bodies, straight into the stacked matrix on the pattern of the transformed operator (the
  // ContactProblem then transforms it in place: the operator is stored once)
  std::function<void(typename BlockSparseMatrix<d>::Pattern&)> widen;
  if (k.basis.rows > 0)
    widen = [&](typename BlockSparseMatrix<d>::Pattern& p) {
      p = ContactProblem<d>::transformedPattern(std::move(p), k.basis);
    };
  BodySystem<d> system = assembleBodies<d>(meshes, materials, conditions, nullptr, widen, skipPrescribedBodies);
  return Parts{std::move(system), std::move(k.contact), std::move(k.basis)};
}

template <int d>
typename ContactModel<d>::Constraints ContactModel<d>::constraints() {
  stackBodies();
  // one-body special case: the obstacle set is already over the stacked (= the body's) vertices
  if (bodies_.size() == 1 && couplings_.size() == 1 && !couplings_[0].mortar) {
    Coupling& c = couplings_[0];
    c.nodes.resize(c.obstacleSet->size());
    std::iota(c.nodes.begin(), c.nodes.end(), 0);
    return Constraints{*c.obstacleSet, mesh::CsrMatrix{}};
  }

  // the couplings' nodes over the stacked vertices
  struct Node {
    Index vertex;
    int coupling;
    Index local;
  };
  std::vector<Node> nodes;
  std::vector<ContactSet> sets;  // per coupling, over the stacked vertices
  mesh::CsrMatrix basis;
  std::vector<mesh::CsrMatrix> transforms;
  for (std::size_t k = 0; k < couplings_.size(); ++k) {
    Coupling& c = couplings_[k];
    if (c.mortar) {
      const Body& s = bodies_[c.slave];
      const Body& m = bodies_[c.master];
      c.coupling = std::make_unique<MortarCoupling>(
          MortarSurface{s.mesh, c.slaveId, s.offset, "body '" + s.name + "'"},
          MortarSurface{m.mesh, c.masterId, m.offset, "body '" + m.name + "'"}, numVertices_, c.options);
      sets.push_back(c.coupling->contactSet());
      transforms.push_back(c.coupling->transformation());
    } else {
      const ContactSet& cs = *c.obstacleSet;
      const Index off = bodies_[c.body].offset;
      ContactSet::Data data;
      data.dimension = cs.dimension();
      data.label = cs.boundaryLabel();
      data.obstacleName = cs.obstacleName();
      data.numMeshVertices = numVertices_;
      for (Index i = 0; i < cs.size(); ++i) {
        data.vertices.push_back(off + cs.vertex(i));
        data.positions.push_back(cs.position(i));
        data.directions.push_back(cs.direction(i));
        data.gaps.push_back(cs.gap(i));
        data.masses.push_back(cs.boundaryMass(i));
      }
      data.faces = cs.faces();
      sets.emplace_back(std::move(data));
    }
    for (Index i = 0; i < sets.back().size(); ++i) nodes.push_back({sets.back().vertex(i), static_cast<int>(k), i});
  }
  std::sort(nodes.begin(), nodes.end(), [](const Node& a, const Node& b) { return a.vertex < b.vertex; });
  ContactSet::Data merged;
  merged.dimension = d;
  merged.numMeshVertices = numVertices_;
  for (const Coupling& c : couplings_) merged.label += (merged.label.empty() ? "" : ", ") + c.label;
  merged.obstacleName = couplings_.size() == 1 ? sets.front().obstacleName() : "several";
  for (auto& c : couplings_) c.nodes.assign(sets[&c - couplings_.data()].size(), -1);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (i > 0 && nodes[i].vertex == nodes[i - 1].vertex)
      throw Error("contact model: stacked vertex " + std::to_string(nodes[i].vertex) + " is constrained by both '" +
                  couplings_[nodes[i - 1].coupling].label + "' and '" + couplings_[nodes[i].coupling].label +
                  "' (a vertex may belong to one contact coupling only)");
    const ContactSet& cs = sets[nodes[i].coupling];
    const Index l = nodes[i].local;
    couplings_[nodes[i].coupling].nodes[l] = static_cast<Index>(i);
    merged.vertices.push_back(nodes[i].vertex);
    merged.positions.push_back(cs.position(l));
    merged.directions.push_back(cs.direction(l));
    merged.gaps.push_back(cs.gap(l));
    merged.masses.push_back(cs.boundaryMass(l));
  }
  for (std::size_t k = 0; k < couplings_.size(); ++k)
    for (ContactSet::Face f : sets[k].faces()) {
      for (Index& n : f.nodes) n = couplings_[k].nodes[n];
      merged.faces.push_back(std::move(f));
    }
  // the basis transformation: the sum of the pairs' C (their rows are disjoint slave vertices)
  if (!transforms.empty()) {
    basis.rows = basis.cols = numVertices_;
    basis.rowStart.assign(numVertices_ + 1, 0);
    for (Index r = 0; r < numVertices_; ++r) {
      for (const auto& T : transforms)
        for (Index m = T.rowStart[r]; m < T.rowStart[r + 1]; ++m) {
          basis.columns.push_back(T.columns[m]);
          basis.values.push_back(T.values[m]);
        }
      basis.rowStart[r + 1] = static_cast<Index>(basis.columns.size());
    }
  }
  return Constraints{ContactSet(std::move(merged)), std::move(basis)};
}

template <int d>
std::vector<CouplingRecord> couplingRecords(const ContactModel<d>& model, const ContactProblem<d>& problem,
                                            const Eigen::VectorXd& x, const ContactOutputs& out) {
  if (x.size() != static_cast<Eigen::Index>(model.numVertices()) * d || out.multiplier.size() != static_cast<std::size_t>(problem.contactSet().size()))
    throw Error("contact model: coupling records need the solution and outputs of the assembled problem");
  std::vector<CouplingRecord> records;
  const ContactSet& cs = problem.contactSet();
  for (const auto& c : model.couplings()) {
    CouplingRecord r;
    r.label = c.label;
    r.mortar = c.mortar;
    r.slaveBody = c.mortar ? c.slave : c.body;
    r.masterBody = c.mortar ? c.master : -1;
    const Index count = static_cast<Index>(c.nodes.size());
    r.slaveVertices = count;
    if (c.mortar) {
      const MortarCoupling::Statistics& st = c.coupling->statistics();
      r.slaveVertices += st.uncoveredNodes;
      r.segments = st.segments;
      r.uncovered = st.uncoveredNodes;
      r.mortarSeconds = st.seconds;
    }
    Eigen::VectorXd mu = Eigen::VectorXd::Zero(count);
    std::vector<char> in(static_cast<std::size_t>(count), 0);
    double pmin = std::numeric_limits<double>::infinity(), pmax = -pmin;
    for (Index k = 0; k < count; ++k) {
      const Index node = c.nodes[k];
      if (!problem.constraint(node).bounded()) continue;
      ++r.potentialVertices;
      mu[k] = out.multiplier[node];
      r.forceSlave -= mu[k] * cs.direction(node);
      r.load += mu[k];
      in[k] = out.inContact[node];
      r.tangentialSlave -= out.tangential[node];
      r.stickVertices += out.state[node] == 1;
      r.slipVertices += out.state[node] == 2;
      if (in[k]) {
        ++r.actualVertices;
        pmin = std::min(pmin, out.pressure[node]);
        pmax = std::max(pmax, out.pressure[node]);
      }
      const Point& nu = cs.direction(node);
      const double xn = nu.template head<d>().dot(x.template segment<d>(static_cast<Eigen::Index>(cs.vertex(node)) * d));
      r.maxViolation = std::max(r.maxViolation, xn - cs.gap(node));
    }
    if (r.actualVertices > 0) {
      r.pressureMin = pmin;
      r.pressureMax = pmax;
    }
    r.forceMaster = -r.forceSlave;  // a rigid obstacle takes the reaction
    if (c.mortar) {
      const Eigen::VectorXd fm = c.coupling->masterForces(mu);
      r.forceMaster.setZero();
      const auto& master = model.bodies()[c.master];
      for (Index v = 0; v < master.mesh->numVertices(); ++v)
        r.forceMaster.template head<d>() += fm.template segment<d>(static_cast<Eigen::Index>(master.offset + v) * d);
    }
    std::optional<ContactSet> mortarSet;  // (built on demand: MortarCoupling returns it by value)
    if (c.mortar) mortarSet.emplace(c.coupling->contactSet());
    const std::vector<ContactSet::Face>& faces = c.mortar ? mortarSet->faces() : c.obstacleSet->faces();
    for (const ContactSet::Face& f : faces) {
      if (std::all_of(f.nodes.begin(), f.nodes.end(), [&](Index n) { return in[static_cast<std::size_t>(n)] != 0; }))
        r.area += f.measure;
      if (std::all_of(f.nodes.begin(), f.nodes.end(),
                      [&](Index n) { return out.state[static_cast<std::size_t>(c.nodes[static_cast<std::size_t>(n)])] == 1; }))
        r.stickArea += f.measure;
    }
    records.push_back(std::move(r));
  }
  return records;
}

template class ContactModel<2>;
template std::vector<CouplingRecord> couplingRecords<2>(const ContactModel<2>&, const ContactProblem<2>&,
                                                        const Eigen::VectorXd&, const ContactOutputs&);
template std::vector<CouplingRecord> couplingRecords<3>(const ContactModel<3>&, const ContactProblem<3>&,
                                                        const Eigen::VectorXd&, const ContactOutputs&);
template class ContactModel<3>;
template ContactModel<2> makeContactModel<2>(const ContactModelSpec&, const std::vector<const mesh::Mesh*>&);
template ContactModel<3> makeContactModel<3>(const ContactModelSpec&, const std::vector<const mesh::Mesh*>&);

}  // namespace obs
