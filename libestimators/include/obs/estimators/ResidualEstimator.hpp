#pragma once
/// \file ResidualEstimator.hpp
/// The standard residual estimator `residual` (docs/theory.md#residual-estimator; thesis Sec. 2.2.1, 3.1.2
/// and 4.1.1) in
/// the patch form of the thesis. With h_p = diam omega_p (patchDiameters), sigma_h = sigma(u_h):
///
///   eta_1,p = h_p     ||r||_{omega_p},        r = div sigma_h + f                 (all nodes)
///   eta_2,p = h_p^1/2 ||J^I||_{gamma_{p,I}},  J^I = (sigma_h|_e~ - sigma_h|_e) n   (all nodes)
///   eta_3,p = h_p^1/2 ||J^N||_{gamma_{p,N}},  J^N = t - sigma_h n          (nodes on Gamma_N)
///   eta_4,p = h_p^1/2 ||sigma_T||_{gamma_{p,C}},  eta_5,p = h_p^1/2 ||sigma_nu||_{gamma_{p,C}}
///                                                                   (nodes on Gamma_C)
/// and eta_k^2 = sum_p eta_k,p^2. The potential contact boundary Gamma_C (EstimatorInput::
/// contactBoundaryIds and the id of contact->set) is treated as a traction-free Neumann boundary
/// (thesis remark after (3.14)): with w = -sigma_h n, sigma_nu = w.nu and sigma_T = w - sigma_nu nu,
/// nu = the normalised interpolation of the contact directions nu_p of contact->set at the face
/// vertices if given, else the outward normal n. Since |w|^2 = sigma_nu^2 + |sigma_T|^2 for any unit
/// nu, eta_4^2 + eta_5^2 does not depend on this choice. Without a contact boundary eta_4 = eta_5 = 0.
///
/// Details:
///  - r uses the second derivatives of the shape functions (PointValues, ElementGeometry.hpp):
///    div sigma_h = sum_i ( mu tr(H_i) u_i + (lambda + mu) H_i u_i ), H_i = d2phi_i/dx2, which is
///    not zero on non-affine cells (thesis Sec. 4.1.1) and vanishes for linear fields.
///  - Gamma_N = every boundary face not fully Dirichlet: faces with Neumann conditions (t summed over
///    the conditions of the id; a pressure p gives t = -p n) and faces without any condition
///    (t = 0, the natural boundary condition the assembly imposes there; this includes one-cell
///    faces missing from the Mesh's boundary faces). On faces whose id has a
///    Dirichlet condition, the fixed Cartesian components of J^N are dropped (a roller keeps the
///    tangential residual); fully clamped faces contribute nothing. The same masking applies to w
///    on contact faces.
///  - Quadrature: Options::elementDegree in cells, Options::faceDegree on faces; J^I is evaluated at
///    matching points of both cells (referencePointOnFace). On flat cells, and on interior faces
///    between flat cells (except a pyramid's triangles), the lowest degree at which the integrand is
///    integrated exactly is used if it is lower (docs/estimators.md#flat-cell-quadrature).
///
/// Element indicators (docs/theory.md#element-indicators), the exact decomposition used:
///   eta_{1,e}^2 = (sum_{p in e} h_p^2) ||r||_e^2                 (omega_p holds e for p in e)
///   eta_{2,e}^2 = sum_{interior faces F of e} 1/2 (sum_{p in F} h_p) ||J^I||_F^2
///   eta_{3,e}^2 = sum_{Neumann faces F of e}      (sum_{p in F} h_p) ||J^N||_F^2
///   eta_{4,e}^2, eta_{5,e}^2 likewise over the contact faces of e,
/// i.e. every piece h_p^a (integral over e or F) of eta_{k,p}^2 goes to e, interior faces half to
/// each side (ContributionTable). Hence sum_e eta_e^2 = sum_k eta_k^2 = sum_p sum_k eta_{k,p}^2 up to
/// summation order. (The thesis weighted ||r||_e^2 by the number of vertices of e, i.e. the same
/// formula with one h per cell.)
///
/// Result fields: contributions "eta_1" ... "eta_5"; cell fields eta_{k,e}; vertex fields eta_{k,p}
/// ("eta_1" ... "eta_5") and "eta" = (sum_k eta_{k,p}^2)^{1/2}, plus "h" = h_p.
///
/// Extension (thesis Fig. 4.1, a class hierarchy of residual-type estimators): the contact
/// estimator (ContactResidualEstimator.hpp) derives from this class and overrides
/// contributionNames(), addContactFaces() (eta_4, eta_5 with node classes, the node terms eta_6,
/// eta_7 and the face terms eta_8, which need all contact faces at once) and decorate() (extra
/// vertex fields).
#include <array>
#include <string>
#include <vector>

#include "obs/estimators/ContributionTable.hpp"
#include "obs/estimators/Estimator.hpp"

namespace obs::estimators {

/// A quadrature point of a potential-contact face, with the discrete boundary stress.
struct ContactFacePoint {
  Point x;                   ///< physical point
  double weight = 0;         ///< surface weight
  Point normal;              ///< outward unit normal n
  std::array<double, 4> shape{};  ///< face shape functions (ContactFace::vertices order)
  Eigen::Vector3d traction;  ///< sigma(u_h) n (z = 0 in 2D)
};

/// One face of the potential contact boundary Gamma_C.
struct ContactFace {
  Index cell = -1;                 ///< the cell having the face
  int localFace = -1;              ///< its local face number
  int boundaryId = 0;
  std::vector<Index> vertices;     ///< global vertex numbers, outward orientation
  std::array<bool, 3> fixed{};     ///< Cartesian components fixed by Dirichlet conditions of the id
  std::vector<ContactFacePoint> points;
};

class ResidualEstimator : public Estimator {
public:
  struct Options {
    int elementDegree = 4;  ///< quadrature exactness for ||r||_e^2 (at most; flat cells: see above)
    int faceDegree = 4;     ///< quadrature exactness for face integrals (at most; see above)
  };
  /// Positions of the contributions in contributionNames() / the ContributionTable.
  enum Row : int { kEta1 = 0, kEta2 = 1, kEta3 = 2, kEta4 = 3, kEta5 = 4 };

  ResidualEstimator() = default;
  explicit ResidualEstimator(Options options) : options_(options) {}

  std::string name() const override { return "residual"; }
  std::string description() const override;
  EstimatorResult estimate(const EstimatorInput& input) const override;

  const Options& options() const { return options_; }

protected:
  /// Names of the table rows; the first five must be eta_1 ... eta_5 as above.
  virtual std::vector<std::string> contributionNames() const;
  /// Adds the terms of one potential-contact face. Default: traction-free Neumann boundary,
  /// h_p ||sigma_T||_F^2 to kEta4 and h_p ||sigma_nu||_F^2 to kEta5 for every vertex p of F.
  virtual void addContactFace(const EstimatorInput& input, const ContactFace& face,
                              const std::vector<double>& h, ContributionTable& table) const;
  /// Adds the terms of all potential-contact faces (called once, after the interior and Neumann
  /// faces, with the faces in face-table order). Default: addContactFace() for each face.
  virtual void addContactFaces(const EstimatorInput& input, const std::vector<ContactFace>& faces,
                               const std::vector<double>& h, ContributionTable& table) const;
  /// Called after all cells and faces (node terms of derived estimators). Default: nothing.
  virtual void finish(const EstimatorInput& input, const std::vector<double>& h,
                      ContributionTable& table) const;
  /// Called on the finished result (extra vertex or cell fields). Default: nothing.
  virtual void decorate(const EstimatorInput& input, EstimatorResult& result) const;

  /// The squared norms over the face of the tangential and normal parts of the boundary stress
  /// w = t_h - sigma_h n (Dirichlet-fixed components dropped), split with nu = the normalised
  /// interpolation of the nodal directions nu_p of contact->set if every face vertex is a node of
  /// the set, else the outward normal n:  normal = ||w.nu||_F^2, tangential = ||w - (w.nu) nu||_F^2.
  /// t_h = sum_p phi_p t_p interpolates a given traction per mesh vertex (`traction`, d entries per
  /// vertex, e.g. the friction traction); without it t_h = 0 (a traction-free boundary).
  static void boundaryStressSquares(const EstimatorInput& input, const ContactFace& face,
                                    double& tangential, double& normal, const Eigen::VectorXd* traction = nullptr);

private:
  template <int d>
  EstimatorResult run(const EstimatorInput& input) const;

  Options options_;
};

/// The potential contact boundary ids of an input: contactBoundaryIds plus the id of contact->set.
std::vector<int> contactBoundaryIds(const EstimatorInput& input);

}  // namespace obs::estimators
