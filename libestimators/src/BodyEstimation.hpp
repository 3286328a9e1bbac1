#pragma once
/// \file BodyEstimation.hpp
/// What the adaptive loops (AdaptiveLoop, DistributedAdaptiveLoop) need to estimate several bodies
/// (docs/theory.md#two-body-estimator): of a mortar pair the boundary surfaces, the lumped boundary
/// mass that turns nodal master forces into a traction and the exact gap of the slave side; the
/// bodies' estimates together. Internal to libestimators.
#include <Eigen/Core>

#include <string>
#include <vector>

#include "obs/estimators/Estimator.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/mesh/SurfaceMesh.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/SurfaceObstacle.hpp"

namespace obs::estimators {

using mesh::Index;

/// The boundary faces with id `id` of `m` as a surface mesh; meshVertex (if given) receives the
/// mesh vertex of each surface vertex.
mesh::SurfaceMesh boundarySurface(const mesh::Mesh& m, int id, const std::string& label,
                                  std::vector<Index>* meshVertex = nullptr);

/// int_{Gamma} phi_q over the boundary faces with id `id`, per vertex (0 elsewhere).
std::vector<double> boundaryLumpedMass(const mesh::Mesh& m, int id);

/// The exact gap of the slave side of a mortar pair (docs/theory.md#two-body-estimator), in the
/// linearisation of the mortar constraint: at a point x of the slave surface with the slave face
/// normal n (of the face nearest to x; the mortar projection direction), the distance t along n to
/// the undeformed, faceted master surface plus the master displacement there along n,
/// g(x) = t + n . u_M(x + t n).
class MortarGapObstacle : public Obstacle {
public:
  /// The slave and master surfaces (whole: every face of the pair's boundaries), the master
  /// displacement at each master surface vertex, and a slave node with its mortar normal (orients
  /// the slave face normals). Throws obs::Error for a surface SurfaceObstacle refuses.
  MortarGapObstacle(const mesh::SurfaceMesh& slave, const mesh::SurfaceMesh& master,
                    std::vector<Point> masterDisplacement, const Point& probe, const Point& probeNormal);
  double gap(const Point& x) const override;
  Point direction(const Point& x) const override;
  std::string name() const override { return "mortar"; }

private:
  SurfaceObstacle slave_, master_;
  double flip_ = 1;
  std::vector<Point> displacement_;
};

/// The estimates of several bodies together: eta = (sum_b eta_b^2)^1/2 and each contribution
/// eta_k = (sum_b eta_{k,b}^2)^1/2 (names in the order they first appear); one estimate: its own
/// values. `results` must not be empty.
struct CombinedEstimate {
  double total = 0;
  std::vector<Contribution> contributions;
};
CombinedEstimate combineEstimates(const std::vector<const EstimatorResult*>& results);

}  // namespace obs::estimators
