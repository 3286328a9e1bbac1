#pragma once
/// \file VtkWriter.hpp
/// Writing a Mesh with point and cell data as a VTK XML unstructured grid (.vtu) for ParaView:
/// binary appended data in zlib-format blocks of 32 KB (compressed by libdeflate), the layout of VTK's own
/// vtkXMLUnstructuredGridWriter (header_type UInt64), written by obs so that the blocks are compressed
/// on threads() threads (the bytes do not depend on the thread count; docs/performance.md#vtk-output).
/// The tests read the files back with VTK's reader.
///
/// Cell types: triangle 5, quadrilateral 9, tetrahedron 10, hexahedron 12, prism (wedge) 13,
/// pyramid 14. obs (= Gmsh) vertex orderings equal VTK's for all of them except the prism: VTK
/// expects the first triangle (0,1,2) to be ordered so that its right-hand normal points *away*
/// from the second one. For the obs reference prism (0,0,0) (1,0,0) (0,1,0) (0,0,1) (1,0,1) (0,1,1)
/// vtkCellSizeFilter reports volume -0.5 in obs order and +0.5 after the reordering
/// (0,2,1,3,5,4), which the writer therefore applies (checked by tests/drivers/test_VtkWriter.cpp).
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::drivers {

/// Values of one data array: `values[i * components + k]` is component k at point (or cell) i.
struct Field {
  std::string name;
  int components = 1;
  std::vector<double> values;
  bool integer = false;  ///< written as a 32-bit integer array (ids, types)
};

/// VTK cell type number of an obs cell type (VTK_TRIANGLE = 5, ..., VTK_PYRAMID = 14).
int vtkCellType(mesh::CellType type);

/// Writes `mesh` to `path` (.vtu). Points always have 3 coordinates (z = 0 in 2D). Each field
/// must have numVertices() (point fields) or numCells() (cell fields) tuples; a 9-component field
/// appears in ParaView as a 3x3 tensor. Parent directories are created. Throws obs::Error if a
/// field has the wrong size or the file cannot be written.
void writeVtu(const std::filesystem::path& path, const mesh::Mesh& mesh,
              std::span<const Field> pointFields, std::span<const Field> cellFields);

/// One data set of a .pvd collection: its time (the step of an adaptive run, the time of a dynamic
/// one, 0 for a static one), its part (the body) and the .vtu file name relative to the .pvd.
struct PvdEntry {
  double time = 0;
  int part = 0;
  std::string file;
};

/// Writes the .pvd collection of every run kind (ParaView's time series and parts): one DataSet
/// per entry in the given order, the time written as the shortest decimal that reads back to the
/// same double ("0", "3", "0.015"). Throws obs::Error if the file cannot be written.
void writePvdCollection(const std::filesystem::path& path, const std::vector<PvdEntry>& entries);

}  // namespace obs::drivers
