#pragma once
/// \file ContactResidualEstimator.hpp
/// The residual-type estimator for contact of the thesis (Sec. 3.1.2, 4.1.1;
/// docs/theory.md#contact-estimator),
/// registered as `contact-residual`. With the patch quantities of ResidualEstimator (h_p = diam
/// omega_p, r, J^I, J^N, the boundary stress w = -sigma_h n on Gamma_C split into sigma_nu = w.nu
/// and sigma_T = w - sigma_nu nu), the discrete pressure s_p = ((b - A u)_p . nu_p) / m_p^C
/// (ContactOutputs::pressure, clipped at 0), the interpolated gap g_m = sum_q g_q phi_q and the
/// interpolated normal displacement u_{m,nu} = sum_q (nu_q'u_q) phi_q:
///
///   eta_1,p = h_p ||r||_{omega_p}                       all nodes
///   eta_2,p = h_p^1/2 ||J^I||_{gamma_{p,I}}              all nodes
///   eta_3,p = h_p^1/2 ||J^N||_{gamma_{p,N}}              nodes on Gamma_N
///   eta_4,p = h_p^1/2 ||sigma_T||_{gamma_{p,C}}          N^C
///   eta_5,p = h_p^1/2 ||sigma_nu||_{gamma_{p,C}}         N^C \ N^fC
///   eta_6,p = (s_p d_p)^1/2,  d_p = int_{gamma~_{p,C}} (g_m - u_{m,nu}) phi_p     N^sC
///   eta_7,p = (s_p m_p^C int_{gamma~_{p,C}} (g - g_m)^+ phi_p / int_{gamma~_{p,C}} phi_p)^1/2    N^sC
///   eta_7,p = (s_p m_p^C sum_{s in gamma_{p,C}} int_s (g - g_m)^+ phi_p / int_s phi_p)^1/2   N^fC
///   eta_8^2 = sum_{s in Gamma_C} ( h_s^-1 ||w8||_s^2 + h_s ||grad_Gamma w8||_s^2 ),
///             w8 = (u_{m,nu} - g)^+ with the exact g at the quadrature points (a local surrogate
///             of ||(u_{m,nu} - g)^+||_{H^1/2(Gamma_C)}), h_s = diam s
///
/// Node classes (classifyContactNodes): N^C = vertices of the potential-contact faces; actual
/// contact if p is a node of the ContactSet with finite gap and g_p - nu_p'u_p <= tol * U,
/// U = max(|u|_inf, max |finite g_q|) (the rule of computeContactOutputs); full contact N^fC if p
/// and every vertex of every contact face containing p are in actual contact (thesis Sec. 4.1.1);
/// semi contact N^sC = actual minus full.
///
/// gamma~_{p,C} (docs/theory.md#estimator-contributions): on each contact face s containing p, the sub-face
/// cut off by the face's edge midpoints around p, i.e. the image of the reference face under the homothety of
/// ratio 1/2 about p's reference corner: half the segment in 2D, a quarter of a triangle or
/// quadrilateral in 3D. The sub-faces of different nodes are disjoint.
///
/// Choices obs makes where the thesis leaves them open:
///  - g_m is undefined on a face with an unconstrained vertex (gap +infinity, e.g. outside the
///    punch's strip) or a vertex outside the ContactSet: such faces contribute nothing to d_p and
///    to eta_7 (and are not counted in int_{gamma~} phi_p); eta_8 is evaluated on every face all
///    of whose vertices are ContactSet nodes (where g = +infinity, w8 = 0).
///  - s_p < 0 (round-off, unconverged solves) is taken as 0; d_p < 0 (an infeasible u) as 0;
///    (g - g_m)^+ and (u_{m,nu} - g)^+ at a quadrature point below 1e-12 U (round-off) as 0, so a
///    plane obstacle (g = g_m) and a feasible u give eta_7 = eta_8 = 0 exactly.
///  - grad_Gamma g in eta_8 by central differences of g along the reference face coordinates
///    (step 1e-6 of the reference face), one-sided where g is infinite on one side.
///  - eta_7 and eta_8 need ContactData::obstacle (the exact g): a contact set without an
///    obstacle is an obs::Error, as are missing pressures.
///  - Without contact data or with no node in actual contact, eta_6 = eta_7 = 0, eta_5 sums over
///    all of N^C, and eta_1 ... eta_5 coincide with `residual`.
///
/// Element indicators (docs/theory.md#element-indicators): eta_1 ... eta_5 as in ResidualEstimator (every
/// h-weighted piece to its cell, interior faces half to each side); eta_{6,p}^2 and eta_{7,p}^2 split equally
/// over the contact faces containing p (each piece to the cell of its face); the eta_8 term of a
/// face split equally over its vertices and given to the face's cell. So sum_e eta_e^2 =
/// sum_k eta_k^2 = sum_p sum_k eta_{k,p}^2.
///
/// Two-body contact (docs/theory.md#two-body-estimator): the slave side of a mortar pair is the
/// contact set above (mortar normals, gaps relative to the displaced master, D_pp, dual-mortar
/// pressures, the exact gap to the master surface); on the faces of ContactData::masterBoundaryIds
/// (master sides) eta_4 and eta_5 are the tangential and normal parts (outward normal) of
/// t_h - sigma_h n, t_h the interpolated mortar traction ContactData::masterTraction, at every
/// vertex of the face; those faces add nothing to eta_6 ... eta_8.
///
/// Input: EstimatorInput with contact data {set, outputs, obstacle} (and for master sides
/// masterTraction, masterBoundaryIds); outputs (pressures s_p, computeContactOutputs) is required
/// when some node is in actual contact.
/// Result: contributions "eta_1" ... "eta_8"; cell fields eta_{k,e}; vertex fields eta_{k,p},
/// "eta", "h", "s" (s_p, 0 off the ContactSet or without outputs), "contact_class" (NodeClass).
#include <string>
#include <vector>

#include "obs/estimators/ResidualEstimator.hpp"

namespace obs::estimators {

/// Contact class of a vertex (the values of the vertex field "contact_class").
enum class NodeClass : int {
  None = 0,       ///< not on the potential contact boundary
  Potential = 1,  ///< in N^C, not in actual contact
  Semi = 2,       ///< N^sC
  Full = 3,       ///< N^fC
};

/// Node classes of every mesh vertex and their counts.
struct ContactNodeClasses {
  std::vector<NodeClass> ofVertex;
  Index potential = 0;  ///< |N^C|
  Index actual = 0;     ///< |N^sC| + |N^fC|
  Index semi = 0;
  Index full = 0;
  bool inContact(Index v) const {
    return ofVertex[v] == NodeClass::Semi || ofVertex[v] == NodeClass::Full;
  }
};

/// Classifies the vertices of the boundary faces of `mesh` with an id in contactIds (see the
/// file comment). `set` may be null (then nobody is in contact); if given, it must belong to the
/// mesh (vertex count) else obs::Error. u is the displacement, vertex-major. A node is in contact
/// if g - u.nu <= relativeTolerance U; U = `scale` if it is positive, else the largest of |u| and
/// the finite gaps of the set.
ContactNodeClasses classifyContactNodes(const mesh::Mesh& mesh, const std::vector<int>& contactIds,
                                        const ContactSet* set, const Eigen::VectorXd& u,
                                        double relativeTolerance = 1e-8, double scale = 0);

class ContactResidualEstimator : public ResidualEstimator {
public:
  struct ContactOptions {
    double contactTolerance = 1e-8;  ///< relative tolerance of actual contact
    int gapDegree = 4;               ///< quadrature exactness for d_p, eta_7 and eta_8
  };
  enum ContactRow : int { kEta6 = 5, kEta7 = 6, kEta8 = 7 };

  ContactResidualEstimator() = default;
  explicit ContactResidualEstimator(Options options) : ResidualEstimator(options) {}
  ContactResidualEstimator(Options options, ContactOptions contactOptions)
      : ResidualEstimator(options), contactOptions_(contactOptions) {}

  std::string name() const override { return "contact-residual"; }
  std::string description() const override;
  const ContactOptions& contactOptions() const { return contactOptions_; }

protected:
  std::vector<std::string> contributionNames() const override;
  void addContactFaces(const EstimatorInput& input, const std::vector<ContactFace>& faces,
                       const std::vector<double>& h, ContributionTable& table) const override;
  void decorate(const EstimatorInput& input, EstimatorResult& result) const override;

private:
  ContactOptions contactOptions_;
};

}  // namespace obs::estimators
