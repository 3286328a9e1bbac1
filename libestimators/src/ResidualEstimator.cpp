#include "obs/estimators/ResidualEstimator.hpp"

#include <algorithm>
#include <cstdint>
#include <exception>
#include <map>
#include <set>
#include <string>
#include <unordered_map>

#include "obs/estimators/ElementGeometry.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/obs/ContactSet.hpp"
#include "ForEachIndex.hpp"

namespace obs::estimators {
namespace {

constexpr int kNoBoundaryId = -2147483647;

/// sigma(u_h) and div sigma(u_h) at one point of one cell.
template <int d>
struct LocalField {
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;

  /// sigma = lambda tr(G) I + mu (G + G'), G = grad u_h = sum_i u_i grad phi_i'
  /// (PointValues::fieldGradient: the per-basis sum on affine cells, one product with J^{-1} on
  /// the others).
  static Mat stress(const PointValues<d>& pv, const Eigen::VectorXd& u, std::span<const Index> verts,
                    double lambda, double mu) {
    return stressOf(pv.fieldGradient(u, verts), lambda, mu);
  }
  /// sigma of the displacement gradient G
  static Mat stressOf(const Mat& G, double lambda, double mu) {
    return lambda * G.trace() * Mat::Identity() + mu * (G + G.transpose());
  }
  /// div sigma = mu Laplace u + (lambda + mu) grad div u = sum_i (mu tr(H_i) u_i + (lambda+mu) H_i u_i)
  /// with the per-basis Hessians H_i (affine cells); on the others from Laplace u and grad div u
  /// of the whole field (PointValues::fieldLaplacianGradDiv).
  static Vec divergence(const PointValues<d>& pv, const Eigen::VectorXd& u,
                        std::span<const Index> verts, double lambda, double mu) {
    Vec r = Vec::Zero();
    if (!pv.perBasis()) {
      Vec laplacian, gradDiv;
      pv.fieldLaplacianGradDiv(u, verts, laplacian, gradDiv);
      return mu * laplacian + (lambda + mu) * gradDiv;
    }
    for (int i = 0; i < pv.numVertices(); ++i) {
      const Vec ui = u.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d);
      r += mu * pv.hessian(i).trace() * ui + (lambda + mu) * pv.hessian(i) * ui;
    }
    return r;
  }
};

Point toPoint(const auto& x) {
  Point p = Point::Zero();
  p.head(x.size()) = x;
  return p;
}

/// Boundary data by id: Dirichlet-fixed components and Neumann conditions.
struct BoundaryData {
  std::map<int, std::array<bool, 3>> fixed;
  std::map<int, std::vector<const NeumannCondition*>> neumann;
  std::set<int> contact;

  std::array<bool, 3> fixedComponents(int id) const {
    const auto it = fixed.find(id);
    return it == fixed.end() ? std::array<bool, 3>{false, false, false} : it->second;
  }
};

BoundaryData boundaryData(const EstimatorInput& in) {
  BoundaryData b;
  for (const DirichletCondition& dc : in.boundaryConditions.dirichlet) {
    if (dc.everywhere) continue;  // no boundary faces of its own
    auto& f = b.fixed.try_emplace(dc.boundaryId, std::array<bool, 3>{false, false, false}).first->second;
    for (int c = 0; c < 3; ++c) f[c] = f[c] || dc.fixed[c];
  }
  for (const NeumannCondition& nc : in.boundaryConditions.neumann)
    if (nc.traction || nc.pressure) b.neumann[nc.boundaryId].push_back(&nc);
  for (int id : contactBoundaryIds(in)) b.contact.insert(id);
  return b;
}

/// A degree at which quadrature integrates |div sigma_h|^2 exactly on a flat (affine) non-simplex
/// cell (at most `requested`, the options' degree). The physical Hessians are J^-T Hhat J^-1 with the
/// reference Hessians Hhat of the shape functions (docs/estimators.md#flat-cell-quadrature):
///  - quadrilaterals and prisms: Hhat is constant, so one point is exact (degree 0);
///  - hexahedra: every entry of Hhat is linear in one coordinate, so |div sigma_h|^2 has degree 2 in
///    each coordinate (2 x 2 x 2 Gauss points);
///  - pyramids: with q = x y / (1 - z), Hhat = M(u, v) / (1 - z) in the collapsed coordinates u =
///    x / (1 - z), v = y / (1 - z), M of degree 1 in u and in v; the volume element (1 - z)^2 du dv dz
///    cancels the 1 / (1 - z)^2 of |div sigma_h|^2, which leaves a polynomial of degree 2 in u and
///    in v and 0 in z: the pyramid rule of degree 2 (2 x 2 x 3 points) is exact.
int flatResidualDegree(mesh::CellType type, int requested) {
  switch (type) {
    case mesh::CellType::Quadrilateral:
    case mesh::CellType::Prism: return std::min(requested, 0);
    case mesh::CellType::Hexahedron:
    case mesh::CellType::Pyramid: return std::min(requested, 2);
    default: return requested;
  }
}

/// The element residual ||div sigma_h||^2_e of a cell whose map is affine although its type is not
/// (PointValues::flat(): the boxes of a refined box mesh, the pyramids of their green closure with a
/// parallelogram base), by a table: the second derivatives of the map vanish, so at quadrature point
/// q div sigma_h = sum_i B_iq u_i with B_iq = mu <Hhat_iq, K> I + (lambda + mu) J^-T Hhat_iq J^-1,
/// K = J^-1 J^-T, Hhat_iq the reference Hessian of shape function i (the sums of
/// PointValues::fieldLaplacianGradDiv, regrouped by vertex). The table depends on the vertex
/// differences x_i - x_0 only, so the next cell of the loop reuses it if it is a translate of the
/// cell it was built for (bitwise the same differences), as most cells of a refined box are.
template <int d>
class FlatResidualTable {
public:
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;

  /// Whether cell c is a translate of the cell of the last build() (same type and differences).
  bool matches(const mesh::Mesh& m, Index c) const {
    if (!valid_ || m.cellType(c) != type_) return false;
    const auto verts = m.cellVertices(c);
    const Vec x0 = m.vertex(verts[0]).template head<d>();
    for (int i = 1; i < n_; ++i)
      if ((m.vertex(verts[i]).template head<d>() - x0) != diffs_[i]) return false;
    return true;
  }
  void invalidate() { valid_ = false; }

  /// The table of cell c with the constant Jacobian J on the quadrature rule.
  void build(const mesh::Mesh& m, Index c, const Mat& J, const mesh::QuadratureRule& rule, double lambda,
             double mu) {
    type_ = m.cellType(c);
    const auto& ref = mesh::referenceElement(type_);
    const auto verts = m.cellVertices(c);
    n_ = static_cast<int>(verts.size());
    const Vec x0 = m.vertex(verts[0]).template head<d>();
    for (int i = 0; i < n_; ++i) diffs_[i] = m.vertex(verts[i]).template head<d>() - x0;
    const Mat Jinv = J.inverse(), K = Jinv * Jinv.transpose();
    const double det = J.determinant();
    const std::size_t nq = rule.size();
    B_.resize(nq * static_cast<std::size_t>(n_));
    weights_.resize(nq);
    std::array<double, 8 * d * d> h{};
    for (std::size_t q = 0; q < nq; ++q) {
      weights_[q] = det * rule.weights[q];
      ref.hessians(rule.points[q], std::span<double>(h.data(), static_cast<std::size_t>(n_ * d * d)));
      for (int i = 0; i < n_; ++i) {
        const Eigen::Map<const Mat> Hi(&h[static_cast<std::size_t>(i * d * d)]);  // symmetric
        B_[q * static_cast<std::size_t>(n_) + static_cast<std::size_t>(i)] =
            mu * Hi.cwiseProduct(K).sum() * Mat::Identity() + (lambda + mu) * Jinv.transpose() * Hi * Jinv;
      }
    }
    valid_ = true;
  }

  /// sum_q w_q det J |sum_i B_iq u_i|^2 for the nodal values u[verts[i] * d + c].
  double integral(const Eigen::VectorXd& u, std::span<const Index> verts) const {
    std::array<Vec, 8> ui;
    for (int i = 0; i < n_; ++i) ui[i] = u.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d);
    double sum = 0;
    for (std::size_t q = 0; q < weights_.size(); ++q) {
      const Mat* Bq = &B_[q * static_cast<std::size_t>(n_)];
      Vec r = Vec::Zero();
      for (int i = 0; i < n_; ++i) r.noalias() += Bq[i] * ui[i];
      sum += weights_[q] * r.squaredNorm();
    }
    return sum;
  }

private:
  mesh::CellType type_{};
  int n_ = 0;
  bool valid_ = false;
  std::array<Vec, 8> diffs_;
  std::vector<Mat> B_;          ///< [q * n + i]
  std::vector<double> weights_;  ///< w_q det J
};

/// The physical shape gradients of a flat non-simplex cell (PointValues::flat()) at the quadrature
/// points of one of its faces, for the stress jumps of the face loop: grad u_h(x_q) = sum_i u_i
/// G_iq' with G_iq = J^-T gradhat_i(xi_q), J constant. Seen from the cell on side 0 of a face the
/// table also keeps the face quadrature (weights, normals and face shape values, for the points of
/// side 1). A table depends on the cell type, the face (side 0: the local face; side 1: the local
/// numbers of the face vertices) and the vertex differences x_i - x_0, not on the position, so the
/// faces of translated cells share it; FaceTableCache keeps the tables of one thread by these keys.
template <int d>
struct FaceSideTable {
  using Vec = Eigen::Matrix<double, d, 1>;
  bool flat = false;             ///< false: the cell is not flat, evaluate point by point
  int n = 0;                     ///< vertices of the cell
  std::vector<Vec> gradients;    ///< G_iq, [q * n + i]
  std::vector<double> weights;   ///< side 0: surface weights
  std::vector<Vec> normals;      ///< side 0: outward unit normals of the cell on side 0
  std::vector<std::array<double, 4>> shapes;  ///< side 0: face shape values (face vertex order)

  /// grad u_h at point q of the field with nodal values u[verts[i] * d + c] (G_ca = du_c / dx_a).
  Eigen::Matrix<double, d, d> gradient(const Eigen::VectorXd& u, std::span<const Index> verts, std::size_t q) const {
    Eigen::Matrix<double, d, d> G = Eigen::Matrix<double, d, d>::Zero();
    const Vec* g = &gradients[q * static_cast<std::size_t>(n)];
    for (int i = 0; i < n; ++i) G.noalias() += u.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d) * g[i].transpose();
    return G;
  }
};

template <int d>
class FaceTableCache {
public:
  using Table = FaceSideTable<d>;

  /// Called before the tables of a face are asked for (not in between: a table stays valid until
  /// the next call): bounds the memory on meshes with few translates.
  void beginFace() {
    if (tables_.size() > kMaxTables) tables_.clear();
  }

  /// The table of local face `localFace` of cell c on side 0 (built on first use).
  const Table& side0(const mesh::Mesh& m, Index c, int localFace, int degree, PointValues<d>& pv,
                     std::vector<CellFacePoint>& pts) {
    makeKey(m, c, 0, degree, std::span<const int>(&localFace, 1));
    auto [it, inserted] = tables_.try_emplace(key_);
    if (!inserted) return it->second;
    Table& t = it->second;
    cellFaceQuadrature(m, c, localFace, degree, pts);
    std::vector<Point> xi(pts.size());
    for (std::size_t q = 0; q < pts.size(); ++q) {
      xi[q] = pts[q].xi;
      t.weights.push_back(pts[q].weight);
      t.normals.push_back(pts[q].normal.template head<d>());
      t.shapes.push_back(pts[q].shape);
    }
    fill(m, c, xi, pv, t);
    return t;
  }

  /// The table of cell c on side 1 of a face whose vertex j is vertex local1[j] of c, at the
  /// points of side 0 (their face shape values `shapes`, of side 0's rule of that degree).
  const Table& side1(const mesh::Mesh& m, Index c, std::span<const int> local1, int degree,
                     const std::vector<std::array<double, 4>>& shapes, PointValues<d>& pv) {
    makeKey(m, c, 1, degree, local1);
    auto [it, inserted] = tables_.try_emplace(key_);
    if (!inserted) return it->second;
    const auto& ref = mesh::referenceElement(m.cellType(c));
    std::vector<Point> xi(shapes.size(), Point::Zero());
    for (std::size_t q = 0; q < shapes.size(); ++q)
      for (std::size_t j = 0; j < local1.size(); ++j) xi[q] += shapes[q][j] * ref.vertices[local1[j]];
    fill(m, c, xi, pv, it->second);
    return it->second;
  }

private:
  /// key_ = cell type, side, quadrature degree, the face numbers, the vertex differences (raw bytes)
  void makeKey(const mesh::Mesh& m, Index c, char side, int degree, std::span<const int> face) {
    const auto verts = m.cellVertices(c);
    key_.clear();
    key_.push_back(static_cast<char>(m.cellType(c)));
    key_.push_back(side);
    key_.push_back(static_cast<char>(degree));
    for (int f : face) key_.push_back(static_cast<char>(f));
    const Point x0 = m.vertex(verts[0]);
    for (std::size_t i = 1; i < verts.size(); ++i) {
      const Point dx = m.vertex(verts[i]) - x0;
      key_.append(reinterpret_cast<const char*>(dx.data()), sizeof(double) * d);
    }
  }
  static void fill(const mesh::Mesh& m, Index c, const std::vector<Point>& xi, PointValues<d>& pv, Table& t) {
    pv.reinit(m, c, xi[0], false, false);
    t.flat = pv.flat();
    if (!t.flat) return;
    const auto& ref = mesh::referenceElement(m.cellType(c));
    t.n = static_cast<int>(m.cellVertices(c).size());
    const Eigen::Matrix<double, d, d> JinvT = pv.jacobian().inverse().transpose();
    std::array<double, 8 * d> g{};
    t.gradients.resize(xi.size() * static_cast<std::size_t>(t.n));
    for (std::size_t q = 0; q < xi.size(); ++q) {
      ref.gradients(xi[q], std::span<double>(g.data(), static_cast<std::size_t>(t.n * d)));
      for (int i = 0; i < t.n; ++i)
        t.gradients[q * static_cast<std::size_t>(t.n) + static_cast<std::size_t>(i)] =
            JinvT * Eigen::Map<const Eigen::Matrix<double, d, 1>>(&g[static_cast<std::size_t>(i * d)]);
    }
  }

  static constexpr std::size_t kMaxTables = 1 << 14;
  std::unordered_map<std::string, Table> tables_;
  std::string key_;
};

/// The cell terms of eta_1 and what the face loop needs of the cells: r2[c] = ||div sigma_h + f||_c^2,
/// the constant stress of affine cells and whether a non-simplex cell is flat (PointValues::flat()).
/// Evaluated on threads() threads into one slot per cell (bitwise the same for any thread count).
template <int d>
struct CellResiduals {
  std::vector<double> r2;
  std::vector<Eigen::Matrix<double, d, d>> cellStress;
  std::vector<std::uint8_t> flatCell;
};

template <int d>
CellResiduals<d> cellResiduals(const EstimatorInput& in, const ResidualEstimator::Options& options) {
  using Vec = Eigen::Matrix<double, d, 1>;
  using F = LocalField<d>;
  const mesh::Mesh& m = in.mesh;
  const Eigen::VectorXd& u = in.displacement;
  const double lambda = in.material.lambda(), mu = in.material.mu();
  CellResiduals<d> out;
  std::vector<double>& r2 = out.r2;
  r2.resize(static_cast<std::size_t>(m.numCells()));
  std::vector<Eigen::Matrix<double, d, d>>& cellStress = out.cellStress;
  cellStress.resize(static_cast<std::size_t>(m.numCells()));
  std::vector<std::uint8_t>& flatCell = out.flatCell;
  flatCell.assign(static_cast<std::size_t>(m.numCells()), 0);
  // eta_1: element residuals r = div sigma_h + f, weighted with h_p^2 for each vertex p of e
  // sigma_h of the affine cells (constant there), for the face loop: bitwise what an evaluation at
  // any point of the cell gives
  // whether a non-simplex cell is flat (PointValues::flat()): only those get face tables
  struct CellScratch {
    PointValues<d> pv;
    FlatResidualTable<d> table;  // of the last flat cell of this thread
  };
  forEachIndex<CellScratch>(m.numCells(), [&](Index c, CellScratch& scratch) {
    PointValues<d>& pv = scratch.pv;
    const auto& rule = mesh::quadratureRule(m.cellType(c), options.elementDegree);
    const auto verts = m.cellVertices(c);
    double sum = 0;
    // on an affine cell div sigma_h and the determinant are constant: without a body force the
    // point itself is not needed after the first quadrature point
    const bool affine = affineCellType(m.cellType(c));
    if (!affine && !in.boundaryConditions.bodyForce) {  // a flat cell: by the table (a translate's)
      if (!scratch.table.matches(m, c)) {
        scratch.table.invalidate();
        pv.reinit(m, c, rule.points[0], false, false);
        if (pv.flat())
          scratch.table.build(m, c, pv.jacobian(),
                              mesh::quadratureRule(m.cellType(c), flatResidualDegree(m.cellType(c), options.elementDegree)),
                              lambda, mu);
      }
      if (scratch.table.matches(m, c)) {
        r2[static_cast<std::size_t>(c)] = scratch.table.integral(u, verts);
        flatCell[static_cast<std::size_t>(c)] = 1;
        return;
      }
    }
    if (affine && !in.boundaryConditions.bodyForce) {
      // the Hessians of affine shape functions vanish: div sigma_h = 0 and r = 0 (the sum below
      // would add exact zeros); only the cell's constant stress is needed, for the face loop
      pv.reinit(m, c, rule.points[0], false, false);
      r2[static_cast<std::size_t>(c)] = 0;
      cellStress[static_cast<std::size_t>(c)] = F::stress(pv, u, verts, lambda, mu);
      return;
    }
    Vec div = Vec::Zero();
    for (std::size_t q = 0; q < rule.size(); ++q) {
      if (q == 0 || !affine || in.boundaryConditions.bodyForce) pv.reinit(m, c, rule.points[q], true, false);
      if (q == 0 || !affine) div = F::divergence(pv, u, verts, lambda, mu);
      Vec r = div;
      if (in.boundaryConditions.bodyForce)
        r += in.boundaryConditions.bodyForce(toPoint(pv.point())).template head<d>();
      sum += pv.determinant() * rule.weights[q] * r.squaredNorm();
    }
    r2[static_cast<std::size_t>(c)] = sum;
    if (affine) cellStress[static_cast<std::size_t>(c)] = F::stress(pv, u, verts, lambda, mu);
    else flatCell[static_cast<std::size_t>(c)] = pv.flat() ? 1 : 0;
  });
  return out;
}

/// The kinds of the faces of the face table: interior, potential contact (numbered in face order:
/// contactSlot), Neumann (also partly fixed) and fully fixed boundary faces; faceId the boundary id
/// of a one-cell face.
enum class FaceKind : std::uint8_t { Interior, Contact, Neumann, Fixed };
struct FaceClasses {
  std::vector<int> faceId;
  std::vector<FaceKind> kind;
  std::vector<Index> contactSlot;
  Index numContact = 0;
};

FaceClasses classifyFaces(const mesh::Mesh& m, const mesh::FaceTable& faces, const BoundaryData& bd,
                          const std::string& estimator, int d) {
  FaceClasses out;
  // boundary ids of the one-cell faces of the face table
  std::vector<int>& faceId = out.faceId;
  faceId.assign(static_cast<std::size_t>(faces.numFaces()), kNoBoundaryId);
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
    const Index k = faces.find(m.boundaryFaceVertices(f));
    if (k >= 0 && faces.numCells(k) == 1) faceId[k] = m.boundaryFaceId(f);
  }

  // faces: eta_2 (interior jumps), eta_3 (Neumann jumps), contact faces through the hook
  std::vector<FaceKind>& kind = out.kind;
  kind.resize(static_cast<std::size_t>(faces.numFaces()));
  out.contactSlot.assign(static_cast<std::size_t>(faces.numFaces()), -1);
  for (Index f = 0; f < faces.numFaces(); ++f) {
    if (faces.numCells(f) > 2)
      throw Error("estimator '" + estimator + "': face " + std::to_string(f) + " is shared by " +
                  std::to_string(faces.numCells(f)) + " cells (non-manifold mesh)");
    FaceKind& k = kind[static_cast<std::size_t>(f)];
    if (faces.numCells(f) == 2) {
      k = FaceKind::Interior;
    } else if (bd.contact.count(faceId[f])) {
      k = FaceKind::Contact;
      out.contactSlot[static_cast<std::size_t>(f)] = out.numContact++;
    } else {
      const std::array<bool, 3> fixed = bd.fixedComponents(faceId[f]);
      k = std::all_of(fixed.begin(), fixed.begin() + d, [](bool b) { return b; }) ? FaceKind::Fixed
                                                                                  : FaceKind::Neumann;
    }
  }
  return out;
}

/// The face terms: j2[f] = the squared jump (interior faces) or Neumann residual (boundary faces)
/// integrated over face f, and the potential contact faces with sigma_h n at their quadrature
/// points (for addContactFaces). Evaluated on threads() threads into one slot per face.
template <int d>
struct FaceResiduals {
  std::vector<double> j2;
  std::vector<ContactFace> contactFaces;
};

template <int d>
FaceResiduals<d> faceResiduals(const EstimatorInput& in, const ResidualEstimator::Options& options,
                               const mesh::FaceTable& faces, const FaceClasses& classes, const BoundaryData& bd,
                               const CellResiduals<d>& cells) {
  using Vec = Eigen::Matrix<double, d, 1>;
  using Mat = Eigen::Matrix<double, d, d>;
  using F = LocalField<d>;
  const mesh::Mesh& m = in.mesh;
  const Eigen::VectorXd& u = in.displacement;
  const double lambda = in.material.lambda(), mu = in.material.mu();
  const std::vector<int>& faceId = classes.faceId;
  const std::vector<FaceKind>& kind = classes.kind;
  const std::vector<Index>& contactSlot = classes.contactSlot;
  const std::vector<Mat>& cellStress = cells.cellStress;
  const std::vector<std::uint8_t>& flatCell = cells.flatCell;
  FaceResiduals<d> out;
  struct FaceScratch {
    PointValues<d> pv, pv1;
    std::vector<Index> fv;  // vertices and quadrature of the current face (buffers reused)
    std::vector<CellFacePoint> pts;
    std::vector<double> weights;  // of a face between two affine cells
    std::vector<std::array<double, 4>> shapes;  // face shape values at the points of side 0
    FaceTableCache<d> tables;
  };
  std::vector<double>& j2 = out.j2;
  j2.assign(static_cast<std::size_t>(faces.numFaces()), 0.0);
  std::vector<ContactFace>& contactFaces = out.contactFaces;
  contactFaces.resize(static_cast<std::size_t>(classes.numContact));
  // whether sigma_h of cell c has degree <= 1 in each coordinate of its face with `faceVertices`
  // vertices: affine cells (constant), flat quadrilaterals and hexahedra (the gradients of Q1 are
  // multilinear, of degree 1 in each coordinate), flat prisms (degree 1 in all) and the base of a
  // flat pyramid (there grad q = (y, x, x y) for q = x y / (1 - z)); not the pyramid's triangles
  // (rational) nor distorted cells
  const auto polynomialJumpSide = [&](Index c, std::size_t faceVertices) {
    const mesh::CellType t = m.cellType(c);
    return affineCellType(t) ||
           ((t != mesh::CellType::Pyramid || faceVertices == 4) && flatCell[static_cast<std::size_t>(c)]);
  };
  forEachIndex<FaceScratch>(faces.numFaces(), [&](Index f, FaceScratch& s) {
    const FaceKind k = kind[static_cast<std::size_t>(f)];
    if (k == FaceKind::Fixed) return;
    std::vector<Index>& fv = s.fv;
    std::vector<CellFacePoint>& pts = s.pts;
    const auto side0 = faces.side(f, 0);
    const Index c0 = side0.cell;
    const auto verts0 = m.cellVertices(c0);
    const bool affine0 = affineCellType(m.cellType(c0));
    cellFaceVertices(m, c0, side0.localFace, fv);
    double sum = 0;

    if (k == FaceKind::Interior) {
      const Index c1 = faces.side(f, 1).cell;
      const auto verts1 = m.cellVertices(c1);
      // on affine cells sigma_h is constant: the cell loop's value
      const bool affine1 = affineCellType(m.cellType(c1));
      Mat s0 = affine0 ? cellStress[static_cast<std::size_t>(c0)] : Mat::Zero();
      Mat s1 = affine1 ? cellStress[static_cast<std::size_t>(c1)] : Mat::Zero();
      // local numbers in c1 of the face vertices (once per face, not per point)
      const auto& ref1 = mesh::referenceElement(m.cellType(c1));
      std::array<int, 4> local1{};
      for (std::size_t j = 0; j < fv.size(); ++j) {
        const auto it = std::find(verts1.begin(), verts1.end(), fv[j]);
        if (it == verts1.end())
          throw Error("vertex " + std::to_string(fv[j]) + " is not a vertex of cell " +
                      std::to_string(c1));
        local1[j] = static_cast<int>(it - verts1.begin());
      }
      Point normal;
      if (affine0 && affine1 && flatCellFaceQuadrature(m, c0, side0.localFace, options.faceDegree, s.weights, normal)) {
        // a constant jump on a flat face: only the weights and the normal (the same sum)
        const double jump = ((s0 - s1) * normal.template head<d>()).squaredNorm();
        for (double w : s.weights) sum += w * jump;
        j2[static_cast<std::size_t>(f)] = sum;
        return;
      }
      // flat non-simplex sides by their tables (FaceTableCache), the others point by point; between
      // sides whose sigma_h has degree <= 1 in each face coordinate the jump's square has degree 2
      const int degree = polynomialJumpSide(c0, fv.size()) && polynomialJumpSide(c1, fv.size())
                             ? std::min(options.faceDegree, 2)
                             : options.faceDegree;
      s.tables.beginFace();
      // (a distorted cell gets no table: its key and lookup would only cost)
      const FaceSideTable<d>* t0 = affine0 || !flatCell[static_cast<std::size_t>(c0)]
                                       ? nullptr
                                       : &s.tables.side0(m, c0, side0.localFace, degree, s.pv, pts);
      if (t0 && !t0->flat) t0 = nullptr;
      if (!t0) cellFaceQuadrature(m, c0, side0.localFace, degree, pts);
      const std::size_t nq = t0 ? t0->weights.size() : pts.size();
      if (t0 && !affine1) {  // side 1 is evaluated at side 0's points
        s.shapes.assign(t0->shapes.begin(), t0->shapes.end());
      } else if (!affine1) {
        s.shapes.resize(nq);
        for (std::size_t q = 0; q < nq; ++q) s.shapes[q] = pts[q].shape;
      }
      const FaceSideTable<d>* t1 =
          affine1 || !flatCell[static_cast<std::size_t>(c1)]
              ? nullptr
              : &s.tables.side1(m, c1, std::span<const int>(local1.data(), fv.size()), degree, s.shapes, s.pv1);
      if (t1 && !t1->flat) t1 = nullptr;
      for (std::size_t q = 0; q < nq; ++q) {
        if (t0) {
          s0 = F::stressOf(t0->gradient(u, verts0, q), lambda, mu);
        } else if (!affine0) {
          s.pv.reinit(m, c0, pts[q].xi, false, false);
          s0 = F::stress(s.pv, u, verts0, lambda, mu);
        }
        if (t1) {
          s1 = F::stressOf(t1->gradient(u, verts1, q), lambda, mu);
        } else if (!affine1) {
          Point xi1 = Point::Zero();  // referencePointOnFace with the local numbers above
          for (std::size_t j = 0; j < fv.size(); ++j) xi1 += s.shapes[q][j] * ref1.vertices[local1[j]];
          s.pv1.reinit(m, c1, xi1, false, false);
          s1 = F::stress(s.pv1, u, verts1, lambda, mu);
        }
        const Vec n = t0 ? t0->normals[q] : Vec(pts[q].normal.template head<d>());
        const double w = t0 ? t0->weights[q] : pts[q].weight;
        sum += w * ((s0 - s1) * n).squaredNorm();
      }
      j2[static_cast<std::size_t>(f)] = sum;
      return;
    }

    // sigma_h of the boundary cell at a face point (an affine cell's: the cell loop's)
    const auto stressAt = [&](PointValues<d>& pv, const CellFacePoint& q) -> Mat {
      if (affine0) return cellStress[static_cast<std::size_t>(c0)];
      pv.reinit(m, c0, q.xi, false, false);
      return F::stress(pv, u, verts0, lambda, mu);
    };
    const int id = faceId[f];
    const std::array<bool, 3> fixed = bd.fixedComponents(id);
    if (k == FaceKind::Contact) {
      ContactFace& cf = contactFaces[static_cast<std::size_t>(contactSlot[static_cast<std::size_t>(f)])];
      cf.cell = c0;
      cf.localFace = side0.localFace;
      cf.boundaryId = id;
      cf.vertices = fv;
      cf.fixed = fixed;
      cf.points.clear();
      cellFaceQuadrature(m, c0, side0.localFace, options.faceDegree, pts);
      for (const CellFacePoint& q : pts) {
        const Vec sn = stressAt(s.pv, q) * q.normal.template head<d>();
        cf.points.push_back({q.x, q.weight, q.normal, q.shape, toPoint(sn)});
      }
      return;
    }
    const auto nit = bd.neumann.find(id);
    cellFaceQuadrature(m, c0, side0.localFace, options.faceDegree, pts);
    for (const CellFacePoint& q : pts) {
      const Vec n = q.normal.template head<d>();
      Vec jump = -stressAt(s.pv, q) * n;
      if (nit != bd.neumann.end())
        for (const NeumannCondition* nc : nit->second)
          jump += nc->traction ? Vec(nc->traction(q.x).template head<d>())
                               : Vec(-nc->pressure(q.x) * n);
      for (int c = 0; c < d; ++c)
        if (fixed[c]) jump[c] = 0;
      sum += q.weight * jump.squaredNorm();
    }
    j2[static_cast<std::size_t>(f)] = sum;
  });
  return out;
}

}  // namespace

std::vector<int> contactBoundaryIds(const EstimatorInput& input) {
  std::vector<int> ids = input.contactBoundaryIds;
  if (input.contact && input.contact->set) ids.push_back(input.contact->set->boundaryId());
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

std::string ResidualEstimator::description() const {
  return "standard residual estimator: element residuals, stress jumps, Neumann residuals "
         "(contact boundary traction-free)";
}

std::vector<std::string> ResidualEstimator::contributionNames() const {
  return {"eta_1", "eta_2", "eta_3", "eta_4", "eta_5"};
}

void ResidualEstimator::boundaryStressSquares(const EstimatorInput& input, const ContactFace& face,
                                              double& tangential, double& normal, const Eigen::VectorXd* traction) {
  const int d = input.mesh.dimension();
  const ContactSet* set = input.contact ? input.contact->set : nullptr;
  // nodal directions if every face vertex is a contact node of the set
  std::vector<Point> nodal;
  if (set && set->numMeshVertices() == input.mesh.numVertices()) {
    for (Index v : face.vertices) {
      const Index k = set->nodeOf(v);
      if (k < 0) break;
      nodal.push_back(set->direction(k));
    }
    if (nodal.size() != face.vertices.size()) nodal.clear();
  }
  tangential = 0;
  normal = 0;
  for (const ContactFacePoint& q : face.points) {
    Eigen::Vector3d w = -q.traction;  // traction-free: J = 0 - sigma n
    if (traction)
      for (std::size_t j = 0; j < face.vertices.size(); ++j)
        w.head(d) += q.shape[j] * traction->segment(static_cast<Eigen::Index>(face.vertices[j]) * d, d);
    for (int c = 0; c < 3; ++c)
      if (c >= d || face.fixed[c]) w[c] = 0;
    Point nu = q.normal;
    if (!nodal.empty()) {
      Point s = Point::Zero();
      for (std::size_t j = 0; j < nodal.size(); ++j) s += q.shape[j] * nodal[j];
      if (s.norm() > 0) nu = s / s.norm();
    }
    const double wn = w.dot(nu);
    normal += q.weight * wn * wn;
    tangential += q.weight * (w - wn * nu).squaredNorm();
  }
}

void ResidualEstimator::addContactFace(const EstimatorInput& input, const ContactFace& face,
                                       const std::vector<double>& h,
                                       ContributionTable& table) const {
  double tangential = 0, normal = 0;
  boundaryStressSquares(input, face, tangential, normal);
  for (Index p : face.vertices) {
    table.add(kEta4, p, face.cell, h[p] * tangential);
    table.add(kEta5, p, face.cell, h[p] * normal);
  }
}

void ResidualEstimator::addContactFaces(const EstimatorInput& input,
                                        const std::vector<ContactFace>& faces,
                                        const std::vector<double>& h,
                                        ContributionTable& table) const {
  for (const ContactFace& face : faces) addContactFace(input, face, h, table);
}

void ResidualEstimator::decorate(const EstimatorInput&, EstimatorResult&) const {}

void ResidualEstimator::finish(const EstimatorInput&, const std::vector<double>&,
                               ContributionTable&) const {}

EstimatorResult ResidualEstimator::estimate(const EstimatorInput& input) const {
  validateInput(input, name());
  return input.mesh.dimension() == 2 ? run<2>(input) : run<3>(input);
}

template <int d>
EstimatorResult ResidualEstimator::run(const EstimatorInput& in) const {
  const mesh::Mesh& m = in.mesh;
  const std::vector<double> h = patchDiameters(m);
  const BoundaryData bd = boundaryData(in);
  ContributionTable table(contributionNames(), m.numCells(), m.numVertices());
  if (table.numContributions() < 5)
    throw Error("estimator '" + name() + "': needs at least the rows eta_1 ... eta_5");
  // The cells and faces are evaluated on threads() threads into one slot each (r2, j2, the
  // contact faces), then added to the table in cell and face order by one thread: the result is
  // bitwise the same for any number of threads (tests/estimators/test_estimator_threads.cpp).

  // eta_1: element residuals r = div sigma_h + f, weighted with h_p^2 for each vertex p of e
  const CellResiduals<d> cells = cellResiduals<d>(in, options_);
  for (Index c = 0; c < m.numCells(); ++c)
    for (Index p : m.cellVertices(c)) table.add(kEta1, p, c, h[p] * h[p] * cells.r2[static_cast<std::size_t>(c)]);

  // faces: eta_2 (interior jumps), eta_3 (Neumann jumps), contact faces through the hook
  const mesh::FaceTable faces(m, threads());
  const FaceClasses classes = classifyFaces(m, faces, bd, name(), d);
  const FaceResiduals<d> faceTerms = faceResiduals<d>(in, options_, faces, classes, bd, cells);
  std::vector<Index> fv;
  for (Index f = 0; f < faces.numFaces(); ++f) {
    const FaceKind k = classes.kind[static_cast<std::size_t>(f)];
    if (k == FaceKind::Fixed || k == FaceKind::Contact) continue;
    const auto side0 = faces.side(f, 0);
    cellFaceVertices(m, side0.cell, side0.localFace, fv);
    const double jf = faceTerms.j2[static_cast<std::size_t>(f)];
    if (k == FaceKind::Interior) {
      const Index c1 = faces.side(f, 1).cell;
      for (Index p : fv) {
        table.add(kEta2, p, side0.cell, 0.5 * h[p] * jf);
        table.add(kEta2, p, c1, 0.5 * h[p] * jf);
      }
    } else {
      for (Index p : fv) table.add(kEta3, p, side0.cell, h[p] * jf);
    }
  }

  addContactFaces(in, faceTerms.contactFaces, h, table);
  finish(in, h, table);
  EstimatorResult result = table.result(name(), meshStamp(m, in.meshRevision));
  result.vertexFields["h"] = Eigen::Map<const Eigen::VectorXd>(h.data(), static_cast<Eigen::Index>(h.size()));
  decorate(in, result);
  return result;
}

template EstimatorResult ResidualEstimator::run<2>(const EstimatorInput&) const;
template EstimatorResult ResidualEstimator::run<3>(const EstimatorInput&) const;

}  // namespace obs::estimators
