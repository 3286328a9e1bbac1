#include "obs/estimators/AnalyticContact.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

void requirePositive(double v, const char* reference, const char* parameter) {
  if (!(v > 0) || !std::isfinite(v))
    throw Error(std::string(reference) + " reference: " + parameter + " must be positive and finite, got " +
                std::to_string(v));
}
void requireMaterial(double E, double nu, const char* reference) {
  requirePositive(E, reference, "Young's modulus");
  if (!(nu > -1 && nu < 0.5))
    throw Error(std::string(reference) + " reference: Poisson ratio must lie in (-1, 0.5), got " + std::to_string(nu));
}
void requireLoad(double load, const char* reference) {
  if (!(load >= 0) || !std::isfinite(load))
    throw Error(std::string(reference) + " reference: the load must be finite and >= 0, got " + std::to_string(load));
}

}  // namespace

double punchPressure(double s, double load, double halfWidth) {
  requirePositive(halfWidth, "punch", "half width");
  requireLoad(load, "punch");
  const double q = halfWidth * halfWidth - s * s;
  return q > 0 ? load / (std::numbers::pi * std::sqrt(q)) : 0.0;
}

double wedgeContactRadius(double load, double E, double nu, double cotAlpha) {
  requireMaterial(E, nu, "wedge");
  requirePositive(cotAlpha, "wedge", "cot alpha");
  requireLoad(load, "wedge");
  return load * (1 - nu * nu) / (E * cotAlpha);
}

double wedgePressure(double s, double load, double E, double nu, double cotAlpha) {
  const double b = wedgeContactRadius(load, E, nu, cotAlpha);
  const double q = b * b - s * s;
  if (!(q > 0)) return 0.0;
  // ln((b + sqrt q) / (b - sqrt q)) = 2 acosh(b / |s|), written without cancellation
  const double logTerm = s == 0 ? std::numeric_limits<double>::infinity() : 2 * std::acosh(b / std::abs(s));
  return E * cotAlpha / (2 * std::numbers::pi * (1 - nu * nu)) * logTerm;
}

double hertzContactRadius(double load, double E, double nu, double radius) {
  requireMaterial(E, nu, "Hertz");
  requirePositive(radius, "Hertz", "ball radius");
  requireLoad(load, "Hertz");
  return std::cbrt(3 * load * radius * (1 - nu * nu) / (4 * E));
}

double hertzPressure(double r, double load, double E, double nu, double radius) {
  const double b = hertzContactRadius(load, E, nu, radius);
  const double q = b * b - r * r;
  return q > 0 ? 3 * load / (2 * std::numbers::pi * b * b * b) * std::sqrt(q) : 0.0;
}

double nodalPressureError(const std::vector<NodalPressure>& nodes, const ContactReference& ref, double load) {
  double num = 0, den = 0;
  for (const NodalPressure& n : nodes) {
    const double p = ref.pressure(n.x, load);
    if (!std::isfinite(p) || !(p > 0)) continue;  // strictly inside the exact contact zone only
    num += n.weight * (n.pressure - p) * (n.pressure - p);
    den += n.weight * p * p;
  }
  return den > 0 ? std::sqrt(num / den) : std::numeric_limits<double>::quiet_NaN();
}

ContactReference punchReference(double halfWidth, const Point& centre) {
  requirePositive(halfWidth, "punch", "half width");
  ContactReference r;
  r.centre = centre;
  r.pressure = [halfWidth, centre](const Point& x, double load) {
    return punchPressure(x[0] - centre[0], load, halfWidth);
  };
  r.radius = [halfWidth](double) { return halfWidth; };
  return r;
}

ContactReference wedgeReference(double E, double nu, double cotAlpha, const Point& centre) {
  wedgeContactRadius(0, E, nu, cotAlpha);  // checks the parameters
  ContactReference r;
  r.centre = centre;
  r.pressure = [=](const Point& x, double load) { return wedgePressure(x[0] - centre[0], load, E, nu, cotAlpha); };
  r.radius = [=](double load) { return wedgeContactRadius(load, E, nu, cotAlpha); };
  return r;
}

ContactReference hertzReference(double E, double nu, double radius, const Point& centre) {
  hertzContactRadius(0, E, nu, radius);
  ContactReference r;
  r.centre = centre;
  r.pressure = [=](const Point& x, double load) {
    return hertzPressure(std::hypot(x[0] - centre[0], x[1] - centre[1]), load, E, nu, radius);
  };
  r.radius = [=](double load) { return hertzContactRadius(load, E, nu, radius); };
  return r;
}

}  // namespace obs::estimators
