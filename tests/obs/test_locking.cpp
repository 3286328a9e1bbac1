// Volumetric locking and the B-bar formulation (docs/theory.md#b-bar, docs/verification.md): Lame's
// thick-walled cylinder under internal pressure (plane strain, exact solution finite as nu -> 1/2)
// on mapped meshes. Standard quadrilaterals and hexahedra lock at nu = 0.4999 (errors of order one
// that decrease slowly); with B-bar they converge at the optimal rates with errors close to those
// of a compressible material. On triangles and tetrahedra B-bar changes nothing (div u is constant
// per cell): they lock either way.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "obs/obs/Verification.hpp"

using namespace obs;
using mesh::CellType;

namespace {

Material material(double nu, VolumetricFormulation f) {
  Material m{1.0, nu};
  m.formulation = f;
  return m;
}

bool verbose() { return std::getenv("OBS_TEST_VERBOSE") != nullptr; }

}  // namespace

TEST(Locking, BBarRemovesLockingOnQuadrilateralsAndHexahedra) {
  for (CellType type : {CellType::Quadrilateral, CellType::Hexahedron}) {
    const std::vector<int> sizes = type == CellType::Quadrilateral ? std::vector<int>{4, 8, 16} : std::vector<int>{4, 8};
    double previous = 0;
    for (int n : sizes) {
      const ManufacturedRun locked = solveThickCylinder(type, n, material(0.4999, VolumetricFormulation::Standard));
      const ManufacturedRun bbar = solveThickCylinder(type, n, material(0.4999, VolumetricFormulation::BBar));
      const ManufacturedRun compressible = solveThickCylinder(type, n, material(0.3, VolumetricFormulation::BBar));
      if (verbose())
        std::printf("%s n=%d: standard %.3e, bbar %.3e, bbar nu=0.3 %.3e\n", std::string(mesh::name(type)).c_str(), n,
                    locked.relativeL2, bbar.relativeL2, compressible.relativeL2);
      EXPECT_GT(locked.relativeL2, 0.4) << n;                          // locked: an error of order one
      EXPECT_LT(bbar.relativeL2, 1.3 * compressible.relativeL2) << n;  // as good as at nu = 0.3
      EXPECT_LT(bbar.relativeH1, 1.1 * compressible.relativeH1) << n;
      if (previous > 0) {
        EXPECT_NEAR(std::log2(previous / bbar.relativeL2), 2.0, 0.1) << n;
      }
      previous = bbar.relativeL2;
    }
  }
}

TEST(Locking, BBarEqualsStandardOnSimplices) {
  for (CellType type : {CellType::Triangle, CellType::Tetrahedron}) {
    const ManufacturedRun s = solveThickCylinder(type, 8, material(0.4999, VolumetricFormulation::Standard));
    const ManufacturedRun b = solveThickCylinder(type, 8, material(0.4999, VolumetricFormulation::BBar));
    EXPECT_NEAR(s.relativeL2, b.relativeL2, 1e-6 * s.relativeL2);
    // and they lock: ten times the error of the compressible material
    const ManufacturedRun c = solveThickCylinder(type, 8, material(0.3, VolumetricFormulation::Standard));
    EXPECT_GT(s.relativeL2, 5 * c.relativeL2);
  }
}

TEST(Locking, StandardFormulationConvergesForCompressibleMaterials) {
  // the exact solution and the mapped meshes themselves: O(h^2) in L2, O(h) in H1 at nu = 0.3
  const ManufacturedRun a = solveThickCylinder(CellType::Quadrilateral, 8, material(0.3, VolumetricFormulation::Standard));
  const ManufacturedRun b = solveThickCylinder(CellType::Quadrilateral, 16, material(0.3, VolumetricFormulation::Standard));
  EXPECT_NEAR(std::log2(a.relativeL2 / b.relativeL2), 2.0, 0.1);
  EXPECT_NEAR(std::log2(a.relativeH1 / b.relativeH1), 1.0, 0.1);
}
