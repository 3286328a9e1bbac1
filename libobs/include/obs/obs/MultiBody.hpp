#pragma once
/// \file MultiBody.hpp
/// Several elastic bodies as one algebraic system (docs/architecture.md#multi-body): the
/// stiffness matrices are stacked block-diagonally, loads and Dirichlet data one after the other, in
/// the order of the bodies; vertex v of body i is stacked vertex offsets[i] + v. Couplings between
/// bodies (MortarCoupling) then act on the stacked numbering through the ContactProblem's
/// constraints and basis transformation, so one body is the one-element case of the same path.
#include <Eigen/Core>

#include <span>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Material.hpp"

namespace obs {

/// The linear elasticity system of one body (or of stacked bodies), Dirichlet values not eliminated.
template <int d>
struct BodySystem {
  BlockSparseMatrix<d> stiffness;
  Eigen::VectorXd load;
  DirichletValues dirichlet;
  Index numVertices() const { return stiffness.rows(); }
};

/// Stiffness, load and Dirichlet data of one body (assembleStiffness, assembleLoad, collectDirichlet).
/// Throws obs::Error on an invalid material or a mesh of another dimension.
template <int d>
BodySystem<d> assembleBody(const mesh::Mesh& mesh, const Material& material, const BoundaryConditions& bc);

/// The stacked system of several bodies assembled at once: bitwise stackBodies() of the
/// assembleBody() of each, but the stiffness blocks are written straight into the stacked matrix
/// (assembleStackedStiffness), so no body's matrix is stored twice. offsets (if given) receives the
/// first stacked vertex of each body; `widen` is assembleStackedStiffness'. With
/// `skipPrescribedBodies`, a body whose Dirichlet data prescribe every component of every vertex gets
/// zero diagonal blocks instead of its stiffness (ContactModel::assembleParts). Throws as
/// assembleBody().
template <int d>
BodySystem<d> assembleBodies(std::span<const mesh::Mesh* const> meshes, std::span<const Material* const> materials,
                             std::span<const BoundaryConditions* const> conditions,
                             std::vector<Index>* offsets = nullptr,
                             const std::function<void(typename BlockSparseMatrix<d>::Pattern&)>& widen = {},
                             bool skipPrescribedBodies = false);

/// Block-diagonal stacking of the bodies' systems; offsets (if given) receives the first stacked
/// vertex of each body. Throws obs::Error on inconsistent sizes. Takes the systems by value: pass
/// them with std::move, and one body is returned without a copy of its matrix.
template <int d>
BodySystem<d> stackBodies(std::vector<BodySystem<d>> bodies, std::vector<Index>* offsets = nullptr);

extern template struct BodySystem<2>;
extern template struct BodySystem<3>;

}  // namespace obs
