#include "obs/drivers/SolutionFields.hpp"

#include <algorithm>

#include "obs/obs/Parallel.hpp"

namespace obs::drivers {

namespace {

Field tensorField(const char* name, const std::vector<Stress>& stresses) {
  Field f{name, 9, std::vector<double>(stresses.size() * 9), false};
  forRanges(static_cast<Index>(stresses.size()), [&](Index begin, Index end) {
    for (Index k = begin; k < end; ++k)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) f.values[static_cast<std::size_t>(k) * 9 + 3 * i + j] = stresses[k](i, j);
  });
  return f;
}

Field vonMisesField(const std::vector<Stress>& stresses) {
  Field f{"von_mises", 1, std::vector<double>(stresses.size()), false};
  forRanges(static_cast<Index>(stresses.size()), [&](Index begin, Index end) {
    for (Index k = begin; k < end; ++k) f.values[static_cast<std::size_t>(k)] = vonMises(stresses[k]);
  });
  return f;
}

}  // namespace

Field boundaryIdField(const mesh::Mesh& mesh) {
  Field f{"boundary_id", 1, std::vector<double>(mesh.numVertices(), -1.0), true};
  for (mesh::Index b = 0; b < mesh.numBoundaryFaces(); ++b)
    for (mesh::Index v : mesh.boundaryFaceVertices(b))
      f.values[v] = std::max(f.values[v], static_cast<double>(mesh.boundaryFaceId(b)));
  return f;
}

Field elementTypeField(const mesh::Mesh& mesh) {
  Field f{"element_type", 1, {}, true};
  f.values.reserve(mesh.numCells());
  for (mesh::Index c = 0; c < mesh.numCells(); ++c)
    f.values.push_back(static_cast<double>(static_cast<int>(mesh.cellType(c))));
  return f;
}

std::vector<Field> pointFields(const mesh::Mesh& mesh, const ElasticitySolution& solution) {
  const int dim = solution.dimension;
  Field u{"displacement", 3,
          std::vector<double>(static_cast<std::size_t>(mesh.numVertices()) * 3, 0.0), false};
  for (mesh::Index v = 0; v < mesh.numVertices(); ++v)
    for (int c = 0; c < dim; ++c) u.values[3 * v + c] = solution.displacement[dim * v + c];
  std::vector<Field> fields;
  fields.push_back(std::move(u));
  fields.push_back(tensorField("stress", solution.vertexStress));
  fields.push_back(vonMisesField(solution.vertexStress));
  fields.push_back(boundaryIdField(mesh));
  return fields;
}

std::vector<Field> cellFields(const mesh::Mesh& mesh, const ElasticitySolution& solution) {
  std::vector<Field> fields;
  fields.push_back(tensorField("stress", solution.cellStress));
  fields.push_back(vonMisesField(solution.cellStress));
  fields.push_back(elementTypeField(mesh));
  return fields;
}

}  // namespace obs::drivers
