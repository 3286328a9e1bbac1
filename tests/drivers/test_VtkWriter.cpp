// .vtu output: written with writeVtu, read back with vtkXMLUnstructuredGridReader and compared
// (points, cells, cell types, connectivity, point and cell data, integer arrays), and every 3D
// cell type has positive volume in VTK's convention (the prism reordering).
#include <gtest/gtest.h>

#include <vtkCell.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkTetra.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "obs/drivers/SolutionFields.hpp"
#include "obs/drivers/VtkWriter.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/ReferenceElement.hpp"
#include "obs/obs/Parallel.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;
using obs::mesh::CellType;
using obs::mesh::Mesh;
using obs::mesh::Point;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "vtk_writer";

/// One reference cell of each given type, shifted apart (vertices not shared).
Mesh referenceCells(int dim, std::initializer_list<CellType> types) {
  Mesh m(dim);
  double shift = 0;
  for (CellType t : types) {
    const auto& ref = obs::mesh::referenceElement(t);
    std::vector<obs::mesh::Index> v;
    for (const Point& x : ref.vertices) v.push_back(m.addVertex(x + Point(shift, 0, 0)));
    m.addCell(t, v);
    shift += 2;
  }
  return m;
}

vtkSmartPointer<vtkUnstructuredGrid> readBack(const fs::path& path) {
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(path.string().c_str());
  reader->Update();
  vtkSmartPointer<vtkUnstructuredGrid> grid = reader->GetOutput();
  return grid;
}

/// Signed volume as vtkCellSizeFilter computes it: VTK's own tetrahedralisation of the cell.
double signedVolume(vtkCell* cell) {
  vtkNew<vtkIdList> ids;
  vtkNew<vtkPoints> pts;
  cell->Triangulate(0, ids, pts);
  double volume = 0;
  for (vtkIdType k = 0; k + 3 < pts->GetNumberOfPoints(); k += 4) {
    std::array<std::array<double, 3>, 4> p;
    for (int i = 0; i < 4; ++i) pts->GetPoint(k + i, p[i].data());
    volume += vtkTetra::ComputeVolume(p[0].data(), p[1].data(), p[2].data(), p[3].data());
  }
  return volume;
}

Field sequenceField(const std::string& name, int components, std::size_t tuples, double offset) {
  Field f{name, components, {}, false};
  for (std::size_t i = 0; i < tuples * components; ++i) f.values.push_back(offset + 0.5 * i);
  return f;
}

}  // namespace

TEST(VtkWriter, CellTypeNumbers) {
  EXPECT_EQ(vtkCellType(CellType::Triangle), 5);
  EXPECT_EQ(vtkCellType(CellType::Quadrilateral), 9);
  EXPECT_EQ(vtkCellType(CellType::Tetrahedron), 10);
  EXPECT_EQ(vtkCellType(CellType::Hexahedron), 12);
  EXPECT_EQ(vtkCellType(CellType::Prism), 13);
  EXPECT_EQ(vtkCellType(CellType::Pyramid), 14);
}

TEST(VtkWriter, RoundTrip3D) {
  const Mesh m = referenceCells(
      3, {CellType::Tetrahedron, CellType::Hexahedron, CellType::Prism, CellType::Pyramid});
  Mesh mesh = m;
  mesh.addBoundaryFace({0, 1, 2}, 4);
  mesh.addBoundaryFace({0, 1, 3}, 7);

  const std::vector<Field> pf{sequenceField("displacement", 3, mesh.numVertices(), 1.0),
                              sequenceField("stress", 9, mesh.numVertices(), -3.0),
                              boundaryIdField(mesh)};
  const std::vector<Field> cf{sequenceField("von_mises", 1, mesh.numCells(), 10.0),
                              elementTypeField(mesh)};
  const fs::path path = kTmp / "sub" / "cells3d.vtu";
  fs::remove_all(kTmp / "sub");
  writeVtu(path, mesh, pf, cf);
  ASSERT_TRUE(fs::exists(path));

  const auto grid = readBack(path);
  ASSERT_EQ(grid->GetNumberOfPoints(), mesh.numVertices());
  ASSERT_EQ(grid->GetNumberOfCells(), mesh.numCells());
  for (obs::mesh::Index v = 0; v < mesh.numVertices(); ++v) {
    std::array<double, 3> x;
    grid->GetPoint(v, x.data());
    for (int k = 0; k < 3; ++k) EXPECT_EQ(x[k], mesh.vertex(v)[k]);
  }
  const std::array<double, 4> volumes{1.0 / 6, 1.0, 0.5, 1.0 / 3};
  for (obs::mesh::Index c = 0; c < mesh.numCells(); ++c) {
    EXPECT_EQ(grid->GetCellType(c), vtkCellType(mesh.cellType(c)));
    vtkCell* cell = grid->GetCell(c);
    const auto verts = mesh.cellVertices(c);
    ASSERT_EQ(cell->GetNumberOfPoints(), static_cast<vtkIdType>(verts.size()));
    // the same vertex set; the order equals obs's except for prisms
    for (std::size_t i = 0; i < verts.size(); ++i) {
      const vtkIdType expected = mesh.cellType(c) == CellType::Prism
                                     ? verts[std::array<int, 6>{0, 2, 1, 3, 5, 4}[i]]
                                     : verts[i];
      EXPECT_EQ(cell->GetPointId(static_cast<int>(i)), expected);
    }
    EXPECT_NEAR(signedVolume(cell), volumes[c], 1e-12) << obs::mesh::name(mesh.cellType(c));
  }

  for (const Field& f : pf) {
    vtkDataArray* a = grid->GetPointData()->GetArray(f.name.c_str());
    ASSERT_NE(a, nullptr) << f.name;
    ASSERT_EQ(a->GetNumberOfComponents(), f.components);
    ASSERT_EQ(a->GetNumberOfTuples(), mesh.numVertices());
    for (vtkIdType i = 0; i < a->GetNumberOfTuples(); ++i)
      for (int k = 0; k < f.components; ++k)
        EXPECT_EQ(a->GetComponent(i, k), f.values[i * f.components + k]);
  }
  for (const Field& f : cf) {
    vtkDataArray* a = grid->GetCellData()->GetArray(f.name.c_str());
    ASSERT_NE(a, nullptr) << f.name;
    ASSERT_EQ(a->GetNumberOfTuples(), mesh.numCells());
    for (vtkIdType i = 0; i < a->GetNumberOfTuples(); ++i)
      EXPECT_EQ(a->GetComponent(i, 0), f.values[i]);
  }
  // integer arrays stay integers; boundary_id: largest id of the touching faces, -1 elsewhere
  vtkDataArray* ids = grid->GetPointData()->GetArray("boundary_id");
  EXPECT_EQ(ids->GetDataType(), VTK_INT);
  EXPECT_EQ(ids->GetComponent(0, 0), 7);
  EXPECT_EQ(ids->GetComponent(2, 0), 4);
  EXPECT_EQ(ids->GetComponent(3, 0), 7);
  EXPECT_EQ(ids->GetComponent(4, 0), -1);
  vtkDataArray* types = grid->GetCellData()->GetArray("element_type");
  EXPECT_EQ(types->GetDataType(), VTK_INT);
  EXPECT_EQ(types->GetComponent(0, 0), static_cast<int>(CellType::Tetrahedron));
  EXPECT_EQ(types->GetComponent(3, 0), static_cast<int>(CellType::Pyramid));
  EXPECT_EQ(grid->GetPointData()->GetArray("stress")->GetDataType(), VTK_DOUBLE);
}

TEST(VtkWriter, RoundTrip2DWithSolutionFields) {
  const Mesh mesh = referenceCells(2, {CellType::Triangle, CellType::Quadrilateral});
  obs::ElasticitySolution solution;
  solution.dimension = 2;
  solution.displacement.resize(2 * mesh.numVertices());
  for (int i = 0; i < solution.displacement.size(); ++i) solution.displacement[i] = 0.1 * i;
  for (obs::mesh::Index v = 0; v < mesh.numVertices(); ++v)
    solution.vertexStress.push_back(obs::Stress::Identity() * (v + 1));
  obs::Stress s;
  s << 1, 2, 0, 2, 3, 0, 0, 0, 4;
  solution.cellStress = {s, 2 * s};

  const fs::path path = kTmp / "cells2d.vtu";
  writeVtu(path, mesh, pointFields(mesh, solution), cellFields(mesh, solution));
  const auto grid = readBack(path);
  ASSERT_EQ(grid->GetNumberOfPoints(), 7);
  ASSERT_EQ(grid->GetNumberOfCells(), 2);
  EXPECT_EQ(grid->GetCellType(0), 5);
  EXPECT_EQ(grid->GetCellType(1), 9);

  vtkDataArray* u = grid->GetPointData()->GetArray("displacement");
  ASSERT_EQ(u->GetNumberOfComponents(), 3);
  EXPECT_DOUBLE_EQ(u->GetComponent(3, 0), 0.6);
  EXPECT_DOUBLE_EQ(u->GetComponent(3, 1), 0.7);
  EXPECT_EQ(u->GetComponent(3, 2), 0.0);  // z = 0 in 2D
  vtkDataArray* ps = grid->GetPointData()->GetArray("stress");
  ASSERT_EQ(ps->GetNumberOfComponents(), 9);
  EXPECT_EQ(ps->GetComponent(2, 0), 3.0);
  EXPECT_EQ(ps->GetComponent(2, 1), 0.0);
  EXPECT_EQ(ps->GetComponent(2, 8), 3.0);
  EXPECT_DOUBLE_EQ(grid->GetPointData()->GetArray("von_mises")->GetComponent(0, 0),
                   0.0);  // hydrostatic
  vtkDataArray* cs = grid->GetCellData()->GetArray("stress");
  ASSERT_EQ(cs->GetNumberOfComponents(), 9);
  EXPECT_EQ(cs->GetComponent(1, 1), 4.0);  // 2 * s(0, 1)
  EXPECT_EQ(cs->GetComponent(1, 3), 4.0);
  EXPECT_DOUBLE_EQ(grid->GetCellData()->GetArray("von_mises")->GetComponent(1, 0),
                   obs::vonMises(2 * s));
  EXPECT_EQ(grid->GetCellData()->GetArray("element_type")->GetComponent(1, 0),
            static_cast<int>(CellType::Quadrilateral));
  EXPECT_EQ(grid->GetPointData()->GetArray("boundary_id")->GetComponent(0, 0), -1);  // no faces

  // positive orientation of the 2D cells (counter-clockwise)
  for (vtkIdType c = 0; c < 2; ++c) {
    vtkCell* cell = grid->GetCell(c);
    double area2 = 0;
    const int n = cell->GetNumberOfPoints();
    for (int i = 0; i < n; ++i) {
      std::array<double, 3> a, b;
      grid->GetPoint(cell->GetPointId(i), a.data());
      grid->GetPoint(cell->GetPointId((i + 1) % n), b.data());
      area2 += a[0] * b[1] - a[1] * b[0];
    }
    EXPECT_GT(area2, 0);
  }
}

TEST(VtkWriter, WrongFieldSizeThrows) {
  const Mesh mesh = referenceCells(2, {CellType::Triangle});
  const std::vector<Field> pf{Field{"bad", 3, {1.0, 2.0}, false}};
  try {
    writeVtu(kTmp / "bad.vtu", mesh, pf, {});
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("'bad'"), std::string::npos) << e.what();
  }
}

TEST(VtkWriter, UnwritablePathThrows) {
  const Mesh mesh = referenceCells(2, {CellType::Triangle});
  fs::create_directories(kTmp);
  std::ofstream(kTmp / "a_file") << "x";
  EXPECT_THROW(writeVtu(kTmp / "a_file" / "x.vtu", mesh, {}, {}), obs::Error);
}

// Arrays larger than one compressed block (32 KB): read back exactly by VTK's reader; the file's bytes
// do not depend on the number of threads that compress the blocks; a field name is escaped for XML.
TEST(VtkWriter, LargeArraysSpanSeveralBlocksAndBytesDoNotDependOnThreads) {
  const Mesh mesh = obs::mesh::boxMesh(CellType::Hexahedron, {12, 12, 12}, Point(0, 0, 0), Point(1, 2, 3));
  ASSERT_GT(mesh.numVertices() * 9 * 8, 4 * 32768);  // the stress field spans several blocks
  std::vector<Field> pf{Field{"u<&\">", 3, {}, false}, sequenceField("stress", 9, mesh.numVertices(), 0.25)};
  for (obs::mesh::Index v = 0; v < mesh.numVertices(); ++v)
    for (int k = 0; k < 3; ++k) pf[0].values.push_back(std::sin(1.0 + v + 0.3 * k) * 1e-3);
  const std::vector<Field> cf{elementTypeField(mesh)};
  const fs::path one = kTmp / "large1.vtu", two = kTmp / "large2.vtu";
  writeVtu(one, mesh, pf, cf);
  obs::setThreads(2);
  writeVtu(two, mesh, pf, cf);
  obs::setThreads(1);
  const auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(one), bytes(two));

  const auto grid = readBack(one);
  ASSERT_EQ(grid->GetNumberOfPoints(), mesh.numVertices());
  ASSERT_EQ(grid->GetNumberOfCells(), mesh.numCells());
  for (const Field& f : pf) {
    vtkDataArray* a = grid->GetPointData()->GetArray(f.name.c_str());
    ASSERT_NE(a, nullptr) << f.name;
    ASSERT_EQ(a->GetNumberOfComponents(), f.components);
    std::size_t differing = 0;
    for (vtkIdType i = 0; i < a->GetNumberOfTuples(); ++i)
      for (int k = 0; k < f.components; ++k)
        differing += a->GetComponent(i, k) != f.values[static_cast<std::size_t>(i) * f.components + k];
    EXPECT_EQ(differing, 0u) << f.name;
  }
  std::size_t wrong = 0;
  for (obs::mesh::Index c = 0; c < mesh.numCells(); ++c) {
    vtkCell* cell = grid->GetCell(c);
    const auto verts = mesh.cellVertices(c);
    for (std::size_t i = 0; i < verts.size(); ++i) wrong += cell->GetPointId(static_cast<int>(i)) != verts[i];
  }
  EXPECT_EQ(wrong, 0u);
}
