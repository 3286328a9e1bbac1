// Tresca and Coulomb friction (docs/theory.md#friction): exact reproduction of affine states in
// uniform slip and in stick, agreement of TNNMG with projected Gauss-Seidel and with the primal-dual
// active set method on curved contact with tangential loads (2D and 3D), the frictionless limit, the
// Coulomb fixed point and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <memory>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactModel.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/Friction.hpp"
#include "obs/obs/KktResiduals.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TNNMG.hpp"

using namespace obs;
using mesh::CellType;

namespace {

const Material kMaterial{3e5, 0.25};

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

Point P(double x, double y, double z = 0) { return Point(x, y, z); }

mesh::Grid uniformGrid(CellType type, int coarseCells, int levels) {
  mesh::Grid grid(mesh::boxMesh(type, coarseCells));
  for (int l = 0; l < levels; ++l) grid.refineUniformly();
  return grid;
}

template <class F>
void expectErrorMentioning(F f, const std::string& word) {
  try {
    f();
    ADD_FAILURE() << "no obs::Error thrown (expected one mentioning '" << word << "')";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
}

/// Coulomb options: coefficient, iteration cap, tolerance.
CoulombOptions coulomb(double mu, int maxIterations = 50, double tolerance = 1e-10) {
  CoulombOptions o;
  o.mu = mu;
  o.maxIterations = maxIterations;
  o.tolerance = tolerance;
  return o;
}

template <int d>
typename TNNMG<d>::Options tight() {
  typename TNNMG<d>::Options o;
  o.tolerance = 1e-12;
  o.kktTolerance = 1e-10;
  o.maxIterations = 200;
  return o;
}

/// The affine state of a block on the rigid plane x_d = 0 (docs/theory.md#friction-verification):
/// u = (s0 + gamma x_d) e_1 - eps x_d e_d, compression eps and shear gamma. Its contact pressure is
/// p = (lambda + 2 G) eps and its shear traction G gamma: with s0 > 0 it slides if G gamma = mu p,
/// with s0 = 0 it sticks if G gamma <= bound.
struct AffineState {
  double s0, gamma, eps;
  Point operator()(const Point& x, int d) const {
    Point u = Point::Zero();
    u[0] = s0 + gamma * x[d - 1];
    u[d - 1] = -eps * x[d - 1];
    return u;
  }
};

/// Every face but the bottom prescribed to the affine state; the bottom on the plane x_d = 0.
template <int d>
ContactProblem<d> affineProblem(const mesh::Mesh& m, const AffineState& a) {
  BoundaryConditions bc;
  const std::vector<int> faces = d == 2 ? std::vector<int>{mesh::kTop, mesh::kLeft, mesh::kRight}
                                        : std::vector<int>{mesh::kTop, mesh::kLeft, mesh::kRight, mesh::kFront, mesh::kBack};
  for (int f : faces) bc.dirichlet.push_back({f, {true, true, true}, [a](const Point& x) { return a(x, d); }});
  const Point normal = d == 2 ? P(0, -1) : P(0, 0, -1);
  const ContactSet cs(m, mesh::kBottom, PlaneObstacle(Point::Zero(), normal));
  return ContactProblem<d>(m, kMaterial, bc, cs);
}

template <int d>
double maxError(const mesh::Mesh& m, const Eigen::VectorXd& u, const AffineState& a) {
  double e = 0;
  for (Index v = 0; v < m.numVertices(); ++v)
    e = std::max(e, (u.template segment<d>(v * d) - a(m.vertex(v), d).template head<d>()).cwiseAbs().maxCoeff());
  return e;
}

template <int d>
void expectAffineSlip(CellType type, int levels) {
  SCOPED_TRACE(std::string("d = ") + std::to_string(d) + ", cells " + std::to_string(static_cast<int>(type)));
  const mesh::Grid grid = uniformGrid(type, 2, levels);
  const mesh::Mesh& m = grid.leafView().mesh;
  const double mu = 0.3, eps = 1e-3, G = kMaterial.mu(), p = (kMaterial.lambda() + 2 * G) * eps;
  const AffineState slide{2e-3, mu * p / G, eps};
  // Tresca with the bound mu p: the state itself
  ContactProblem<d> problem = affineProblem<d>(m, slide);
  problem.setFriction(trescaSlipBounds(problem.contactSet(), mu * p));
  TNNMG<d> tnnmg(grid, tight<d>());
  Eigen::VectorXd u;
  const ContactResult r = tnnmg.solve(problem, u);
  EXPECT_TRUE(r.converged);
  const double scale = slide.s0 + slide.gamma + eps;
  EXPECT_LT(maxError<d>(m, u, slide), 1e-10 * scale);
  const ContactOutputs out = computeContactOutputs(problem, u, 1e-8);
  Index free = 0;
  for (Index k = 0; k < problem.contactSet().size(); ++k) {
    if (!problem.constraint(k).bounded()) continue;  // corners on the prescribed faces
    ++free;
    // the friction force mu times the normal force, node by node
    EXPECT_NEAR(out.tangential[k].norm(), mu * out.multiplier[k], 1e-10 * mu * out.multiplier[k]);
    EXPECT_EQ(out.state[k], 2);
  }
  EXPECT_GT(free, 0);
  EXPECT_EQ(out.slipNodes, free);
  EXPECT_LT(r.kkt.max(), 1e-10);
  // Coulomb from zero: the same state, as a fixed point
  ContactProblem<d> coulombProblem = affineProblem<d>(m, slide);
  TNNMG<d> solver(grid, tight<d>());
  Eigen::VectorXd v;
  const CoulombResult c = solveCoulomb(coulombProblem, solver, v, coulomb(mu));
  EXPECT_TRUE(c.converged);
  EXPECT_LT(maxError<d>(m, v, slide), 1e-8 * scale);
  if (verbose())
    std::cout << "  affine slip: TNNMG " << r.iterations << " it; Coulomb " << c.iterations << " fixed-point steps, "
              << c.innerIterations << " TNNMG it, changes";
  if (verbose())
    for (double x : c.changes) std::cout << " " << x;
  if (verbose()) std::cout << "\n";
}

TEST(Friction, UniformSlipIsReproducedExactly2D) {
  expectAffineSlip<2>(CellType::Quadrilateral, 3);
  expectAffineSlip<2>(CellType::Triangle, 3);
}

TEST(Friction, UniformSlipIsReproducedExactly3D) { expectAffineSlip<3>(CellType::Hexahedron, 2); }

template <int d>
void expectAffineStick(CellType type, int levels) {
  const mesh::Grid grid = uniformGrid(type, 2, levels);
  const mesh::Mesh& m = grid.leafView().mesh;
  const double eps = 1e-3, G = kMaterial.mu(), p = (kMaterial.lambda() + 2 * G) * eps;
  const AffineState stick{0, 0.2 * p / G, eps};  // shear traction 0.2 p
  ContactProblem<d> problem = affineProblem<d>(m, stick);
  problem.setFriction(trescaSlipBounds(problem.contactSet(), 0.3 * p));
  TNNMG<d> tnnmg(grid, tight<d>());
  Eigen::VectorXd u;
  const ContactResult r = tnnmg.solve(problem, u);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(maxError<d>(m, u, stick), 1e-10 * (stick.gamma + eps));
  const ContactOutputs out = computeContactOutputs(problem, u, 1e-8);
  for (Index k = 0; k < problem.contactSet().size(); ++k)
    if (problem.constraint(k).bounded()) {
      EXPECT_EQ(out.state[k], 1);
      EXPECT_NEAR(out.tangential[k].norm(), 0.2 * out.multiplier[k], 1e-9 * out.multiplier[k]);
    }
  EXPECT_EQ(out.slipNodes, 0);
  EXPECT_LT(r.kkt.max(), 1e-10);
}

TEST(Friction, UniformStickIsReproducedExactly) {
  expectAffineStick<2>(CellType::Quadrilateral, 3);
  expectAffineStick<3>(CellType::Tetrahedron, 2);
}

/// A block pressed onto a curved obstacle and sheared at the top: partial slip.
template <int d>
ContactProblem<d> shearedHertz(const mesh::Mesh& m, double shear) {
  BoundaryConditions bc;
  const Point top = d == 2 ? P(shear, -0.04) : P(shear, 0.5 * shear, -0.03);
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [top](const Point&) { return top; }});
  std::unique_ptr<Obstacle> obstacle;
  if constexpr (d == 2) obstacle = std::make_unique<DiskObstacle>(P(0.5, -0.5), 0.5);
  else obstacle = std::make_unique<BallObstacle>(P(0.5, 0.5, -0.75), 0.75);
  return ContactProblem<d>(m, kMaterial, bc, ContactSet(m, mesh::kBottom, *obstacle));
}

template <int d>
void expectTnnmgAgreesWithGaussSeidel(CellType type, int levels, double shear, double bound) {
  const mesh::Grid grid = uniformGrid(type, 2, levels);
  const mesh::Mesh& m = grid.leafView().mesh;
  ContactProblem<d> problem = shearedHertz<d>(m, shear);
  // frictionless first: the reference iteration count and the scale of the bound
  TNNMG<d> tnnmg(grid, tight<d>());
  Eigen::VectorXd u0;
  const ContactResult frictionless = tnnmg.solve(problem, u0);
  const ContactOutputs out0 = computeContactOutputs(problem, u0, 1e-8);
  double pmax = 0;
  for (double s : out0.pressure) pmax = std::max(pmax, s);
  problem.setFriction(trescaSlipBounds(problem.contactSet(), bound * pmax));
  Eigen::VectorXd u;
  const ContactResult r = tnnmg.solve(problem, u);
  typename ProjectedGaussSeidel<d>::Options po;
  po.tolerance = 1e-13;
  po.maxIterations = 200000;
  po.stagnationIterations = 100000;
  ProjectedGaussSeidel<d> pgs(po);
  Eigen::VectorXd v;
  const ContactResult g = pgs.solve(problem, v);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.kkt.max(), 1e-10);
  EXPECT_LT(g.kkt.max(), 1e-7);
  EXPECT_LT((u - v).norm(), 1e-6 * u.norm());
  EXPECT_LE(r.energy, g.energy + 1e-12 * std::abs(g.energy));
  const ContactOutputs out = computeContactOutputs(problem, u, 1e-8);
  EXPECT_GT(out.stickNodes, 0);
  EXPECT_GT(out.slipNodes, 0);
  // Tresca: |f_T| <= s_k everywhere, = s_k where slipping
  const std::vector<double>& s = problem.slipBounds();
  for (Index k = 0; k < problem.contactSet().size(); ++k) {
    EXPECT_LE(out.tangential[k].norm(), s[k] * (1 + 1e-8) + 1e-10 * s[0]);
    if (out.state[k] == 2) {
      EXPECT_NEAR(out.tangential[k].norm(), s[k], 1e-8 * s[k]);
    }
  }
  if (verbose())
    std::cout << "  " << problem.numDofs() << " dofs: TNNMG " << frictionless.iterations << " it frictionless, "
              << r.iterations << " it with friction (stick " << out.stickNodes << ", slip " << out.slipNodes
              << "), PGS " << g.iterations << " it\n";
}

TEST(Friction, TnnmgAgreesWithGaussSeidel2D) {
  expectTnnmgAgreesWithGaussSeidel<2>(CellType::Quadrilateral, 4, 0.003, 0.2);
  expectTnnmgAgreesWithGaussSeidel<2>(CellType::Triangle, 4, 0.003, 0.2);
}

TEST(Friction, TnnmgAgreesWithGaussSeidel3D) { expectTnnmgAgreesWithGaussSeidel<3>(CellType::Hexahedron, 2, 0.006, 0.05); }

/// The primal-dual active set method with friction (semismooth Newton) against TNNMG: two
/// independent solvers of the same Tresca and Coulomb problems.
template <int d>
void expectPdasAgreesWithTnnmg(CellType type, int levels, double shear, double bound) {
  const mesh::Grid grid = uniformGrid(type, 2, levels);
  const mesh::Mesh& m = grid.leafView().mesh;
  ContactProblem<d> problem = shearedHertz<d>(m, shear);
  TNNMG<d> tnnmg(grid, tight<d>());
  Eigen::VectorXd u0;
  tnnmg.solve(problem, u0);
  const ContactOutputs out0 = computeContactOutputs(problem, u0, 1e-8);
  double pmax = 0;
  for (double s : out0.pressure) pmax = std::max(pmax, s);
  problem.setFriction(trescaSlipBounds(problem.contactSet(), bound * pmax));
  Eigen::VectorXd u, v;
  const ContactResult a = tnnmg.solve(problem, u);
  typename PrimalDualActiveSet<d>::Options po;
  po.kktTolerance = 1e-10;
  PrimalDualActiveSet<d> pdas(po);
  const ContactResult b = pdas.solve(problem, v);
  EXPECT_TRUE(a.converged);
  EXPECT_TRUE(b.converged);
  EXPECT_LT((u - v).norm(), 1e-8 * u.norm());
  const ContactOutputs oa = computeContactOutputs(problem, u, 1e-8), ob = computeContactOutputs(problem, v, 1e-8);
  EXPECT_EQ(oa.state, ob.state);
  EXPECT_GT(ob.stickNodes, 0);
  EXPECT_GT(ob.slipNodes, 0);
  // Coulomb with either solver inside the fixed point
  ContactProblem<d> pa = shearedHertz<d>(m, shear), pb = shearedHertz<d>(m, shear);
  Eigen::VectorXd x, y;
  TNNMG<d> t2(grid, tight<d>());
  const CoulombResult ca = solveCoulomb(pa, t2, x, coulomb(0.3));
  const CoulombResult cb = solveCoulomb(pb, pdas, y, coulomb(0.3));
  EXPECT_TRUE(ca.converged);
  EXPECT_TRUE(cb.converged) << cb.iterations << " solves, last: " << cb.last.iterations << " it, converged "
                            << cb.last.converged << ", kkt " << cb.last.kkt.max();
  EXPECT_LT((x - y).norm(), 1e-7 * x.norm());
  if (verbose())
    std::cout << "  " << problem.numDofs() << " dofs: Tresca TNNMG " << a.iterations << " it, PDAS " << b.iterations
              << " it (stick " << ob.stickNodes << ", slip " << ob.slipNodes << "); Coulomb " << ca.iterations << " / "
              << cb.iterations << " solves\n";
}

TEST(Friction, PrimalDualActiveSetAgreesWithTnnmg2D) {
  expectPdasAgreesWithTnnmg<2>(CellType::Quadrilateral, 4, 0.003, 0.2);
  expectPdasAgreesWithTnnmg<2>(CellType::Triangle, 4, 0.003, 0.2);
}

// 3D: the slip direction linearised in each Newton step (PrimalDualActiveSet.hpp)
TEST(Friction, PrimalDualActiveSetAgreesWithTnnmg3D) {
  expectPdasAgreesWithTnnmg<3>(CellType::Hexahedron, 2, 0.006, 0.05);
}

/// The frictional patch test on non-matching meshes (docs/verification.md#friction): two blocks, the
/// lower of one cell type, the upper of another, touching at x_d = 1; every face but the interface is
/// moved by the affine field u = (s + gamma (x_d - 1)) e_1 - eps (x_d - 1) e_d, with s = 0 below and
/// s = s0 above, so the upper block slides by s0 on the lower one under the uniform pressure
/// p = (lambda + 2G) eps and shear G gamma = mu p. The dual-mortar pair must reproduce the fields
/// exactly, and every constrained slave node carry the friction force mu times its normal force.
template <int d>
void expectFrictionalMortarPatch(CellType lowerType, int nLower, CellType upperType, int nUpper) {
  SCOPED_TRACE(std::string(mesh::name(lowerType)) + " / " + std::string(mesh::name(upperType)));
  mesh::Mesh lower = mesh::boxMesh(lowerType, nLower);
  mesh::Mesh upper = mesh::boxMesh(upperType, nUpper);
  for (Index v = 0; v < upper.numVertices(); ++v) upper.vertex(v)[d - 1] += 1;
  const double mu = 0.3, eps = 1e-3, G = kMaterial.mu(), p = (kMaterial.lambda() + 2 * G) * eps;
  const double gamma = mu * p / G, s0 = 2e-3;
  const auto field = [=](double s) {
    return [=](const Point& x) {
      Point u = Point::Zero();
      u[0] = s + gamma * (x[d - 1] - 1);
      u[d - 1] = -eps * (x[d - 1] - 1);
      return u;
    };
  };
  const std::vector<int> sides = d == 2 ? std::vector<int>{mesh::kLeft, mesh::kRight}
                                        : std::vector<int>{mesh::kLeft, mesh::kRight, mesh::kFront, mesh::kBack};
  // the slave (upper) sides carry the exact traction sigma n instead of Dirichlet data (uniform
  // stress: sigma_11 = sigma_22 = -lambda eps, sigma_dd = -(lambda + 2G) eps, sigma_1d = G gamma), so
  // that the slave nodes on the rim of the interface are ordinary contact nodes (Dirichlet data there
  // would be left out of the mortar transformation, ContactProblem::basisSkip)
  const double lam = kMaterial.lambda();
  const auto traction = [=](int side) {
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    if (side == mesh::kLeft) n[0] = -1;
    if (side == mesh::kRight) n[0] = 1;
    if (side == mesh::kFront) n[1] = -1;
    if (side == mesh::kBack) n[1] = 1;
    Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
    for (int a = 0; a < d - 1; ++a) sigma(a, a) = -lam * eps;
    sigma(d - 1, d - 1) = -(lam + 2 * G) * eps;
    sigma(0, d - 1) = sigma(d - 1, 0) = G * gamma;
    const Eigen::Vector3d t = sigma * n;
    return [t](const Point&) { return t; };
  };
  BoundaryConditions bl, bu;
  for (int f : sides) {
    bl.dirichlet.push_back({f, {true, true, true}, field(0)});
    NeumannCondition nc;
    nc.boundaryId = f;
    nc.traction = traction(f);
    bu.neumann.push_back(nc);
  }
  bl.dirichlet.push_back({mesh::kBottom, {true, true, true}, field(0)});
  bu.dirichlet.push_back({mesh::kTop, {true, true, true}, field(s0)});
  ContactModel<d> model;
  model.addBody("lower", lower, kMaterial, bl);
  model.addBody("upper", upper, kMaterial, bu);
  model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "bottom / top");
  model.setFriction(0, {FrictionLaw::Type::Coulomb, mu});
  ContactProblem<d> problem = model.assemble();
  const mesh::Grid gl(lower), gu(upper);
  TNNMG<d> tnnmg(std::vector<const mesh::Grid*>{&gl, &gu}, tight<d>());
  Eigen::VectorXd x;
  const CoulombResult c = solveFriction(problem, tnnmg, x, nodalFriction(model, problem.contactSet()), coulomb(0));
  EXPECT_TRUE(c.converged);
  if (verbose())
    std::cout << "  mortar patch: " << c.iterations << " Tresca solves, last " << c.last.iterations << " it, kkt "
              << c.last.kkt.max() << "\n";
  const Eigen::VectorXd u = problem.toDisplacement(x);
  double error = 0;
  for (Index v = 0; v < lower.numVertices(); ++v)
    error = std::max(error, (u.template segment<d>(v * d) - field(0)(lower.vertex(v)).template head<d>()).cwiseAbs().maxCoeff());
  const Index off = lower.numVertices();
  for (Index v = 0; v < upper.numVertices(); ++v)
    error = std::max(error, (u.template segment<d>((off + v) * d) - field(s0)(upper.vertex(v)).template head<d>())
                                .cwiseAbs()
                                .maxCoeff());
  EXPECT_LT(error, 1e-8 * (s0 + gamma + eps));
  const ContactOutputs out = computeContactOutputs(problem, x, 1e-8);
  Index constrained = 0;
  for (Index k = 0; k < problem.contactSet().size(); ++k) {
    if (!problem.constraint(k).bounded()) continue;
    ++constrained;
    EXPECT_EQ(out.state[k], 2);
    EXPECT_NEAR(out.tangential[k].norm(), mu * out.multiplier[k], 1e-8 * mu * out.multiplier[k]);
    EXPECT_NEAR(out.slip[k], s0, 1e-8 * s0);
  }
  EXPECT_GT(constrained, 0);
}

/// A roller on the slave side of a mortar interface whose master side is free: the prescribed
/// component is left out of the mortar transformation, so friction could not see the relative slip
/// along it. The problem refuses the friction term there instead of solving something else.
/// Two unit squares stacked in 2D (quadrilaterals below, triangles above), the lower one clamped at
/// its bottom, the upper one's top moved down by 1e-3.
struct StackedSquares {
  mesh::Mesh lower = mesh::boxMesh(CellType::Quadrilateral, 3);
  mesh::Mesh upper = mesh::boxMesh(CellType::Triangle, 4);
  BoundaryConditions bl, bu;
  StackedSquares() {
    for (Index v = 0; v < upper.numVertices(); ++v) upper.vertex(v)[1] += 1;
    bl.dirichlet.push_back({mesh::kBottom, {true, true, true}, [](const Point&) { return Point::Zero(); }});
    bu.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0.0, -1e-3, 0.0); }});
  }
};

TEST(Friction, SlaveRollerAgainstAFreeMasterIsRefused) {
  StackedSquares sq;
  const mesh::Mesh &lower = sq.lower, &upper = sq.upper;
  BoundaryConditions &bl = sq.bl, &bu = sq.bu;
  for (int side : {mesh::kLeft, mesh::kRight})  // rollers on the slave's sides, reaching the interface
    bu.dirichlet.push_back({side, {true, false, false}, [](const Point&) { return Point::Zero(); }});
  ContactModel<2> model;
  model.addBody("lower", lower, kMaterial, bl);
  model.addBody("upper", upper, kMaterial, bu);
  model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "bottom / top");
  ContactProblem<2> problem = model.assemble();
  const auto n = static_cast<std::size_t>(problem.contactSet().size());
  expectErrorMentioning([&] { problem.setFriction(std::vector<double>(n, 1.0)); }, "would escape friction");
  problem.setFriction(std::vector<double>(n, 0.0));  // no friction: nothing to refuse
  EXPECT_FALSE(problem.frictional());
}

/// The nodal friction of one law on a contact set is the one of a model whose only coupling has
/// that law, node by node and bit for bit (one body (distributed runs) and a model share it):
/// Tresca m_k g, Coulomb mu, none empty.
TEST(Friction, OneLawOnAContactSetIsTheOneCouplingModels) {
  const StackedSquares sq;
  const mesh::Mesh &lower = sq.lower, &upper = sq.upper;
  const BoundaryConditions &bl = sq.bl, &bu = sq.bu;
  for (const FrictionLaw law : {FrictionLaw{FrictionLaw::Type::Tresca, 2.5}, FrictionLaw{FrictionLaw::Type::Coulomb, 0.3},
                                FrictionLaw{}}) {
    ContactModel<2> model;
    model.addBody("lower", lower, kMaterial, bl);
    model.addBody("upper", upper, kMaterial, bu);
    model.addMortarPair(1, mesh::kBottom, 0, mesh::kTop, "bottom / top");
    model.setFriction(0, law);
    const ContactProblem<2> problem = model.assemble();
    const ContactSet& set = problem.contactSet();
    const NodalFriction one = nodalFriction(law, set), all = nodalFriction(model, set);
    EXPECT_EQ(one.bound, all.bound);
    EXPECT_EQ(one.mu, all.mu);
    if (law.type == FrictionLaw::Type::None) {
      EXPECT_TRUE(one.bound.empty() && one.mu.empty());
      continue;
    }
    ASSERT_EQ(one.bound.size(), static_cast<std::size_t>(set.size()));
    for (Index k = 0; k < set.size(); ++k) {
      const auto i = static_cast<std::size_t>(k);
      EXPECT_EQ(one.bound[i], law.type == FrictionLaw::Type::Tresca ? 2.5 * set.boundaryMass(k) : 0.0);
      EXPECT_EQ(one.mu[i], law.type == FrictionLaw::Type::Coulomb ? 0.3 : 0.0);
    }
    EXPECT_EQ(one.coulomb(), law.type == FrictionLaw::Type::Coulomb);
  }
}

TEST(Friction, UniformSlipOnNonMatchingMeshes) {
  expectFrictionalMortarPatch<2>(CellType::Triangle, 3, CellType::Quadrilateral, 4);
  expectFrictionalMortarPatch<3>(CellType::Tetrahedron, 3, CellType::Hexahedron, 4);
}

TEST(Friction, ZeroBoundsAreTheFrictionlessSolveBitForBit) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 3);
  const mesh::Mesh& m = grid.leafView().mesh;
  ContactProblem<2> problem = shearedHertz<2>(m, 0.004);
  TNNMG<2> a(grid, tight<2>()), b(grid, tight<2>());
  Eigen::VectorXd u, v;
  const ContactResult ra = a.solve(problem, u);
  problem.setFriction(std::vector<double>(problem.contactSet().size(), 0.0), Eigen::VectorXd::Ones(problem.numDofs()));
  EXPECT_FALSE(problem.frictional());
  const ContactResult rb = b.solve(problem, v);
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ(ra.energy, rb.energy);
  EXPECT_TRUE(u == v);
  // mu = 0 Coulomb: one frictionless solve
  Eigen::VectorXd w;
  TNNMG<2> c(grid, tight<2>());
  const CoulombResult rc = solveCoulomb(problem, c, w, coulomb(0.0));
  EXPECT_EQ(rc.iterations, 1);
  EXPECT_TRUE(u == w);
}

TEST(Friction, BadInputIsRefused) {
  const mesh::Grid grid = uniformGrid(CellType::Quadrilateral, 2, 1);
  const mesh::Mesh& m = grid.leafView().mesh;
  ContactProblem<2> problem = shearedHertz<2>(m, 0.004);
  const auto n = static_cast<std::size_t>(problem.contactSet().size());
  expectErrorMentioning([&] { problem.setFriction(std::vector<double>(n + 1, 1.0)); }, "slip bounds");
  expectErrorMentioning([&] { problem.setFriction(std::vector<double>(n, -1.0)); }, "slip bound");
  expectErrorMentioning([&] { problem.setFriction(std::vector<double>(n, std::nan(""))); }, "slip bound");
  expectErrorMentioning([&] { problem.setFriction(std::vector<double>(n, 1.0), Eigen::VectorXd::Zero(3)); }, "origin");
  expectErrorMentioning([&] { trescaSlipBounds(problem.contactSet(), -1); }, "slip bound");
  problem.setFriction(std::vector<double>(n, 1.0));
  Eigen::VectorXd u;
  TNNMG<2> tnnmg(grid);
  expectErrorMentioning([&] { solveCoulomb(problem, tnnmg, u, coulomb(-0.1)); }, "coefficient");
  expectErrorMentioning([&] { solveCoulomb(problem, tnnmg, u, coulomb(0.1, 0)); }, "options");
}

}  // namespace
