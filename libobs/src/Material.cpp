#include "obs/obs/Material.hpp"

#include <cmath>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs {

void Material::validate() const {
  if (!std::isfinite(youngsModulus) || youngsModulus <= 0)
    throw Error("material: Young's modulus E must be positive and finite, got " +
                std::to_string(youngsModulus));
  if (!std::isfinite(poissonRatio) || poissonRatio < 0 || poissonRatio >= 0.5)
    throw Error("material: Poisson's ratio nu must lie in [0, 0.5), got " +
                std::to_string(poissonRatio));
  if (!std::isfinite(density) || density <= 0)
    throw Error("material: density rho must be positive and finite, got " + std::to_string(density));
}

}  // namespace obs
