// The Newmark family for dynamic contact (docs/theory.md#newmark, thesis Sec. 5.2-5.3): conservation without
// contact, dissipativity of the contact-implicit / contact-stabilized / alpha(p) / alpha = 1/2 schemes
// on a one-vertex and a multi-vertex impact, the normal-velocity laws (thesis (5.29), (5.48)),
// energy conservation of the persistency schemes, non-penetration, the exact 1D bar of
// docs/theory.md#bar-reference, extreme time steps and stiffnesses, inexact solves and their
// time-error estimate (docs/theory.md#dynamic-inexact-solves), and bad input.
#include <gtest/gtest.h>

#include <algorithm>

#include <Eigen/Dense>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Newmark.hpp"

using namespace obs;
using mesh::CellType;

namespace {

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }
Point P(double x, double y, double z = 0) { return Point(x, y, z); }

Material material(double E, double nu = 0.3, double rho = 1) {
  Material m{E, nu};
  m.density = rho;
  return m;
}

/// A 2D block [0, w] x [y0, y0 + h] above the obstacle {y <= 0} (plane through the origin,
/// constraint direction -y, gap = y), contact boundary = bottom.
struct Block {
  mesh::Grid grid;
  std::unique_ptr<PlaneObstacle> obstacle;
  std::unique_ptr<ContactSet> contact;
  Block(CellType t, std::array<int, 3> cells, double w, double h, double y0, Point normal = P(0, -1), int levels = 0)
      : grid(mesh::boxMesh(t, cells, P(0, y0), P(w, y0 + h))) {
    for (int l = 0; l < levels; ++l) grid.refineUniformly();
    obstacle = std::make_unique<PlaneObstacle>(P(0, 0), normal.normalized());
    contact = std::make_unique<ContactSet>(grid.leafView().mesh, mesh::kBottom, *obstacle);
  }
  Index vertices() const { return contact->numMeshVertices(); }
};

NewmarkOptions opts(NewmarkScheme s, double tau) {
  NewmarkOptions o;
  o.scheme = s;
  o.timeStep = tau;
  o.solver.tolerance = 1e-11;  // tighter than the default 1e-10: the checks below are this tight
  return o;
}

Eigen::VectorXd uniform(Index n, double vx, double vy) {
  Eigen::VectorXd v(2 * n);
  for (Index p = 0; p < n; ++p) v[2 * p] = vx, v[2 * p + 1] = vy;
  return v;
}

std::vector<StepRecord> runSteps(NewmarkFamily<2>& s, const Eigen::VectorXd& u0, const Eigen::VectorXd& v0, int steps) {
  s.initialize(u0, v0);
  std::vector<StepRecord> out{s.record()};
  for (int k = 0; k < steps; ++k) out.push_back(s.step());
  return out;
}

const std::vector<NewmarkScheme> kDissipative{NewmarkScheme::ContactImplicit, NewmarkScheme::ContactStabilized,
                                              NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::AlphaHalf};

TEST(Newmark, WithoutContactClassicalConservesEnergyAndAllConserveMomentum) {
  Block b(CellType::Quadrilateral, {4, 4, 1}, 1, 1, 100);  // obstacle far away
  const Index n = b.vertices();
  const mesh::Mesh m = b.grid.leafView().mesh;
  // translation plus a deformation mode (shear and stretch velocities)
  Eigen::VectorXd v0 = uniform(n, 1.0, -0.5);
  for (Index p = 0; p < n; ++p) v0[2 * p] += 0.3 * (m.vertex(p)[1] - 100), v0[2 * p + 1] += 0.2 * m.vertex(p)[0];
  for (NewmarkScheme s : allNewmarkSchemes()) {
    NewmarkFamily<2> st(b.grid, material(100), {}, *b.contact, opts(s, 0.01));
    const auto rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), v0, 40);
    const StepRecord& r0 = rec.front();
    double drift = 0, momentum = 0;
    for (const StepRecord& r : rec) {
      drift = std::max(drift, std::abs(r.energy - r0.energy) / r0.energy);
      const Eigen::Vector3d p = usesRedistributedMass(s) ? r.momentumRedistributed : r.momentum;
      const Eigen::Vector3d p0 = usesRedistributedMass(s) ? r0.momentumRedistributed : r0.momentum;
      momentum = std::max(momentum, (p - p0).norm() / p0.norm());
      EXPECT_EQ(r.activeSolution, 0);
    }
    if (verbose()) std::cout << name(s) << ": energy drift " << drift << ", momentum drift " << momentum << "\n";
    EXPECT_LT(momentum, 1e-12) << name(s);
    if (s == NewmarkScheme::Classical) { EXPECT_LT(drift, 1e-12); }
  }
}

/// Energy never increases (beyond round-off) and no penetration, for a block dropped flat
/// (multi-vertex) and onto a tilted plane so that one corner hits (one vertex).
void checkDissipative(bool oneVertex) {
  Block b = oneVertex ? Block(CellType::Quadrilateral, {4, 4, 1}, 1, 0.5, 0.02, P(-0.5, -1))
                      : Block(CellType::Triangle, {6, 3, 1}, 1, 0.5, 0.02);
  const Index n = b.vertices();
  for (NewmarkScheme s : kDissipative) {
    NewmarkFamily<2> st(b.grid, material(200), {}, *b.contact, opts(s, 0.005));
    const auto rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0.1, -1.0), 80);
    const double E0 = rec.front().energy;
    Index maxActive = 0;
    int contactSteps = 0;
    for (std::size_t k = 1; k < rec.size(); ++k) {
      EXPECT_LE(rec[k].energy, rec[k - 1].energy + 1e-10 * E0) << name(s) << " step " << k;
      EXPECT_LE(rec[k].maxPenetration, 1e-9) << name(s) << " step " << k;
      maxActive = std::max(maxActive, rec[k].activeSolution);
      contactSteps += rec[k].activeSolution > 0;
    }
    if (verbose())
      std::cout << name(s) << (oneVertex ? " (one vertex)" : " (multi-vertex)") << ": E_end/E_0 = "
                << rec.back().energy / E0 << ", contact steps " << contactSteps << ", max active " << maxActive << "\n";
    EXPECT_GT(contactSteps, 0) << name(s);
    if (oneVertex) {
      EXPECT_EQ(maxActive, 1) << name(s);
    } else {
      EXPECT_GE(maxActive, 3) << name(s);
    }
    EXPECT_LT(rec.back().energy, E0) << name(s);  // the impact dissipates
  }
}

TEST(Newmark, DissipativeSchemesOneVertexImpact) { checkDissipative(true); }
TEST(Newmark, DissipativeSchemesMultiVertexImpact) { checkDissipative(false); }

/// The bar of docs/theory.md#bar-reference as a 2D column of quadrilaterals (nu = 0): every bottom vertex
/// moves like the contact node of the 1D bar.
struct Bar {
  Block block{CellType::Quadrilateral, {1, 20, 1}, 1, 10, 5};
  Index bottom = 0;  // vertex (0, 5)
  Bar() {
    const mesh::Mesh m = block.grid.leafView().mesh;
    for (Index p = 0; p < m.numVertices(); ++p)
      if (m.vertex(p)[0] == 0 && m.vertex(p)[1] == 5) bottom = p;
  }
  std::vector<StepRecord> run(NewmarkScheme s, double tau, int steps, const BoundaryConditions& bc = {}) {
    NewmarkOptions o = opts(s, tau);
    o.trackedVertices = {bottom};
    NewmarkFamily<2> st(block.grid, material(900, 0.0, 1.0), bc, *block.contact, o);
    const Index n = block.vertices();
    return runSteps(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0, -10), steps);
  }
};


TEST(Newmark, NormalVelocityLawsDuringContact) {
  Bar bar;
  for (NewmarkScheme s : {NewmarkScheme::ContactImplicit, NewmarkScheme::ContactStabilized,
                          NewmarkScheme::ImprovedContactStabilized}) {
    const auto rec = bar.run(s, 0.01, 100);
    int checked = 0;
    for (std::size_t k = 1; k < rec.size(); ++k) {
      const TrackedVertex& a = rec[k - 1].tracked[0];
      const TrackedVertex& b = rec[k].tracked[0];
      if (std::abs(a.gap) > 1e-9 || std::abs(b.gap) > 1e-9) continue;  // in contact at t^n and t^{n+1}
      ++checked;
      if (s == NewmarkScheme::ContactImplicit) { EXPECT_NEAR(b.normalVelocity, -a.normalVelocity, 1e-8) << k; }
      if (s == NewmarkScheme::ContactStabilized && a.normalVelocity > 0) {
        EXPECT_NEAR(b.normalVelocity, a.normalVelocity, 1e-8) << k;
      }
      if (s == NewmarkScheme::ImprovedContactStabilized) { EXPECT_NEAR(b.normalVelocity, 0.0, 1e-8) << k; }
    }
    if (verbose()) std::cout << name(s) << ": " << checked << " step pairs in contact\n";
    EXPECT_GE(checked, 20) << name(s);
  }
}

TEST(Newmark, BarMatchesTheExactSolutionBeforeImpactAndAlphaDetachesCloser) {
  const double tImpact = 0.5, tDetach = 0.5 + 2 * 10 / 30.0;
  const double tau = 0.003;  // the impact t = 0.5 falls inside a step (tau* = tau/3)
  for (bool clamped : {false, true}) {
    BoundaryConditions bc;
    if (clamped) {  // lateral faces with u_x = 0
      bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, nullptr});
      bc.dirichlet.push_back({mesh::kRight, {true, false, false}, nullptr});
      for (auto& c : bc.dirichlet) c.value = [](const Point&) { return Eigen::Vector3d::Zero(); };
    }
    Bar bar;
    // Both schemes solve the same displacement system (alpha + beta = 1) and the contact node sits on
    // the bound during contact either way, so their positions agree and the last contact step is the
    // same (`lastContact`). They differ in the velocity: detachment = first time after the impact at
    // which the node moves away from the obstacle (nu'v < 0); exactly: 0 during contact, -v0 after.
    // The thesis (Sec. 5.3.3, Fig. 5.13) compares the displacements around detachment: `liftOff` = first
    // time after the impact at which the gap exceeds v0 tau (the exact lift-off of one step after t_d).
    double detach[2] = {0, 0}, lastContact[2] = {0, 0}, liftOff[2] = {0, 0};
    int idx = 0;
    for (NewmarkScheme s : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::ContactStabilized}) {
      const auto rec = bar.run(s, tau, 534, bc);
      bool touched = false;
      for (const StepRecord& r : rec) {
        const double h = 5 + r.tracked[0].displacement[1];
        if (r.time <= tImpact + 1e-12) { EXPECT_NEAR(h, 5 - 10 * r.time, 1e-9) << name(s) << " t = " << r.time; }
        if (r.tracked[0].gap <= 1e-9) touched = true, lastContact[idx] = r.time;
        if (touched && detach[idx] == 0 && r.tracked[0].normalVelocity < -1e-9) detach[idx] = r.time;
        if (touched && liftOff[idx] == 0 && r.tracked[0].gap > 10 * tau) liftOff[idx] = r.time;  // 10 tau = v0 tau
      }
      EXPECT_GT(detach[idx], 0) << name(s) << " never detached";
      ++idx;
    }
    if (verbose())
      std::cout << (clamped ? "u_x = 0: " : "free: ") << "detach alpha(p) " << detach[0] << ", contact-stabilized "
                << detach[1] << ", exact " << tDetach << "; last contact step " << lastContact[0] << " / "
                << lastContact[1] << "; gap > v0 tau at " << liftOff[0] << " / " << liftOff[1] << " (exact "
                << tDetach + tau << ")\n";
    EXPECT_EQ(lastContact[0], lastContact[1]);
    EXPECT_LT(std::abs(detach[0] - tDetach), std::abs(detach[1] - tDetach));
    EXPECT_LT(std::abs(detach[0] - tDetach), 0.05);
    // after the last contact step the displacements differ (v^n enters the next predictor): alpha(p)
    // also lifts off closer to the exact solution, as in the thesis' Fig. 5.13
    EXPECT_GT(liftOff[0], 0);
    EXPECT_LT(std::abs(liftOff[0] - (tDetach + tau)), std::abs(liftOff[1] - (tDetach + tau)));
  }
}

/// Classical Newmark with contact (thesis (5.21)-(5.22)), F^n the nodal contact forces on the obstacle
/// (contactForces(); the force on the body is -F), on the free components:
///   M(u^{n+1} - u^n - tau v^n) = tau^2/4 (2f - A(u^n + u^{n+1}) - F^n - F^{n+1}),
///   v^{n+1} = 2/tau (u^{n+1} - u^n) - v^n.
/// Hence the impulse balance M(v^{n+1} - v^n) = tau/2 (2f - A(u^n + u^{n+1}) - F^n - F^{n+1}) and,
/// multiplied by v^{n+1} + v^n = 2/tau (u^{n+1} - u^n) (zero on Dirichlet components), the energy
/// identity (5.24)
///   E^{n+1} - E^n = -1/2 (F^n + F^{n+1}) . (u^{n+1} - u^n).
/// Both forces enter with the same sign. With the opposite sign on F^n (the old defect) a body pressed
/// onto the obstacle accumulates force step by step and sticks; the identity then fails at every
/// step in which a node leaves the obstacle under a non-zero F^n ("release" steps below).
struct ClassicalIdentities {
  /// max_n |E^{n+1} - E^n + 1/2 (F^n + F^{n+1}).(u^{n+1} - u^n)| / s_n, s_n the sum of the kinetic,
  /// elastic and |load| energies at t^n and t^{n+1} (the size of what is subtracted)
  double energy = 0;
  double work = 0;       ///< max_n |1/2 (F^n + F^{n+1}).(u^{n+1} - u^n)| / s_n (size of the checked term)
  double impulse = 0;    ///< max_n relative residual of the impulse balance (free components)
  int contactSteps = 0;  ///< steps with a contact force at t^{n+1}
  int releaseSteps = 0;  ///< steps with |F^n.(u^{n+1} - u^n)| > 1e-6 s_n
  std::vector<StepRecord> records;
};

ClassicalIdentities checkClassical(NewmarkFamily<2>& st, const Eigen::VectorXd& u0, const Eigen::VectorXd& v0,
                                   int steps) {
  ClassicalIdentities out;
  const double tau = st.options().timeStep;
  const std::vector<char>& fixed = st.problem().dirichlet().constrained;
  st.initialize(u0, v0);
  out.records.push_back(st.record());
  auto size = [](const StepRecord& r) { return r.kineticEnergy + r.elasticEnergy + std::abs(r.loadPotential); };
  Eigen::VectorXd u = u0, v = v0, F = st.contactForces();
  EXPECT_EQ(F.norm(), 0.0);
  for (int k = 0; k < steps; ++k) {
    out.records.push_back(st.step());
    const StepRecord& a = out.records[out.records.size() - 2];
    const StepRecord& b = out.records.back();
    const Eigen::VectorXd& un = st.state().u;
    const Eigen::VectorXd& vn = st.state().v;
    const Eigen::VectorXd Fn = st.contactForces();
    const Eigen::VectorXd du = un - u;
    const double work = -0.5 * (F + Fn).dot(du);
    const double s = size(a) + size(b);
    out.energy = std::max(out.energy, std::abs(b.energy - a.energy - work) / s);
    out.work = std::max(out.work, std::abs(work) / s);
    out.contactSteps += Fn.norm() > 0;
    out.releaseSteps += std::abs(F.dot(du)) > 1e-6 * s;
    const Eigen::VectorXd Au = st.stiffness() * (u + un);
    Eigen::VectorXd r = st.mass() * (vn - v) - (0.5 * tau) * (2 * st.load() - Au - F - Fn);
    for (Eigen::Index i = 0; i < r.size(); ++i)
      if (fixed[static_cast<std::size_t>(i)]) r[i] = 0;
    const double scale =
        (st.mass() * v).norm() + (st.mass() * vn).norm() + 0.5 * tau * (Au.norm() + (F + Fn).norm() + 2 * st.load().norm());
    out.impulse = std::max(out.impulse, r.norm() / scale);
    u = un, v = vn, F = Fn;
  }
  return out;
}

TEST(Newmark, ClassicalEnergyIdentityWithContactOneDof) {
  // one unknown: the unit square of one quadrilateral, clamped on the left and on the top, u_x = 0 on
  // the right, so only the vertical displacement of the lower right vertex is free; it is thrown onto
  // the plane y = 0 (gap 0.02) and pressed onto it by a downward body force: repeated impacts,
  // chatter and releases under load
  Block b(CellType::Quadrilateral, {1, 1, 1}, 1, 1, 0.02);
  const mesh::Mesh m = b.grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kLeft, {true, true, true}, [](const Point&) { return Eigen::Vector3d::Zero(); }});
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Eigen::Vector3d::Zero(); }});
  bc.dirichlet.push_back({mesh::kRight, {true, false, false}, [](const Point&) { return Eigen::Vector3d::Zero(); }});
  bc.bodyForce = [](const Point&) { return Eigen::Vector3d(0, -20, 0); };
  Index corner = -1;
  for (Index p = 0; p < m.numVertices(); ++p)
    if (m.vertex(p)[0] == 1 && m.vertex(p)[1] == 0.02) corner = p;
  ASSERT_GE(corner, 0);
  for (MassKind mass : {MassKind::Lumped, MassKind::Consistent}) {
    NewmarkOptions o = opts(NewmarkScheme::Classical, 0.01);
    o.mass = mass;
    o.solver.tolerance = 1e-14;
    NewmarkFamily<2> st(b.grid, material(100), bc, *b.contact, o);
    int free = 0;
    for (char c : st.problem().dirichlet().constrained) free += !c;
    ASSERT_EQ(free, 1);
    Eigen::VectorXd v0 = Eigen::VectorXd::Zero(2 * b.vertices());
    v0[2 * corner + 1] = -1;
    const ClassicalIdentities c = checkClassical(st, Eigen::VectorXd::Zero(2 * b.vertices()), v0, 200);
    if (verbose())
      std::cout << "classical, one unknown (" << (mass == MassKind::Lumped ? "lumped" : "consistent")
                << " M): energy identity " << c.energy << " (work term up to " << c.work << "), impulse balance "
                << c.impulse << ", contact steps " << c.contactSteps << ", release steps " << c.releaseSteps
                << ", E_end/E_0 " << c.records.back().energy / c.records.front().energy << "\n";
    EXPECT_GE(c.contactSteps, 10);
    EXPECT_GE(c.releaseSteps, 3);
    EXPECT_GT(c.work, 1e-3);
    EXPECT_LT(c.energy, 1e-12);
    EXPECT_LT(c.impulse, 1e-12);
  }
}

TEST(Newmark, ClassicalEnergyIdentityWithContactOnTheBar) {
  // the bar of data/scenes/dynamics_bar.toml (tau = 3e-3, 450 steps): the identity holds at every
  // step, and the contact end leaves the obstacle again (it did not with the sign defect)
  Bar bar;
  NewmarkOptions o = opts(NewmarkScheme::Classical, 0.003);
  o.trackedVertices = {bar.bottom};
  o.solver.tolerance = 1e-14;
  NewmarkFamily<2> st(bar.block.grid, material(900, 0.0, 1.0), {}, *bar.block.contact, o);
  const Index n = bar.block.vertices();
  const ClassicalIdentities c = checkClassical(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0, -10), 450);
  bool touched = false;
  double detach = 0;
  for (const StepRecord& r : c.records) {
    if (r.tracked[0].gap <= 1e-9) touched = true;
    if (touched && detach == 0 && r.tracked[0].gap > 1e-6) detach = r.time;
  }
  if (verbose())
    std::cout << "classical, bar: energy identity " << c.energy << " (work term up to " << c.work
              << "), impulse balance " << c.impulse << ", contact steps " << c.contactSteps << ", release steps "
              << c.releaseSteps << ", first detachment " << detach << " (exact 1.1667), E_end/E_0 "
              << c.records.back().energy / c.records.front().energy << "\n";
  EXPECT_GE(c.contactSteps, 20);
  EXPECT_GE(c.releaseSteps, 1);
  EXPECT_GT(c.work, 1e-3);
  EXPECT_LT(c.energy, 1e-12);
  EXPECT_LT(c.impulse, 1e-12);
  EXPECT_GT(detach, 0.5);
  // independent reference: the 1D bar (20 linear elements, lumped masses h/2 at the ends, h inside)
  // with the classical scheme and its one-unknown complementarity problem solved in closed form,
  // S u = b + tau^2/4 (r^n + r^{n+1}) e_0, u_0 >= -h0, r^{n+1} >= 0 (reaction on the end, upwards).
  // Each impact of the chatter amplifies differences of round-off size about tenfold (1e-12 in free
  // flight, 6e-10 after the third impact, 2e-8 after the fourth), so the comparison stops after the
  // fourth contact episode (t = 0.543, 181 steps; impact at t = 0.5).
  {
    const int N = 20, nodes = N + 1;
    const double E = 900, h = 0.5, h0 = 5, tau = 0.003;
    Eigen::MatrixXd K = Eigen::MatrixXd::Zero(nodes, nodes), M = Eigen::MatrixXd::Zero(nodes, nodes);
    for (int e = 0; e < N; ++e) {
      K(e, e) += E / h, K(e + 1, e + 1) += E / h, K(e, e + 1) -= E / h, K(e + 1, e) -= E / h;
      M(e, e) += h / 2, M(e + 1, e + 1) += h / 2;
    }
    const Eigen::MatrixXd S = M + 0.25 * tau * tau * K;
    const Eigen::LDLT<Eigen::MatrixXd> Sf(S);
    const Eigen::VectorXd s0 = Sf.solve(Eigen::VectorXd::Unit(nodes, 0));
    Eigen::VectorXd u = Eigen::VectorXd::Zero(nodes), v = Eigen::VectorXd::Constant(nodes, -10);
    double r = 0, maxDiff = 0, maxForce = 0;
    for (int k = 1; k <= 181; ++k) {
      const Eigen::VectorXd b = M * (u + tau * v) - 0.25 * tau * tau * (K * u) + 0.25 * tau * tau * r * Eigen::VectorXd::Unit(nodes, 0);
      Eigen::VectorXd un = Sf.solve(b);
      double rn = 0;
      if (un[0] < -h0) {
        const double c = (-h0 - un[0]) / s0[0];
        un += c * s0, rn = 4 * c / (tau * tau);
      }
      v = (2 / tau) * (un - u) - v, u = un, r = rn;
      // the 2D column: two bottom vertices, each carries half of the 1D end's force
      const StepRecord& rec = c.records[static_cast<std::size_t>(k)];
      maxDiff = std::max(maxDiff, std::abs(rec.tracked[0].displacement[1] - u[0]));
      maxForce = std::max(maxForce, r);
      EXPECT_NEAR(-rec.contactForce[1], r, 1e-6 * std::max(1.0, r)) << "step " << k;  // 4/tau^2 x displacements
    }
    if (verbose()) std::cout << "1D reference, 181 steps: max |u_end difference| " << maxDiff << ", max force " << maxForce << "\n";
    EXPECT_LT(maxDiff, 1e-9);
    EXPECT_GT(maxForce, 0);
  }
}

TEST(Newmark, PersistencySchemesConserveEnergy) {
  // (a finer mesh than for the lumped schemes: M~ needs several cells across, see test_mass)
  Block b(CellType::Triangle, {8, 4, 1}, 1, 0.5, 0.02);
  const Index n = b.vertices();
  for (NewmarkScheme s : {NewmarkScheme::LaursenChawla, NewmarkScheme::HagerHuebnerWohlmuth}) {
    NewmarkFamily<2> st(b.grid, material(200), {}, *b.contact, opts(s, 0.005));
    const auto rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0.1, -1.0), 80);
    const bool hhw = s == NewmarkScheme::HagerHuebnerWohlmuth;
    const double E0 = hhw ? rec.front().energyRedistributed : rec.front().energy;
    double drift = 0, penetration = 0;
    int contact = 0;
    for (const StepRecord& r : rec) {
      drift = std::max(drift, std::abs((hhw ? r.energyRedistributed : r.energy) - E0) / E0);
      penetration = std::max(penetration, r.maxPenetration);
      contact += r.activeSolution > 0;
    }
    if (verbose()) std::cout << name(s) << ": energy drift " << drift << ", max penetration " << penetration << "\n";
    EXPECT_GT(contact, 0);
    EXPECT_LT(drift, 1e-9) << name(s);
  }
}

TEST(Newmark, KhenousLabordeRenardConservesTheModifiedEnergyWithoutContact) {
  // Newmark beta = gamma = 1/2 with M~: M~ a^n = f - A u^n at every level (massless rows: 0 = 0 without
  // contact), u^{n+1} - u^n = tau/2 (v^n + v^{n+1}) + tau^2/4 (a^{n+1} - a^n), v^{n+1} - v^n = tau/2 (a^n +
  // a^{n+1}) give E~^{n+1} - E~^n = -tau^2/8 (a^{n+1}'M~a^{n+1} - a^n'M~a^n): E~ + tau^2/8 a'M~a is
  // conserved exactly, E~ (and E with the standard mass) only up to O(tau^2).
  Block b(CellType::Quadrilateral, {6, 6, 1}, 1, 1, 100);  // obstacle far away
  const Index n = b.vertices();
  const mesh::Mesh m = b.grid.leafView().mesh;
  Eigen::VectorXd v0 = uniform(n, 1.0, -0.5);
  for (Index p = 0; p < n; ++p) v0[2 * p] += 0.3 * (m.vertex(p)[1] - 100), v0[2 * p + 1] += 0.2 * m.vertex(p)[0];
  NewmarkFamily<2> st(b.grid, material(100), {}, *b.contact, opts(NewmarkScheme::KhenousLabordeRenard, 0.01));
  const auto rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), v0, 40);
  const StepRecord& r0 = rec.front();
  ASSERT_TRUE(r0.hasAcceleration && r0.hasRedistributed);
  EXPECT_EQ(r0.accelerationEnergy, 0.0);  // u^0 = 0, f = 0: a^0 = 0
  double modified = 0, redistributed = 0, standard = 0;
  for (const StepRecord& r : rec) {
    ASSERT_TRUE(r.hasAcceleration);
    EXPECT_NEAR(r.energyModified, r.energyRedistributed + r.accelerationEnergy, 1e-15 * r0.energyModified);
    modified = std::max(modified, std::abs(r.energyModified - r0.energyModified) / r0.energyModified);
    redistributed = std::max(redistributed, std::abs(r.energyRedistributed - r0.energyRedistributed) / r0.energyRedistributed);
    standard = std::max(standard, std::abs(r.energy - r0.energy) / r0.energy);
    EXPECT_EQ(r.activeSolution, 0);
  }
  if (verbose())
    std::cout << "KLR without contact, 40 steps: drift of E~ + tau^2/8 a'M~a " << modified << ", of E~ " << redistributed
              << ", of E (standard mass) " << standard << "\n";
  EXPECT_LT(modified, 1e-11);
  EXPECT_GT(redistributed, 1e3 * modified);  // the acceleration term is what makes the difference
  // the other schemes have no acceleration term
  NewmarkFamily<2> hhw(b.grid, material(100), {}, *b.contact, opts(NewmarkScheme::HagerHuebnerWohlmuth, 0.01));
  hhw.initialize(Eigen::VectorXd::Zero(2 * n), v0);
  EXPECT_FALSE(hhw.step().hasAcceleration);
}

/// Hager-Huebner-Wohlmuth (both constraint sets) over a long multi-vertex impact with release: E~
/// (kinetic energy with M~) is conserved exactly with the persistency set (no such statement holds for
/// the non-penetration set: only the update algebra is checked there). The rows of the
/// massless contact vertices read tau^2/4 (A(u^{n+1} + u^n) - 2f)_C = lambda_C: without contact their
/// residual r^n = (A u^n - f)_C alternates, r^{n+1} = -r^n, so u_C keeps an undamped oscillation of
/// period 2 tau after release, which the velocity recursion v^{n+1} = -v^n + 2/tau (u^{n+1} - u^n)
/// integrates resonantly: the velocities of the massless vertices grow linearly, and with them the
/// energy E with the standard mass (which weights them with the mass that M~ moved away). They do
/// not feed back into the motion (M~ has zero columns there).
template <int d>
void checkHagerHuebnerWohlmuthLongRun(const mesh::Grid& grid, const ContactSet& contact, const Eigen::VectorXd& v0,
                                      double tau, int steps) {
  const Index n = contact.numMeshVertices();
  for (NewmarkScheme s : {NewmarkScheme::HagerHuebnerWohlmuth, NewmarkScheme::HagerHuebnerWohlmuthNonPenetration}) {
    NewmarkFamily<d> st(grid, material(200), {}, contact, opts(s, tau));
    st.initialize(Eigen::VectorXd::Zero(d * n), v0);
    const StepRecord r0 = st.record();
    std::vector<char> massless(static_cast<std::size_t>(n), 0);
    for (Index p : contact.vertices()) massless[static_cast<std::size_t>(p)] = 1;
    double drift = 0, maxIdentity = 0, releaseVelocity = 0, finalVelocity = 0;
    int contactSteps = 0, freeSteps = 0;
    Index previousActive = 0;
    Eigen::VectorXd u = st.state().u, v = st.state().v;
    for (int k = 1; k <= steps; ++k) {
      const StepRecord r = st.step();
      const Eigen::VectorXd& un = st.state().u;
      const Eigen::VectorXd& vn = st.state().v;
      drift = std::max(drift, std::abs(r.energyRedistributed - r0.energyRedistributed) / r0.energyRedistributed);
      contactSteps += r.activeSolution > 0;
      // velocity update (all vertices) and the massless rows after release (no bound at t^n and t^{n+1})
      EXPECT_LT((vn + v - (2 / tau) * (un - u)).norm(), 1e-10 * (vn.norm() + v.norm() + 1)) << name(s) << " step " << k;
      if (contactSteps > 0 && r.activeSolution == 0 && previousActive == 0 && r.maxPenetration == 0) {
        const Eigen::VectorXd r1 = st.stiffness() * un, r2 = st.stiffness() * u;
        double scale = 0, mismatch = 0;
        for (Index p = 0; p < n; ++p)
          if (massless[static_cast<std::size_t>(p)]) {
            const auto i = static_cast<Eigen::Index>(p) * d;
            scale = std::max(scale, r2.template segment<d>(i).norm());
            mismatch = std::max(mismatch, (r1.template segment<d>(i) + r2.template segment<d>(i)).norm());
          }
        if (scale > 0) maxIdentity = std::max(maxIdentity, mismatch / scale);
        double vc = 0;
        for (Index p = 0; p < n; ++p)
          if (massless[static_cast<std::size_t>(p)]) vc = std::max(vc, vn.template segment<d>(static_cast<Eigen::Index>(p) * d).norm());
        if (freeSteps++ == 0) releaseVelocity = vc;
        finalVelocity = vc;
      }
      previousActive = r.activeSolution;
      u = un;
      v = vn;
    }
    if (verbose())
      std::cout << d << "D " << name(s) << ": E~ drift " << drift << ", contact steps " << contactSteps << ", free steps "
                << freeSteps << ", massless-row identity " << maxIdentity << ", max |v_C| at release " << releaseVelocity
                << ", at the end " << finalVelocity << ", E_end/E_0 " << st.record().energy / r0.energy << "\n";
    EXPECT_GT(contactSteps, 0) << name(s);
    ASSERT_GT(freeSteps, 10) << name(s) << ": the body must leave the obstacle";
    EXPECT_LT(maxIdentity, 1e-8) << name(s);
    if (s == NewmarkScheme::HagerHuebnerWohlmuth) { EXPECT_LT(drift, 1e-9) << name(s); }
  }
}

TEST(Newmark, HagerHuebnerWohlmuthLongMultiVertexImpact2D) {
  Block b(CellType::Triangle, {8, 4, 1}, 1, 0.5, 0.01);
  const Index n = b.vertices();
  checkHagerHuebnerWohlmuthLongRun<2>(b.grid, *b.contact, uniform(n, 0.1, -1.0), 0.005, 300);
}

TEST(Newmark, PredictorActiveSetCountsNodesTouchingTheObstacle) {
  // thesis Sec. 5.3.1/5.3.3: a node is active for the predictor if the projected predictor lies on the
  // obstacle, u_pred(p) = g(p). A block resting on the plane (gap 0, v = 0) and pressed onto it by a body
  // force: the predictor u^n + tau v^n = u^n touches the plane at every bottom vertex, so all of them are
  // active for the predictor and for the solution, none only for the solution. (Counting only
  // penetrating predictors, as before, gave activePredictor = 0 and solutionOnly = 5 here.)
  Block b(CellType::Quadrilateral, {4, 2, 1}, 1, 0.5, 0.0);
  BoundaryConditions bc;
  bc.bodyForce = [](const Point&) { return Eigen::Vector3d(0, -20, 0); };
  const Index n = b.vertices();
  for (NewmarkScheme s : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::ContactStabilized,
                          NewmarkScheme::AlphaHalf, NewmarkScheme::ContactImplicit}) {
    NewmarkFamily<2> st(b.grid, material(200), bc, *b.contact, opts(s, 0.005));
    st.initialize(Eigen::VectorXd::Zero(2 * n), Eigen::VectorXd::Zero(2 * n));
    const StepRecord r = st.step();
    EXPECT_EQ(r.activeSolution, 5) << name(s);
    EXPECT_EQ(r.activePredictor, 5) << name(s);
    EXPECT_EQ(r.solutionOnly, 0) << name(s);
    EXPECT_EQ(r.predictorOnly, 0) << name(s);
  }
  // a dropped block (multi-vertex impact): the counts are consistent in every step, and the
  // contact-stabilized scheme, which keeps the impact velocity during contact, never has a node active
  // only for the solution (the thesis' Fig. 5.11(c)); alpha(p) zeroes the normal velocity, so its
  // resting nodes stay active for the predictor and only arriving nodes can be solution-only
  Block drop(CellType::Triangle, {6, 3, 1}, 1, 0.5, 0.02);
  const Index m = drop.vertices();
  for (NewmarkScheme s : {NewmarkScheme::ContactStabilized, NewmarkScheme::ImprovedContactStabilized}) {
    NewmarkFamily<2> st(drop.grid, material(200), {}, *drop.contact, opts(s, 0.005));
    const auto rec = runSteps(st, Eigen::VectorXd::Zero(2 * m), uniform(m, 0.0, -1.0), 80);
    Index active = 0, solutionOnly = 0;
    for (const StepRecord& r : rec) {
      EXPECT_EQ(r.activePredictor - r.predictorOnly, r.activeSolution - r.solutionOnly) << name(s) << " step " << r.step;
      if (s == NewmarkScheme::ContactStabilized) { EXPECT_EQ(r.solutionOnly, 0) << "step " << r.step; }
      active += r.activeSolution;
      solutionOnly += r.solutionOnly;
    }
    if (verbose()) std::cout << name(s) << ": node-steps active " << active << ", solution only " << solutionOnly << "\n";
    EXPECT_GT(active, 20) << name(s);
    EXPECT_LE(solutionOnly, active / 4) << name(s);
  }
}

TEST(Newmark, RedistributedSchemesRejectAnIndefiniteStepMatrix) {
  // 5 x 5 x 2 tetrahedral block [0, 1]^2 x [0, 0.5] without mass at the bottom: M~ has a positive
  // diagonal and one negative eigenvalue (coarser or odd layer counts give non-positive diagonal
  // entries, rejected earlier with the vertex; docs/dynamics.md).
  // With a small c tau^2 A the step matrix S = M~ + c tau^2 A is indefinite too: clear error before
  // stepping (formerly a CHOLMOD error of the coarse solve); with a large one S is positive definite,
  // the stepper is built and reports the indefinite M~.
  mesh::Grid grid(mesh::boxMesh(CellType::Tetrahedron, {5, 5, 2}, P(0, 0, 0), P(1, 1, 0.5)));
  PlaneObstacle plane(P(0, 0, -0.1), P(0, 0, -1));
  ContactSet contact(grid.leafView().mesh, mesh::kBottom, plane);
  // Two cell layers: with the default lower bound M~_ij >= 0.1 M_ij no M~ keeps the second moments
  // (MassRedistribution.hpp), a clear error; the unbounded M~ exists and is indefinite
  auto unbounded = [](NewmarkScheme s, double tau) {
    NewmarkOptions o = opts(s, tau);
    o.redistribution.minimumScale = -std::numeric_limits<double>::infinity();
    return o;
  };
  for (NewmarkScheme s : allNewmarkSchemes()) {
    if (!usesRedistributedMass(s)) {
      NewmarkFamily<3> st(grid, material(1), {}, contact, opts(s, 1e-4));
      EXPECT_THROW(st.redistributedMassDefiniteness(), obs::Error);
      continue;
    }
    try {
      NewmarkFamily<3>(grid, material(1), {}, contact, opts(s, 1e-4));
      ADD_FAILURE() << name(s) << ": no error with the bound";
    } catch (const obs::Error& e) {
      EXPECT_NE(std::string(e.what()).find("entries are at the bound"), std::string::npos) << e.what();
    }
    try {
      NewmarkFamily<3>(grid, material(1), {}, contact, unbounded(s, 1e-4));
      ADD_FAILURE() << name(s) << ": no error";
    } catch (const obs::Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("is not positive definite"), std::string::npos) << what;
      EXPECT_NE(what.find("(1 negative eigenvalues)"), std::string::npos) << what;
      EXPECT_NE(what.find("Refine the mesh near the contact boundary"), std::string::npos) << what;
      EXPECT_NE(what.find(std::string(name(s))), std::string::npos) << what;
    }
    NewmarkFamily<3> stiff(grid, material(1e4), {}, contact, unbounded(s, 0.01));
    EXPECT_FALSE(stiff.redistributedMassDefiniteness().positiveDefinite) << name(s);
    EXPECT_EQ(stiff.redistributedMassDefiniteness().nonPositivePivots, 1) << name(s);
  }
  // one refinement: M~ positive definite, accepted for any tau
  grid.refineUniformly();
  ContactSet fine(grid.leafView().mesh, mesh::kBottom, plane);
  NewmarkFamily<3> st(grid, material(1), {}, fine, opts(NewmarkScheme::HagerHuebnerWohlmuth, 1e-4));
  EXPECT_TRUE(st.redistributedMassDefiniteness().positiveDefinite);
}

TEST(Newmark, NonPenetrationSchemesNeverPenetrate) {
  Block b(CellType::Quadrilateral, {8, 4, 1}, 1, 0.5, 0.02);
  const Index n = b.vertices();
  for (NewmarkScheme s : allNewmarkSchemes()) {
    if (usesPersistency(s)) continue;
    NewmarkFamily<2> st(b.grid, material(200), {}, *b.contact, opts(s, 0.005));
    const auto rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0.0, -1.0), 60);
    int contact = 0;
    for (const StepRecord& r : rec) {
      EXPECT_LE(r.maxPenetration, 1e-9) << name(s) << " step " << r.step;
      contact += r.activeSolution > 0;
      EXPECT_TRUE(std::isfinite(r.energy));
    }
    EXPECT_GT(contact, 0) << name(s);
  }
}

TEST(Newmark, ExtremeTimeStepsAndStiffnesses) {
  Block b(CellType::Quadrilateral, {2, 2, 1}, 1, 1, 0.0);  // starts touching
  const Index n = b.vertices();
  for (double tau : {5e-6, 5e-2})
    for (double E : {1.0, 1e3, 1e6, 1e9})
      for (NewmarkScheme s : kDissipative) {
        SCOPED_TRACE(std::string(name(s)) + " tau " + std::to_string(tau) + " E " + std::to_string(E));
        NewmarkFamily<2> st(b.grid, material(E), {}, *b.contact, opts(s, tau));
        std::vector<StepRecord> rec;
        ASSERT_NO_THROW(rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0.3, -1.0), 10));
        const double E0 = rec.front().energy;
        // round-off of evaluating 1/2 u'Au for the (nearly rigid) u: eps |u|'|A||u| <= eps ||A|| ||u||^2,
        // ||u||^2 <= n (10 tau |v0|)^2; 1e-9 E0 for the solver tolerance
        double rowSum = 0;
        for (Index p = 0; p < st.stiffness().rows(); ++p) {
          double r = 0;
          for (Index k = st.stiffness().rowBegin(p); k < st.stiffness().rowEnd(p); ++k) r += st.stiffness().blockAt(k).norm();
          rowSum = std::max(rowSum, r);
        }
        const double allowed = 1e-9 * E0 + 1e-14 * rowSum * n * std::pow(10 * tau * 1.1, 2);
        for (std::size_t k = 1; k < rec.size(); ++k) {
          ASSERT_TRUE(std::isfinite(rec[k].energy)) << name(s) << " tau " << tau << " E " << E;
          EXPECT_LE(rec[k].energy, rec[k - 1].energy + allowed) << name(s) << " tau " << tau << " E " << E;
          EXPECT_LE(rec[k].maxPenetration, 1e-9);
        }
      }
}

TEST(Newmark, EverySchemeFromTinyToHugeTimeSteps) {
  // tau = 1e-7 ... 1 (the block's lowest period is about 0.1): every scheme runs without NaN or a
  // crash, the dissipative ones do not gain energy, Laursen-Chawla keeps it. A redistributed mass
  // that the time step makes indefinite is the documented one-line error, not a NaN.
  Block b(CellType::Quadrilateral, {2, 2, 1}, 1, 1, 0.0);  // starts touching
  const Index n = b.vertices();
  for (double tau : {1e-7, 1e-5, 1e-3, 1e-1, 1.0})
    for (NewmarkScheme s : allNewmarkSchemes()) {
      SCOPED_TRACE(std::string(name(s)) + " tau " + std::to_string(tau));
      std::vector<StepRecord> rec;
      try {
        NewmarkFamily<2> st(b.grid, material(1e3), {}, *b.contact, opts(s, tau));
        rec = runSteps(st, Eigen::VectorXd::Zero(2 * n), uniform(n, 0.3, -1.0), 10);
      } catch (const obs::Error& e) {
        EXPECT_NE(std::string(e.what()).find("redistributed mass"), std::string::npos) << e.what();
        if (verbose()) std::cout << name(s) << " tau " << tau << ": " << e.what() << "\n";
        continue;
      }
      const double E0 = rec.front().energy;
      for (const StepRecord& r : rec) {
        ASSERT_TRUE(std::isfinite(r.energy));
        ASSERT_TRUE(std::isfinite(r.maxPenetration));
      }
      const bool dissipative = std::find(kDissipative.begin(), kDissipative.end(), s) != kDissipative.end();
      if (dissipative) {
        for (std::size_t k = 1; k < rec.size(); ++k) EXPECT_LE(rec[k].energy, rec[k - 1].energy + 1e-9 * E0) << k;
      }
      if (s == NewmarkScheme::LaursenChawla) {
        EXPECT_NEAR(rec.back().energy, E0, 1e-8 * E0);
      }
      if (verbose()) std::cout << name(s) << " tau " << tau << ": E_end/E_0 = " << rec.back().energy / E0 << "\n";
    }
}

TEST(Newmark, OperatorReuseAcrossLoadsAndGaps) {
  // ContactProblem::setLoad/setGaps keep the operator id; a TNNMG that reuses its operators gives the
  // solution of a fresh solver, with Dirichlet values on the top (eliminated again by setLoad)
  Block b(CellType::Quadrilateral, {4, 4, 1}, 1, 1, 0.0, P(0, -1), 1);
  const mesh::Mesh m = b.grid.leafView().mesh;
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Eigen::Vector3d(0, -0.05, 0); }});
  ContactProblem<2> problem(m, material(100), bc, *b.contact);
  const auto id = problem.operatorId();
  TNNMG<2> reused(b.grid);
  Eigen::VectorXd u0;
  reused.solve(problem, u0);
  Eigen::VectorXd load = Eigen::VectorXd::Zero(2 * m.numVertices());
  for (Index p = 0; p < m.numVertices(); ++p) load[2 * p] = 0.5, load[2 * p + 1] = -1;
  std::vector<double> gaps(b.contact->size());
  for (Index k = 0; k < b.contact->size(); ++k) gaps[k] = k % 3 == 0 ? std::numeric_limits<double>::infinity() : -0.01;
  problem.setLoad(load);
  problem.setGaps(gaps);
  EXPECT_EQ(problem.operatorId(), id);
  Eigen::VectorXd u1, u2;
  const ContactResult r1 = reused.solve(problem, u1);
  TNNMG<2> fresh(b.grid);
  const ContactResult r2 = fresh.solve(problem, u2);
  EXPECT_TRUE(r1.converged && r2.converged);
  EXPECT_LT((u1 - u2).norm(), 1e-8 * u2.norm());
  EXPECT_LT(r1.kkt.primalFeasibility, 1e-10);
  EXPECT_LT(r1.kkt.dirichlet, 1e-14);
  // every constructed problem gets a new id
  ContactSet moved(m, mesh::kBottom, *b.obstacle);
  EXPECT_NE(ContactProblem<2>(m, material(100), bc, moved).operatorId(), id);
  EXPECT_THROW(problem.setGaps(std::vector<double>(2, 0.0)), obs::Error);
  EXPECT_THROW(problem.setLoad(Eigen::VectorXd::Zero(3)), obs::Error);
}

TEST(Newmark, InexactSolvesSaveIterationsNotAccuracy) {
  // docs/theory.md#dynamic-inexact-solves: with inexactFraction = 0.1 step n+1 (from the third) stops
  // once the estimated algebraic error is below a tenth of step n's time-error estimate. A block of
  // two refinement levels (multigrid) dropped onto a tilted plane: a corner hits, then the edge.
  Block b(CellType::Quadrilateral, {4, 2, 1}, 1, 0.5, 0.02, P(-0.2, -1), 2);
  const Index n = b.vertices();
  for (NewmarkScheme s : {NewmarkScheme::ImprovedContactStabilized, NewmarkScheme::ContactImplicit,
                          NewmarkScheme::Classical}) {
    SCOPED_TRACE(std::string(name(s)));
    const NewmarkOptions exactOptions = opts(s, 0.005);
    NewmarkOptions inexactOptions = exactOptions;
    inexactOptions.inexactFraction = 0.1;
    EXPECT_EQ(NewmarkOptions{}.inexactFraction, 0.0);  // off by default
    NewmarkFamily<2> exact(b.grid, material(200), {}, *b.contact, exactOptions);
    NewmarkFamily<2> inexact(b.grid, material(200), {}, *b.contact, inexactOptions);
    const Eigen::VectorXd u0 = Eigen::VectorXd::Zero(2 * n), v0 = uniform(n, 0.1, -1.0);
    const auto re = runSteps(exact, u0, v0, 100);
    const auto ri = runSteps(inexact, u0, v0, 100);
    const double base = exactOptions.solver.tolerance, E0 = re.front().energy;
    long long itExact = 0, itInexact = 0;
    int loose = 0, contactSteps = 0;
    double maxForce = 0, forceDifference = 0;
    for (std::size_t k = 1; k < re.size(); ++k) {
      // off: every step to the solver tolerance, no estimate computed
      EXPECT_EQ(re[k].solverTolerance, base) << "step " << k;
      EXPECT_TRUE(std::isnan(re[k].timeError)) << "step " << k;
      // on: the first two steps to the solver tolerance, then within [solverTolerance, 1e-2]
      EXPECT_GE(ri[k].solverTolerance, base) << "step " << k;
      EXPECT_LE(ri[k].solverTolerance, 1e-2) << "step " << k;
      if (k <= 2) {
        EXPECT_EQ(ri[k].solverTolerance, base) << "step " << k;
      }
      EXPECT_EQ(std::isnan(ri[k].timeError), k == 1) << "step " << k;
      if (k > 1) {
        EXPECT_GE(ri[k].timeError, 0) << "step " << k;
      }
      loose += ri[k].solverTolerance > base;
      itExact += re[k].solverIterations;
      itInexact += ri[k].solverIterations;
      if (s != NewmarkScheme::Classical) {
        EXPECT_LE(ri[k].maxPenetration, 1e-9) << "step " << k;
      }
      contactSteps += re[k].activeSolution > 0;
      maxForce = std::max(maxForce, re[k].contactForce.norm());
      forceDifference = std::max(forceDifference, (ri[k].contactForce - re[k].contactForce).norm());
    }
    const double energyDifference = std::abs(ri.back().energy - re.back().energy) / E0;
    // the time error they are measured against: exact solves with tau / 2 to the same end time
    NewmarkFamily<2> half(b.grid, material(200), {}, *b.contact, opts(s, 0.5 * exactOptions.timeStep));
    const auto rh = runSteps(half, u0, v0, 200);
    double timeForceDifference = 0;
    for (std::size_t k = 1; k < re.size(); ++k)
      timeForceDifference = std::max(timeForceDifference, (rh[2 * k].contactForce - re[k].contactForce).norm());
    const double timeEnergyDifference = std::abs(rh.back().energy - re.back().energy) / E0;
    if (verbose())
      std::cout << name(s) << ": TNNMG iterations " << itExact << " -> " << itInexact << ", loose steps " << loose
                << ", contact steps " << contactSteps << ", E_end/E_0 " << re.back().energy / E0 << " -> "
                << ri.back().energy / E0 << " (difference " << energyDifference << "; tau/2: "
                << timeEnergyDifference << "), max |F| " << maxForce << ", max |F_inexact - F| " << forceDifference
                << " (tau/2: " << timeForceDifference << ")\n";
    // measured: 200 -> 102 iterations (2 -> 1 per step from the third; the exact solves stop on
    // TNNMG's error bound after 2); the inexact solves change the end energy by 1e-7 (classical:
    // 4e-6) of E_0 and the forces by 2e-6 to 7e-5: 1e-6 to 5e-6 of what halving tau changes. The
    // contract of inexactFraction = 0.1: an algebraic error of at most a tenth of the time error
    EXPECT_GT(contactSteps, 20);
    EXPECT_GT(loose, 50);
    EXPECT_LT(itInexact, 0.75 * itExact);
    EXPECT_LT(energyDifference, inexactOptions.inexactFraction * timeEnergyDifference);
    EXPECT_LT(forceDifference, inexactOptions.inexactFraction * timeForceDifference);
  }
  // bad fractions
  for (double f : {-0.1, 1.0, std::numeric_limits<double>::quiet_NaN()}) {
    NewmarkOptions o = opts(NewmarkScheme::ContactStabilized, 0.1);
    o.inexactFraction = f;
    EXPECT_THROW(NewmarkFamily<2>(b.grid, material(1), {}, *b.contact, o), obs::Error) << f;
  }
}

TEST(Newmark, TimeErrorEstimateMatchesTheLocalErrorOfOneStep) {
  // docs/theory.md#dynamic-inexact-solves: eta_n = tau/12 ||v^n - 2 v^{n-1} + v^{n-2}||_S estimates the
  // displacement error (beta - 1/6) tau^3 u''' of one trapezoidal step. Checked against the exact
  // solution of the semi-discrete system (lumped mass, no contact: the plane is far away) for a free
  // block vibrating in its lowest deformation mode: u(t) = sin(omega t)/omega phi.
  Block b(CellType::Quadrilateral, {3, 2, 1}, 1, 0.5, 100);
  const Index n = b.vertices();
  const Eigen::Index N = 2 * n;
  NewmarkFamily<2> probe(b.grid, material(100), {}, *b.contact, opts(NewmarkScheme::ContactImplicit, 0.01));
  Eigen::MatrixXd A(N, N);
  for (Eigen::Index j = 0; j < N; ++j) A.col(j) = probe.stiffness() * Eigen::VectorXd::Unit(N, j);
  const Eigen::VectorXd m = probe.mass() * Eigen::VectorXd::Ones(N);  // lumped: the diagonal
  const Eigen::VectorXd s = m.cwiseSqrt().cwiseInverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(s.asDiagonal() * A * s.asDiagonal());
  Eigen::Index mode = 0;
  while (eig.eigenvalues()[mode] < 1e-8 * eig.eigenvalues()[N - 1]) ++mode;  // skip the 3 rigid motions
  ASSERT_EQ(mode, 3);
  const double omega = std::sqrt(eig.eigenvalues()[mode]);
  const Eigen::VectorXd phi = s.asDiagonal() * eig.eigenvectors().col(mode);
  auto u = [&](double t) -> Eigen::VectorXd { return std::sin(omega * t) / omega * phi; };
  auto v = [&](double t) -> Eigen::VectorXd { return std::cos(omega * t) * phi; };
  const double T = 0.3 / omega;  // a fixed time, reached by every tau
  double previous = 0;
  for (int steps : {10, 20, 40}) {
    const double tau = T / steps;
    NewmarkOptions o = opts(NewmarkScheme::ContactImplicit, tau);
    o.inexactFraction = 1e-12;  // computes the estimate; every tolerance stays at solver.tolerance
    NewmarkFamily<2> st(b.grid, material(100), {}, *b.contact, o);
    const auto rec = runSteps(st, u(0), v(0), steps);
    EXPECT_EQ(rec.back().solverTolerance, o.solver.tolerance);
    const double eta = rec.back().timeError;
    // the local error of the last step: one step from the exact state at t^{n-1}
    NewmarkFamily<2> one(b.grid, material(100), {}, *b.contact, opts(NewmarkScheme::ContactImplicit, tau));
    one.initialize(u(T - tau), v(T - tau));
    one.step();
    const Eigen::VectorXd e = one.state().u - u(T);
    const Eigen::VectorXd Se = probe.mass() * e + (0.25 * tau * tau) * (probe.stiffness() * e);
    const double local = std::sqrt(e.dot(Se));
    if (verbose())
      std::cout << "tau omega = " << tau * omega << ": eta " << eta << ", local error " << local << ", ratio "
                << eta / local << (previous > 0 ? ", eta(2 tau)/eta(tau) " + std::to_string(previous / eta) : "")
                << "\n";
    // measured: ratio 1.009, 1.005, 1.002 at tau omega = 0.03, 0.015, 0.0075; eta(2 tau)/eta(tau) 8.03, 8.02
    EXPECT_NEAR(eta / local, 1.0, 0.02) << "tau omega = " << tau * omega;
    if (previous > 0) {
      EXPECT_NEAR(previous / eta, 8.0, 0.2);  // third order in tau
    }
    previous = eta;
  }
}

TEST(Newmark, BadInput) {
  Block b(CellType::Quadrilateral, {2, 2, 1}, 1, 1, 0.1);
  const Index n = b.vertices();
  EXPECT_THROW(NewmarkFamily<2>(b.grid, material(1), {}, *b.contact, opts(NewmarkScheme::Classical, 0)), obs::Error);
  EXPECT_THROW(NewmarkFamily<2>(b.grid, material(1), {}, *b.contact, opts(NewmarkScheme::Classical, -1)), obs::Error);
  EXPECT_THROW(NewmarkFamily<2>(b.grid, material(1, 0.3, 0.0), {}, *b.contact, opts(NewmarkScheme::Classical, 0.1)),
               obs::Error);
  NewmarkOptions consistent = opts(NewmarkScheme::ContactStabilized, 0.1);
  consistent.mass = MassKind::Consistent;
  EXPECT_THROW(NewmarkFamily<2>(b.grid, material(1), {}, *b.contact, consistent), obs::Error);
  try {
    newmarkSchemeFromName("newmark-xyz");
    ADD_FAILURE() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("newmark-xyz"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("improved-contact-stabilized"), std::string::npos);
  }
  for (NewmarkScheme s : allNewmarkSchemes()) EXPECT_EQ(newmarkSchemeFromName(name(s)), s);
  NewmarkFamily<2> st(b.grid, material(1), {}, *b.contact, opts(NewmarkScheme::ContactStabilized, 0.1));
  EXPECT_THROW(st.step(), obs::Error);  // not initialised
  Eigen::VectorXd u = Eigen::VectorXd::Zero(2 * n);
  u[2 * b.contact->vertex(0) + 1] = -0.2;  // below the plane (gap 0.1)
  try {
    st.initialize(u, Eigen::VectorXd::Zero(2 * n));
    ADD_FAILURE() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("violates the contact constraint"), std::string::npos) << e.what();
  }
  EXPECT_THROW(st.initialize(Eigen::VectorXd::Zero(3), Eigen::VectorXd::Zero(3)), obs::Error);
  NewmarkOptions tracked = opts(NewmarkScheme::ContactStabilized, 0.1);
  tracked.trackedVertices = {n + 5};
  EXPECT_THROW(NewmarkFamily<2>(b.grid, material(1), {}, *b.contact, tracked), obs::Error);
}

}  // namespace
