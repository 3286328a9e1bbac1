#include "BodyEstimation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <utility>

#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs::estimators {

mesh::SurfaceMesh boundarySurface(const mesh::Mesh& m, int id, const std::string& label,
                                  std::vector<Index>* meshVertex) {
  mesh::SurfaceMesh s;
  s.dimension = m.dimension();
  s.source = label;
  std::vector<Index> local(static_cast<std::size_t>(m.numVertices()), -1);
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
    if (m.boundaryFaceId(f) != id) continue;
    const auto fv = m.boundaryFaceVertices(f);
    std::array<Index, 4> face{};
    for (std::size_t i = 0; i < fv.size(); ++i) {
      Index& l = local[static_cast<std::size_t>(fv[i])];
      if (l < 0) {
        l = static_cast<Index>(s.vertices.size());
        s.vertices.push_back(m.vertex(fv[i]));
        if (meshVertex) meshVertex->push_back(fv[i]);
      }
      face[i] = l;
    }
    s.types.push_back(mesh::faceTypeFromVertexCount(static_cast<int>(fv.size())));
    s.faces.push_back(face);
  }
  return s;
}

std::vector<double> boundaryLumpedMass(const mesh::Mesh& m, int id) {
  std::vector<double> mass(static_cast<std::size_t>(m.numVertices()), 0.0);
  double shape[4], grad[8];
  for (Index f = 0; f < m.numBoundaryFaces(); ++f) {
    if (m.boundaryFaceId(f) != id) continue;
    const auto fv = m.boundaryFaceVertices(f);
    const mesh::CellType ft = mesh::faceTypeFromVertexCount(static_cast<int>(fv.size()));
    const auto& ref = mesh::referenceElement(ft);
    const auto& rule = mesh::quadratureRule(ft, 2);
    for (std::size_t q = 0; q < rule.size(); ++q) {
      ref.values(rule.points[q], std::span<double>(shape, fv.size()));
      ref.gradients(rule.points[q], std::span<double>(grad, fv.size() * ref.dim));
      Point ds = Point::Zero(), dt = Point::Zero();
      for (std::size_t i = 0; i < fv.size(); ++i) {
        ds += grad[i * ref.dim] * m.vertex(fv[i]);
        if (ref.dim == 2) dt += grad[i * ref.dim + 1] * m.vertex(fv[i]);
      }
      const double w = rule.weights[q] * (ref.dim == 1 ? ds.norm() : ds.cross(dt).norm());
      for (std::size_t i = 0; i < fv.size(); ++i) mass[static_cast<std::size_t>(fv[i])] += w * shape[i];
    }
  }
  return mass;
}

MortarGapObstacle::MortarGapObstacle(const mesh::SurfaceMesh& slave, const mesh::SurfaceMesh& master,
                                     std::vector<Point> masterDisplacement, const Point& probe, const Point& probeNormal)
    : slave_(slave, SurfaceObstacle::ClosestPoint{}), master_(master, probeNormal),
      displacement_(std::move(masterDisplacement)) {
  flip_ = slave_.nearest(probe).normal.dot(probeNormal) < 0 ? -1.0 : 1.0;
}

double MortarGapObstacle::gap(const Point& x) const {
  const Point n = direction(x);
  const auto hit = master_.hitAlong(x, n);
  if (!hit) return std::numeric_limits<double>::infinity();
  Point u = Point::Zero();
  for (std::size_t i = 0; i < 3; ++i)
    if (hit->vertices[i] >= 0) u += hit->weights[i] * displacement_[static_cast<std::size_t>(hit->vertices[i])];
  return hit->t + n.dot(u);
}

Point MortarGapObstacle::direction(const Point& x) const {
  const Point n = slave_.nearest(x).normal;
  return flip_ * n.normalized();
}

CombinedEstimate combineEstimates(const std::vector<const EstimatorResult*>& results) {
  if (results.size() == 1) return {results.front()->total, results.front()->contributions};
  CombinedEstimate c;
  for (const EstimatorResult* r : results) {
    c.total += r->total * r->total;
    for (const Contribution& part : r->contributions) {
      auto it = std::find_if(c.contributions.begin(), c.contributions.end(),
                             [&](const Contribution& e) { return e.name == part.name; });
      if (it == c.contributions.end()) it = c.contributions.insert(c.contributions.end(), Contribution{part.name, 0});
      it->value += part.value * part.value;
    }
  }
  c.total = std::sqrt(c.total);
  for (Contribution& part : c.contributions) part.value = std::sqrt(part.value);
  return c;
}

}  // namespace obs::estimators
