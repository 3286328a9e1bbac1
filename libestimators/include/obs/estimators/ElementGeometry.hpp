#pragma once
/// \file ElementGeometry.hpp
/// Geometry needed by residual-type estimators (thesis Sec. 4.1.1, docs/theory.md#patches):
///  - PointValues: shape functions, physical gradients and physical second derivatives at any
///    reference point of a cell (also on its faces, where CellValues' quadrature does not reach);
///  - cellFaceQuadrature: quadrature points on a face of a cell with the outward normal and the
///    corresponding reference point in the cell, and the matching point in the neighbour cell;
///  - patchDiameters: h_p = diam omega_p.
///
/// Second derivatives. With the multilinear (isoparametric) map x(xi) = sum_i x_i phihat_i(xi),
/// J_ak = dx_a/dxi_k and phi = phihat o x^{-1}, differentiating dphihat/dxi_k = sum_a dphi/dx_a J_ak
/// once more in xi_l gives
///     Hhat_kl = sum_ab (d2phi/dx_a dx_b) J_ak J_bl + sum_m (dphi/dx_m) X^m_kl,
///     X^m_kl = d2x_m/dxi_k dxi_l = sum_i (x_i)_m Hhat^i_kl,
/// hence
///     d2phi/dx2 = J^{-T} ( Hhat - sum_m (dphi/dx_m) X^m ) J^{-1}.
/// This equals the thesis' chain rule with the second derivatives of x^{-1} (Sec. 4.1.1) without
/// forming them. On simplices Hhat = X = 0; on non-affine quadrilaterals, hexahedra, prisms and
/// pyramids both terms matter, and their cancellation makes the Hessian of an interpolated linear
/// field vanish exactly (the patch test of eta_1).
#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs::estimators {

using mesh::Index;
using mesh::Point;

/// Whether the cell map of a cell type is affine (first-order simplices: constant Jacobian,
/// physical gradients and zero second derivatives).
inline bool affineCellType(mesh::CellType type) {
  return type == mesh::CellType::Triangle || type == mesh::CellType::Tetrahedron;
}

/// Shape functions of one cell at one reference point.
///
/// Affine cells (affineCellType): a reinit for the same mesh and cell as the previous one only
/// re-evaluates the values and the point; the Jacobian, the gradients and the Hessians are
/// constant on the cell and kept (the reference gradients of P1 do not depend on xi, so the kept
/// numbers are bitwise those a full re-evaluation would give), and the Hessians are set to zero
/// without the chain rule below. The mesh must not change between two such calls (the estimators
/// use one PointValues per run on a const mesh).
///
/// Non-affine cells without per-basis quantities (reinit with perBasis = false): only the
/// reference gradients and Hessians, J^{-1} and X are kept, and a field u_h = sum_i u_i phi_i is
/// differentiated as a whole (fieldGradient, fieldHessians):
///     grad u_h = (sum_i u_i gradhat_i') J^{-1},
///     d2 u_c / dx2 = J^{-T} ( sum_i u_ic Hhat_i - sum_m (grad u_h)_cm X^m ) J^{-1},
/// the sums over i of the per-basis formulas above, with one d x d product per point (gradient) and
/// per component (Hessian) instead of per basis function. The result agrees with the per-basis sums
/// to round-off, not bitwise. A non-affine cell type whose vertices are an affine image of the
/// reference vertices (flat(): e.g. the boxes of a refined box mesh and the pyramids of their green
/// closure) has an affine map: J is computed at the first point and kept for the cell's following
/// points, X = 0. On affine cells perBasis is ignored (the per-basis quantities are
/// constant and kept, see above), so their numbers are bitwise unchanged.
template <int d>
class PointValues {
public:
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;

  /// Evaluates at reference point xi of cell c; second derivatives only if withHessians.
  /// perBasis = false on a non-affine cell: gradient(i) and hessian(i) are not formed (use
  /// fieldGradient and fieldHessians). Throws obs::Error if the Jacobian determinant is not
  /// positive there.
  void reinit(const mesh::Mesh& m, Index c, const Point& xi, bool withHessians,
              bool perBasis = true) {
    const auto& ref = mesh::referenceElement(m.cellType(c));
    const auto verts = m.cellVertices(c);
    const bool same = affine_ && mesh_ == &m && cell_ == c;
    if (same && (hessiansValid_ || !withHessians)) {
      ref.values(xi, std::span<double>(values_.data(), n_));
      x_.setZero();
      for (int i = 0; i < n_; ++i) {
        const Vec xi_i = m.vertex(verts[i]).template head<d>();
        x_ += values_[i] * xi_i;
      }
      return;
    }
    if (flat_ && !perBasis && mesh_ == &m && cell_ == c) {  // affine map of a non-affine cell type: J, X = 0 kept
      ref.values(xi, std::span<double>(values_.data(), n_));
      ref.gradients(xi, std::span<double>(refGrads_.data(), n_ * d));
      x_.setZero();
      for (int i = 0; i < n_; ++i) x_ += values_[i] * m.vertex(verts[i]).template head<d>();
      if (withHessians) ref.hessians(xi, std::span<double>(refHessians_.data(), n_ * d * d));
      hessiansValid_ = withHessians;
      return;
    }
    mesh_ = &m;
    cell_ = c;
    flat_ = false;
    affine_ = affineCellType(ref.type);
    hessiansValid_ = false;
    n_ = ref.numVertices;
    perBasis_ = perBasis || affine_;
    double* g = refGrads_.data();
    ref.values(xi, std::span<double>(values_.data(), n_));
    ref.gradients(xi, std::span<double>(g, n_ * d));
    J_.setZero();
    x_.setZero();
    for (int i = 0; i < n_; ++i) {
      const Vec xi_i = m.vertex(verts[i]).template head<d>();
      x_ += values_[i] * xi_i;
      J_ += xi_i * Eigen::Map<const Vec>(&g[i * d]).transpose();
    }
    det_ = J_.determinant();
    if (!(det_ > 0))
      throw Error("cell " + std::to_string(c) + " is degenerate or inverted at a reference point: "
                  "Jacobian determinant " + std::to_string(det_));
    Jinv_ = J_.inverse();
    const Mat& Jinv = Jinv_;
    if (!perBasis_) {
      // the vertices an affine image of the reference vertices (a parallelogram, parallelepiped,
      // prism with parallel congruent ends, pyramid with a parallelogram base) up to round-off of
      // the coordinates: the shape functions reproduce linear functions, so x(xi) is that affine
      // map, J is constant and X = 0
      double dev = 0, size = 0, mag = 0;
      const Vec x0 = m.vertex(verts[0]).template head<d>();
      for (int i = 0; i < n_; ++i) {
        const Vec xi_i = m.vertex(verts[i]).template head<d>();
        const Vec r = xi_i - x_ - J_ * (ref.vertices[i] - xi).template head<d>();
        dev = std::max(dev, r.cwiseAbs().maxCoeff());
        size = std::max(size, (xi_i - x0).cwiseAbs().maxCoeff());
        mag = std::max(mag, xi_i.cwiseAbs().maxCoeff());
      }
      flat_ = dev <= 1e-12 * size + 32 * std::numeric_limits<double>::epsilon() * mag;
    }
    if (perBasis_)
      for (int i = 0; i < n_; ++i) grads_[i] = Jinv.transpose() * Eigen::Map<const Vec>(&g[i * d]);
    if (!withHessians) return;
    hessiansValid_ = true;
    if (affine_) {  // Hhat = X = 0: the second derivatives vanish
      for (int i = 0; i < n_; ++i) hessians_[i].setZero();
      return;
    }
    double* h = refHessians_.data();
    ref.hessians(xi, std::span<double>(h, n_ * d * d));
    std::array<Mat, d>& X = X_;  // X^m_kl = d2 x_m / dxi_k dxi_l
    for (int mm = 0; mm < d; ++mm) X[mm].setZero();
    for (int i = 0; i < n_ && !flat_; ++i) {
      const Point& xi_i = m.vertex(verts[i]);
      const Eigen::Map<const Mat> Hi(&h[i * d * d]);  // symmetric, so storage order is irrelevant
      for (int mm = 0; mm < d; ++mm) X[mm] += xi_i[mm] * Hi;
    }
    if (!perBasis_) return;
    for (int i = 0; i < n_; ++i) {
      Mat M = Eigen::Map<const Mat>(&h[i * d * d]);
      for (int mm = 0; mm < d; ++mm) M -= grads_[i][mm] * X[mm];
      hessians_[i] = Jinv.transpose() * M * Jinv;
    }
  }

  /// Whether gradient(i) and hessian(i) were formed by the last reinit (always on affine cells).
  bool perBasis() const { return perBasis_; }
  /// Whether the last reinit (perBasis = false) found the map of its non-affine cell affine; then
  /// the following reinits on the same cell keep J, its determinant and inverse, and X = 0.
  bool flat() const { return flat_; }

  /// grad u_h = sum_i u_i grad phi_i' (G_ca = du_c / dx_a) of the field with nodal values
  /// u[verts[i] * d + c]: the per-basis sum if perBasis(), else (sum_i u_i gradhat_i') J^{-1}.
  Mat fieldGradient(const Eigen::VectorXd& u, std::span<const Index> verts) const {
    Mat G = Mat::Zero();
    if (perBasis_) {
      for (int i = 0; i < n_; ++i)
        G += u.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d) * grads_[i].transpose();
      return G;
    }
    // plain arrays: the accumulator stays in registers (a 3 x 3 Eigen accumulator was spilled
    // to the stack with overlapping partial stores and reloads)
    double Gh[d * d] = {};
    for (int i = 0; i < n_; ++i) {
      const double* ui = u.data() + static_cast<Eigen::Index>(verts[i]) * d;
      const double* gi = &refGrads_[i * d];
      for (int c = 0; c < d; ++c)
        for (int k = 0; k < d; ++k) Gh[c * d + k] += ui[c] * gi[k];
    }
    return Eigen::Map<const Eigen::Matrix<double, d, d, Eigen::RowMajor>>(Gh) * Jinv_;
  }

  /// H[c] = d2 u_c / dx2 of the same field (valid after reinit with withHessians): the per-basis
  /// sum sum_i u_ic hessian(i) if perBasis(), else the whole-field formula (class comment).
  void fieldHessians(const Eigen::VectorXd& u, std::span<const Index> verts,
                     std::array<Mat, d>& H) const {
    for (int c = 0; c < d; ++c) H[c].setZero();
    if (perBasis_) {
      for (int i = 0; i < n_; ++i)
        for (int c = 0; c < d; ++c)
          H[c] += u[static_cast<Eigen::Index>(verts[i]) * d + c] * hessians_[i];
      return;
    }
    double Uh[d * d * d] = {};  // sum_i u_ic Hhat_i, [c * d * d + kl] (plain arrays, see above)
    for (int i = 0; i < n_; ++i) {
      const double* ui = u.data() + static_cast<Eigen::Index>(verts[i]) * d;
      const double* hi = &refHessians_[i * d * d];
      for (int c = 0; c < d; ++c)
        for (int kl = 0; kl < d * d; ++kl) Uh[c * d * d + kl] += ui[c] * hi[kl];
    }
    for (int c = 0; c < d; ++c) H[c] = Eigen::Map<const Mat>(&Uh[c * d * d]);
    if (!flat_) {
      const Mat G = fieldGradient(u, verts);
      for (int c = 0; c < d; ++c)
        for (int mm = 0; mm < d; ++mm) H[c] -= G(c, mm) * X_[mm];
    }
    for (int c = 0; c < d; ++c) H[c] = Jinv_.transpose() * H[c] * Jinv_;
  }

  /// Laplace u_c = tr(d2 u_c / dx2) and (grad div u)_a = sum_b d2 u_b / dx_a dx_b of the same
  /// field (valid after reinit with withHessians), what div sigma needs. Without perBasis() from the
  /// reference matrices M_c = sum_i u_ic Hhat_i - sum_m (grad u_h)_cm X^m with
  /// tr(J^{-T} M_c J^{-1}) = <M_c, J^{-1} J^{-T}> and sum_b (J^{-T} M_b J^{-1})_ab =
  /// (J^{-T} sum_b M_b J^{-1} e_b)_a: O(d^3) per point, no product per basis function or component.
  void fieldLaplacianGradDiv(const Eigen::VectorXd& u, std::span<const Index> verts, Vec& laplacian,
                             Vec& gradDiv) const {
    if (perBasis_) {
      std::array<Mat, d> H;
      fieldHessians(u, verts, H);
      for (int a = 0; a < d; ++a) {
        laplacian[a] = H[a].trace();
        gradDiv[a] = 0;
        for (int b = 0; b < d; ++b) gradDiv[a] += H[b](a, b);
      }
      return;
    }
    double M[d * d * d] = {};  // M_c, [c * d * d + k * d + l] (plain arrays, see fieldGradient)
    for (int i = 0; i < n_; ++i) {
      const double* ui = u.data() + static_cast<Eigen::Index>(verts[i]) * d;
      const double* hi = &refHessians_[i * d * d];
      for (int c = 0; c < d; ++c)
        for (int kl = 0; kl < d * d; ++kl) M[c * d * d + kl] += ui[c] * hi[kl];
    }
    if (!flat_) {
      const Mat G = fieldGradient(u, verts);
      for (int c = 0; c < d; ++c)
        for (int mm = 0; mm < d; ++mm) {
          const double* Xm = X_[mm].data();
          for (int kl = 0; kl < d * d; ++kl) M[c * d * d + kl] -= G(c, mm) * Xm[kl];
        }
    }
    const Mat K = Jinv_ * Jinv_.transpose();
    double w[d] = {};
    for (int c = 0; c < d; ++c) {
      double tr = 0;
      for (int k = 0; k < d; ++k)
        for (int l = 0; l < d; ++l) {
          const double mkl = M[c * d * d + k * d + l];  // symmetric: the storage order is irrelevant
          tr += mkl * K(k, l);
          w[k] += mkl * Jinv_(l, c);
        }
      laplacian[c] = tr;
    }
    gradDiv = Jinv_.transpose() * Eigen::Map<const Vec>(w);
  }

  /// Whether the cell of the last reinit is affine (everything but values() and point() is
  /// constant on it).
  bool affine() const { return affine_; }

  int numVertices() const { return n_; }
  double value(int i) const { return values_[i]; }
  const Vec& gradient(int i) const { return grads_[i]; }
  /// d2phi_i / dx_a dx_b (valid after reinit with withHessians).
  const Mat& hessian(int i) const { return hessians_[i]; }
  const Vec& point() const { return x_; }
  const Mat& jacobian() const { return J_; }
  double determinant() const { return det_; }

private:
  int n_ = 0;
  std::array<double, 8> values_{};
  std::array<Vec, 8> grads_;
  std::array<Mat, 8> hessians_;
  std::array<double, 8 * d> refGrads_{};         ///< reference gradients, [i * d + k]
  std::array<double, 8 * d * d> refHessians_{};  ///< reference Hessians (non-affine cells)
  std::array<Mat, d> X_;                         ///< X^m = d2 x_m / dxi2 (non-affine cells)
  Vec x_;
  Mat J_, Jinv_;
  double det_ = 0;
  const mesh::Mesh* mesh_ = nullptr;  ///< mesh and cell of the last reinit (cache of affine cells)
  Index cell_ = -1;
  bool affine_ = false, hessiansValid_ = false, perBasis_ = true, flat_ = false;
};

/// A quadrature point on a face of a cell.
struct CellFacePoint {
  Point xi;        ///< reference coordinates in the cell
  Point x;         ///< physical point
  double weight;   ///< surface quadrature weight (length / area element included)
  Point normal;    ///< outward unit normal of the cell (z = 0 in 2D)
  std::array<double, 4> shape{};  ///< face shape functions at the point, face vertex order
};

/// Global vertex numbers of local face `localFace` of `cell`, in outward orientation
/// (MeshTopology localFaces()).
std::vector<Index> cellFaceVertices(const mesh::Mesh& mesh, Index cell, int localFace);
/// The same into `out` (its storage reused: no allocation in loops over faces).
void cellFaceVertices(const mesh::Mesh& mesh, Index cell, int localFace, std::vector<Index>& out);

/// Quadrature of exactness `degree` on local face `localFace` of `cell` (face shape functions
/// are those of the face's reference element with the face vertices in cellFaceVertices() order;
/// on every cell type the trace of the cell map is that face map). Throws obs::Error on a
/// degenerate face.
std::vector<CellFacePoint> cellFaceQuadrature(const mesh::Mesh& mesh, Index cell, int localFace,
                                              int degree);
/// The same into `out` (its storage reused).
void cellFaceQuadrature(const mesh::Mesh& mesh, Index cell, int localFace, int degree,
                        std::vector<CellFacePoint>& out);

/// The weights and the outward unit normal of cellFaceQuadrature() (bitwise the same numbers)
/// without the points, on a flat face (a segment or a triangle: the normal is constant); returns
/// false and computes nothing on other faces.
bool flatCellFaceQuadrature(const mesh::Mesh& mesh, Index cell, int localFace, int degree,
                            std::vector<double>& weights, Point& normal);

/// Reference coordinates in `cell` of the face point sum_j shape[j] x(faceVertices[j]), where all
/// faceVertices are vertices of `cell` (the matching point on the neighbour's side of a face:
/// the reference face map is the same multilinear map in any vertex order). Throws obs::Error if a
/// face vertex is not a vertex of the cell.
Point referencePointOnFace(const mesh::Mesh& mesh, Index cell, std::span<const Index> faceVertices,
                           std::span<const double> shape);

/// h_p = diam omega_p for every vertex p: the largest distance between two vertices of the cells
/// containing p (exact: first-order cells lie in the convex hull of their vertices). Vertices in
/// no cell get 0.
std::vector<double> patchDiameters(const mesh::Mesh& mesh);

}  // namespace obs::estimators
