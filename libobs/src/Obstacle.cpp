#include "obs/obs/Obstacle.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "obs/mesh/Error.hpp"

namespace obs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string str(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

[[noreturn]] void fail(const std::string& obstacle, const std::string& parameter, const std::string& what) {
  throw Error("obstacle '" + obstacle + "': parameter '" + parameter + "' " + what);
}

void requirePositive(const std::string& obstacle, const std::string& parameter, double v) {
  if (!std::isfinite(v) || v <= 0) fail(obstacle, parameter, "must be positive and finite, got " + str(v));
}

void requireNonNegative(const std::string& obstacle, const std::string& parameter, double v) {
  if (!std::isfinite(v) || v < 0) fail(obstacle, parameter, "must be non-negative and finite, got " + str(v));
}

void requireFinite(const std::string& obstacle, const std::string& parameter, const Point& p) {
  if (!p.allFinite()) fail(obstacle, parameter, "must be finite");
}

/// Unit vector of a non-zero finite direction.
Point unitDirection(const std::string& obstacle, const std::string& parameter, const Point& v) {
  const double n = v.norm();
  if (!v.allFinite() || !(n > 1e-300))
    fail(obstacle, parameter, "must be a non-zero finite vector");
  return v / n;
}

}  // namespace

// --- plane -------------------------------------------------------------------------------------

PlaneObstacle::PlaneObstacle(const Point& point, const Point& direction)
    : point_(point), nu_(unitDirection("plane", "direction", direction)) {
  requireFinite("plane", "point", point);
}

double PlaneObstacle::gap(const Point& x) const { return (point_ - x).dot(nu_); }

// --- height fields -----------------------------------------------------------------------------

HeightFieldObstacle::HeightFieldObstacle(const std::string& name, const Point& point,
                                         const Point& direction, const Point& firstTangent)
    : name_(name), point_(point), nu_(unitDirection(name, "direction", direction)) {
  requireFinite(name, "point", point);
  const Point t = unitDirection(name, "tangent", firstTangent);
  Point t1 = t - t.dot(nu_) * nu_;
  if (t1.norm() < 1e-8) {  // the tangent hint is parallel to nu: fall back to e_y (then e_x)
    t1 = Point::UnitY() - nu_.y() * nu_;
    if (t1.norm() < 1e-8) t1 = Point::UnitX() - nu_.x() * nu_;
  }
  t1_ = t1.normalized();
  t2_ = t1_.cross(nu_);
}

double HeightFieldObstacle::gap(const Point& x) const {
  const Point dx = x - point_;
  const double h = height(dx.dot(t1_), dx.dot(t2_));
  if (h == -kInf) return kInf;
  return -dx.dot(nu_) - h;
}

StripObstacle::StripObstacle(const Point& point, double halfWidth, const Point& direction,
                             const Point& across, double outsideGap)
    : HeightFieldObstacle("strip", point, direction, across), halfWidth_(halfWidth), outsideGap_(outsideGap) {
  requirePositive("strip", "halfWidth", halfWidth);
  if (std::isnan(outsideGap) || outsideGap == -kInf)
    fail("strip", "outsideGap", "must be a number or +infinity, got " + str(outsideGap));
}

double StripObstacle::height(double s1, double) const {
  return std::abs(s1) <= halfWidth_ * (1 + 1e-12) ? 0.0 : -kInf;
}

double StripObstacle::gap(const Point& x) const {
  const double g = HeightFieldObstacle::gap(x);
  return g == kInf ? outsideGap_ : g;
}

WedgeObstacle::WedgeObstacle(const Point& apex, double slope, const Point& direction)
    : HeightFieldObstacle("wedge", apex, direction), slope_(slope) {
  requireNonNegative("wedge", "slope", slope);
}

PyramidObstacle::PyramidObstacle(const Point& apex, double slope, const Point& direction)
    : HeightFieldObstacle("pyramid", apex, direction), slope_(slope) {
  requireNonNegative("pyramid", "slope", slope);
}

double PyramidObstacle::height(double s1, double s2) const {
  return -slope_ * std::max(std::abs(s1), std::abs(s2));
}

HatObstacle::HatObstacle(const Point& centre, double height, double radius, const Point& direction)
    : HeightFieldObstacle("hat", centre, direction), height_(height), radius_(radius) {
  if (!std::isfinite(height)) fail("hat", "height", "must be finite, got " + str(height));
  requirePositive("hat", "radius", radius);
}

double HatObstacle::height(double s1, double s2) const {
  const double q = (s1 * s1 + s2 * s2) / (radius_ * radius_);
  return q < 1 ? height_ * (1 - q) * (1 - q) : 0.0;
}

SineWaveObstacle::SineWaveObstacle(const Point& point, double amplitude, double wavelength,
                                   const Point& direction)
    : HeightFieldObstacle("sine-wave", point, direction), amplitude_(amplitude), wavelength_(wavelength) {
  if (!std::isfinite(amplitude)) fail("sine-wave", "amplitude", "must be finite, got " + str(amplitude));
  requirePositive("sine-wave", "wavelength", wavelength);
}

double SineWaveObstacle::height(double s1, double) const {
  return amplitude_ * std::cos(2 * std::numbers::pi * s1 / wavelength_);
}

SmileyObstacle::SmileyObstacle(const Point& centre, double radius, double slope, const Point& direction)
    : HeightFieldObstacle("smiley", centre, direction), radius_(radius), slope_(slope) {
  requirePositive("smiley", "radius", radius);
  requireNonNegative("smiley", "slope", slope);
}

double SmileyObstacle::distance(double s1, double s2) const {
  const double R = radius_;
  const double r = std::hypot(s1, s2);
  double d = std::abs(r - R);  // the outline
  for (const double side : {-1.0, 1.0})  // the eyes: discs of radius R/10
    d = std::min(d, std::max(0.0, std::hypot(s1 - side * 0.35 * R, s2 - 0.3 * R) - 0.1 * R));
  // the mouth: arc of radius 0.6 R between the polar angles 210 and 330 degrees
  constexpr double deg = std::numbers::pi / 180;
  const double rm = 0.6 * R, a0 = 210 * deg, a1 = 330 * deg;
  double angle = std::atan2(s2, s1);
  if (angle < 0) angle += 2 * std::numbers::pi;
  if (r > 0 && angle >= a0 && angle <= a1) {
    d = std::min(d, std::abs(r - rm));
  } else {
    for (const double a : {a0, a1})
      d = std::min(d, std::hypot(s1 - rm * std::cos(a), s2 - rm * std::sin(a)));
  }
  return d;
}

// --- ball / disk -------------------------------------------------------------------------------

BallObstacle::BallObstacle(const Point& centre, double radius, const Point& direction, Direction mode)
    : BallObstacle("ball", centre, radius, direction, mode) {}

BallObstacle::BallObstacle(const std::string& name, const Point& centre, double radius,
                           const Point& direction, Direction mode)
    : centre_(centre), nu_(unitDirection(name, "direction", direction)), radius_(radius), mode_(mode) {
  requireFinite(name, "centre", centre);
  requirePositive(name, "radius", radius);
}

double BallObstacle::gap(const Point& x) const {
  const Point dx = x - centre_;
  if (mode_ == Direction::Normal) return dx.norm() - radius_;
  const double a = dx.dot(nu_);
  const double r2 = (dx - a * nu_).squaredNorm();
  const double R2 = radius_ * radius_;
  if (r2 > R2) return kInf;
  return -a - std::sqrt(R2 - r2);
}

Point BallObstacle::direction(const Point& x) const {
  if (mode_ == Direction::Fixed) return nu_;
  const Point dx = centre_ - x;
  const double n = dx.norm();
  return n > 0 ? Point(dx / n) : nu_;  // at the centre any direction is as good: use the fixed one
}

DiskObstacle::DiskObstacle(const Point& centre, double radius, const Point& direction, Direction mode)
    : BallObstacle("disk", centre, radius, direction, mode) {}

// --- user callable -----------------------------------------------------------------------------

FunctionObstacle::FunctionObstacle(GapFunction gap, DirectionFunction direction, std::string name,
                                   int dimension)
    : gap_(std::move(gap)), direction_(std::move(direction)), name_(std::move(name)), dimension_(dimension) {
  if (!gap_) fail(name_, "gap", "must be a callable");
  if (!direction_) fail(name_, "direction", "must be a callable");
  if (dimension != 0 && dimension != 2 && dimension != 3)
    fail(name_, "dimension", "must be 0, 2 or 3, got " + std::to_string(dimension));
}

}  // namespace obs
