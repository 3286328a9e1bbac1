#pragma once
/// \file Obstacle.hpp
/// Rigid obstacles of the Signorini problem (docs/theory.md#signorini, thesis Sec. 1.2.2 and 4.2): an
/// obstacle gives,
/// at a point x of the undeformed body, the constraint direction nu(x) (unit, pointing from the body
/// into the obstacle) and the gap g(x), the signed distance from x to the obstacle surface measured
/// along nu(x). The linearised non-penetration condition is u(x) . nu(x) <= g(x).
///   g > 0  the body is apart from the obstacle;  g = 0  touching;  g < 0  the undeformed body
///   penetrates the obstacle (valid: the solution is then pushed out);  g = +infinity  the line through
///   x along nu misses the obstacle, i.e. x is unconstrained.
///
/// Most obstacles here are height fields over a reference point a with a fixed direction nu: with the
/// orthonormal tangential frame t1, t2 of nu (t1 = e_x projected onto nu^perp and normalised, or e_y if
/// nu is parallel to e_x; t2 = t1 x nu), tangential coordinates s_i = (x - a) . t_i and the height of
/// the obstacle surface above a measured against nu, h(s) (h = -infinity: no obstacle there),
///   g(x) = (a - x) . nu - h(s)  =  "height of x above a"  -  "height of the surface".
/// For nu = -e_y (2D) or nu = -e_z (3D) this is t1 = e_x, t2 = e_y (3D) and g = x_vert - a_vert - h.
///
/// Parameter validation throws obs::Error naming the obstacle and the parameter.
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>

#include "obs/mesh/Mesh.hpp"

namespace obs {

using mesh::Point;

class Obstacle {
public:
  virtual ~Obstacle() = default;
  /// Signed gap g(x) along direction(x); +infinity where unconstrained.
  virtual double gap(const Point& x) const = 0;
  /// Constraint direction nu(x), a unit vector (z = 0 in 2D).
  virtual Point direction(const Point& x) const = 0;
  /// Short name used in messages and scene files ("plane", "ball", ...).
  virtual std::string name() const = 0;
  /// Spatial dimension the obstacle is made for (2 or 3), 0 if it works in both.
  virtual int dimension() const { return 0; }
};

/// Half-space obstacle {y : (y - point) . nu >= 0} bounded by the plane through `point` with normal nu;
/// nu is the constraint direction (the outward normal of the body's contact boundary, pointing into
/// the obstacle):  g(x) = (point - x) . nu.
class PlaneObstacle : public Obstacle {
public:
  PlaneObstacle(const Point& point, const Point& direction);
  double gap(const Point& x) const override;
  Point direction(const Point&) const override { return nu_; }
  std::string name() const override { return "plane"; }

private:
  Point point_, nu_;
};

/// Base of the height-field obstacles (see the file comment): reference point a, direction nu,
/// tangential frame t1, t2 and g(x) = (a - x) . nu - height(s1, s2).
class HeightFieldObstacle : public Obstacle {
public:
  double gap(const Point& x) const override;
  Point direction(const Point&) const override { return nu_; }
  std::string name() const override { return name_; }
  /// Height of the obstacle surface above the reference point at tangential coordinates (s1, s2);
  /// -infinity where there is no obstacle.
  virtual double height(double s1, double s2) const = 0;
  const Point& referencePoint() const { return point_; }
  const Point& tangent1() const { return t1_; }
  const Point& tangent2() const { return t2_; }

protected:
  /// `firstTangent` (optional, non-zero) replaces e_x as the vector projected to get t1.
  HeightFieldObstacle(const std::string& name, const Point& point, const Point& direction,
                      const Point& firstTangent = Point::UnitX());

private:
  std::string name_;
  Point point_, nu_, t1_, t2_;
};

/// Flat punch of half width w (thesis Sec. 1.2.2 (1.27), docs/theory.md#punch): a flat face through
/// `point` on the band |s1| <= w across t1, nothing elsewhere:
///   h(s) = 0 for |s1| <= w (1e-12 relative tolerance at the band edge), h = -infinity otherwise,
/// i.e. g(x) = (point - x) . nu on the band and g = +infinity outside (`outsideGap` replaces +infinity,
/// e.g. 0.5 as in the thesis' Example 4). In 3D the band is a strip along t2.
class StripObstacle : public HeightFieldObstacle {
public:
  StripObstacle(const Point& point, double halfWidth, const Point& direction,
                const Point& across = Point::UnitX(),
                double outsideGap = std::numeric_limits<double>::infinity());
  double gap(const Point& x) const override;
  double height(double s1, double s2) const override;

private:
  double halfWidth_, outsideGap_;
};

/// Wedge with apex a and slope cot(alpha) = m (thesis (1.28)-(1.29), docs/theory.md#wedge: a = (0.5, 0),
/// m = 0.2, nu = -e_y gives g = 0.2 |x - 0.5| on y = 0):  h(s) = -m |s1|,  g = (a - x) . nu + m |s1|.
/// A 2D obstacle; in 3D it is a ridge along t2.
class WedgeObstacle : public HeightFieldObstacle {
public:
  WedgeObstacle(const Point& apex, double slope, const Point& direction = -Point::UnitY());
  double height(double s1, double) const override { return -slope_ * std::abs(s1); }

private:
  double slope_;
};

/// Square pyramid with apex a and side slope m (tan of the angle between a side and the base; the
/// thesis' Example 5 has 45 degrees, m = 1), sides along t1 and t2:
///   h(s) = -m max(|s1|, |s2|).
class PyramidObstacle : public HeightFieldObstacle {
public:
  PyramidObstacle(const Point& apex, double slope, const Point& direction = -Point::UnitZ());
  double height(double s1, double s2) const override;
  int dimension() const override { return 3; }

private:
  double slope_;
};

/// A hat (thesis Example 7, whose shape the thesis only shows in a figure; obs' choice): a smooth
/// crown of height H and radius R on a flat brim through the reference point,
///   h(s) = H (1 - r^2/R^2)^2 for r = |s| < R,  h = 0 otherwise,
/// convex near the top and concave towards the brim, so both g > g_m and g < g_m occur (eta_7, eta_8).
class HatObstacle : public HeightFieldObstacle {
public:
  HatObstacle(const Point& centre, double height, double radius, const Point& direction);
  double height(double s1, double s2) const override;

private:
  double height_, radius_;
};

/// Corrugated surface with amplitude A and wavelength L along t1 (constant along t2), crest at the
/// reference point:  h(s) = A cos(2 pi s1 / L).
class SineWaveObstacle : public HeightFieldObstacle {
public:
  SineWaveObstacle(const Point& point, double amplitude, double wavelength, const Point& direction);
  double height(double s1, double) const override;

private:
  double amplitude_, wavelength_;
};

/// A "smiley" (thesis Example 9, whose obstacle the thesis only shows through the refined grids;
/// obs' design): sharp ridges of side slope m whose crests, at the height of the reference point a
/// (the face centre), draw a face of radius R in the tangential plane:
///   the outline  |s| = R,
///   two eyes     discs of radius R/10 centred at s = (-0.35 R, 0.3 R) and (0.35 R, 0.3 R),
///   a mouth      the arc |s| = 0.6 R for polar angles atan2(s2, s1) in [210, 330] degrees.
/// With d(s) the Euclidean distance of s = (s1, s2) to the union S of these curves and discs,
///   h(s) = -m d(s),   g(x) = (a - x) . nu + m d(s),
/// so g = 0 exactly on S (x in the tangential plane through a) and grows linearly away from it: a
/// body pressed against the obstacle touches it along the smiley only (for small enough loads).
/// A 3D obstacle (a 2D body would see a cross-section only).
class SmileyObstacle : public HeightFieldObstacle {
public:
  SmileyObstacle(const Point& centre, double radius, double slope, const Point& direction = -Point::UnitZ());
  double height(double s1, double s2) const override { return -slope_ * distance(s1, s2); }
  /// d(s): distance of (s1, s2) to the smiley's curves and discs (0 on them).
  double distance(double s1, double s2) const;
  int dimension() const override { return 3; }

private:
  double radius_, slope_;
};

/// Rigid ball (3D) with centre c and radius R. Two choices of direction:
///  - Fixed (default, nu = -e_z, thesis Sec. 1.2.2 / 4.2.2 Hertz): g is the distance along nu from x to
///    the near cap of the sphere. With x - c = a nu + w, w . nu = 0, r = |w|:
///      g(x) = -a - sqrt(R^2 - r^2)  for r <= R,   g = +infinity for r > R.
///    For nu = -e_z: g = (x_z - c_z) - sqrt(R^2 - r^2); for c = (0.5, 0.5, -R) and x on z = 0 this is
///    the Hertz gap g = R - sqrt(R^2 - r^2) (docs/theory.md#hertz), r = distance from (0.5, 0.5).
///  - Normal: nu(x) = (c - x)/|c - x| (the obstacle normal at the closest point), g = |x - c| - R.
class BallObstacle : public Obstacle {
public:
  enum class Direction { Fixed, Normal };
  BallObstacle(const Point& centre, double radius, const Point& direction = -Point::UnitZ(),
               Direction mode = Direction::Fixed);
  double gap(const Point& x) const override;
  Point direction(const Point& x) const override;
  std::string name() const override { return "ball"; }
  int dimension() const override { return 3; }

protected:
  BallObstacle(const std::string& name, const Point& centre, double radius, const Point& direction,
               Direction mode);

private:
  Point centre_, nu_;
  double radius_;
  Direction mode_;
};

/// The 2D ball: a rigid disk (centre z = 0), same formulas as BallObstacle with default nu = -e_y.
class DiskObstacle : public BallObstacle {
public:
  DiskObstacle(const Point& centre, double radius, const Point& direction = -Point::UnitY(),
               Direction mode = Direction::Fixed);
  std::string name() const override { return "disk"; }
  int dimension() const override { return 2; }
};

/// A user obstacle from callables: gap(x) and direction(x) (normalised by the ContactSet).
class FunctionObstacle : public Obstacle {
public:
  using GapFunction = std::function<double(const Point&)>;
  using DirectionFunction = std::function<Point(const Point&)>;
  FunctionObstacle(GapFunction gap, DirectionFunction direction, std::string name = "function",
                   int dimension = 0);
  double gap(const Point& x) const override { return gap_(x); }
  Point direction(const Point& x) const override { return direction_(x); }
  std::string name() const override { return name_; }
  int dimension() const override { return dimension_; }

private:
  GapFunction gap_;
  DirectionFunction direction_;
  std::string name_;
  int dimension_;
};

}  // namespace obs
