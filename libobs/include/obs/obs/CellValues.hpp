#pragma once
/// \file CellValues.hpp
/// Shape function values and physical gradients at the quadrature points of one cell (in the spirit
/// of deal.II's FEValues): reference tables from ReferenceElement + the multilinear geometry map
/// x(xi) = sum_i x_i phi_i(xi)  ->  J = dx/dxi,  grad phi = J^{-T} grad_xi phi,  JxW = |det J| w.
#include <Eigen/Dense>

#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs {

template <int d>
class CellValues {
public:
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;

  /// Quadrature of exactness `degree` on every cell passed to reinit().
  explicit CellValues(int degree) : degree_(degree) {
    for (Vec& r : rel_) r.setZero();
  }

  /// Evaluates everything on cell c. Throws obs::Error on a degenerate or inverted cell.
  /// The geometry enters only through the vertices relative to the cell's first vertex,
  /// x(xi) = x_0 + sum_i phi_i(xi) (x_i - x_0) (the same map: sum_i phi_i = 1), so the gradients and
  /// JxW of two cells whose vertices are translates of each other (the same type and bitwise the same
  /// differences x_i - x_0) are bitwise equal. For such a cell, following the previous one, only the
  /// points are moved, and reinit returns true (docs/performance.md#assembly); false if it computed.
  bool reinit(const mesh::Mesh& m, mesh::Index c) {
    const mesh::CellType t = m.cellType(c);
    const auto verts = m.cellVertices(c);
    const Vec x0 = m.vertex(verts[0]).template head<d>();
    bool translate = t == type_ && valid_;
    if (t != type_) tabulate(t);
    for (int i = 1; i < n_; ++i) {
      const Vec r = m.vertex(verts[i]).template head<d>() - x0;
      translate = translate && r == rel_[i];
      rel_[i] = r;
    }
    if (translate) {
      for (int q = 0; q < nq_; ++q) points_[q] = x0 + relPoints_[q];
      return true;
    }
    valid_ = false;  // until the cell is complete (reinit may throw)
    for (int q = 0; q < nq_; ++q) {
      const double* refGrad = &refGrads_[static_cast<std::size_t>(q) * n_ * d];
      Mat J = Mat::Zero();
      Vec x = Vec::Zero();
      for (int i = 1; i < n_; ++i) {
        x += values_[q * n_ + i] * rel_[i];
        for (int k = 0; k < d; ++k) J.col(k) += refGrad[i * d + k] * rel_[i];
      }
      const double det = J.determinant();
      if (!(det > 0))
        throw Error("cell " + std::to_string(c) + " (" + std::string(mesh::name(t)) +
                    ") is degenerate or inverted: Jacobian determinant " + std::to_string(det));
      const Mat Jinv = J.inverse();
      relPoints_[q] = x;
      points_[q] = x0 + x;
      jxw_[q] = det * weights_[q];
      for (int i = 0; i < n_; ++i)
        grads_[q * n_ + i] = Jinv.transpose() * Eigen::Map<const Vec>(&refGrad[i * d]);
    }
    valid_ = true;
    return false;
  }

  int numVertices() const { return n_; }
  int numPoints() const { return nq_; }
  double value(int q, int i) const { return values_[q * n_ + i]; }
  const Vec& gradient(int q, int i) const { return grads_[q * n_ + i]; }
  const Vec& point(int q) const { return points_[q]; }
  double JxW(int q) const { return jxw_[q]; }

private:
  /// The reference tables of cell type t (values and reference gradients at the points of the rule),
  /// computed when the type changes from one reinit to the next.
  void tabulate(mesh::CellType t) {
    const auto& ref = mesh::referenceElement(t);
    const auto& rule = mesh::quadratureRule(t, degree_);
    n_ = ref.numVertices;
    nq_ = static_cast<int>(rule.size());
    values_.resize(static_cast<std::size_t>(nq_) * n_);
    refGrads_.resize(static_cast<std::size_t>(nq_) * n_ * d);
    grads_.resize(static_cast<std::size_t>(nq_) * n_);
    points_.resize(nq_);
    relPoints_.resize(nq_);
    jxw_.resize(nq_);
    weights_.assign(rule.weights.begin(), rule.weights.end());
    for (int q = 0; q < nq_; ++q) {
      ref.values(rule.points[q], std::span<double>(&values_[q * n_], n_));
      ref.gradients(rule.points[q], std::span<double>(&refGrads_[static_cast<std::size_t>(q) * n_ * d], n_ * d));
    }
    type_ = t;
    valid_ = false;
  }

  int degree_;
  mesh::CellType type_ = static_cast<mesh::CellType>(0xff);  // the type tabulated (none yet)
  int n_ = 0, nq_ = 0;
  bool valid_ = false;  // the values are those of a complete cell of type_ with vertices x_0 + rel_
  Vec rel_[8];
  std::vector<double> refGrads_, weights_;
  std::vector<Vec> relPoints_;
  std::vector<double> values_;
  std::vector<Vec> grads_;
  std::vector<Vec> points_;
  std::vector<double> jxw_;
};

}  // namespace obs
