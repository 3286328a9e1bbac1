#pragma once
// Vertex positions of the box meshes of the mpi tests, to match a rank's vertices with the serial
// grid's: the box meshes' vertices are dyadic, so rounding to the 2^-30 lattice is exact whatever
// the last bits of the arithmetic that made them.
#include <array>
#include <cmath>

#include "obs/mesh/Mesh.hpp"

namespace obs::test {

using Position = std::array<long long, 3>;

inline Position quantise(const obs::mesh::Point& x) {
  return {std::llround(std::ldexp(x[0], 30)), std::llround(std::ldexp(x[1], 30)), std::llround(std::ldexp(x[2], 30))};
}

}  // namespace obs::test
