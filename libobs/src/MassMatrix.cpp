#include "obs/obs/MassMatrix.hpp"

#include <Eigen/Dense>

#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CellValues.hpp"

namespace obs {
namespace {

constexpr int kMassDegree = 4;

/// Calls f(cell, local consistent matrix) for every cell of the mesh.
template <int d, class F>
void forEachCellMass(const mesh::Mesh& mesh, double rho, F&& f) {
  CellValues<d> cv(kMassDegree);
  Eigen::MatrixXd local;
  for (Index c = 0; c < mesh.numCells(); ++c) {
    cv.reinit(mesh, c);
    const int n = cv.numVertices();
    local.setZero(n, n);
    for (int q = 0; q < cv.numPoints(); ++q) {
      const double w = rho * cv.JxW(q);
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) local(i, j) += w * cv.value(q, i) * cv.value(q, j);
    }
    f(c, local);
  }
}

template <class F>
void dispatch(const mesh::Mesh& mesh, double rho, F&& f) {
  if (mesh.dimension() == 2)
    forEachCellMass<2>(mesh, rho, f);
  else if (mesh.dimension() == 3)
    forEachCellMass<3>(mesh, rho, f);
  else
    throw Error("mass matrix: unsupported mesh dimension " + std::to_string(mesh.dimension()));
}

}  // namespace

ScalarSparseMatrix assembleConsistentMass(const mesh::Mesh& mesh, const Material& material) {
  material.validate();
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(static_cast<std::size_t>(mesh.numCells()) * 64);
  dispatch(mesh, material.density, [&](Index c, const Eigen::MatrixXd& local) {
    const auto v = mesh.cellVertices(c);
    for (Eigen::Index i = 0; i < local.rows(); ++i)
      for (Eigen::Index j = 0; j < local.cols(); ++j) triplets.emplace_back(v[i], v[j], local(i, j));
  });
  ScalarSparseMatrix M(mesh.numVertices(), mesh.numVertices());
  M.setFromTriplets(triplets.begin(), triplets.end());
  M.makeCompressed();
  return M;
}

Eigen::VectorXd lumpCellMass(const Eigen::MatrixXd& local, bool* usedHrz) {
  const Eigen::VectorXd rows = local.rowwise().sum();
  if (usedHrz) *usedHrz = false;
  if ((rows.array() > 0).all()) return rows;
  const double total = local.sum(), trace = local.trace();
  if (!(total > 0) || !(local.diagonal().array() > 0).all())
    throw Error("mass lumping: local mass matrix with non-positive total " + std::to_string(total) +
                " or diagonal entry (no positive lumping)");
  if (usedHrz) *usedHrz = true;
  return local.diagonal() * (total / trace);
}

Eigen::VectorXd assembleLumpedMass(const mesh::Mesh& mesh, const Material& material, int* hrzCells) {
  material.validate();
  Eigen::VectorXd m = Eigen::VectorXd::Zero(mesh.numVertices());
  int hrz = 0;
  dispatch(mesh, material.density, [&](Index c, const Eigen::MatrixXd& local) {
    bool used = false;
    const Eigen::VectorXd l = lumpCellMass(local, &used);
    hrz += used;
    const auto v = mesh.cellVertices(c);
    for (Eigen::Index i = 0; i < l.size(); ++i) m[v[i]] += l[i];
  });
  if (hrzCells) *hrzCells = hrz;
  return m;
}

template <int d>
BlockSparseMatrix<d> expandMass(const ScalarSparseMatrix& M, const BlockSparseMatrix<d>& pattern) {
  if (M.rows() != pattern.rows() || M.cols() != pattern.rows())
    throw Error("expandMass: the mass matrix has " + std::to_string(M.rows()) + " rows, the pattern " +
                std::to_string(pattern.rows()));
  BlockSparseMatrix<d> out = pattern;
  out.setZero();
  for (Eigen::Index i = 0; i < M.outerSize(); ++i)
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it) {
      if (it.value() == 0) continue;
      const Index k = out.find(static_cast<Index>(i), static_cast<Index>(it.col()));
      if (k < 0)
        throw Error("expandMass: entry (" + std::to_string(i) + ", " + std::to_string(it.col()) +
                    ") of the mass matrix is not in the block pattern");
      out.blockAt(k).diagonal().setConstant(it.value());
    }
  return out;
}

template <int d>
BlockSparseMatrix<d> expandLumpedMass(const Eigen::VectorXd& m, const BlockSparseMatrix<d>& pattern) {
  if (m.size() != pattern.rows())
    throw Error("expandLumpedMass: " + std::to_string(m.size()) + " masses for " + std::to_string(pattern.rows()) +
                " rows");
  BlockSparseMatrix<d> out = pattern;
  out.setZero();
  for (Index i = 0; i < out.rows(); ++i) {
    const Index k = out.diagonal(i);
    if (k < 0) throw Error("expandLumpedMass: the pattern has no diagonal block in row " + std::to_string(i));
    out.blockAt(k).diagonal().setConstant(m[i]);
  }
  return out;
}

template BlockSparseMatrix<2> expandMass<2>(const ScalarSparseMatrix&, const BlockSparseMatrix<2>&);
template BlockSparseMatrix<3> expandMass<3>(const ScalarSparseMatrix&, const BlockSparseMatrix<3>&);
template BlockSparseMatrix<2> expandLumpedMass<2>(const Eigen::VectorXd&, const BlockSparseMatrix<2>&);
template BlockSparseMatrix<3> expandLumpedMass<3>(const Eigen::VectorXd&, const BlockSparseMatrix<3>&);

}  // namespace obs
