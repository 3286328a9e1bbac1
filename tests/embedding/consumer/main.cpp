// Embedding example: a program outside the obs source tree that uses the installed package.
// It builds a small mesh by hand (obs::mesh), validates a material (obs::obs), checks that
// invalid input is reported as obs::Error, and prints "embedding ok" when all of that worked.
//
// Sample run:  ./consumer
//   mesh: 2D, 4 vertices, 2 triangles, 4 boundary faces
//   material: E = 1, nu = 0.3, lambda = 0.576923, mu = 0.384615
//   invalid material rejected: material: Poisson's ratio nu must lie in [0, 0.5), got 0.500000
//   embedding ok
#include <obs/mesh/CellType.hpp>
#include <obs/mesh/Error.hpp>
#include <obs/mesh/Mesh.hpp>
#include <obs/obs/Material.hpp>

#include <cmath>
#include <iostream>

namespace {

int failures = 0;

void check(bool ok, const char* what) {
  if (!ok) {
    std::cerr << "consumer: check failed: " << what << '\n';
    ++failures;
  }
}

}  // namespace

int main() {
  using obs::mesh::CellType;
  using obs::mesh::Point;

  // Unit square split along the diagonal 0-2 into two triangles; boundary ids 1..4 counter-clockwise
  // from the bottom edge.
  //   3 ---- 2
  //   |    / |
  //   |  /   |
  //   0 ---- 1
  obs::mesh::Mesh mesh(2);
  mesh.addVertex(Point(0, 0, 0));
  mesh.addVertex(Point(1, 0, 0));
  mesh.addVertex(Point(1, 1, 0));
  mesh.addVertex(Point(0, 1, 0));
  mesh.addCell(CellType::Triangle, {0, 1, 2});
  mesh.addCell(CellType::Triangle, {0, 2, 3});
  mesh.addBoundaryFace({0, 1}, 1);
  mesh.addBoundaryFace({1, 2}, 2);
  mesh.addBoundaryFace({2, 3}, 3);
  mesh.addBoundaryFace({3, 0}, 4);
  mesh.setBoundaryName(1, "bottom");
  mesh.setBoundaryName(3, "top");

  check(mesh.dimension() == 2, "mesh dimension is 2");
  check(mesh.numVertices() == 4, "4 vertices");
  check(mesh.numCells() == 2, "2 cells");
  check(mesh.numBoundaryFaces() == 4, "4 boundary faces");
  check(mesh.cellCounts()[static_cast<int>(CellType::Triangle)] == 2, "2 triangles");
  check(mesh.boundaryFaceType(0) == CellType::Segment, "boundary faces are segments");
  check(mesh.boundaryId("top") == 3, "boundary 'top' has id 3");
  std::cout << "mesh: " << mesh.dimension() << "D, " << mesh.numVertices() << " vertices, "
            << mesh.numCells() << " triangles, " << mesh.numBoundaryFaces() << " boundary faces\n";

  // A material from libobs: Lame parameters of E = 1, nu = 0.3.
  obs::Material material;
  material.youngsModulus = 1.0;
  material.poissonRatio = 0.3;
  material.validate();
  const double lambda = material.lambda(), mu = material.mu();
  check(std::abs(lambda - 0.3 / (1.3 * 0.4)) < 1e-14, "lambda = E nu / ((1+nu)(1-2nu))");
  check(std::abs(mu - 1.0 / 2.6) < 1e-14, "mu = E / (2(1+nu))");
  std::cout << "material: E = " << material.youngsModulus << ", nu = " << material.poissonRatio
            << ", lambda = " << lambda << ", mu = " << mu << '\n';

  // Errors cross the library boundary as obs::Error.
  obs::Material incompressible = material;
  incompressible.poissonRatio = 0.5;
  bool rejected = false;
  try {
    incompressible.validate();
  } catch (const obs::Error& e) {
    rejected = true;
    std::cout << "invalid material rejected: " << e.what() << '\n';
  }
  check(rejected, "nu = 0.5 is rejected with obs::Error");

  if (failures != 0) {
    std::cerr << "consumer: " << failures << " check(s) failed\n";
    return 1;
  }
  std::cout << "embedding ok\n";
  return 0;
}
