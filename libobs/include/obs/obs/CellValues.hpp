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
  explicit CellValues(int degree) : degree_(degree) {}

  /// Evaluates everything on cell c. Throws obs::Error on a degenerate or inverted cell.
  void reinit(const mesh::Mesh& m, mesh::Index c) {
    const mesh::CellType t = m.cellType(c);
    const auto& ref = mesh::referenceElement(t);
    const auto& rule = mesh::quadratureRule(t, degree_);
    const auto verts = m.cellVertices(c);
    n_ = ref.numVertices;
    nq_ = static_cast<int>(rule.size());
    values_.resize(static_cast<std::size_t>(nq_) * n_);
    grads_.resize(static_cast<std::size_t>(nq_) * n_);
    points_.resize(nq_);
    jxw_.resize(nq_);
    double refGrad[8 * 3];
    for (int q = 0; q < nq_; ++q) {
      ref.values(rule.points[q], std::span<double>(&values_[q * n_], n_));
      ref.gradients(rule.points[q], std::span<double>(refGrad, n_ * d));
      Mat J = Mat::Zero();
      Vec x = Vec::Zero();
      for (int i = 0; i < n_; ++i) {
        const Vec xi = m.vertex(verts[i]).template head<d>();
        x += values_[q * n_ + i] * xi;
        for (int k = 0; k < d; ++k) J.col(k) += refGrad[i * d + k] * xi;
      }
      const double det = J.determinant();
      if (!(det > 0))
        throw Error("cell " + std::to_string(c) + " (" + std::string(mesh::name(t)) +
                    ") is degenerate or inverted: Jacobian determinant " + std::to_string(det));
      const Mat Jinv = J.inverse();
      points_[q] = x;
      jxw_[q] = det * rule.weights[q];
      for (int i = 0; i < n_; ++i)
        grads_[q * n_ + i] = Jinv.transpose() * Eigen::Map<const Vec>(&refGrad[i * d]);
    }
  }

  int numVertices() const { return n_; }
  int numPoints() const { return nq_; }
  double value(int q, int i) const { return values_[q * n_ + i]; }
  const Vec& gradient(int q, int i) const { return grads_[q * n_ + i]; }
  const Vec& point(int q) const { return points_[q]; }
  double JxW(int q) const { return jxw_[q]; }

private:
  int degree_;
  int n_ = 0, nq_ = 0;
  std::vector<double> values_;
  std::vector<Vec> grads_;
  std::vector<Vec> points_;
  std::vector<double> jxw_;
};

}  // namespace obs
