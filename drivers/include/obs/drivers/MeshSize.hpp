#pragma once
/// \file MeshSize.hpp
/// The number of cells a scene's [mesh] asks for, computed from the parsed MeshSpec alone, so that
/// an oversized request (a typo like cells = [9000, 9000] or a ball with cells = 1000) is rejected
/// before any memory is allocated for it rather than after the generator has built the mesh.
#include "obs/drivers/Scene.hpp"

namespace obs::drivers {

/// Cells of the coarse mesh of a generated [mesh] (box, ball, disk, half_ball, half_disk,
/// rounded_block), exactly as the
/// generators in BoxMesh.hpp and CurvedMeshes.hpp build them; 0 for a mesh file (unknown until
/// the file is read).
double generatedCoarseCells(const MeshSpec& spec);

/// Upper bound on the cells of `coarseCells` cells of `type` after `refine` uniform red
/// refinements (4 children per 2D cell, 8 per 3D cell, 10 for the first refinement of a pyramid:
/// 6 pyramids and 4 tetrahedra).
double refinedCells(double coarseCells, mesh::CellType type, int refine);

}  // namespace obs::drivers
