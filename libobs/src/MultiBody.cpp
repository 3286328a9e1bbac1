#include "obs/obs/MultiBody.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
BodySystem<d> assembleBody(const mesh::Mesh& mesh, const Material& material, const BoundaryConditions& bc) {
  const mesh::Mesh* meshes[] = {&mesh};
  const Material* materials[] = {&material};
  const BoundaryConditions* conditions[] = {&bc};
  return assembleBodies<d>(meshes, materials, conditions);
}

template <int d>
BodySystem<d> assembleBodies(std::span<const mesh::Mesh* const> meshes, std::span<const Material* const> materials,
                             std::span<const BoundaryConditions* const> conditions, std::vector<Index>* offsets,
                             const std::function<void(typename BlockSparseMatrix<d>::Pattern&)>& widen,
                             bool skipPrescribedBodies) {
  if (meshes.empty() || meshes.size() != materials.size() || meshes.size() != conditions.size())
    throw Error("assembleBodies: " + std::to_string(meshes.size()) + " meshes, " + std::to_string(materials.size()) +
                " materials and " + std::to_string(conditions.size()) + " sets of boundary conditions");
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    materials[i]->validate();
    if (meshes[i]->dimension() != d)
      throw Error("body: the mesh has dimension " + std::to_string(meshes[i]->dimension()) + ", the problem " +
                  std::to_string(d));
  }
  std::vector<DirichletValues> dirichlet;
  std::vector<char> skip(meshes.size(), 0);
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    dirichlet.push_back(collectDirichlet(*meshes[i], conditions[i]->dirichlet));
    const auto& c = dirichlet.back().constrained;
    skip[i] = skipPrescribedBodies && std::all_of(c.begin(), c.end(), [](char f) { return f != 0; });
  }
  BodySystem<d> out;
  out.stiffness = assembleStackedStiffness<d>(meshes, materials, widen, skip);
  const Index n = out.stiffness.rows();
  out.load.resize(static_cast<Eigen::Index>(n) * d);
  out.dirichlet.values.resize(static_cast<Eigen::Index>(n) * d);
  out.dirichlet.constrained.reserve(static_cast<std::size_t>(n) * d);
  if (offsets) offsets->clear();
  Eigen::Index at = 0;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    if (offsets) offsets->push_back(static_cast<Index>(at / d));
    const Eigen::VectorXd load = assembleLoad<d>(*meshes[i], *conditions[i]);
    const DirichletValues& g = dirichlet[i];
    out.load.segment(at, load.size()) = load;
    out.dirichlet.values.segment(at, load.size()) = g.values;
    out.dirichlet.constrained.insert(out.dirichlet.constrained.end(), g.constrained.begin(), g.constrained.end());
    at += load.size();
  }
  return out;
}

template <int d>
BodySystem<d> stackBodies(std::vector<BodySystem<d>> bodies, std::vector<Index>* offsets) {
  if (bodies.empty()) throw Error("stackBodies: no body");
  Index n = 0;
  std::size_t blocks = 0;
  std::vector<Index> first;  // first stacked row of each body
  for (const auto& b : bodies) {
    const Index m = b.stiffness.rows();
    if (b.load.size() != static_cast<Eigen::Index>(m) * d || b.dirichlet.constrained.size() != static_cast<std::size_t>(m) * d ||
        b.dirichlet.values.size() != static_cast<Eigen::Index>(m) * d)
      throw Error("stackBodies: body " + std::to_string(first.size()) + " has inconsistent matrix, load and Dirichlet sizes");
    first.push_back(n);
    n += m;
    blocks += static_cast<std::size_t>(b.stiffness.nonZeroBlocks());
  }
  if (offsets) *offsets = first;
  if (bodies.size() == 1) return std::move(bodies.front());  // no copy of the one body's matrix
  // the stacked pattern, then the blocks in one pass over the rows (BlockSparseMatrix::fromRowRanges:
  // on the threads, each page written once, repeated blocks shared as in the bodies' matrices)
  const auto bodyOf = [&](Index r) {
    return static_cast<std::size_t>(std::upper_bound(first.begin(), first.end(), r) - first.begin()) - 1;
  };
  typename BlockSparseMatrix<d>::Pattern pattern;
  pattern.rowStart.resize(static_cast<std::size_t>(n) + 1);
  pattern.rowStart[0] = 0;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const auto& A = bodies[i].stiffness;
    for (Index r = 0; r < A.rows(); ++r)
      pattern.rowStart[first[i] + r + 1] = pattern.rowStart[first[i] + r] + (A.rowEnd(r) - A.rowBegin(r));
  }
  pattern.columns.resize(blocks);
  forRanges(n, [&](Index begin, Index end) {
    for (Index r = begin; r < end; ++r) {
      const std::size_t i = bodyOf(r);
      const auto& A = bodies[i].stiffness;
      const Index local = r - first[i];
      Index k = pattern.rowStart[r];
      for (Index m = A.rowBegin(local); m < A.rowEnd(local); ++m) pattern.columns[k++] = first[i] + A.column(m);
    }
  });
  const std::vector<Index> rowStart = pattern.rowStart;
  BodySystem<d> out;
  out.stiffness = BlockSparseMatrix<d>::fromRowRanges(
      std::move(pattern), [&](Index from, Index to, typename BlockSparseMatrix<d>::Block* values) {
        for (Index r = from; r < to; ++r) {
          const std::size_t i = bodyOf(r);
          const auto& A = bodies[i].stiffness;
          const Index local = r - first[i];
          Index k = rowStart[r] - rowStart[from];
          for (Index m = A.rowBegin(local); m < A.rowEnd(local); ++m) values[k++] = A.blockAt(m);
        }
      });
  out.load.resize(static_cast<Eigen::Index>(n) * d);
  out.dirichlet.values.resize(static_cast<Eigen::Index>(n) * d);
  out.dirichlet.constrained.reserve(static_cast<std::size_t>(n) * d);
  Eigen::Index at = 0;
  for (const auto& b : bodies) {
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
template BodySystem<2> assembleBodies<2>(std::span<const mesh::Mesh* const>, std::span<const Material* const>,
                                         std::span<const BoundaryConditions* const>, std::vector<Index>*,
                                         const std::function<void(BlockSparseMatrix<2>::Pattern&)>&, bool);
template BodySystem<3> assembleBodies<3>(std::span<const mesh::Mesh* const>, std::span<const Material* const>,
                                         std::span<const BoundaryConditions* const>, std::vector<Index>*,
                                         const std::function<void(BlockSparseMatrix<3>::Pattern&)>&, bool);
template BodySystem<2> stackBodies<2>(std::vector<BodySystem<2>>, std::vector<Index>*);
template BodySystem<3> stackBodies<3>(std::vector<BodySystem<3>>, std::vector<Index>*);

}  // namespace obs
