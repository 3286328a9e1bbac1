#pragma once
/// \file LinearElasticity.hpp
/// Solve the linear-elastic problem  -div sigma(u) = f, u = u_D on Gamma_D, sigma n = t on Gamma_N
/// with first-order Lagrange elements on any mesh of the six cell types: assemble, eliminate the
/// Dirichlet values symmetrically, factorise with CHOLMOD, and recover stresses.
#include <Eigen/Core>

#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Material.hpp"

namespace obs {

/// Symmetric stress tensors are stored as full 3x3 matrices; in 2D (plane strain) sigma_zz =
/// lambda (eps_xx + eps_yy) is filled in, the other z entries are zero.
using Stress = Eigen::Matrix3d;

struct ElasticitySolution {
  int dimension = 2;
  /// Nodal displacements, vertex-major: u[v*dim + c].
  Eigen::VectorXd displacement;
  /// Stress averaged over each cell (volume mean of sigma(u_h)).
  std::vector<Stress> cellStress;
  /// Stress recovered at vertices: volume-weighted mean of the cell means around each vertex.
  std::vector<Stress> vertexStress;

  // figures of the run
  long long dofs = 0;             ///< unknowns including Dirichlet ones (numVertices * dim)
  long long freeDofs = 0;         ///< unknowns not prescribed
  double assemblySeconds = 0;     ///< matrix and load assembly
  double solveSeconds = 0;        ///< CHOLMOD analyse + factorise + solve
  long long factorNonZeros = 0;   ///< entries of the Cholesky factor
};

ElasticitySolution solveLinearElasticity(const mesh::Mesh& mesh, const Material& material,
                                         const BoundaryConditions& bc);

/// Fills solution.cellStress and solution.vertexStress from solution.displacement (cell means of
/// sigma(u_h) and their volume-weighted vertex averages, as solveLinearElasticity does), e.g. for a
/// displacement computed by a contact solver.
void recoverStresses(const mesh::Mesh& mesh, const Material& material, ElasticitySolution& solution);

/// von Mises equivalent stress of a (3x3) stress tensor.
double vonMises(const Stress& s);

}  // namespace obs
