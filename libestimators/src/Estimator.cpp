#include "obs/estimators/Estimator.hpp"

#include <cmath>
#include <cstring>
#include <type_traits>

#include "obs/estimators/ContributionTable.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

/// FNV-1a, 64 bit, over values instead of bytes: each value's bits (up to 64) are xored in whole,
/// then one multiplication. Both steps are invertible, so changing one value always changes the
/// hash, as with the bytewise FNV-1a, at one multiplication per value instead of one per byte.
struct Hasher {
  std::uint64_t h = 14695981039346656037ull;
  template <class T>
  void value(const T& v) {
    static_assert(sizeof(T) <= sizeof(std::uint64_t) && std::is_trivially_copyable_v<T>);
    std::uint64_t w = 0;
    std::memcpy(&w, &v, sizeof(T));
    h ^= w;
    h *= 1099511628211ull;
  }
};

std::string sizes(const mesh::Mesh& m) {
  return std::to_string(m.numCells()) + " cells, " + std::to_string(m.numVertices()) + " vertices";
}

}  // namespace

MeshStamp meshStamp(const mesh::Mesh& mesh, std::uint64_t revision) {
  Hasher h;
  h.value(mesh.dimension());
  for (Index c = 0; c < mesh.numCells(); ++c) {
    h.value(static_cast<int>(mesh.cellType(c)));
    for (Index v : mesh.cellVertices(c)) h.value(v);
  }
  for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
    h.value(mesh.boundaryFaceId(f));
    for (Index v : mesh.boundaryFaceVertices(f)) h.value(v);
  }
  for (const Point& x : mesh.vertices())
    for (int a = 0; a < 3; ++a) h.value(x[a] == 0.0 ? 0.0 : x[a]);  // -0 and +0 alike
  MeshStamp s;
  s.dimension = mesh.dimension();
  s.numVertices = mesh.numVertices();
  s.numCells = mesh.numCells();
  s.hash = h.h;
  s.revision = revision;
  return s;
}

bool EstimatorResult::validFor(const mesh::Mesh& mesh) const {
  if (mesh.numCells() != stamp.numCells || mesh.numVertices() != stamp.numVertices) return false;
  return stamp.sameMesh(meshStamp(mesh));
}

bool EstimatorResult::validFor(const mesh::Mesh& mesh, std::uint64_t revision) const {
  return revision == stamp.revision && validFor(mesh);
}

void EstimatorResult::requireValidFor(const mesh::Mesh& mesh) const {
  if (!validFor(mesh))
    throw Error("estimator result of '" + estimator + "' is stale: computed for a mesh with " +
                std::to_string(stamp.numCells) + " cells, " + std::to_string(stamp.numVertices) +
                " vertices (hash " + std::to_string(stamp.hash) + "), used with " + sizes(mesh) +
                (mesh.numCells() == stamp.numCells ? " of different content" : ""));
}

double EstimatorResult::contribution(const std::string& name) const {
  std::string known;
  for (const Contribution& c : contributions) {
    if (c.name == name) return c.value;
    known += (known.empty() ? "" : ", ") + c.name;
  }
  throw Error("estimator '" + estimator + "' has no contribution '" + name + "' (it has: " +
              known + ")");
}

void validateInput(const EstimatorInput& in, const std::string& estimatorName) {
  const int d = in.mesh.dimension();
  const std::string where = "estimator '" + estimatorName + "': ";
  if (d != 2 && d != 3) throw Error(where + "mesh dimension " + std::to_string(d) + " unsupported");
  const Eigen::Index expected = static_cast<Eigen::Index>(in.mesh.numVertices()) * d;
  if (in.displacement.size() != expected)
    throw Error(where + "displacement has " + std::to_string(in.displacement.size()) +
                " entries, the mesh needs " + std::to_string(expected) + " (" +
                std::to_string(in.mesh.numVertices()) + " vertices x " + std::to_string(d) + ")");
  if (!in.displacement.allFinite()) throw Error(where + "displacement contains NaN or infinity");
  try {
    in.material.validate();
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
  // The residuals of the built-in estimators use the pointwise stress of the standard formulation.
  if (in.material.formulation != VolumetricFormulation::Standard)
    throw Error(where + "the B-bar formulation (formulation = \"bbar\") is not supported by the "
                "estimators yet; use formulation = \"standard\" in adaptive runs");
}

// --- ContributionTable ----------------------------------------------------------------------------

ContributionTable::ContributionTable(std::vector<std::string> names, Index numCells,
                                     Index numVertices)
    : names_(std::move(names)),
      cell_(names_.size(), std::vector<double>(static_cast<std::size_t>(numCells), 0.0)),
      vertex_(names_.size(), std::vector<double>(static_cast<std::size_t>(numVertices), 0.0)) {}

int ContributionTable::index(const std::string& name) const {
  std::string known;
  for (std::size_t k = 0; k < names_.size(); ++k) {
    if (names_[k] == name) return static_cast<int>(k);
    known += (k ? ", " : "") + names_[k];
  }
  throw Error("unknown estimator contribution '" + name + "' (known: " + known + ")");
}

EstimatorResult ContributionTable::result(const std::string& estimator,
                                          const MeshStamp& stamp) const {
  EstimatorResult r;
  r.estimator = estimator;
  r.stamp = stamp;
  const std::size_t nc = static_cast<std::size_t>(stamp.numCells);
  const std::size_t nv = static_cast<std::size_t>(stamp.numVertices);
  r.indicators.assign(nc, 0.0);
  Eigen::VectorXd vertexTotal = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(nv));
  for (std::size_t k = 0; k < names_.size(); ++k) {
    if (cell_[k].size() != nc || vertex_[k].size() != nv)
      throw Error("estimator '" + estimator + "': contribution table sizes do not match the mesh");
    double sum = 0;
    std::vector<double> cellField(nc);
    for (std::size_t e = 0; e < nc; ++e) {
      const double s = cell_[k][e];
      if (!(s >= 0) || !std::isfinite(s))
        throw Error("estimator '" + estimator + "': " + names_[k] + " of cell " +
                    std::to_string(e) + " is " + std::to_string(s) + " (not a finite square)");
      sum += s;
      r.indicators[e] += s;
      cellField[e] = std::sqrt(s);
    }
    Eigen::VectorXd vertexField(static_cast<Eigen::Index>(nv));
    for (std::size_t p = 0; p < nv; ++p) {
      vertexField[static_cast<Eigen::Index>(p)] = std::sqrt(vertex_[k][p]);
      vertexTotal[static_cast<Eigen::Index>(p)] += vertex_[k][p];
    }
    r.contributions.push_back({names_[k], std::sqrt(sum)});
    r.cellFields[names_[k]] = std::move(cellField);
    r.vertexFields[names_[k]] = std::move(vertexField);
  }
  double total = 0;
  for (double& e : r.indicators) {
    total += e;
    e = std::sqrt(e);
  }
  r.total = std::sqrt(total);
  r.vertexFields["eta"] = vertexTotal.cwiseSqrt();
  return r;
}

}  // namespace obs::estimators
