#include "obs/estimators/ContactResidualEstimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs::estimators {
namespace {

/// The first-order map of a boundary face (segment, triangle or quadrilateral) at a reference
/// point: shape functions, their reference gradients, the physical point, the tangent vectors
/// J = dx/deta (3 x k, k = face dimension), the surface element and (J'J)^{-1}.
struct FaceMap {
  int n = 0, k = 0;
  double shape[4]{};
  double grad[8]{};  ///< grad[i*k + a] = d phi_i / d eta_a
  Point x = Point::Zero();
  Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
  double element = 0;
  Eigen::Matrix2d metricInverse = Eigen::Matrix2d::Zero();

  void evaluate(const mesh::Mesh& m, const std::vector<Index>& fv, const mesh::ReferenceElement& ref,
                const Point& eta) {
    n = static_cast<int>(fv.size());
    k = ref.dim;
    ref.values(eta, std::span<double>(shape, static_cast<std::size_t>(n)));
    ref.gradients(eta, std::span<double>(grad, static_cast<std::size_t>(n * k)));
    x.setZero();
    J.setZero();
    for (int i = 0; i < n; ++i) {
      const Point& xi = m.vertex(fv[static_cast<std::size_t>(i)]);
      x += shape[i] * xi;
      for (int a = 0; a < k; ++a) J.col(a) += grad[i * k + a] * xi;
    }
    if (k == 1) {
      const double g = J.col(0).squaredNorm();
      element = std::sqrt(g);
      metricInverse(0, 0) = g > 0 ? 1 / g : 0;
    } else {
      const Eigen::Matrix2d G = J.transpose() * J;
      const double det = G.determinant();
      element = std::sqrt(std::max(det, 0.0));
      metricInverse = det > 0 ? Eigen::Matrix2d(G.inverse()) : Eigen::Matrix2d::Zero();
    }
    if (!(element > 0))
      throw Error("contact-residual: degenerate contact face with first vertex " + std::to_string(fv[0]));
  }
};

double faceDiameter(const mesh::Mesh& m, const std::vector<Index>& fv) {
  double h = 0;
  for (std::size_t i = 0; i < fv.size(); ++i)
    for (std::size_t j = i + 1; j < fv.size(); ++j) h = std::max(h, (m.vertex(fv[i]) - m.vertex(fv[j])).norm());
  return h;
}

/// Per-vertex contact data: nodal normal displacement nu_q'u_q and gap g_q (NaN off the set).
struct NodalData {
  std::vector<double> normalDisplacement, gap;
  std::vector<char> inSet;
};

NodalData nodalData(const mesh::Mesh& m, const ContactSet* set, const Eigen::VectorXd& u) {
  const int d = m.dimension();
  NodalData nd;
  const std::size_t n = static_cast<std::size_t>(m.numVertices());
  nd.normalDisplacement.assign(n, 0.0);
  nd.gap.assign(n, std::numeric_limits<double>::quiet_NaN());
  nd.inSet.assign(n, 0);
  if (!set) return nd;
  for (Index k = 0; k < set->size(); ++k) {
    const Index v = set->vertex(k);
    nd.inSet[v] = 1;
    nd.gap[v] = set->gap(k);
    nd.normalDisplacement[v] = set->direction(k).head(d).dot(u.segment(static_cast<Eigen::Index>(v) * d, d));
  }
  return nd;
}

void requireSetOfMesh(const mesh::Mesh& m, const ContactSet* set, const std::string& where) {
  if (set && set->numMeshVertices() != m.numVertices())
    throw Error(where + ": the contact set " + set->boundaryLabel() + " was built for a mesh with " +
                std::to_string(set->numMeshVertices()) + " vertices, this mesh has " +
                std::to_string(m.numVertices()));
}

/// s_p per mesh vertex (0 off the set); throws if pressures are needed but missing.
std::vector<double> pressures(const EstimatorInput& in, const ContactNodeClasses& classes, bool required) {
  std::vector<double> s(static_cast<std::size_t>(in.mesh.numVertices()), 0.0);
  const ContactSet* set = in.contact ? in.contact->set : nullptr;
  const ContactOutputs* out = in.contact ? in.contact->outputs : nullptr;
  if (!set) return s;
  if (!out) {
    if (required && classes.actual > 0)
      throw Error("estimator 'contact-residual': " + std::to_string(classes.actual) +
                  " nodes are in actual contact but the input has no contact outputs (pressures s_p; "
                  "set ContactData::outputs from computeContactOutputs)");
    return s;
  }
  if (out->pressure.size() != static_cast<std::size_t>(set->size()))
    throw Error("estimator 'contact-residual': the contact outputs have " +
                std::to_string(out->pressure.size()) + " pressures, the contact set " +
                set->boundaryLabel() + " has " + std::to_string(set->size()) + " nodes");
  for (Index k = 0; k < set->size(); ++k) {
    const double p = out->pressure[static_cast<std::size_t>(k)];
    if (!std::isfinite(p))
      throw Error("estimator 'contact-residual': the pressure s_p of contact node " + std::to_string(k) +
                  " (vertex " + std::to_string(set->vertex(k)) + ") is not finite");
    s[set->vertex(k)] = std::max(p, 0.0);
  }
  return s;
}

/// ||w.n||_F^2 and ||w - (w.n) n||_F^2 of w = t_h - sigma_h n on a master face (Dirichlet-fixed
/// components dropped), t_h = sum_j phi_j t_j the interpolated nodal traction, n the outward normal.
void masterTractionSquares(int d, const ContactFace& face, const Eigen::VectorXd& traction, double& tangential,
                           double& normal) {
  tangential = normal = 0;
  for (const ContactFacePoint& q : face.points) {
    Eigen::Vector3d w = -q.traction;
    for (std::size_t j = 0; j < face.vertices.size(); ++j)
      w.head(d) += q.shape[j] * traction.segment(static_cast<Eigen::Index>(face.vertices[j]) * d, d);
    for (int c = 0; c < 3; ++c)
      if (c >= d || face.fixed[c]) w[c] = 0;
    const double wn = w.dot(q.normal);
    normal += q.weight * wn * wn;
    tangential += q.weight * (w - wn * q.normal).squaredNorm();
  }
}

/// The friction traction on the body per mesh vertex (d entries each; empty without friction):
/// -f_T,k / m_k at the vertex of contact node k in actual contact with a friction force (stick or
/// slip, ContactOutputs::state; f_T = ContactOutputs::tangential, m_k = ContactSet::boundaryMass),
/// zero off actual contact. A vertex in actual contact (`actual`) without a friction force (its
/// tangential displacement prescribed, e.g. where a Dirichlet side meets the contact boundary) has
/// a nodal residual that mixes the Dirichlet reaction in: it gets the mean traction of the
/// friction nodes it shares a contact face with (docs/theory.md#friction-estimators).
Eigen::VectorXd frictionTraction(const EstimatorInput& in, const std::vector<ContactFace>& faces,
                                 const ContactNodeClasses& classes) {
  const ContactData* c = in.contact;
  if (!c || !c->friction || !c->set || !c->outputs) return {};
  const ContactSet& set = *c->set;
  const ContactOutputs& out = *c->outputs;
  if (out.tangential.size() != static_cast<std::size_t>(set.size()) || out.state.size() != out.tangential.size())
    throw Error("estimator 'contact-residual': the contact outputs have " + std::to_string(out.tangential.size()) +
                " tangential forces, the contact set " + set.boundaryLabel() + " has " + std::to_string(set.size()) +
                " nodes (friction needs ContactOutputs::tangential and state)");
  const int d = in.mesh.dimension();
  const auto nv = static_cast<std::size_t>(in.mesh.numVertices());
  Eigen::VectorXd t = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(nv) * d);
  std::vector<char> known(nv, 0);
  for (Index k = 0; k < set.size(); ++k) {
    const auto s = static_cast<std::size_t>(k);
    const Point& fk = out.tangential[s];
    if (!fk.allFinite())
      throw Error("estimator 'contact-residual': the friction force of contact node " + std::to_string(k) +
                  " (vertex " + std::to_string(set.vertex(k)) + ") is not finite");
    const double m = set.boundaryMass(k);
    if (out.state[s] == 0 || !(m > 0)) continue;
    t.segment(static_cast<Eigen::Index>(set.vertex(k)) * d, d) = -fk.head(d) / m;
    known[static_cast<std::size_t>(set.vertex(k))] = 1;
  }
  const auto actual = [&](Index v) {
    const NodeClass k = classes.ofVertex[static_cast<std::size_t>(v)];
    return k == NodeClass::Semi || k == NodeClass::Full;
  };
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(t.size());
  std::vector<int> count(nv, 0);
  for (const ContactFace& face : faces)
    for (Index v : face.vertices) {
      if (known[static_cast<std::size_t>(v)] || !actual(v)) continue;
      for (Index w : face.vertices)
        if (known[static_cast<std::size_t>(w)]) {
          sum.segment(static_cast<Eigen::Index>(v) * d, d) += t.segment(static_cast<Eigen::Index>(w) * d, d);
          ++count[static_cast<std::size_t>(v)];
        }
    }
  for (std::size_t v = 0; v < nv; ++v)
    if (count[v] > 0) t.segment(static_cast<Eigen::Index>(v) * d, d) = sum.segment(static_cast<Eigen::Index>(v) * d, d) / count[v];
  return t;
}

}  // namespace

ContactNodeClasses classifyContactNodes(const mesh::Mesh& mesh, const std::vector<int>& contactIds,
                                        const ContactSet* set, const Eigen::VectorXd& u,
                                        double relativeTolerance, double scale) {
  const int d = mesh.dimension();
  const Index n = mesh.numVertices();
  if (u.size() != static_cast<Eigen::Index>(n) * d)
    throw Error("contact node classes: displacement has " + std::to_string(u.size()) +
                " entries, the mesh needs " + std::to_string(static_cast<long long>(n) * d));
  requireSetOfMesh(mesh, set, "contact node classes");
  std::vector<char> actual(static_cast<std::size_t>(n), 0);
  if (set) {
    double U = scale;
    if (!(U > 0)) {
      U = u.size() ? u.lpNorm<Eigen::Infinity>() : 0.0;
      for (Index k = 0; k < set->size(); ++k)
        if (std::isfinite(set->gap(k))) U = std::max(U, std::abs(set->gap(k)));
    }
    if (!(U > 0)) U = 1;
    for (Index k = 0; k < set->size(); ++k) {
      const double g = set->gap(k);
      if (!std::isfinite(g)) continue;
      const Index v = set->vertex(k);
      const double un = set->direction(k).head(d).dot(u.segment(static_cast<Eigen::Index>(v) * d, d));
      actual[v] = g - un <= relativeTolerance * U;
    }
  }
  const std::set<int> ids(contactIds.begin(), contactIds.end());
  std::vector<char> on(static_cast<std::size_t>(n), 0), neighboursInContact(static_cast<std::size_t>(n), 1);
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    if (!ids.count(mesh.boundaryFaceId(f))) continue;
    const auto fv = mesh.boundaryFaceVertices(f);
    const bool all = std::all_of(fv.begin(), fv.end(), [&](Index v) { return actual[v] != 0; });
    for (Index v : fv) {
      on[v] = 1;
      if (!all) neighboursInContact[v] = 0;
    }
  }
  ContactNodeClasses c;
  c.ofVertex.assign(static_cast<std::size_t>(n), NodeClass::None);
  for (Index v = 0; v < n; ++v) {
    if (!on[v]) continue;
    ++c.potential;
    if (!actual[v]) {
      c.ofVertex[v] = NodeClass::Potential;
    } else if (neighboursInContact[v]) {
      c.ofVertex[v] = NodeClass::Full;
      ++c.full;
      ++c.actual;
    } else {
      c.ofVertex[v] = NodeClass::Semi;
      ++c.semi;
      ++c.actual;
    }
  }
  return c;
}

std::string ContactResidualEstimator::description() const {
  return "residual-type estimator for contact (thesis Sec. 3.1.2): residual terms plus node classes, "
         "complementarity and gap-approximation terms eta_6 ... eta_8";
}

std::vector<std::string> ContactResidualEstimator::contributionNames() const {
  return {"eta_1", "eta_2", "eta_3", "eta_4", "eta_5", "eta_6", "eta_7", "eta_8"};
}

void ContactResidualEstimator::addContactFaces(const EstimatorInput& input,
                                               const std::vector<ContactFace>& faces,
                                               const std::vector<double>& h,
                                               ContributionTable& table) const {
  const mesh::Mesh& m = input.mesh;
  const Index nv = m.numVertices();
  const ContactSet* set = input.contact ? input.contact->set : nullptr;
  const Obstacle* obstacle = input.contact ? input.contact->obstacle : nullptr;
  const ContactNodeClasses classes = classifyContactNodes(
      m, contactBoundaryIds(input), set, input.displacement, contactOptions_.contactTolerance,
      input.contact ? input.contact->contactScale : 0.0);
  const std::vector<double> s = pressures(input, classes, true);
  if (set && !obstacle)  // eta_7 and eta_8 would silently be 0
    throw Error("estimator 'contact-residual': the input has the contact set " + set->boundaryLabel() +
                " but no obstacle; eta_7 and eta_8 need the exact gap g (set ContactData::obstacle)");
  const NodalData nd = nodalData(m, set, input.displacement);
  auto cls = [&](Index v) { return classes.ofVertex[v]; };

  // master sides of mortar pairs: w = t_h - sigma_h n, t_h the interpolated mortar traction
  const Eigen::VectorXd* traction = input.contact ? input.contact->masterTraction : nullptr;
  const std::vector<int> noIds;
  const std::vector<int>& masterIds = input.contact ? input.contact->masterBoundaryIds : noIds;
  if (traction && traction->size() != static_cast<Eigen::Index>(nv) * m.dimension())
    throw Error("estimator 'contact-residual': the master traction has " + std::to_string(traction->size()) +
                " entries, the mesh needs " + std::to_string(static_cast<long long>(nv) * m.dimension()));
  auto onMaster = [&](const ContactFace& f) {
    return traction && std::find(masterIds.begin(), masterIds.end(), f.boundaryId) != masterIds.end();
  };

  // with friction, the friction traction on the body, -f_T,p / m_p per contact node (f_T the
  // tangential force on the obstacle, ContactOutputs::tangential): eta_4 then measures the
  // tangential stress against it (docs/theory.md#friction-estimators)
  const Eigen::VectorXd friction = frictionTraction(input, faces, classes);

  // eta_4 over N^C, eta_5 over N^C \ N^fC; on master faces the tangential and normal parts of
  // t_h - sigma_h n at every vertex (docs/theory.md#two-body-estimator)
  std::vector<int> faceCount(static_cast<std::size_t>(nv), 0);
  for (const ContactFace& face : faces) {
    double tangential = 0, normal = 0;
    if (onMaster(face)) {
      masterTractionSquares(m.dimension(), face, *traction, tangential, normal);
      for (Index p : face.vertices) {
        table.add(kEta4, p, face.cell, h[p] * tangential);
        table.add(kEta5, p, face.cell, h[p] * normal);
      }
      continue;
    }
    boundaryStressSquares(input, face, tangential, normal, friction.size() > 0 ? &friction : nullptr);
    for (Index p : face.vertices) {
      ++faceCount[p];
      table.add(kEta4, p, face.cell, h[p] * tangential);
      if (cls(p) != NodeClass::Full) table.add(kEta5, p, face.cell, h[p] * normal);
    }
  }
  if (!set) return;

  // gap differences below round-off (relative to the scale U of the contact rule) count as 0, so
  // that g = g_m (e.g. a plane) and a feasible u give eta_7 = eta_8 = 0 exactly
  double U = input.displacement.lpNorm<Eigen::Infinity>();
  for (Index k = 0; k < set->size(); ++k)
    if (std::isfinite(set->gap(k))) U = std::max(U, std::abs(set->gap(k)));
  const double roundOff = 1e-12 * U;
  auto positivePart = [roundOff](double x) { return x > roundOff ? x : 0.0; };

  // integrals over the faces and quarter sub-faces for eta_6, eta_7 (faces on which g_m exists)
  const std::size_t n = static_cast<std::size_t>(nv);
  std::vector<double> dTilde(n, 0.0), phiTilde(n, 0.0), gapTilde(n, 0.0), gapFull(n, 0.0);
  std::vector<double> eta8(faces.size(), 0.0);
  FaceMap fm;
  for (std::size_t fi = 0; fi < faces.size(); ++fi) {
    const ContactFace& face = faces[fi];
    const std::vector<Index>& fv = face.vertices;
    const bool inSet = std::all_of(fv.begin(), fv.end(), [&](Index v) { return nd.inSet[v] != 0; });
    if (!inSet || onMaster(face)) continue;
    const bool gapDefined = std::all_of(fv.begin(), fv.end(), [&](Index v) { return std::isfinite(nd.gap[v]); });
    const mesh::CellType ft = mesh::faceTypeFromVertexCount(static_cast<int>(fv.size()));
    const auto& ref = mesh::referenceElement(ft);
    const auto& rule = mesh::quadratureRule(ft, contactOptions_.gapDegree);
    auto interpolate = [&](const std::vector<double>& values) {
      double r = 0;
      for (int i = 0; i < fm.n; ++i) r += fm.shape[i] * values[fv[static_cast<std::size_t>(i)]];
      return r;
    };

    if (gapDefined) {
      for (std::size_t j = 0; j < fv.size(); ++j) {
        const Index p = fv[j];
        if (cls(p) != NodeClass::Semi && cls(p) != NodeClass::Full) continue;
        const Point& corner = ref.vertices[j];
        const double scale = std::pow(0.5, ref.dim);
        // sub-face gamma~: homothety of ratio 1/2 about p's reference corner
        if (cls(p) == NodeClass::Semi) {
          for (std::size_t q = 0; q < rule.size(); ++q) {
            fm.evaluate(m, fv, ref, corner + 0.5 * (rule.points[q] - corner));
            const double w = scale * rule.weights[q] * fm.element;
            const double phi = fm.shape[j];
            dTilde[p] += w * (interpolate(nd.gap) - interpolate(nd.normalDisplacement)) * phi;
            phiTilde[p] += w * phi;
            if (obstacle) {
              const double g = obstacle->gap(fm.x);
              if (std::isfinite(g)) gapTilde[p] += w * positivePart(g - interpolate(nd.gap)) * phi;
            }
          }
        } else if (obstacle) {
          double num = 0, den = 0;
          for (std::size_t q = 0; q < rule.size(); ++q) {
            fm.evaluate(m, fv, ref, rule.points[q]);
            const double w = rule.weights[q] * fm.element;
            const double phi = fm.shape[j];
            den += w * phi;
            const double g = obstacle->gap(fm.x);
            if (std::isfinite(g)) num += w * positivePart(g - interpolate(nd.gap)) * phi;
          }
          if (den > 0) gapFull[p] += num / den;
        }
      }
    }

    // eta_8: h_s^-1 ||w||^2 + h_s ||grad_Gamma w||^2, w = (u_{m,nu} - g)^+
    if (obstacle) {
      const double hs = faceDiameter(m, fv);
      const double eps = 1e-6;
      double w2 = 0, g2 = 0;
      for (std::size_t q = 0; q < rule.size(); ++q) {
        fm.evaluate(m, fv, ref, rule.points[q]);
        const double g = obstacle->gap(fm.x);
        if (!std::isfinite(g)) continue;
        const double f = interpolate(nd.normalDisplacement) - g;
        if (positivePart(f) == 0) continue;
        const double w = rule.weights[q] * fm.element;
        w2 += w * f * f;
        Eigen::Vector2d grad = Eigen::Vector2d::Zero();
        for (int a = 0; a < fm.k; ++a) {
          for (int i = 0; i < fm.n; ++i) grad[a] += fm.grad[i * fm.k + a] * nd.normalDisplacement[fv[static_cast<std::size_t>(i)]];
          auto gapAt = [&](double step) {
            Point y = fm.x;
            for (int i = 0; i < fm.n; ++i) y += step * fm.grad[i * fm.k + a] * m.vertex(fv[static_cast<std::size_t>(i)]);
            return obstacle->gap(y);  // x(eta + step e_a) for the (multi)linear face map along e_a
          };
          const double gp = gapAt(eps), gm = gapAt(-eps);
          double dg = 0;
          if (std::isfinite(gp) && std::isfinite(gm)) dg = (gp - gm) / (2 * eps);
          else if (std::isfinite(gp)) dg = (gp - g) / eps;
          else if (std::isfinite(gm)) dg = (g - gm) / eps;
          grad[a] -= dg;
        }
        const Eigen::Vector2d gk = grad.head(2);
        g2 += w * (fm.k == 1 ? gk[0] * gk[0] * fm.metricInverse(0, 0)
                             : gk.dot(fm.metricInverse * gk));
      }
      eta8[fi] = w2 / hs + hs * g2;
    }
  }

  // node terms, split equally over the contact faces at p; eta_8 face terms over the face's vertices
  std::vector<double> e6(n, 0.0), e7(n, 0.0);
  for (Index p = 0; p < nv; ++p) {
    const Index k = set->nodeOf(p);
    if (k < 0) continue;
    const double mass = set->boundaryMass(k);
    if (cls(p) == NodeClass::Semi) {
      e6[p] = s[p] * std::max(dTilde[p], 0.0);
      if (phiTilde[p] > 0) e7[p] = s[p] * mass * gapTilde[p] / phiTilde[p];
    } else if (cls(p) == NodeClass::Full) {
      e7[p] = s[p] * mass * gapFull[p];
    }
  }
  for (std::size_t fi = 0; fi < faces.size(); ++fi) {
    const ContactFace& face = faces[fi];
    if (onMaster(face)) continue;
    const double nf = static_cast<double>(face.vertices.size());
    for (Index p : face.vertices) {
      if (e6[p] > 0) table.add(kEta6, p, face.cell, e6[p] / faceCount[p]);
      if (e7[p] > 0) table.add(kEta7, p, face.cell, e7[p] / faceCount[p]);
      if (eta8[fi] > 0) table.add(kEta8, p, face.cell, eta8[fi] / nf);
    }
  }
}

void ContactResidualEstimator::decorate(const EstimatorInput& input, EstimatorResult& result) const {
  const ContactSet* set = input.contact ? input.contact->set : nullptr;
  const ContactNodeClasses classes = classifyContactNodes(
      input.mesh, contactBoundaryIds(input), set, input.displacement, contactOptions_.contactTolerance,
      input.contact ? input.contact->contactScale : 0.0);
  const std::vector<double> s = pressures(input, classes, false);
  const Eigen::Index n = input.mesh.numVertices();
  Eigen::VectorXd cls(n), sp(n);
  for (Eigen::Index v = 0; v < n; ++v) {
    cls[v] = static_cast<double>(static_cast<int>(classes.ofVertex[static_cast<std::size_t>(v)]));
    sp[v] = s[static_cast<std::size_t>(v)];
  }
  result.vertexFields["contact_class"] = std::move(cls);
  result.vertexFields["s"] = std::move(sp);
}

}  // namespace obs::estimators
