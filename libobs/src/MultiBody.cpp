#include "obs/obs/MultiBody.hpp"

#include <string>
#include <utility>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
BodySystem<d> assembleBody(const mesh::Mesh& mesh, const Material& material, const BoundaryConditions& bc) {
  material.validate();
  if (mesh.dimension() != d)
    throw Error("body: the mesh has dimension " + std::to_string(mesh.dimension()) + ", the problem " +
                std::to_string(d));
  return {assembleStiffness<d>(mesh, material), assembleLoad<d>(mesh, bc), collectDirichlet(mesh, bc.dirichlet)};
}

template <int d>
BodySystem<d> stackBodies(std::vector<BodySystem<d>> bodies, std::vector<Index>* offsets) {
  if (bodies.empty()) throw Error("stackBodies: no body");
  Index n = 0;
  std::size_t blocks = 0;
  if (offsets) offsets->clear();
  for (const auto& b : bodies) {
    const Index m = b.stiffness.rows();
    if (b.load.size() != static_cast<Eigen::Index>(m) * d || b.dirichlet.constrained.size() != static_cast<std::size_t>(m) * d ||
        b.dirichlet.values.size() != static_cast<Eigen::Index>(m) * d)
      throw Error("stackBodies: body " + std::to_string(offsets ? offsets->size() : 0) +
                  " has inconsistent matrix, load and Dirichlet sizes");
    if (offsets) offsets->push_back(n);
    n += m;
    blocks += static_cast<std::size_t>(b.stiffness.nonZeroBlocks());
  }
  if (bodies.size() == 1) return std::move(bodies.front());  // no copy of the one body's matrix
  std::vector<Index> rowStart{0};
  typename BlockSparseMatrix<d>::IndexArray columns;
  rowStart.reserve(n + 1);
  columns.reserve(blocks);
  Index offset = 0;
  for (const auto& b : bodies) {
    const auto& A = b.stiffness;
    for (Index r = 0; r < A.rows(); ++r) {
      for (Index k = A.rowBegin(r); k < A.rowEnd(r); ++k) columns.push_back(offset + A.column(k));
      rowStart.push_back(static_cast<Index>(columns.size()));
    }
    offset += A.rows();
  }
  BodySystem<d> out;
  out.stiffness = BlockSparseMatrix<d>({std::move(rowStart), std::move(columns)});
  out.load.resize(static_cast<Eigen::Index>(n) * d);
  out.dirichlet.values.resize(static_cast<Eigen::Index>(n) * d);
  out.dirichlet.constrained.reserve(static_cast<std::size_t>(n) * d);
  Index pos = 0;
  Eigen::Index at = 0;
  for (const auto& b : bodies) {
    for (Index k = 0; k < b.stiffness.nonZeroBlocks(); ++k) out.stiffness.blockAt(pos++) = b.stiffness.blockAt(k);
    out.load.segment(at, b.load.size()) = b.load;
    out.dirichlet.values.segment(at, b.load.size()) = b.dirichlet.values;
    out.dirichlet.constrained.insert(out.dirichlet.constrained.end(), b.dirichlet.constrained.begin(),
                                     b.dirichlet.constrained.end());
    at += b.load.size();
  }
  return out;
}

template struct BodySystem<2>;
template struct BodySystem<3>;
template BodySystem<2> assembleBody<2>(const mesh::Mesh&, const Material&, const BoundaryConditions&);
template BodySystem<3> assembleBody<3>(const mesh::Mesh&, const Material&, const BoundaryConditions&);
template BodySystem<2> stackBodies<2>(std::vector<BodySystem<2>>, std::vector<Index>*);
template BodySystem<3> stackBodies<3>(std::vector<BodySystem<3>>, std::vector<Index>*);

}  // namespace obs
