#include "ContactReports.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

namespace obs::drivers {

std::optional<FrictionReport> frictionReport(const FrictionLaw& law, const Eigen::Vector3d& tangential, long long stick,
                                             long long slip, double stickArea, int dim) {
  if (law.type == FrictionLaw::Type::None) return std::nullopt;
  FrictionReport f;
  f.law = law.type == FrictionLaw::Type::Coulomb ? "coulomb" : "tresca";
  f.value = law.value;
  for (int a = 0; a < 3; ++a) f.tangentialForce[static_cast<std::size_t>(a)] = tangential[a];
  f.stickVertices = stick;
  f.slipVertices = slip;
  f.stickArea = stickArea;
  f.stickRadius = dim == 3 ? std::sqrt(stickArea / std::numbers::pi) : stickArea / 2;
  return f;
}

template <int d>
ContactReport obstacleContactReport(const Scene& scene, const ContactProblem<d>& problem, const Eigen::VectorXd& x,
                                    const ContactOutputs& out, const OwnedPart& part, std::vector<char>* states) {
  const ContactSet& set = problem.contactSet();
  const Index n = set.size();
  const auto owned = [&](Index k) { return set.vertex(k) < part.owned; };
  ContactReport c;
  c.obstacle = scene.contact->obstacle;
  c.boundary = scene.contact->boundary.name.empty() ? std::to_string(scene.contact->boundary.id)
                                                    : scene.contact->boundary.name;
  // the sums over the owned contact nodes, reduced in one call (the counts are exact as doubles)
  enum : std::size_t { kForce = 0, kTangential = 3, kCentre = 6, kWeight = 9, kPositions = 10, kNormal = 13,
                       kLoad = 16, kBoundary, kPotential, kActual, kStick, kSlip, kSums };
  std::vector<double> sums(kSums, 0.0);
  for (Index k = 0; k < n; ++k) {
    if (!owned(k)) continue;
    const Point& nu = set.direction(k);
    const double m = out.multiplier[static_cast<std::size_t>(k)];
    sums[kBoundary] += 1;
    sums[kPotential] += problem.constraint(k).bounded() ? 1 : 0;
    sums[kLoad] += m;
    for (std::size_t a = 0; a < 3; ++a) {
      sums[kForce + a] += m * nu[static_cast<Eigen::Index>(a)];
      sums[kTangential + a] += out.tangential[static_cast<std::size_t>(k)][static_cast<Eigen::Index>(a)];
    }
    sums[kStick] += out.state[static_cast<std::size_t>(k)] == 1 ? 1 : 0;
    sums[kSlip] += out.state[static_cast<std::size_t>(k)] == 2 ? 1 : 0;
    if (!out.inContact[static_cast<std::size_t>(k)]) continue;
    sums[kActual] += 1;
    const double w = std::max(m, 0.0);
    for (std::size_t a = 0; a < 3; ++a) {
      sums[kCentre + a] += w * set.position(k)[static_cast<Eigen::Index>(a)];
      sums[kPositions + a] += set.position(k)[static_cast<Eigen::Index>(a)];
      sums[kNormal + a] += nu[static_cast<Eigen::Index>(a)];
    }
    sums[kWeight] += w;
  }
  part.comm.sum(sums);
  const auto count = [&](std::size_t i) { return static_cast<long long>(std::llround(sums[i])); };
  c.boundaryVertices = count(kBoundary);
  c.potentialVertices = count(kPotential);
  c.actualVertices = count(kActual);
  c.load = sums[kLoad];
  for (std::size_t a = 0; a < 3; ++a) c.force[a] = sums[kForce + a];

  // the radius of the contact vertices around the force centre (no force: their plain mean),
  // tangential to their mean normal
  if (c.actualVertices > 0) {
    Point centre, normal(sums[kNormal], sums[kNormal + 1], sums[kNormal + 2]);
    if (sums[kWeight] > 0)
      centre = Point(sums[kCentre], sums[kCentre + 1], sums[kCentre + 2]) / sums[kWeight];
    else
      centre = Point(sums[kPositions], sums[kPositions + 1], sums[kPositions + 2]) / static_cast<double>(c.actualVertices);
    if (normal.norm() > 0) normal.normalize();
    double radius = 0;
    for (Index k = 0; k < n; ++k) {
      if (!owned(k) || !out.inContact[static_cast<std::size_t>(k)]) continue;
      const Point r = set.position(k) - centre;
      radius = std::max(radius, (r - r.dot(normal) * normal).norm());
    }
    c.radiusNodes = part.comm.max(radius);
  }

  // the contact and stick areas: the faces all of whose nodes are in contact (stick), each counted
  // by the owner of its vertex of smallest global index (every cell around an owned vertex is held,
  // so the face is exact); the ghosts' decisions from their owners (a ghost's row is incomplete)
  std::vector<char> code(static_cast<std::size_t>(n), 0);  // 1: in contact, 2: sticking
  for (Index k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    code[i] = static_cast<char>((out.inContact[i] ? 1 : 0) + (out.state[i] == 1 ? 2 : 0) + 4 * out.state[i]);
  }
  if (part.halo) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(part.halo->numLocal());
    for (Index k = 0; k < n; ++k)
      if (owned(k)) v[set.vertex(k)] = code[static_cast<std::size_t>(k)];
    part.halo->update(v);
    for (Index k = 0; k < n; ++k) code[static_cast<std::size_t>(k)] = static_cast<char>(v[set.vertex(k)]);
  }
  const auto globalOf = [&](Index v) { return part.global.empty() ? v : part.global[static_cast<std::size_t>(v)]; };
  std::vector<double> areas{0, 0};
  for (const ContactSet::Face& f : set.faces()) {
    Index first = -1, firstGlobal = std::numeric_limits<Index>::max();
    bool contact = true, sticking = true;
    for (Index k : f.nodes) {
      contact = contact && (code[static_cast<std::size_t>(k)] & 1) != 0;
      sticking = sticking && (code[static_cast<std::size_t>(k)] & 2) != 0;
      if (const Index g = globalOf(set.vertex(k)); g < firstGlobal) {
        firstGlobal = g;
        first = set.vertex(k);
      }
    }
    if (first < 0 || first >= part.owned) continue;
    if (contact) areas[0] += f.measure;
    if (sticking) areas[1] += f.measure;
  }
  part.comm.sum(areas);
  c.area = areas[0];
  c.radius = d == 3 ? std::sqrt(c.area / std::numbers::pi) : c.area / 2;
  c.maxViolation = part.comm.max(problem.maxViolation(x));
  if (scene.contact->friction)
    c.friction = frictionReport(scene.contact->friction->law,
                                Eigen::Vector3d(sums[kTangential], sums[kTangential + 1], sums[kTangential + 2]),
                                count(kStick), count(kSlip), areas[1], d);
  if (states) {
    states->resize(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < states->size(); ++i) (*states)[i] = static_cast<char>(code[i] / 4);
  }
  return c;
}

IncrementReport incrementReport(const ContactSet& set, const ContactOutputs& out, const OwnedPart& part, int step,
                                int steps, long long iterations, bool converged) {
  IncrementReport inc;
  inc.step = step;
  inc.t = static_cast<double>(step) / steps;
  inc.iterations = iterations;
  inc.converged = converged;
  std::vector<double> sums(9, 0.0);  // force, tangential force, contact / stick / slip vertices
  for (Index k = 0; k < set.size(); ++k) {
    if (set.vertex(k) >= part.owned) continue;
    const auto i = static_cast<std::size_t>(k);
    for (std::size_t a = 0; a < 3; ++a) {
      sums[a] += out.multiplier[i] * set.direction(k)[static_cast<Eigen::Index>(a)];
      sums[3 + a] += out.tangential[i][static_cast<Eigen::Index>(a)];
    }
    sums[6] += out.inContact[i] ? 1 : 0;
    sums[7] += out.state[i] == 1 ? 1 : 0;
    sums[8] += out.state[i] == 2 ? 1 : 0;
  }
  part.comm.sum(sums);
  for (std::size_t a = 0; a < 3; ++a) {
    inc.force[a] = sums[a];
    inc.tangentialForce[a] = sums[3 + a];
  }
  inc.contactVertices = std::llround(sums[6]);
  inc.stickVertices = std::llround(sums[7]);
  inc.slipVertices = std::llround(sums[8]);
  return inc;
}

std::string incrementLine(const IncrementReport& inc, int steps) {
  std::ostringstream line;
  line << "increment " << inc.step << " of " << steps << " (t = " << inc.t << "): " << inc.contactVertices
       << " contact vertices (" << inc.stickVertices << " stick, " << inc.slipVertices << " slip), " << inc.iterations
       << " iterations";
  return line.str();
}

template ContactReport obstacleContactReport<2>(const Scene&, const ContactProblem<2>&, const Eigen::VectorXd&,
                                                const ContactOutputs&, const OwnedPart&, std::vector<char>*);
template ContactReport obstacleContactReport<3>(const Scene&, const ContactProblem<3>&, const Eigen::VectorXd&,
                                                const ContactOutputs&, const OwnedPart&, std::vector<char>*);

}  // namespace obs::drivers
