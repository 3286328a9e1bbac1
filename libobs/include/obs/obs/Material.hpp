#pragma once
/// \file Material.hpp
/// Isotropic linear-elastic material (Hooke's law). In 2D obs uses plane strain.
///   lambda = E nu / ((1+nu)(1-2nu)),  mu = E / (2(1+nu))          (docs/theory.md#signorini)
/// and how its volumetric part is discretised: the standard displacement formulation, or B-bar
/// (mean dilatation) for nearly incompressible materials, nu -> 1/2 (docs/theory.md#b-bar).
#include "obs/mesh/Error.hpp"

namespace obs {

/// Discretisation of the volumetric strain energy lambda/2 (div u)^2.
enum class VolumetricFormulation {
  Standard,  ///< full integration: locks (too stiff) as nu -> 1/2 for every cell type
  BBar,      ///< B-bar / mean dilatation: div u replaced by its cell mean in the volumetric part;
             ///< removes locking on quadrilaterals and hexahedra and reduces it on pyramids; on
             ///< triangles and tetrahedra div u is constant per cell, so it equals Standard and still
             ///< locks (prisms: only where u varies along the prism axis)
};

struct Material {
  double youngsModulus = 1.0;  ///< E > 0
  double poissonRatio = 0.0;   ///< 0 <= nu < 0.5 (obs does not accept auxetic materials)
  double density = 1.0;        ///< rho > 0 (mass per volume), used by the mass matrices (docs/theory.md#newmark)
  VolumetricFormulation formulation = VolumetricFormulation::Standard;

  double lambda() const {
    const double E = youngsModulus, nu = poissonRatio;
    return E * nu / ((1 + nu) * (1 - 2 * nu));
  }
  double mu() const { return youngsModulus / (2 * (1 + poissonRatio)); }
  /// Bulk modulus kappa = lambda + 2 mu / 3 (of the 3D material; plane strain is a 3D state).
  double bulkModulus() const { return lambda() + 2 * mu() / 3; }

  /// Throws obs::Error unless E > 0 (finite), 0 <= nu < 0.5 and rho > 0 (finite).
  void validate() const;
};

}  // namespace obs
