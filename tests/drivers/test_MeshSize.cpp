// The cell counts that reject oversized generated meshes before they are built
// (drivers/MeshSize.hpp) equal the cells the generators actually build, for every curved generator
// and its cell types.
#include <gtest/gtest.h>

#include "obs/drivers/MeshSize.hpp"
#include "obs/mesh/CurvedMeshes.hpp"

using namespace obs;
using drivers::MeshSpec;
using mesh::CellType;

namespace {

double predicted(MeshSpec::Source source, CellType type, int n) {
  MeshSpec spec;
  spec.source = source;
  spec.cellType = type;
  spec.cells = {n, n, n};
  return drivers::generatedCoarseCells(spec);
}

}  // namespace

TEST(MeshSize, CurvedGeneratorsPredictTheirCellCounts) {
  const mesh::Point c = mesh::Point::Zero();
  for (int n : {1, 2, 3, 4}) {
    for (CellType t : {CellType::Triangle, CellType::Quadrilateral}) {
      EXPECT_EQ(predicted(MeshSpec::Source::Disk, t, n), mesh::diskMesh(c, 1, t, n).mesh.numCells()) << n;
      EXPECT_EQ(predicted(MeshSpec::Source::HalfDisk, t, n), mesh::halfDiskMesh(c, 1, t, n).mesh.numCells()) << n;
    }
    for (CellType t : {CellType::Hexahedron, CellType::Tetrahedron, CellType::Prism, CellType::Pyramid}) {
      EXPECT_EQ(predicted(MeshSpec::Source::Ball, t, n), mesh::ballMesh(c, 1, t, n).mesh.numCells()) << n;
      EXPECT_EQ(predicted(MeshSpec::Source::HalfBall, t, n), mesh::halfBallMesh(c, 1, t, n).mesh.numCells()) << n;
    }
  }
}
