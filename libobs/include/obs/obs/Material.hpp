#pragma once
/// \file Material.hpp
/// Isotropic linear-elastic material (Hooke's law). In 2D obs uses plane strain.
///   lambda = E nu / ((1+nu)(1-2nu)),  mu = E / (2(1+nu))          (docs/theory.md#signorini)
#include "obs/mesh/Error.hpp"

namespace obs {

struct Material {
  double youngsModulus = 1.0;  ///< E > 0
  double poissonRatio = 0.0;   ///< 0 <= nu < 0.5 (obs does not accept auxetic materials)
  double density = 1.0;        ///< rho > 0 (mass per volume), used by the mass matrices (docs/theory.md#newmark)

  double lambda() const {
    const double E = youngsModulus, nu = poissonRatio;
    return E * nu / ((1 + nu) * (1 - 2 * nu));
  }
  double mu() const { return youngsModulus / (2 * (1 + poissonRatio)); }

  /// Throws obs::Error unless E > 0 (finite), 0 <= nu < 0.5 and rho > 0 (finite).
  void validate() const;
};

}  // namespace obs
