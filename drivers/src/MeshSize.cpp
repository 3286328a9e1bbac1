/// \file MeshSize.cpp
/// Cell counts of the mesh generators, from their parameters (see MeshSize.hpp). The counts follow
/// the cell splits documented in BoxMesh.hpp (cells per box) and CurvedMeshes.hpp (cubed-sphere
/// blocks: n^d cells in the inner cube plus 2d blocks of n^(d-1) x ceil(n/2) cells; the half ball
/// and half disk are the halves of those with 2n cells).
#include "obs/drivers/MeshSize.hpp"

#include <cmath>

namespace obs::drivers {

namespace {

/// Cells of one box (box and rounded-block generators) of the given type.
double cellsPerBox(mesh::CellType t) {
  switch (t) {
    case mesh::CellType::Triangle:
    case mesh::CellType::Prism:
      return 2;
    case mesh::CellType::Tetrahedron:
    case mesh::CellType::Pyramid:
      return 6;
    default:
      return 1;
  }
}

/// Cells of one block hexahedron of the ball (pyramids from the centre, tetrahedra from them).
double cellsPerBallHexahedron(mesh::CellType t) {
  switch (t) {
    case mesh::CellType::Triangle:
    case mesh::CellType::Prism:
      return 2;
    case mesh::CellType::Pyramid:
      return 6;
    case mesh::CellType::Tetrahedron:
      return 12;
    default:
      return 1;
  }
}

/// Cells of the cubed ball (3D) or disk (2D) with n cells per direction of its inner cube/square.
double cubedBallCells(double n, int dim, mesh::CellType t) {
  const double m = std::ceil(n / 2);
  const double blocks = std::pow(n, dim) + 2 * dim * std::pow(n, dim - 1) * m;
  return blocks * cellsPerBallHexahedron(t);
}

}  // namespace

double generatedCoarseCells(const MeshSpec& spec) {
  const int dim = mesh::dimension(spec.cellType);
  switch (spec.source) {
    case MeshSpec::Source::File:
      return 0;
    case MeshSpec::Source::Ball:
    case MeshSpec::Source::Disk:
      return cubedBallCells(spec.cells[0], dim, spec.cellType);
    case MeshSpec::Source::HalfBall:
    case MeshSpec::Source::HalfDisk:
      // the half of the cubed ball/disk with 2n cells below its mid plane (a mesh plane of it)
      return cubedBallCells(2.0 * spec.cells[0], dim, spec.cellType) / 2;
    case MeshSpec::Source::Box:
    case MeshSpec::Source::RoundedBlock: {
      double boxes = 1;
      for (int i = 0; i < dim; ++i) boxes *= spec.cells[static_cast<std::size_t>(i)];
      return boxes * cellsPerBox(spec.cellType);
    }
  }
  return 0;
}

double refinedCells(double coarseCells, mesh::CellType type, int refine) {
  if (refine <= 0) return coarseCells;
  const int dim = mesh::dimension(type);
  const double children = dim == 2 ? 4 : 8;
  const double first = type == mesh::CellType::Pyramid ? 10 : children;
  return coarseCells * first * std::pow(children, refine - 1);
}

}  // namespace obs::drivers
