#include "obs/drivers/VtkWriter.hpp"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDoubleArray.h>
#include <vtkIntArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <array>
#include <fstream>
#include <system_error>

#include "obs/mesh/Error.hpp"

namespace obs::drivers {

namespace {

/// VTK wedges want (0,2,1,3,5,4) of an obs/Gmsh prism, see the file comment of VtkWriter.hpp.
constexpr std::array<int, 6> kPrismToVtk{0, 2, 1, 3, 5, 4};

vtkSmartPointer<vtkDataArray> toVtk(const Field& f, vtkIdType tuples, const char* kind) {
  if (f.components < 1 || f.values.size() != static_cast<std::size_t>(tuples) * f.components)
    throw Error("writeVtu: " + std::string(kind) + " field '" + f.name + "' has " +
                std::to_string(f.values.size()) + " values, expected " + std::to_string(tuples) +
                " x " + std::to_string(f.components));
  vtkSmartPointer<vtkDataArray> a;
  if (f.integer)
    a = vtkSmartPointer<vtkIntArray>::New();
  else
    a = vtkSmartPointer<vtkDoubleArray>::New();
  a->SetName(f.name.c_str());
  a->SetNumberOfComponents(f.components);
  a->SetNumberOfTuples(tuples);
  for (vtkIdType i = 0; i < tuples; ++i)
    for (int k = 0; k < f.components; ++k)
      a->SetComponent(i, k, f.values[static_cast<std::size_t>(i) * f.components + k]);
  return a;
}

}  // namespace

int vtkCellType(mesh::CellType type) {
  switch (type) {
    case mesh::CellType::Segment:
      return VTK_LINE;
    case mesh::CellType::Triangle:
      return VTK_TRIANGLE;
    case mesh::CellType::Quadrilateral:
      return VTK_QUAD;
    case mesh::CellType::Tetrahedron:
      return VTK_TETRA;
    case mesh::CellType::Hexahedron:
      return VTK_HEXAHEDRON;
    case mesh::CellType::Prism:
      return VTK_WEDGE;
    case mesh::CellType::Pyramid:
      return VTK_PYRAMID;
  }
  return VTK_EMPTY_CELL;
}

void writeVtu(const std::filesystem::path& path, const mesh::Mesh& mesh,
              std::span<const Field> pointFields, std::span<const Field> cellFields) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(mesh.numVertices());
  for (mesh::Index v = 0; v < mesh.numVertices(); ++v) {
    const mesh::Point& x = mesh.vertex(v);
    points->SetPoint(v, x[0], x[1], x[2]);
  }

  vtkNew<vtkUnstructuredGrid> grid;
  grid->SetPoints(points);
  grid->Allocate(mesh.numCells());
  std::array<vtkIdType, 8> ids{};
  for (mesh::Index c = 0; c < mesh.numCells(); ++c) {
    const mesh::CellType type = mesh.cellType(c);
    const auto verts = mesh.cellVertices(c);
    for (std::size_t i = 0; i < verts.size(); ++i)
      ids[i] = type == mesh::CellType::Prism ? verts[kPrismToVtk[i]] : verts[i];
    grid->InsertNextCell(vtkCellType(type), static_cast<vtkIdType>(verts.size()), ids.data());
  }

  for (const Field& f : pointFields)
    grid->GetPointData()->AddArray(toVtk(f, mesh.numVertices(), "point"));
  for (const Field& f : cellFields)
    grid->GetCellData()->AddArray(toVtk(f, mesh.numCells(), "cell"));

  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  // Check writability first: VTK would print a multi-line error report of its own.
  if (!std::ofstream(path, std::ios::binary | std::ios::trunc))
    throw Error(path.string() + ": cannot open for writing");
  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->SetFileName(path.string().c_str());
  writer->SetInputData(grid);
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToZLib();
  if (writer->Write() != 1) throw Error(path.string() + ": cannot write the VTK file");
}

}  // namespace obs::drivers
