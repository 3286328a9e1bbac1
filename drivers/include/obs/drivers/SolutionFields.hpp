#pragma once
/// \file SolutionFields.hpp
/// The data arrays that `obs run` writes to its .vtu file:
///   point data  displacement (3 components, z = 0 in 2D), stress (3x3 tensor, 9 components,
///               recovered at vertices), von_mises, boundary_id (int: the largest boundary id of
///               the boundary faces touching the vertex, -1 for interior vertices);
///   contact scenes add the point data of SceneSolver (0 away from the contact boundary):
///               gap (g_p at constrained contact vertices), normal_displacement (nu_p . u_p on the
///               contact boundary), contact_pressure (s_p = mu_p / m_p^C, docs/theory.md#contact-pressure),
///               contact_state (int: 0 not constrained, 1 potential contact, 2 actual contact),
///               constraint_direction (nu_p, 3 components);
///   cell data   stress (cell mean, 9 components), von_mises (of the cell mean),
///               element_type (int: the obs CellType index, 1 triangle, 2 quadrilateral,
///               3 tetrahedron, 4 hexahedron, 5 prism, 6 pyramid).
#include <vector>

#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/LinearElasticity.hpp"

namespace obs::drivers {

std::vector<Field> pointFields(const mesh::Mesh& mesh, const ElasticitySolution& solution);
std::vector<Field> cellFields(const mesh::Mesh& mesh, const ElasticitySolution& solution);

/// Point field "boundary_id" (see above).
Field boundaryIdField(const mesh::Mesh& mesh);
/// Cell field "element_type" (see above).
Field elementTypeField(const mesh::Mesh& mesh);

}  // namespace obs::drivers
