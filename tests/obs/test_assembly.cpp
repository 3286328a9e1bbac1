// CellValues and the stiffness assembly reuse the values and the matrix of the last computed cell for
// a cell that is a translate of it (docs/performance.md#assembly). The reuse must be invisible:
// CellValues gives bitwise the values of a fresh one on every cell, the assembled matrix is bitwise
// the sum, in cell order, of the matrices of each cell computed on its own, on grids where most cells
// are translates (uniform boxes, red-refined ones) and where none are (distorted boxes), and the
// assembled matrix is exactly symmetric.
#include <gtest/gtest.h>

#include <cstring>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/CellValues.hpp"
#include "obs/obs/ElasticityAssembly.hpp"

using namespace obs;
using mesh::CellType;

namespace {

template <int d>
bool bitwiseEqual(const typename BlockSparseMatrix<d>::Block& a, const typename BlockSparseMatrix<d>::Block& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * d * d) == 0;
}

/// The cell's own matrix: the cell alone in a mesh of its vertices (numbered 0 ... n-1 in cell order),
/// where there is no other cell whose matrix could be reused.
template <int d>
BlockSparseMatrix<d> singleCellMatrix(const mesh::Mesh& m, Index c, const Material& material) {
  mesh::Mesh one(d);
  std::vector<Index> local;
  for (Index v : m.cellVertices(c)) local.push_back(one.addVertex(m.vertex(v)));
  one.addCell(m.cellType(c), local);
  return assembleStiffness<d>(one, material);
}

/// A == sum over the cells, in cell order, of the single-cell matrices (bitwise), and A exactly symmetric.
template <int d>
void expectSumOfCellMatrices(const mesh::Mesh& m, const Material& material) {
  const BlockSparseMatrix<d> A = assembleStiffness<d>(m, material);
  BlockSparseMatrix<d> sum = BlockSparseMatrix<d>::withMeshPattern(m);
  for (Index c = 0; c < m.numCells(); ++c) {
    const BlockSparseMatrix<d> K = singleCellMatrix<d>(m, c, material);
    const auto verts = m.cellVertices(c);
    for (std::size_t i = 0; i < verts.size(); ++i)
      for (std::size_t j = 0; j < verts.size(); ++j)
        sum(verts[i], verts[j]) += K(static_cast<Index>(i), static_cast<Index>(j));
  }
  Index differing = 0, asymmetric = 0;
  for (Index i = 0; i < A.rows(); ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) {
      const Index j = A.column(k);
      if (!bitwiseEqual<d>(A.blockAt(k), sum(i, j))) ++differing;
      const typename BlockSparseMatrix<d>::Block t = A(j, i).transpose();
      if (!bitwiseEqual<d>(A.blockAt(k), t)) ++asymmetric;
    }
  EXPECT_EQ(differing, 0) << "of " << A.nonZeroBlocks() << " blocks";
  EXPECT_EQ(asymmetric, 0);
}

class AssemblyTest : public ::testing::TestWithParam<CellType> {};

TEST_P(AssemblyTest, TranslatedCellsReuseAMatrixBitwiseEqualToTheirOwn) {
  const CellType t = GetParam();
  const int dim = mesh::dimension(t);
  const Material material{.youngsModulus = 210.0, .poissonRatio = 0.3};
  // uniform box (translates), red-refined twice (translates of many shapes), distorted (none)
  mesh::Grid grid(mesh::boxMesh(t, {2, 2, 2}, Point(0.25, -1, 0.5), Point(1.75, 0.5, 2)));
  grid.refineUniformly();
  grid.refineUniformly();
  const mesh::Mesh refined = grid.leafMesh();
  mesh::Mesh distorted = mesh::boxMesh(t, {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1));
  mesh::perturbInteriorVertices(distorted, 0.25, 99);
  for (const mesh::Mesh* m : {&refined, static_cast<const mesh::Mesh*>(&distorted)}) {
    if (dim == 2) expectSumOfCellMatrices<2>(*m, material);
    else expectSumOfCellMatrices<3>(*m, material);
  }
}

/// CellValues reused from cell to cell (moving only the points of translates) gives bitwise the values
/// of a fresh CellValues on each cell; returns the number of cells it took as translates.
template <int d>
int expectReusedValuesAreFresh(const mesh::Mesh& m) {
  CellValues<d> reused(2);
  int translates = 0;
  for (Index c = 0; c < m.numCells(); ++c) {
    translates += reused.reinit(m, c) ? 1 : 0;
    CellValues<d> fresh(2);
    EXPECT_FALSE(fresh.reinit(m, c));
    for (int q = 0; q < fresh.numPoints(); ++q) {
      EXPECT_EQ(reused.JxW(q), fresh.JxW(q));
      EXPECT_TRUE(reused.point(q) == fresh.point(q));
      for (int i = 0; i < fresh.numVertices(); ++i) EXPECT_TRUE(reused.gradient(q, i) == fresh.gradient(q, i));
    }
  }
  return translates;
}

TEST_P(AssemblyTest, CellValuesOfTranslatesAreBitwiseFresh) {
  const CellType t = GetParam();
  const bool plane = mesh::dimension(t) == 2;
  mesh::Grid grid(mesh::boxMesh(t, {2, 2, 2}, Point(0.25, -1, 0.5), Point(1.75, 0.5, 2)));
  grid.refineUniformly();
  const mesh::Mesh refined = grid.leafMesh();
  const int translates = plane ? expectReusedValuesAreFresh<2>(refined) : expectReusedValuesAreFresh<3>(refined);
  EXPECT_GT(translates, 0);  // red refinement makes translates of every cell type
  mesh::Mesh distorted = mesh::boxMesh(t, {3, 3, 3}, Point(0, 0, 0), Point(1, 1, 1));
  mesh::perturbInteriorVertices(distorted, 0.25, 7);
  if (plane) expectReusedValuesAreFresh<2>(distorted);
  else expectReusedValuesAreFresh<3>(distorted);
}

TEST(Assembly, BBarMatrixOfTranslatesIsTheSumOfCellMatrices) {
  Material material{.youngsModulus = 1.0, .poissonRatio = 0.4999};
  material.formulation = VolumetricFormulation::BBar;
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, {2, 1, 1}, Point(0, 0, 0), Point(2, 1, 1)));
  grid.refineUniformly();
  grid.refineUniformly();
  expectSumOfCellMatrices<3>(grid.leafMesh(), material);
}

INSTANTIATE_TEST_SUITE_P(AllCellTypes, AssemblyTest,
                         ::testing::Values(CellType::Triangle, CellType::Quadrilateral, CellType::Tetrahedron,
                                           CellType::Hexahedron, CellType::Prism, CellType::Pyramid),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

}  // namespace
