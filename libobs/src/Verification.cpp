#include "obs/obs/Verification.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/obs/CellValues.hpp"
#include "obs/obs/LinearElasticity.hpp"

namespace obs {
namespace {

template <int d>
ErrorNorms errors(const mesh::Mesh& mesh, const Eigen::VectorXd& uh, const VectorField& exact,
                  const std::function<Eigen::Matrix3d(const Point&)>& gradient, int degree) {
  ErrorNorms e;
  CellValues<d> cv(degree);
  for (Index c = 0; c < mesh.numCells(); ++c) {
    cv.reinit(mesh, c);
    const auto verts = mesh.cellVertices(c);
    for (int q = 0; q < cv.numPoints(); ++q) {
      Eigen::Matrix<double, d, 1> u = Eigen::Matrix<double, d, 1>::Zero();
      Eigen::Matrix<double, d, d> G = Eigen::Matrix<double, d, d>::Zero();
      for (int i = 0; i < cv.numVertices(); ++i) {
        const auto ui = uh.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d);
        u += cv.value(q, i) * ui;
        G += ui * cv.gradient(q, i).transpose();
      }
      Point x = Point::Zero();
      x.template head<d>() = cv.point(q);
      const Eigen::Matrix<double, d, 1> ue = exact(x).template head<d>();
      const Eigen::Matrix<double, d, d> Ge = gradient(x).template topLeftCorner<d, d>();
      const double w = cv.JxW(q);
      e.l2 += w * (u - ue).squaredNorm();
      e.h1 += w * (G - Ge).squaredNorm();
      e.l2Exact += w * ue.squaredNorm();
      e.h1Exact += w * Ge.squaredNorm();
    }
  }
  e.l2 = std::sqrt(e.l2);
  e.h1 = std::sqrt(e.h1);
  e.l2Exact = std::sqrt(e.l2Exact);
  e.h1Exact = std::sqrt(e.h1Exact);
  return e;
}

}  // namespace

ErrorNorms computeErrors(const mesh::Mesh& mesh, const Eigen::VectorXd& uh, const VectorField& exact,
                         const std::function<Eigen::Matrix3d(const Point&)>& gradient, int degree) {
  return mesh.dimension() == 2 ? errors<2>(mesh, uh, exact, gradient, degree)
                               : errors<3>(mesh, uh, exact, gradient, degree);
}

PlaneWaveSolution::PlaneWaveSolution(int dimension, const Material& material)
    : d_(dimension), lambda_(material.lambda()), mu_(material.mu()) {
  k_ = 0.5 * std::numbers::pi * Eigen::Vector3d(1.3, 0.9, 0.6);
  if (d_ == 2) k_[2] = 0;
}

Eigen::Vector3d PlaneWaveSolution::value(const Point& x) const {
  Eigen::Vector3d u = Eigen::Vector3d::Zero();
  for (int c = 0; c < d_; ++c) u[c] = std::sin(k_.dot(x) + c);
  return u;
}

Eigen::Matrix3d PlaneWaveSolution::gradient(const Point& x) const {
  Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
  for (int c = 0; c < d_; ++c) G.row(c) = std::cos(k_.dot(x) + c) * k_.transpose();
  return G;
}

Eigen::Matrix3d PlaneWaveSolution::stress(const Point& x) const {
  const Eigen::Matrix3d G = gradient(x);
  const Eigen::Matrix3d eps = 0.5 * (G + G.transpose());
  return 2 * mu_ * eps + lambda_ * eps.trace() * Eigen::Matrix3d::Identity();
}

Eigen::Vector3d PlaneWaveSolution::bodyForce(const Point& x) const {
  // -div sigma = -(mu Laplace u + (lambda + mu) grad div u)
  //   Laplace u_a = -|k|^2 sin(k.x + a),  (grad div u)_a = -k_a sum_c k_c sin(k.x + c)
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  for (int c = 0; c < d_; ++c) s[c] = std::sin(k_.dot(x) + c);
  return mu_ * k_.squaredNorm() * s + (lambda_ + mu_) * k_.dot(s) * k_;
}

Eigen::Vector3d PlaneWaveSolution::traction(const Point& x, const Eigen::Vector3d& n) const {
  return stress(x) * n;
}

namespace {

/// Solves the problem on m, measures the errors against the exact solution u (value, gradient)
/// and fills the row of a convergence study with n cells per direction.
template <class Exact>
ManufacturedRun studyRun(mesh::CellType type, int n, const mesh::Mesh& m, const Material& material,
                         const BoundaryConditions& bc, const Exact& u) {
  const auto s = solveLinearElasticity(m, material, bc);
  const auto e = computeErrors(m, s.displacement, [&](const Point& x) { return u.value(x); },
                               [&](const Point& x) { return u.gradient(x); });
  ManufacturedRun r;
  r.type = type;
  r.cellsPerDirection = n;
  r.h = 1.0 / n;
  r.dofs = s.dofs;
  r.relativeL2 = e.l2 / e.l2Exact;
  r.relativeH1 = e.h1 / e.h1Exact;
  r.solveSeconds = s.assemblySeconds + s.solveSeconds;
  return r;
}

}  // namespace

ManufacturedRun solveManufactured(mesh::CellType type, int n, double distortion,
                                  const Material& material) {
  auto m = mesh::boxMesh(type, {n, n, n}, Point(0, 0, 0), Point(1, 1, 1));
  distortUnitBox(m, distortion);
  const int d = m.dimension();
  const PlaneWaveSolution u(d, material);
  BoundaryConditions bc;
  bc.bodyForce = [&](const Point& x) { return u.bodyForce(x); };
  // box face ids: 1/2 = x low/high, 3/4 = last coordinate low/high, 5/6 = y low/high (3D)
  for (int id = 1; id <= 2 * d; ++id) {
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal[id <= 2 ? 0 : id <= 4 ? d - 1 : 1] = id % 2 == 0 ? 1.0 : -1.0;
    if (id % 2 == 1)
      bc.dirichlet.push_back({id, {true, true, true}, [&](const Point& x) { return u.value(x); }});
    else
      bc.neumann.push_back({id, [&u, normal](const Point& x) { return u.traction(x, normal); }, {}});
  }
  return studyRun(type, n, m, material, bc, u);
}

void distortUnitBox(mesh::Mesh& mesh, double amplitude) {
  const int d = mesh.dimension();
  const double pi = std::numbers::pi;
  for (Index v = 0; v < mesh.numVertices(); ++v) {
    Point& x = mesh.vertex(v);
    const Point x0 = x;
    for (int a = 0; a < d; ++a) {
      double p = std::sin(pi * x0[a]);
      for (int b = 0; b < d; ++b)
        if (b != a) p *= std::sin(pi * x0[b]);
      x[a] = x0[a] + amplitude * p;
    }
  }
}

ThickCylinderSolution::ThickCylinderSolution(const Material& material, double a, double b, double p)
    : E_(material.youngsModulus), nu_(material.poissonRatio), A_(p * a * a / (b * b - a * a)), B_(A_ * b * b) {}

Eigen::Vector3d ThickCylinderSolution::value(const Point& x) const {
  const double r = std::hypot(x[0], x[1]);
  const double ur = (1 + nu_) / E_ * ((1 - 2 * nu_) * A_ * r + B_ / r);
  return Eigen::Vector3d(ur * x[0] / r, ur * x[1] / r, 0);
}

Eigen::Matrix3d ThickCylinderSolution::gradient(const Point& x) const {
  // grad u = u_r' e_r e_r' + (u_r / r) e_t e_t'
  const double r = std::hypot(x[0], x[1]);
  const double ur = (1 + nu_) / E_ * ((1 - 2 * nu_) * A_ * r + B_ / r);
  const double dur = (1 + nu_) / E_ * ((1 - 2 * nu_) * A_ - B_ / (r * r));
  const Eigen::Vector3d er(x[0] / r, x[1] / r, 0), et(-x[1] / r, x[0] / r, 0);
  return dur * er * er.transpose() + (ur / r) * et * et.transpose();
}

ManufacturedRun solveThickCylinder(mesh::CellType type, int n, const Material& material) {
  const int d = mesh::dimension(type);
  const double quarter = std::acos(0.0);
  const int layers = std::max(1, n / 4);
  auto m = mesh::boxMesh(type, {n, n, layers}, Point(1, 0, 0), Point(2, quarter, 0.25));
  for (Index v = 0; v < m.numVertices(); ++v) {
    Point& x = m.vertex(v);
    x = Point(x[0] * std::cos(x[1]), x[0] * std::sin(x[1]), x[2]);
  }
  const ThickCylinderSolution u(material);
  // box ids: 1 r = 1 (pressure), 2 r = 2 (free); the angle is the second coordinate: 3/4 in 2D,
  // 5/6 in 3D (t = 0: u_y = 0; t = pi/2, the plane x = 0: u_x = 0); 3D: 3/4 the ends z = 0, 1/4
  BoundaryConditions bc;
  bc.neumann.push_back({1, {}, [](const Point&) { return 1.0; }});
  const int low = d == 2 ? 3 : 5, high = d == 2 ? 4 : 6;
  bc.dirichlet.push_back({low, {false, true, false}});
  bc.dirichlet.push_back({high, {true, false, false}});
  if (d == 3) {
    bc.dirichlet.push_back({3, {false, false, true}});
    bc.dirichlet.push_back({4, {false, false, true}});
  }
  return studyRun(type, n, m, material, bc, u);
}

}  // namespace obs
