#include "obs/obs/BlockSparseMatrix.hpp"

namespace obs {

template <int d>
BlockSparseMatrix<d> BlockSparseMatrix<d>::withMeshPattern(const mesh::Mesh& mesh) {
  const Index n = mesh.numVertices();
  // vertex -> cells (compressed)
  std::vector<Index> start(n + 1, 0);
  for (Index c = 0; c < mesh.numCells(); ++c)
    for (Index v : mesh.cellVertices(c)) ++start[v + 1];
  for (Index v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<Index> cellsOf(start[n]);
  {
    std::vector<Index> pos(start.begin(), start.end() - 1);
    for (Index c = 0; c < mesh.numCells(); ++c)
      for (Index v : mesh.cellVertices(c)) cellsOf[pos[v]++] = c;
  }
  // neighbours of each vertex: union of the vertices of its cells
  std::vector<Index> rowStart(n + 1, 0), cols, row;
  cols.reserve(static_cast<std::size_t>(n) * (d == 2 ? 9 : 27));
  for (Index v = 0; v < n; ++v) {
    row.clear();
    for (Index k = start[v]; k < start[v + 1]; ++k)
      for (Index w : mesh.cellVertices(cellsOf[k])) row.push_back(w);
    if (row.empty()) row.push_back(v);  // isolated vertex keeps its diagonal
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    cols.insert(cols.end(), row.begin(), row.end());
    rowStart[v + 1] = static_cast<Index>(cols.size());
  }
  return BlockSparseMatrix(std::move(rowStart), std::move(cols));
}

template class BlockSparseMatrix<2>;
template class BlockSparseMatrix<3>;

}  // namespace obs
