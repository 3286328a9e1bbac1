#include "obs/obs/BoundaryConditions.hpp"

#include <Eigen/Eigenvalues>

#include "obs/obs/ElasticityAssembly.hpp"

namespace obs {

int countFreeRigidMotions(const mesh::Mesh& mesh, const std::vector<DirichletCondition>& dirichlet) {
  const int d = mesh.dimension();
  const int modes = d == 2 ? 3 : 6;
  const DirichletValues g = collectDirichlet(mesh, dirichlet);
  // Centre and scale coordinates so that translations and rotations are equally weighted.
  Point lo = Point::Constant(1e300), hi = Point::Constant(-1e300);
  for (const Point& x : mesh.vertices()) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  const Point centre = 0.5 * (lo + hi);
  const double scale = std::max((hi - lo).maxCoeff(), 1e-300);
  // Gram matrix R'R of the rigid-motion basis evaluated at the prescribed components.
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(modes, modes);
  Eigen::VectorXd r(modes);
  for (Index v = 0; v < mesh.numVertices(); ++v) {
    const Point x = (mesh.vertex(v) - centre) / scale;
    for (int c = 0; c < d; ++c) {
      if (!g.constrained[static_cast<std::size_t>(v) * d + c]) continue;
      r.setZero();
      r[c] = 1;  // translation in direction c
      if (d == 2) {
        r[2] = c == 0 ? -x[1] : x[0];  // rotation (-y, x)
      } else {
        // rotations omega_k e_k x x, component c
        const Eigen::Vector3d e0 = Eigen::Vector3d::UnitX().cross(x);
        const Eigen::Vector3d e1 = Eigen::Vector3d::UnitY().cross(x);
        const Eigen::Vector3d e2 = Eigen::Vector3d::UnitZ().cross(x);
        r[3] = e0[c];
        r[4] = e1[c];
        r[5] = e2[c];
      }
      G.noalias() += r * r.transpose();
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(G);
  const double top = std::max(eig.eigenvalues().maxCoeff(), 1.0);
  int free = 0;
  for (int k = 0; k < modes; ++k)
    if (eig.eigenvalues()[k] <= 1e-10 * top) ++free;
  return free;
}

}  // namespace obs
