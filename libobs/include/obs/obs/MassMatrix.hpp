#pragma once
/// \file MassMatrix.hpp
/// Mass matrices of the first-order Lagrange spaces on all six element types (docs/theory.md#newmark):
///   consistent  M_ij = rho int phi_i phi_j  (scalar; the vector-valued mass matrix is M (x) I_d),
///   lumped      m_i  = sum_j M_ij = rho int phi_i  (row sum, per cell),
/// with a fallback for cells whose local row sums are not all positive (HRZ, Hinton-Rock-Zienkiewicz:
/// the diagonal of the local consistent matrix scaled to the cell's mass, m_i = M_ii rho|T| / sum_k M_kk).
/// All obs elements have non-negative shape functions (P1, Q1, P1xQ1 and the rational pyramid
/// element), so int phi_i > 0 and the row sum is used on every cell; the fallback guards the rule for
/// element types with sign-changing basis functions.
/// Integration: quadrature of degree 4 (exact for phi_i phi_j det J on affine cells of every type,
/// including the rational pyramid in collapsed coordinates; see Quadrature.hpp).
#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/BlockSparseMatrix.hpp"
#include "obs/obs/Material.hpp"

namespace obs {

/// Scalar sparse matrix in compressed rows (one row per vertex).
using ScalarSparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// Consistent scalar mass matrix M_ij = rho int phi_i phi_j on the vertex-adjacency pattern of the
/// mesh (every pair of vertices sharing a cell, the pattern of BlockSparseMatrix::withMeshPattern).
/// Throws obs::Error for an invalid material (Material::validate) or a degenerate cell.
ScalarSparseMatrix assembleConsistentMass(const mesh::Mesh& mesh, const Material& material);

/// Lumped mass per vertex: cell-wise row sums of the consistent matrix, HRZ on cells with a
/// non-positive row sum (file comment). `hrzCells` (optional) receives the number of such cells.
Eigen::VectorXd assembleLumpedMass(const mesh::Mesh& mesh, const Material& material, int* hrzCells = nullptr);

/// The lumping rule of one cell: row sums of the local consistent matrix, or the HRZ diagonal
/// scaling if a row sum is <= 0 (sets *usedHrz). Throws obs::Error if the local matrix has a
/// non-positive diagonal entry or total (no positive lumping exists).
Eigen::VectorXd lumpCellMass(const Eigen::MatrixXd& local, bool* usedHrz = nullptr);

/// The vector-valued form M (x) I_d: blocks M_ij I_d on the pattern of `pattern` (which must
/// contain the pattern of M). Returns a matrix with the pattern of `pattern`.
template <int d>
BlockSparseMatrix<d> expandMass(const ScalarSparseMatrix& M, const BlockSparseMatrix<d>& pattern);

/// Diagonal lumped mass as a block matrix on `pattern`: diagonal blocks m_i I_d, zero elsewhere.
template <int d>
BlockSparseMatrix<d> expandLumpedMass(const Eigen::VectorXd& m, const BlockSparseMatrix<d>& pattern);

extern template BlockSparseMatrix<2> expandMass<2>(const ScalarSparseMatrix&, const BlockSparseMatrix<2>&);
extern template BlockSparseMatrix<3> expandMass<3>(const ScalarSparseMatrix&, const BlockSparseMatrix<3>&);
extern template BlockSparseMatrix<2> expandLumpedMass<2>(const Eigen::VectorXd&, const BlockSparseMatrix<2>&);
extern template BlockSparseMatrix<3> expandLumpedMass<3>(const Eigen::VectorXd&, const BlockSparseMatrix<3>&);

}  // namespace obs
