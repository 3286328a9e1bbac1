// The contact estimator `contact-residual` (docs/theory.md#contact-estimator): it coincides with `residual`
// without contact; eta_6 ... eta_8 vanish for a plane obstacle (g = g_m) without semi contact, eta_7 and
// eta_8 for any plane; hand-computed eta_6, eta_7, eta_8 (closed forms in 2D, an independent
// composite Gauss quadrature on a non-affine 3D face); node classes; the sum identity; the
// registry lists it; missing pressures are an error.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <numeric>

#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"

#include "EstimatorTestSupport.hpp"

using namespace obs;
using namespace obs::estimators;
using mesh::CellType;

namespace {

constexpr double kPi = std::numbers::pi;
const Material kMaterial{3e5, 0.25};

double sumSquares(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0, [](double s, double x) { return s + x * x; });
}

void expectSumIdentity(const EstimatorResult& r) {
  const double eta2 = r.total * r.total;
  double byContribution = 0;
  for (const Contribution& c : r.contributions) {
    byContribution += c.value * c.value;
    EXPECT_NEAR(sumSquares(r.cellFields.at(c.name)), c.value * c.value, 1e-12 * eta2) << c.name;
    EXPECT_NEAR(r.vertexFields.at(c.name).squaredNorm(), c.value * c.value, 1e-12 * eta2) << c.name;
  }
  EXPECT_NEAR(sumSquares(r.indicators), eta2, 1e-12 * eta2);
  EXPECT_NEAR(byContribution, eta2, 1e-12 * eta2);
}

/// Composite Gauss-Legendre quadrature, by default with 64 panels.
double integrate(const std::function<double(double)>& f, double a, double b, int n = 64) {
  return obs::test::integrate(f, a, b, n);
}
double integrate2(const std::function<double(double, double)>& f, double a0, double b0, double a1,
                  double b1, int n = 24) {
  return integrate([&](double s) { return integrate([&](double t) { return f(s, t); }, a1, b1, n); }, a0, b0, n);
}

/// Solves a 2D Signorini problem with the primal-dual active set method.
struct Solved {
  Eigen::VectorXd u;
  ContactOutputs outputs;
};
Solved solve2D(const mesh::Mesh& m, const BoundaryConditions& bc, const ContactSet& set) {
  const ContactProblem<2> problem(m, kMaterial, bc, set);
  Solved s;
  PrimalDualActiveSet<2> pdas;
  const ContactResult r = pdas.solve(problem, s.u);
  EXPECT_TRUE(r.converged);
  s.outputs = computeContactOutputs(problem, s.u);
  return s;
}

BoundaryConditions pressed(double uy) {
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [uy](const Point&) { return Eigen::Vector3d(0, uy, 0); }});
  return bc;
}

// No node in actual contact: the two estimators coincide (eta_6 = eta_7 = eta_8 = 0), with and
// without contact data, on a distorted (non-affine) quadrilateral mesh.
TEST(ContactResidualEstimator, CoincidesWithResidualWithoutContact) {
  auto m = mesh::boxMesh(CellType::Quadrilateral, 4);
  mesh::perturbInteriorVertices(m, 0.2, 3);
  const PlaneObstacle far(Point(0, -1, 0), Point(0, -1, 0));  // g = 1 on the bottom
  const ContactSet set(m, mesh::kBottom, far);
  const BoundaryConditions bc = pressed(-0.01);
  const Solved s = solve2D(m, bc, set);
  ASSERT_EQ(s.outputs.contactNodes, 0);
  const ContactData data{&set, &s.outputs, &far};
  EstimatorInput in(m, kMaterial, bc, s.u);
  in.contact = &data;
  const EstimatorResult r = ResidualEstimator().estimate(in);
  const EstimatorResult c = ContactResidualEstimator().estimate(in);
  EstimatorInput bare(m, kMaterial, bc, s.u);
  bare.contactBoundaryIds = {mesh::kBottom};
  const EstimatorResult cb = ContactResidualEstimator().estimate(bare);
  ASSERT_EQ(c.contributions.size(), 8u);
  EXPECT_EQ(c.estimator, "contact-residual");
  ASSERT_GT(r.total, 0);
  for (const EstimatorResult* x : {&c, &cb}) {
    EXPECT_NEAR(x->total, r.total, 1e-13 * r.total);
    for (int k = 0; k < 5; ++k)
      EXPECT_NEAR(x->contributions[k].value, r.contributions[k].value, 1e-13 * r.total) << k;
    for (int k = 5; k < 8; ++k) EXPECT_EQ(x->contributions[k].value, 0.0) << k;
    for (std::size_t e = 0; e < r.indicators.size(); ++e)
      EXPECT_NEAR(x->indicators[e], r.indicators[e], 1e-13 * r.total);
  }
  EXPECT_GT(r.contribution("eta_5"), 0);
  expectSumIdentity(c);
}

// A flat block pressed onto a plane (g = g_m): the whole bottom is in full contact, so eta_5,
// eta_6, eta_7, eta_8 vanish; a tilted plane gives semi contact: eta_7 = 0 (g = g_m), eta_8 = 0
// (feasible), eta_6 > 0.
TEST(ContactResidualEstimator, PlaneObstacleTermsVanish) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, 8);
  const BoundaryConditions bc = pressed(-0.01);
  {
    const PlaneObstacle plane(Point(0, -0.004, 0), Point(0, -1, 0));
    const ContactSet set(m, mesh::kBottom, plane);
    const Solved s = solve2D(m, bc, set);
    const ContactNodeClasses cls = classifyContactNodes(m, {mesh::kBottom}, &set, s.u);
    ASSERT_EQ(cls.full, cls.potential);
    EXPECT_EQ(cls.semi, 0);
    const ContactData data{&set, &s.outputs, &plane};
    EstimatorInput in(m, kMaterial, bc, s.u);
    in.contact = &data;
    const EstimatorResult c = ContactResidualEstimator().estimate(in);
    EXPECT_GT(c.contribution("eta_4") + c.contribution("eta_1") + c.contribution("eta_2"), 0);
    EXPECT_EQ(c.contribution("eta_5"), 0.0);
    EXPECT_EQ(c.contribution("eta_6"), 0.0);
    EXPECT_EQ(c.contribution("eta_7"), 0.0);
    EXPECT_EQ(c.contribution("eta_8"), 0.0);
  }
  {
    const PlaneObstacle tilted(Point(0.5, -0.004, 0), Point(0.1, -1, 0).normalized());
    const ContactSet set(m, mesh::kBottom, tilted);
    const Solved s = solve2D(m, bc, set);
    const ContactNodeClasses cls = classifyContactNodes(m, {mesh::kBottom}, &set, s.u);
    ASSERT_GT(cls.semi, 0);
    ASSERT_LT(cls.actual, cls.potential);
    const ContactData data{&set, &s.outputs, &tilted};
    EstimatorInput in(m, kMaterial, bc, s.u);
    in.contact = &data;
    const EstimatorResult c = ContactResidualEstimator().estimate(in);
    EXPECT_GT(c.contribution("eta_6"), 0);
    EXPECT_EQ(c.contribution("eta_7"), 0.0);
    EXPECT_EQ(c.contribution("eta_8"), 0.0);
    expectSumIdentity(c);
  }
}

// Node classes on a row of four potential contact nodes: actual contact where g_p - nu'u_p is
// within the relative tolerance, full where all face neighbours are in contact too.
TEST(ContactResidualEstimator, ClassifiesNodes) {
  const auto m = mesh::boxMesh(CellType::Quadrilateral, {3, 1, 1}, Point(0, 0, 0), Point(3, 1, 0));
  const PlaneObstacle plane(Point(0, -0.01, 0), Point(0, -1, 0));  // g = 0.01
  const ContactSet set(m, mesh::kBottom, plane);
  ASSERT_EQ(set.size(), 4);
  auto classesFor = [&](std::array<double, 4> uy) {
    Eigen::VectorXd u = Eigen::VectorXd::Zero(m.numVertices() * 2);
    for (Index k = 0; k < 4; ++k) u[set.vertex(k) * 2 + 1] = uy[static_cast<std::size_t>(k)];
    return classifyContactNodes(m, {mesh::kBottom}, &set, u);
  };
  // nodes sorted by vertex index; their x positions
  std::array<Index, 4> byX{};
  for (Index k = 0; k < 4; ++k) byX[static_cast<std::size_t>(std::lround(set.position(k)[0]))] = set.vertex(k);
  auto cls = classesFor({-0.01, -0.01, -0.01, -0.01});
  for (Index v : byX) EXPECT_EQ(cls.ofVertex[v], NodeClass::Full);
  EXPECT_EQ(cls.full, 4);
  // one node 1e-3 away from the obstacle: it is potential, its neighbours semi
  std::array<double, 4> uy{-0.01, -0.01, -0.01, -0.01};
  for (Index k = 0; k < 4; ++k)
    if (set.vertex(k) == byX[0]) uy[static_cast<std::size_t>(k)] = -0.009;
  cls = classesFor(uy);
  EXPECT_EQ(cls.ofVertex[byX[0]], NodeClass::Potential);
  EXPECT_EQ(cls.ofVertex[byX[1]], NodeClass::Semi);
  EXPECT_EQ(cls.ofVertex[byX[2]], NodeClass::Full);
  EXPECT_EQ(cls.ofVertex[byX[3]], NodeClass::Full);
  EXPECT_EQ(cls.potential, 4);
  EXPECT_EQ(cls.actual, 3);
  EXPECT_EQ(cls.semi, 1);
  // within the relative tolerance (1e-8 * 0.01) still in contact; nobody in contact: all potential
  for (double& y : uy) y = -0.01 + 1e-12;
  EXPECT_EQ(classesFor(uy).full, 4);
  // a given scale replaces max(|u|, g) = 0.01 (a distributed run passes the one over all ranks):
  // 1e-12 is beyond 1e-8 * 1e-5
  Eigen::VectorXd u = Eigen::VectorXd::Zero(m.numVertices() * 2);
  for (Index k = 0; k < 4; ++k) u[set.vertex(k) * 2 + 1] = uy[static_cast<std::size_t>(k)];
  EXPECT_EQ(classifyContactNodes(m, {mesh::kBottom}, &set, u, 1e-8, 1e-5).actual, 0);
  EXPECT_EQ(classifyContactNodes(m, {mesh::kBottom}, &set, u, 1e-8, 1.0).full, 4);
  cls = classesFor({0, 0, 0, 0});
  EXPECT_EQ(cls.actual, 0);
  for (Index v : byX) EXPECT_EQ(cls.ofVertex[v], NodeClass::Potential);
  EXPECT_EQ(cls.ofVertex[m.numVertices() - 1], NodeClass::None);  // a top vertex
  // a contact set of another mesh is an error
  const auto other = mesh::boxMesh(CellType::Quadrilateral, 2);
  EXPECT_THROW(classifyContactNodes(other, {mesh::kBottom}, &set, Eigen::VectorXd::Zero(other.numVertices() * 2)),
               obs::Error);
}

// 2D, three non-affine quadrilaterals on the bottom nodes x = 0, 1, 2, 3 (y = 0), obstacle
// g(x) = 0.02 + 0.003 x + 0.01 sin(pi x), nu = -e_y, so g - g_m = 0.01 sin(pi x) on every face.
// u_nu = g_p at x = 1, 2, 3 and g_0 - 0.004 at x = 0: classes potential, semi, full, full.
// Hand computation (closed forms):
//   eta_6^2 = s_1 d_1,  d_1 = int_{1/2}^{1} 0.004 (1 - x) x dx = 0.004 / 12
//   eta_7^2 = s_1 m_1 (0.01 int_{1/2}^1 x sin(pi x) dx) / (3/4)            (semi, gamma~ = [1/2, 3/2])
//           + s_2 m_2 (0.01 / pi) / (1/2) + s_3 m_3 (0.01 / pi) / (1/2)     (full, face [2, 3])
//   eta_8^2 = face [1, 2]: w = -0.01 sin(pi x): int w^2 + int w'^2 = 1e-4 (1 + pi^2) / 2
TEST(ContactResidualEstimator, HandComputed2D) {
  mesh::Mesh m(2);
  const double top[4] = {1.0, 1.3, 0.9, 1.1};
  for (int i = 0; i < 4; ++i) m.addVertex(Point(i, 0, 0));
  for (int i = 0; i < 4; ++i) m.addVertex(Point(i, top[i], 0));
  for (Index i = 0; i < 3; ++i) {
    m.addCell(CellType::Quadrilateral, {i, i + 1, i + 5, i + 4});
    m.addBoundaryFace({i, i + 1}, mesh::kBottom);
    m.addBoundaryFace({i + 5, i + 4}, mesh::kTop);
  }
  m.addBoundaryFace({4, 0}, mesh::kLeft);
  m.addBoundaryFace({3, 7}, mesh::kRight);
  const FunctionObstacle obstacle([](const Point& x) { return 0.02 + 0.003 * x[0] + 0.01 * std::sin(kPi * x[0]); },
                                  [](const Point&) { return Point(0, -1, 0); }, "sine", 2);
  const ContactSet set(m, mesh::kBottom, obstacle);
  ASSERT_EQ(set.size(), 4);
  Eigen::VectorXd u(16);
  for (int i = 0; i < 4; ++i) {
    const double gi = obstacle.gap(Point(i, 0, 0));
    u.segment<2>(2 * i) << 0.001 * i, -(gi - (i == 0 ? 0.004 : 0.0));
    u.segment<2>(2 * (i + 4)) << 0.0005 * i, -0.015 + 0.001 * i;
  }
  ContactOutputs out;
  const double s[4] = {0.7, 2.0, 3.0, 5.0};
  out.pressure.assign(s, s + 4);
  out.inContact = {0, 1, 1, 1};
  out.multiplier = {0, 0, 0, 0};
  const ContactData data{&set, &out, &obstacle};
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, {}});
  EstimatorInput in(m, kMaterial, bc, u);
  in.contact = &data;
  ResidualEstimator::Options o;
  ContactResidualEstimator::ContactOptions co;
  co.gapDegree = 20;
  const EstimatorResult c = ContactResidualEstimator(o, co).estimate(in);
  const EstimatorResult r = ResidualEstimator().estimate(in);

  const double eta6sq = s[1] * 0.004 / 12;
  const double eta7sq = s[1] * 1.0 * 0.01 * (1 / kPi - 1 / (kPi * kPi)) / 0.75 + s[2] * 1.0 * 0.02 / kPi +
                        s[3] * 0.5 * 0.02 / kPi;
  const double eta8sq = 1e-4 * (1 + kPi * kPi) / 2;
  EXPECT_NEAR(c.contribution("eta_6"), std::sqrt(eta6sq), 1e-12 * std::sqrt(eta6sq));
  EXPECT_NEAR(c.contribution("eta_7"), std::sqrt(eta7sq), 1e-10 * std::sqrt(eta7sq));
  EXPECT_NEAR(c.contribution("eta_8"), std::sqrt(eta8sq), 1e-7 * std::sqrt(eta8sq));  // FD of g
  // eta_6,1 split equally over the faces [0,1] (cell 0) and [1,2] (cell 1)
  EXPECT_NEAR(c.cellFields.at("eta_6")[0], std::sqrt(eta6sq / 2), 1e-12 * std::sqrt(eta6sq));
  EXPECT_NEAR(c.cellFields.at("eta_6")[1], std::sqrt(eta6sq / 2), 1e-12 * std::sqrt(eta6sq));
  EXPECT_EQ(c.cellFields.at("eta_6")[2], 0.0);
  // eta_8 of face [1,2] half to each vertex, all to cell 1
  EXPECT_NEAR(c.vertexFields.at("eta_8")[1], std::sqrt(eta8sq / 2), 1e-7 * std::sqrt(eta8sq));
  EXPECT_NEAR(c.cellFields.at("eta_8")[1], std::sqrt(eta8sq), 1e-7 * std::sqrt(eta8sq));
  // eta_1 ... eta_3 as `residual`; eta_4 on N^C; eta_5 only off full contact
  for (const char* k : {"eta_1", "eta_2", "eta_3", "eta_4"})
    EXPECT_NEAR(c.contribution(k), r.contribution(k), 1e-13 * r.total) << k;
  const Eigen::VectorXd& r5 = r.vertexFields.at("eta_5");
  const Eigen::VectorXd& c5 = c.vertexFields.at("eta_5");
  EXPECT_GT(r5[2], 0);
  EXPECT_EQ(c5[2], 0.0);
  EXPECT_EQ(c5[3], 0.0);
  EXPECT_NEAR(c5[0], r5[0], 1e-14 * r.total);
  EXPECT_NEAR(c5[1], r5[1], 1e-14 * r.total);
  // vertex fields: classes and pressures
  const Eigen::VectorXd& cls = c.vertexFields.at("contact_class");
  EXPECT_EQ(cls[0], 1.0);
  EXPECT_EQ(cls[1], 2.0);
  EXPECT_EQ(cls[2], 3.0);
  EXPECT_EQ(cls[3], 3.0);
  EXPECT_EQ(cls[5], 0.0);
  EXPECT_EQ(c.vertexFields.at("s")[2], 3.0);
  expectSumIdentity(c);

  // pressures are needed when nodes are in contact
  const ContactData noOutputs{&set, nullptr, &obstacle};
  in.contact = &noOutputs;
  try {
    ContactResidualEstimator().estimate(in);
    FAIL();
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no contact outputs"), std::string::npos) << e.what();
  }

  // ... and the obstacle whenever there is a contact set: without it eta_7 and eta_8 cannot be
  // evaluated, which must not pass as eta_7 = eta_8 = 0
  const ContactData noObstacle{&set, &out, nullptr};
  in.contact = &noObstacle;
  try {
    ContactResidualEstimator().estimate(in);
    FAIL() << "a contact set without an obstacle was accepted";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no obstacle"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("eta_7"), std::string::npos) << e.what();
  }
}

// 3D: one hexahedron whose contact face is the trapezoid (0,0), (1,0), (1.25,1), (0,1) in z = 0
// (a non-affine bilinear face), nu = -e_z. Independent computation: my own bilinear face map
// x(a, b), |J|, shape functions, composite Gauss quadrature over the quarters [0,1/2]^2 etc.
TEST(ContactResidualEstimator, HandComputed3DOnNonAffineFace) {
  mesh::Mesh m(3);
  const Point corner[4] = {Point(0, 0, 0), Point(1, 0, 0), Point(1.25, 1, 0), Point(0, 1, 0)};
  for (const Point& x : corner) m.addVertex(x);
  for (const Point& x : corner) m.addVertex(Point(x[0] == 1.25 ? 1.0 : x[0], x[1], 1));
  m.addCell(CellType::Hexahedron, {0, 1, 2, 3, 4, 5, 6, 7});
  m.addBoundaryFace({0, 3, 2, 1}, mesh::kBottom);
  // reference coordinates (a, b) of the corners in the order 0, 1, 2, 3 and the bilinear map
  const double ca[4] = {0, 1, 1, 0}, cb[4] = {0, 0, 1, 1};
  auto phi = [&](int i, double a, double b) { return (ca[i] ? a : 1 - a) * (cb[i] ? b : 1 - b); };
  auto xAt = [&](double a, double b) {
    Point x = Point::Zero();
    for (int i = 0; i < 4; ++i) x += phi(i, a, b) * corner[i];
    return x;
  };
  auto jac = [&](double a, double b) {  // |x_a x x_b|, planar face
    Point xa = (1 - b) * (corner[1] - corner[0]) + b * (corner[2] - corner[3]);
    Point xb = (1 - a) * (corner[3] - corner[0]) + a * (corner[2] - corner[1]);
    return xa.cross(xb).norm();
  };
  auto quarter = [&](int i, const std::function<double(double, double)>& f) {  // sub-face at corner i
    const double a0 = ca[i] ? 0.5 : 0, b0 = cb[i] ? 0.5 : 0;
    return integrate2([&](double a, double b) { return f(a, b) * jac(a, b); }, a0, a0 + 0.5, b0, b0 + 0.5);
  };
  auto gLin = [](const Point& x) { return 0.01 + 0.002 * x[0] - 0.003 * x[1]; };
  ContactResidualEstimator::ContactOptions co;
  co.gapDegree = 20;
  const ContactResidualEstimator estimator(ResidualEstimator::Options{}, co);
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, {}});

  // (a) g = gLin + 0.02 sin(pi y) >= g_m; nodes 0, 1, 2 in contact, node 3 off by 0.003: all
  // contact nodes are semi (the single face has a non-contact node)
  {
    const FunctionObstacle obstacle([&](const Point& x) { return gLin(x) + 0.02 * std::sin(kPi * x[1]); },
                                    [](const Point&) { return Point(0, 0, -1); }, "bump", 3);
    const ContactSet set(m, mesh::kBottom, obstacle);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(24);
    for (int i = 0; i < 4; ++i) {
      u[3 * i + 2] = -(obstacle.gap(corner[i]) - (i == 3 ? 0.003 : 0.0));
      u[3 * (i + 4) + 2] = -0.01;
    }
    ContactOutputs out;
    const double s[4] = {1.5, 2.5, 3.5, 0};
    out.pressure.assign(s, s + 4);
    const ContactData data{&set, &out, &obstacle};
    EstimatorInput in(m, kMaterial, bc, u);
    in.contact = &data;
    const EstimatorResult c = estimator.estimate(in);
    double eta6sq = 0, eta7sq = 0;
    for (int p = 0; p < 3; ++p) {
      const double d = quarter(p, [&](double a, double b) { return 0.003 * phi(3, a, b) * phi(p, a, b); });
      eta6sq += s[p] * d;
      const double mass = integrate2([&](double a, double b) { return phi(p, a, b) * jac(a, b); }, 0, 1, 0, 1);
      const double num = quarter(p, [&](double a, double b) { return 0.02 * std::sin(kPi * xAt(a, b)[1]) * phi(p, a, b); });
      const double den = quarter(p, [&](double a, double b) { return phi(p, a, b); });
      eta7sq += s[p] * mass * num / den;
    }
    EXPECT_EQ(c.vertexFields.at("contact_class")[0], 2.0);
    EXPECT_EQ(c.vertexFields.at("contact_class")[3], 1.0);
    EXPECT_NEAR(c.contribution("eta_6"), std::sqrt(eta6sq), 1e-10 * std::sqrt(eta6sq));
    EXPECT_NEAR(c.contribution("eta_7"), std::sqrt(eta7sq), 1e-9 * std::sqrt(eta7sq));
    EXPECT_EQ(c.contribution("eta_8"), 0.0);
    expectSumIdentity(c);
  }
  // (b) g = gLin - 0.02 sin(pi y) and u_nu = g_p + 0.001 (penetration) at every node: all full,
  // w = 0.001 + 0.02 sin(pi y), grad_Gamma w = (0, 0.02 pi cos(pi y)), h_s = |(1.25, 1)|;
  // eta_8^2 = int w^2 / h_s + h_s int |grad w|^2 over the trapezoid (width 1 + y / 4 at height y)
  {
    const FunctionObstacle obstacle([&](const Point& x) { return gLin(x) - 0.02 * std::sin(kPi * x[1]); },
                                    [](const Point&) { return Point(0, 0, -1); }, "dent", 3);
    const ContactSet set(m, mesh::kBottom, obstacle);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(24);
    for (int i = 0; i < 4; ++i) u[3 * i + 2] = -(obstacle.gap(corner[i]) + 0.001);
    ContactOutputs out;
    out.pressure = {1, 1, 1, 1};
    const ContactData data{&set, &out, &obstacle};
    EstimatorInput in(m, kMaterial, bc, u);
    in.contact = &data;
    const EstimatorResult c = estimator.estimate(in);
    const double hs = std::hypot(1.25, 1.0);
    const double w2 = integrate([](double y) { const double w = 0.001 + 0.02 * std::sin(kPi * y); return w * w * (1 + y / 4); }, 0, 1);
    const double g2 = integrate([](double y) { const double g = 0.02 * kPi * std::cos(kPi * y); return g * g * (1 + y / 4); }, 0, 1);
    const double eta8sq = w2 / hs + hs * g2;
    EXPECT_EQ(c.vertexFields.at("contact_class")[2], 3.0);
    EXPECT_NEAR(c.contribution("eta_8"), std::sqrt(eta8sq), 1e-7 * std::sqrt(eta8sq));
    EXPECT_EQ(c.contribution("eta_5"), 0.0);
    EXPECT_EQ(c.contribution("eta_6"), 0.0);
    EXPECT_EQ(c.contribution("eta_7"), 0.0);
    for (int p = 0; p < 4; ++p)
      EXPECT_NEAR(c.vertexFields.at("eta_8")[p], std::sqrt(eta8sq / 4), 1e-7 * std::sqrt(eta8sq));
    expectSumIdentity(c);
  }
}

TEST(ContactResidualEstimator, IsRegisteredAndUnknownNamesAreListed) {
  EstimatorRegistry r;
  registerBuiltinEstimators(r);
  EXPECT_EQ(r.names(), (std::vector<std::string>{"contact-residual", "residual"}));
  EXPECT_EQ(r.create("contact-residual")->name(), "contact-residual");
  EXPECT_EQ(r.description("contact-residual").find('\n'), std::string::npos);
  try {
    r.create("contact");
    FAIL();
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown estimator 'contact' (registered: contact-residual, residual)"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
