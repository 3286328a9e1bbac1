#include "obs/obs/ContactSet.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs {
namespace {

std::string pointString(const Point& x, int dim) {
  std::ostringstream os;
  os << "(" << x[0] << ", " << x[1];
  if (dim == 3) os << ", " << x[2];
  os << ")";
  return os.str();
}

std::string labelOf(const mesh::Mesh& mesh, int id) {
  const auto it = mesh.boundaryNames().find(id);
  return it != mesh.boundaryNames().end() ? "'" + it->second + "' (id " + std::to_string(id) + ")"
                                          : "id " + std::to_string(id);
}

int idOf(const mesh::Mesh& mesh, const std::string& name) {
  const auto id = mesh.boundaryId(name);
  if (!id) throw Error("contact set: the mesh has no boundary named '" + name + "'");
  return *id;
}

}  // namespace

Eigen::Matrix3d householderRotation(const Point& nu) {
  // nu_1 <= 0: H = I - 2 v v'/(v'v), v = e_1 - nu, H e_1 = nu.
  // nu_1 > 0:  H = I - 2 v v'/(v'v), v = e_1 + nu, H e_1 = -nu; Q = H diag(-1, 1, 1).
  // Either way v'v >= 2, so there is no cancellation.
  const bool flip = nu[0] > 0;
  Point v = flip ? Point(Point::UnitX() + nu) : Point(Point::UnitX() - nu);
  Eigen::Matrix3d Q = Eigen::Matrix3d::Identity() - (2 / v.squaredNorm()) * v * v.transpose();
  if (flip) Q.col(0) = -Q.col(0);
  return Q;
}

ContactSet::ContactSet(const mesh::Mesh& mesh, int boundaryId, const Obstacle& obstacle, bool allowEmpty)
    : dim_(mesh.dimension()), boundaryId_(boundaryId), label_(labelOf(mesh, boundaryId)),
      obstacleName_(obstacle.name()) {
  build(mesh, obstacle, allowEmpty);
}

ContactSet::ContactSet(const mesh::Mesh& mesh, const std::string& boundaryName, const Obstacle& obstacle)
    : ContactSet(mesh, idOf(mesh, boundaryName), obstacle) {}

ContactSet::ContactSet(Data data)
    : dim_(data.dimension), boundaryId_(-1), label_(std::move(data.label)), obstacleName_(std::move(data.obstacleName)) {
  const std::size_t n = data.vertices.size();
  if ((dim_ != 2 && dim_ != 3) || data.positions.size() != n || data.directions.size() != n || data.gaps.size() != n ||
      data.masses.size() != n)
    throw Error("contact set " + label_ + ": inconsistent data (dimension or sizes)");
  nodeOf_.assign(data.numMeshVertices, -1);
  for (std::size_t k = 0; k < n; ++k) {
    const Index v = data.vertices[k];
    if (v < 0 || v >= data.numMeshVertices || (k > 0 && v <= data.vertices[k - 1]))
      throw Error("contact set " + label_ + ": vertices out of range or not increasing");
    nodeOf_[v] = static_cast<Index>(k);
    const Point& nu = data.directions[k];
    if (!nu.allFinite() || std::abs(nu.norm() - 1) > 1e-12 || std::isnan(data.gaps[k]) || !(data.masses[k] > 0))
      throw Error("contact set " + label_ + ", vertex " + std::to_string(v) +
                  ": non-unit direction, NaN gap or non-positive boundary mass");
  }
  for (const Face& f : data.faces)
    for (Index k : f.nodes)
      if (k < 0 || k >= static_cast<Index>(n)) throw Error("contact set " + label_ + ": face node out of range");
  vertices_ = std::move(data.vertices);
  positions_ = std::move(data.positions);
  directions_ = std::move(data.directions);
  gaps_ = std::move(data.gaps);
  masses_ = std::move(data.masses);
  faces_ = std::move(data.faces);
  rotations_.resize(n);
  for (std::size_t k = 0; k < n; ++k) rotations_[k] = householderRotation(directions_[k]);
}

double ContactSet::measure() const {
  double s = 0;
  for (const Face& f : faces_) s += f.measure;
  return s;
}

void ContactSet::build(const mesh::Mesh& mesh, const Obstacle& obstacle, bool allowEmpty) {
  const std::string where = "contact boundary " + label_;
  if (obstacle.dimension() != 0 && obstacle.dimension() != dim_)
    throw Error(where + ": obstacle '" + obstacleName_ + "' is made for dimension " +
                std::to_string(obstacle.dimension()) + ", the mesh has dimension " + std::to_string(dim_));

  // vertices of the contact faces, in increasing vertex order
  nodeOf_.assign(mesh.numVertices(), -1);
  std::vector<Index> contactFaces;
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    if (mesh.boundaryFaceId(f) != boundaryId_) continue;
    contactFaces.push_back(f);
    for (Index v : mesh.boundaryFaceVertices(f)) nodeOf_[v] = 0;
  }
  // vertices on the boundary whose faces the mesh lacks (a ghost at the edge of a distributed run's
  // ghost layer, Mesh::addBoundaryVertex): constrained as their owner constrains them; their
  // boundary mass is 0 here (their owner's is the whole one)
  for (const auto& [v, id] : mesh.boundaryVertices())
    if (id == boundaryId_) nodeOf_[v] = 0;
  if (contactFaces.empty() && !allowEmpty)
    throw Error(where + ": no boundary face has this id (empty potential contact boundary)");
  for (Index v = 0; v < mesh.numVertices(); ++v)
    if (nodeOf_[v] == 0) {
      nodeOf_[v] = static_cast<Index>(vertices_.size());
      vertices_.push_back(v);
    }

  // obstacle data per node
  const Index n = size();
  positions_.resize(n);
  directions_.resize(n);
  gaps_.resize(n);
  rotations_.resize(n);
  masses_.assign(n, 0.0);
  for (Index k = 0; k < n; ++k) {
    const Point& x = mesh.vertex(vertices_[k]);
    positions_[k] = x;
    // the location of an error, formatted only when there is one
    const auto at = [&] { return where + ", vertex " + std::to_string(vertices_[k]) + " at " + pointString(x, dim_); };
    Point nu = obstacle.direction(x);
    if (dim_ == 2) nu[2] = 0;
    const double len = nu.norm();
    if (!nu.allFinite() || !(len > 1e-300))
      throw Error(at() + ": obstacle '" + obstacleName_ + "' gives a zero or non-finite constraint direction");
    nu /= len;
    const double g = obstacle.gap(x);
    if (std::isnan(g) || g == -std::numeric_limits<double>::infinity())
      throw Error(at() + ": obstacle '" + obstacleName_ + "' gives the gap " + std::to_string(g));
    directions_[k] = nu;
    gaps_[k] = g;
    rotations_[k] = householderRotation(nu);
  }

  // lumped boundary masses m_p^C = int phi_p and face measures, by face quadrature (degree 2 is exact
  // for phi_p |J| on segments, triangles and parallelogram quadrilaterals, accurate otherwise)
  double shape[4], grad[8];
  for (Index f : contactFaces) {
    const auto fv = mesh.boundaryFaceVertices(f);
    const mesh::CellType ft = mesh::faceTypeFromVertexCount(static_cast<int>(fv.size()));
    const auto& ref = mesh::referenceElement(ft);
    const auto& rule = mesh::quadratureRule(ft, 2);
    Face face;
    for (Index v : fv) face.nodes.push_back(nodeOf_[v]);
    for (std::size_t q = 0; q < rule.size(); ++q) {
      ref.values(rule.points[q], std::span<double>(shape, fv.size()));
      ref.gradients(rule.points[q], std::span<double>(grad, fv.size() * ref.dim));
      Point ds = Point::Zero(), dt = Point::Zero();
      for (std::size_t i = 0; i < fv.size(); ++i) {
        ds += grad[i * ref.dim] * mesh.vertex(fv[i]);
        if (ref.dim == 2) dt += grad[i * ref.dim + 1] * mesh.vertex(fv[i]);
      }
      const double J = ref.dim == 1 ? ds.norm() : ds.cross(dt).norm();
      if (!(J > 0))
        throw Error(where + ": boundary face with first vertex " + std::to_string(fv[0]) + " is degenerate");
      const double w = J * rule.weights[q];
      face.measure += w;
      for (std::size_t i = 0; i < fv.size(); ++i) masses_[face.nodes[i]] += w * shape[i];
    }
    faces_.push_back(std::move(face));
  }
}

}  // namespace obs
