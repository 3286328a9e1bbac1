#pragma once
/// \file BoundaryConditions.hpp
/// Boundary data of a linear-elastic problem, addressed by boundary id of the mesh.
#include <array>
#include <functional>
#include <vector>

#include "obs/mesh/Mesh.hpp"

namespace obs {

using mesh::Index;
using mesh::Point;
/// A vector field of the position (components beyond the dimension are ignored).
using VectorField = std::function<Eigen::Vector3d(const Point&)>;
/// A scalar field of the position.
using ScalarField = std::function<double(const Point&)>;

/// Prescribed displacement components on the faces with `boundaryId` (and their vertices), or with
/// `everywhere` at every vertex of the mesh, interior ones included (a rigid or driven body: a meshed
/// obstacle that takes part in mortar contact; boundaryId is then ignored). Only components with
/// fixed[c] are prescribed: a clamp fixes all, a roller or symmetry plane one.
struct DirichletCondition {
  int boundaryId = 0;
  std::array<bool, 3> fixed{true, true, true};
  VectorField value = [](const Point&) { return Eigen::Vector3d::Zero(); };
  bool everywhere = false;
};

/// Surface load on the faces with `boundaryId`: a traction vector t(x), or a pressure p(x) acting
/// against the outward normal (t = -p n).
struct NeumannCondition {
  int boundaryId = 0;
  VectorField traction;  ///< used when set
  ScalarField pressure;  ///< used when set (traction unset)
};

struct BoundaryConditions {
  std::vector<DirichletCondition> dirichlet;
  std::vector<NeumannCondition> neumann;
  VectorField bodyForce;  ///< volume load f(x); unset means zero
};

/// Number of rigid motions (of d(d+1)/2) that the Dirichlet conditions leave free: the rank
/// deficiency of the rigid-motion basis restricted to the prescribed components. 0 means the
/// elasticity problem has a unique solution.
int countFreeRigidMotions(const mesh::Mesh& mesh, const std::vector<DirichletCondition>& dirichlet);

}  // namespace obs
