#pragma once
/// \file AnalyticContact.hpp
/// Analytic half-space references of the thesis' benchmark examples (docs/theory.md#analytic-references;
/// thesis Sec. 1.2.2, 4.2.1, 4.2.2; Johnson, Contact Mechanics): contact pressures p = -sigma_nu and contact
/// radii for a given total load P (per unit thickness in 2D, plane strain E* = E / (1 - nu^2)).
/// Every pressure integrates to P over the contact zone. Parameters are checked (obs::Error naming
/// the reference and the parameter); points outside the contact zone have pressure 0.
///
///   punch (2D, flat rigid punch of half width b):  p(s) = P / (pi sqrt(b^2 - s^2)),  |s| < b
///   wedge (2D, cot alpha = m):  b = P (1 - nu^2) / (E m),
///         p(s) = E m / (2 pi (1 - nu^2)) ln((b + sqrt(b^2 - s^2)) / (b - sqrt(b^2 - s^2)))
///   Hertz (3D, rigid ball of radius R):  b = (3 P R (1 - nu^2) / (4 E))^{1/3},
///         p(r) = 3 P / (2 pi b^3) sqrt(b^2 - r^2)
/// s is the signed distance from the centre of contact along the surface, r the radial distance.
/// The punch pressure is singular at s = +-b (and not square integrable there); the wedge
/// pressure is logarithmically singular at s = 0.
#include <functional>
#include <vector>

#include "obs/mesh/Mesh.hpp"

namespace obs::estimators {

using mesh::Point;

double punchPressure(double s, double load, double halfWidth);

double wedgeContactRadius(double load, double youngsModulus, double poissonRatio, double cotAlpha);
double wedgePressure(double s, double load, double youngsModulus, double poissonRatio, double cotAlpha);

double hertzContactRadius(double load, double youngsModulus, double poissonRatio, double radius);
double hertzPressure(double r, double load, double youngsModulus, double poissonRatio, double radius);

/// An analytic reference for AdaptiveLoop: the exact pressure at a point of Gamma_C for a load P,
/// the exact contact radius for a load P, and the centre of contact (the "centre node" is the
/// potential contact vertex nearest to it). The docs/theory.md#analytic-references examples:
/// punchReference(), wedgeReference(), hertzReference() with the thesis' geometry (centre (0.5, 0) in 2D,
/// (0.5, 0.5, 0) in 3D).
struct ContactReference {
  std::function<double(const Point& x, double load)> pressure;
  std::function<double(double load)> radius;
  Point centre = Point::Zero();
  int quadratureDegree = 6;  ///< face quadrature of the L2 norms (docs/theory.md#pressure-error)
};

/// One potential contact vertex for nodalPressureError: its position x_p, its boundary weight m_p
/// (the lumped boundary mass int_{Gamma_C} phi_p; in 2D the trapezoidal weights) and its discrete
/// contact pressure s_p.
struct NodalPressure {
  Point x = Point::Zero();
  double weight = 0;
  double pressure = 0;
};

/// The relative nodal L2 pressure error against the reference for the load P
/// (docs/theory.md#pressure-error):
///   sqrt( sum_p m_p (s_p - p(x_p; P))^2 / sum_p m_p p(x_p; P)^2 ),
/// the sums over the vertices strictly inside the exact contact zone, 0 < p(x_p; P) < inf (for the
/// punch |s_p| < b: its two edge vertices, where p is infinite, are left out; nothing else is).
/// P is whatever the caller passes: the load computed on the same grid, or a fixed one (the
/// thesis' P = 1549.10 for the punch). NaN if no vertex lies inside the exact contact zone.
double nodalPressureError(const std::vector<NodalPressure>& nodes, const ContactReference& ref, double load);

ContactReference punchReference(double halfWidth = 0.0625, const Point& centre = Point(0.5, 0, 0));
ContactReference wedgeReference(double youngsModulus = 3e5, double poissonRatio = 0.25,
                                double cotAlpha = 0.2, const Point& centre = Point(0.5, 0, 0));
ContactReference hertzReference(double youngsModulus = 3e5, double poissonRatio = 0.25,
                                double radius = 0.75, const Point& centre = Point(0.5, 0.5, 0));

}  // namespace obs::estimators
