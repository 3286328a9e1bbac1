#pragma once
/// \file ObstacleFactory.hpp
/// Obstacle types of the scene section [contact] (docs/scenes.md): name -> parameters -> the
/// obs::Obstacle of libobs (Obstacle.hpp, docs/theory.md#signorini). Every obstacle gives the constraint
/// u . nu <= g(x) at the vertices of the contact boundary, nu pointing from the body into the
/// obstacle. Types (gap formulas with d = (a - x) . nu the height of the reference point a above
/// x along nu, s1, s2 the tangential coordinates of x - a, see Obstacle.hpp):
///   plane       point, direction                      g = (point - x) . nu
///   strip       point, half_width > 0, direction, across, outside_gap
///                                                     g = d for |s1| <= half_width, else outside_gap
///                                                     (default +inf: unconstrained)
///   wedge  (2D) apex, slope >= 0, direction           g = d + slope |s1|
///   pyramid(3D) apex, slope >= 0, direction           g = d + slope max(|s1|, |s2|)
///   hat         centre, height, radius > 0, direction g = d - height (1 - r^2/radius^2)^2 for r < radius,
///                                                     d elsewhere (r = |s|)
///   sine-wave   point, amplitude, wavelength > 0, direction
///                                                     g = d - amplitude cos(2 pi s1 / wavelength)
///   ball   (3D) centre, radius > 0, direction or "normal"
///   disk   (2D) centre, radius > 0, direction or "normal"
///               fixed nu: g = -(x - c) . nu - sqrt(R^2 - r^2) for r <= R (r distance of x from the
///               axis through c along nu), +inf beyond; "normal": nu = (c - x)/|c - x|, g = |x - c| - R
///   expression  gap (expression of x, y, z), direction   g = gap(x), fixed nu
///   surface     file (.msh or .stl, relative to the scene file), direction or "normal", reverse
///               fixed nu: g = distance along nu to the surface mesh (SurfaceObstacle.hpp), +inf
///               where the line misses it; "normal": g = signed distance to the nearest point c of
///               the surface, nu along c - x; the mesh must have the scene's dimension
/// `direction` defaults to -e_y (2D) / -e_z (3D) for every type.
#include <memory>
#include <string>
#include <vector>

#include "obs/drivers/Scene.hpp"
#include "obs/obs/Obstacle.hpp"

namespace obs::drivers {

/// One parameter of an obstacle type as written in [contact].
struct ObstacleParameter {
  enum class Kind { Number, Point, Direction, Expression, File, Boolean };
  enum class Range { Any, Positive, NonNegative };
  const char* key;
  Kind kind;
  bool required;
  Range range = Range::Any;  ///< for numbers
};

struct ObstacleType {
  const char* name;
  int dimension;        ///< 2 or 3: only for meshes of that dimension; 0: both
  bool normalDirection; ///< accepts direction = "normal"
  std::vector<ObstacleParameter> parameters;
};

/// Every obstacle type, in documentation order.
const std::vector<ObstacleType>& obstacleTypes();
/// The type called `name`, or nullptr.
const ObstacleType* findObstacleType(const std::string& name);
/// "plane, strip, wedge, ..." for messages.
std::string obstacleTypeNames();
/// Every parameter key of any type, plus "boundary", "obstacle" and "friction" (the keys allowed in
/// [contact]).
const std::vector<std::string>& contactKeys();

/// Builds the obstacle of scene.contact for a mesh of dimension `dim`: checks that the type is made
/// for this dimension and that every point / direction has `dim` entries (directions non-zero).
/// Throws obs::Error "<file>:<line>: [contact] <key> ..." naming the offending key.
std::unique_ptr<Obstacle> makeObstacle(const Scene& scene, int dim);

}  // namespace obs::drivers
