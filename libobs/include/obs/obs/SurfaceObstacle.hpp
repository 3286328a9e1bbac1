#pragma once
/// \file SurfaceObstacle.hpp
/// A rigid obstacle given by a surface mesh (mesh::SurfaceMesh: Gmsh or STL; the thesis' tibial
/// head is such an obstacle), docs/theory.md#surface-obstacles. The gap is exact for the piecewise
/// planar surface: quadrilaterals are split into two triangles along their first diagonal (exact
/// for planar quadrilaterals), and the line x + t nu through a point of the body is intersected with
/// every face it meets, found through a bounding-volume hierarchy (axis-aligned boxes, median
/// split) in O(log n) per point.
///
/// Gap. Each crossing of the line with a face is an entry (the face's outward normal, see
/// SurfaceMesh.hpp, opposes nu: the line enters the obstacle there) or an exit. Along the line the
/// obstacle occupies the intervals from an entry to the next exit (to +infinity if there is none,
/// as behind an open surface patch); exits without a preceding entry (the back of an open patch)
/// are ignored. Then
///   g(x) = t_entry <= 0  if x (t = 0) lies in such an interval (the body penetrates the obstacle),
///   g(x) = the smallest t_entry > 0 otherwise,   g(x) = +infinity if the line meets no entry.
/// Coinciding crossings through shared edges and vertices count once.
///
/// The constructor checks the surface and throws obs::Error naming the source and the face: non-
/// finite coordinates, degenerate faces (zero area or length), edges shared by more than two faces,
/// neighbouring faces with opposite orientation ("flipped normals"), and holes: a connected piece
/// of a 3D surface whose boundary consists of more than one closed loop (a line through the hole
/// would miss the obstacle). `reverse` flips every face (for a surface whose faces are ordered
/// clockwise seen from outside the obstacle).
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "obs/mesh/SurfaceMesh.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs {

class SurfaceObstacle : public Obstacle {
public:
  /// Tag of the closest-point mode (see below).
  struct ClosestPoint {};

  /// `direction` (non-zero, normalised here) is the constraint direction nu for every point.
  SurfaceObstacle(const mesh::SurfaceMesh& surface, const Point& direction, bool reverse = false);
  /// Closest-point mode (docs/theory.md#surface-obstacles): with c(x) the point of the surface
  /// nearest to x, g(x) = +|x - c| outside the obstacle and -|x - c| inside (the side is that of
  /// the outward normals of the faces nearest to x), and nu(x) the unit vector from the outside
  /// towards the inside along x - c (on the surface: the inward normal). The gap is finite
  /// everywhere; it is the signed distance, the linearisation the thesis uses for complex obstacles.
  SurfaceObstacle(const mesh::SurfaceMesh& surface, ClosestPoint, bool reverse = false);
  ~SurfaceObstacle() override;

  double gap(const Point& x) const override;
  Point direction(const Point& x) const override;
  std::string name() const override { return "surface"; }
  int dimension() const override { return dimension_; }

  /// One crossing of the line x + t nu with the surface.
  struct Crossing {
    double t;
    bool entry;      ///< the face's outward normal opposes nu
    int piece = -1;  ///< the planar piece crossed (internal numbering; -1 if not recorded)
  };
  /// All crossings of the line through x, sorted by t (entries first at equal t), duplicates through
  /// shared edges removed. gap() is computed from these.
  std::vector<Crossing> crossings(const Point& x) const;
  /// The same along another (unit) direction.
  std::vector<Crossing> crossings(const Point& x, const Point& direction) const;
  /// The gap of the fixed-direction mode along `direction` instead of the obstacle's own (in either
  /// mode): the distance from x along the line x + t direction to the obstacle, as gap() describes.
  /// Used for the gap to a mortar master surface along the slave normals (AdaptiveLoop.hpp).
  double gapAlong(const Point& x, const Point& direction) const;
  /// Where the line of gapAlong() meets the surface: its t (= the gap), and the point as weights
  /// of surface vertices (the corners of the segment, or of the triangle of a quadrilateral split
  /// along its first diagonal; unused entries -1 / 0), to interpolate vertex data there. nullopt
  /// where the gap is +infinity.
  struct Hit {
    double t;
    std::array<mesh::Index, 3> vertices;
    std::array<double, 3> weights;
  };
  std::optional<Hit> hitAlong(const Point& x, const Point& direction) const;
  /// The same by testing every face (no hierarchy): for tests of the hierarchy.
  std::vector<Crossing> crossingsBruteForce(const Point& x) const;
  /// True if the line through x meets the surface but only from the back (exits, no entry): the
  /// faces are probably oriented the wrong way round (see `reverse`).
  bool seesOnlyBackFaces(const Point& x) const;

  mesh::Index numTriangles() const;
  bool closestPointMode() const { return closest_; }
  /// The point of the surface nearest to x, the signed distance (negative inside the obstacle) and
  /// the sum of the outward unit normals of the faces nearest to x (several at edges and vertices).
  struct Nearest {
    Point point;
    double signedDistance;
    Point normal;
  };
  Nearest nearest(const Point& x) const;  ///< faces after quadrilaterals are split (segments in 2D)
  const std::string& source() const { return source_; }

private:
  void build(const mesh::SurfaceMesh& surface, bool reverse);

  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool closest_ = false;
  Point nu_;
  int dimension_;
  std::string source_;
};

}  // namespace obs
