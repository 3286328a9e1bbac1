#pragma once
/// \file Verification.hpp
/// Tools to verify discretisations: error norms of a finite element displacement against an
/// exact solution, and a smooth manufactured solution of linear elasticity with its data.
#include <Eigen/Core>

#include <functional>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Material.hpp"

namespace obs {

struct ErrorNorms {
  double l2 = 0;        ///< ||u - u_h||_{L2}
  double h1 = 0;        ///< |u - u_h|_{H1} (seminorm)
  double l2Exact = 0;   ///< ||u||_{L2}, for relative errors
  double h1Exact = 0;   ///< |u|_{H1}
};

/// Errors of the nodal displacement u_h (vertex-major, mesh.dimension() components per vertex)
/// computed cell by cell with a quadrature rule of exactness `degree`.
/// `gradient(x)` returns du_a/dx_b in entry (a, b).
ErrorNorms computeErrors(const mesh::Mesh& mesh, const Eigen::VectorXd& uh,
                         const VectorField& exact,
                         const std::function<Eigen::Matrix3d(const Point&)>& gradient,
                         int degree = 4);

/// Manufactured solution u_c(x) = sin(k.x + c), c = 0..d-1, with k = (1.3, 0.9, 0.6) pi/2
/// (restricted to d components): smooth, non-polynomial, all strain components non-zero.
/// Supplies the body force f = -div sigma(u) and the traction sigma(u) n on a face with outward
/// normal n, so that any mix of Dirichlet and Neumann boundaries reproduces u.
class PlaneWaveSolution {
public:
  PlaneWaveSolution(int dimension, const Material& material);
  Eigen::Vector3d value(const Point& x) const;
  Eigen::Matrix3d gradient(const Point& x) const;
  Eigen::Matrix3d stress(const Point& x) const;
  Eigen::Vector3d bodyForce(const Point& x) const;
  Eigen::Vector3d traction(const Point& x, const Eigen::Vector3d& outwardNormal) const;

private:
  int d_;
  double lambda_, mu_;
  Eigen::Vector3d k_;
};

/// One run of the manufactured-solution study: the unit box with n cells per direction of `type`
/// (BoxMesh), distorted by distortUnitBox(mesh, distortion), Dirichlet data u on the left, bottom
/// (and front) faces and exact tractions sigma(u) n on the others, body force f = -div sigma(u).
struct ManufacturedRun {
  mesh::CellType type;
  int cellsPerDirection = 0;
  double h = 0;            ///< 1 / cellsPerDirection
  long long dofs = 0;
  double relativeL2 = 0;   ///< ||u - u_h|| / ||u||
  double relativeH1 = 0;   ///< |u - u_h|_1 / |u|_1
  double solveSeconds = 0; ///< assembly + solve
};
ManufacturedRun solveManufactured(mesh::CellType type, int cellsPerDirection,
                                  double distortion = 0.08, const Material& material = {100.0, 0.3});

/// Lame's thick-walled cylinder in plane strain (docs/theory.md#b-bar): inner radius a, outer
/// radius b, internal pressure p, outer surface free. With A = p a^2/(b^2 - a^2), B = A b^2:
///   sigma_rr = A - B/r^2,  sigma_tt = A + B/r^2,  u = u_r(r) e_r,  u_r = (1 + nu)/E ((1 - 2 nu) A r + B/r),
/// finite as nu -> 1/2 (the standard test of volumetric locking).
class ThickCylinderSolution {
public:
  ThickCylinderSolution(const Material& material, double innerRadius = 1, double outerRadius = 2,
                        double pressure = 1);
  Eigen::Vector3d value(const Point& x) const;
  Eigen::Matrix3d gradient(const Point& x) const;

private:
  double E_, nu_, A_, B_;
};

/// One run of the locking study: a quarter of the cylinder 1 <= r <= 2 (pressure 1 inside) as the
/// box [1, 2] x [0, pi/2] of n x n cells of `type` mapped by (r, t) -> (r cos t, r sin t) (in 3D
/// extruded to 0 <= z <= 1/4 with max(1, n/4) layers and u_z = 0 on both ends: plane strain),
/// symmetry conditions u . n = 0 on the cut planes. Errors relative to the exact solution.
ManufacturedRun solveThickCylinder(mesh::CellType type, int cellsPerDirection, const Material& material);

/// Smooth interior distortion of the unit box: x_a += amplitude sin(pi x_a) prod_{b != a} sin(pi x_b)
/// (over the first d coordinates). Boundary vertices stay; cells become non-affine.
void distortUnitBox(mesh::Mesh& mesh, double amplitude);

}  // namespace obs
