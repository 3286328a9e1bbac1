#pragma once
/// \file Material.hpp
/// Isotropic linear-elastic material (Hooke's law). In 2D obs uses plane strain.
///   lambda = E nu / ((1+nu)(1-2nu)),  mu = E / (2(1+nu))          (MATH.md §1)
#include "obs/mesh/Error.hpp"

namespace obs {

struct Material {
  double youngsModulus = 1.0;  ///< E > 0
  double poissonRatio = 0.0;   ///< 0 <= nu < 0.5 (obs does not accept auxetic materials)
  double density = 0.0;        ///< rho, used by dynamic scenes only

  double lambda() const {
    const double E = youngsModulus, nu = poissonRatio;
    return E * nu / ((1 + nu) * (1 - 2 * nu));
  }
  double mu() const { return youngsModulus / (2 * (1 + poissonRatio)); }

  /// Throws obs::Error unless E > 0 (finite) and 0 <= nu < 0.5.
  void validate() const;
};

}  // namespace obs
