#pragma once
/// \file ElasticityAssembly.hpp
/// Element-local kernels and global assembly for linear elasticity with first-order Lagrange
/// elements (vertex-based, d unknowns per vertex, vertex-major numbering u[v*d + c]):
///   a(u, v) = int lambda div u div v + 2 mu eps(u) : eps(v)
///   l(v)    = int f . v + int_{Gamma_N} t . v
/// and the symmetric elimination of Dirichlet values.
#include <Eigen/Core>

#include <functional>
#include <span>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Material.hpp"

namespace obs {

/// Stiffness matrix on the mesh's vertex-adjacency pattern, filled by row ranges
/// (BlockSparseMatrix::fromRowRanges): its repeated blocks are stored once (shared()) where at most
/// a quarter of the blocks are distinct, as on grids of translated cells. Read it through a const
/// reference; a non-const accessor returns it to one block per entry.
template <int d>
BlockSparseMatrix<d> assembleStiffness(const mesh::Mesh& mesh, const Material& material);

/// The stiffness matrices of several meshes stacked block-diagonally (mesh i's vertex v is row
/// n_0 + ... + n_{i-1} + v), each block bitwise that of assembleStiffness(*meshes[i], *materials[i]),
/// assembled straight into the stacked matrix (no per-mesh matrix and no copy: the bodies of a
/// multi-body problem cost what they cost alone, docs/performance.md#multi-body-assembly).
/// assembleStiffness() is the case of one mesh. `widen` (if set) may add columns to the stacked
/// pattern before the blocks are written (they stay zero there): the fill-in of a later
/// transformation in place (ContactProblem::transformedPattern). A mesh with skip[i] != 0 (skip
/// empty: none) gets zero diagonal blocks and nothing else, and its cells are not visited (a body
/// prescribed everywhere, whose rows are Dirichlet rows). Throws obs::Error on a mesh of another
/// dimension, a degenerate cell, or as many materials (or skip flags) as meshes missing.
template <int d>
BlockSparseMatrix<d> assembleStackedStiffness(
    std::span<const mesh::Mesh* const> meshes, std::span<const Material* const> materials,
    const std::function<void(typename BlockSparseMatrix<d>::Pattern&)>& widen = {}, std::span<const char> skip = {});

/// Load vector from the body force and the Neumann conditions of `bc` (Dirichlet data ignored).
template <int d>
Eigen::VectorXd assembleLoad(const mesh::Mesh& mesh, const BoundaryConditions& bc);

/// Prescribed components: constrained[v*d + c] != 0 where a Dirichlet condition fixes component c
/// at vertex v (the vertices of the boundary faces with the condition's id), with values.
/// When conditions overlap, later ones in the list win.
struct DirichletValues {
  std::vector<char> constrained;
  Eigen::VectorXd values;
  long long count() const;
};
DirichletValues collectDirichlet(const mesh::Mesh& mesh, const std::vector<DirichletCondition>& dirichlet);

/// Symmetric elimination: b -= A g on free rows, constrained rows and columns of A replaced by
/// the identity and b = g there. The solution of the modified system satisfies the Dirichlet
/// values exactly and the matrix stays symmetric positive definite.
template <int d>
void applyDirichlet(BlockSparseMatrix<d>& A, Eigen::VectorXd& b, const DirichletValues& g);

}  // namespace obs
