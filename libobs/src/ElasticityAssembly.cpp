#include "obs/obs/ElasticityAssembly.hpp"

#include <algorithm>
#include <atomic>
#include <memory>
#include <span>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"
#include "obs/obs/CellValues.hpp"

namespace obs {
namespace {

// Quadrature degrees: stiffness integrands are quadratic on affine cells (exact with degree 2,
// also for the rational pyramid, see Quadrature.hpp); loads use one degree more for smooth data.
// On triangles and tetrahedra the gradients of P1 functions are constant: one point (degree 1) is
// exact there and a quarter of the work of the degree-2 rule.
constexpr int kStiffnessDegree = 2;
constexpr int kSimplexStiffnessDegree = 1;
constexpr int kLoadDegree = 3;

/// Quadrature point on a boundary face: physical point, surface weight and unit normal as
/// oriented by the face's vertex order.
struct FacePoint {
  Point x;
  double weight;
  Point normal;
};

std::vector<FacePoint> faceQuadrature(const mesh::Mesh& m, std::span<const Index> fv, int degree,
                                      std::vector<std::vector<double>>& shape) {
  const mesh::CellType ft = mesh::faceTypeFromVertexCount(static_cast<int>(fv.size()));
  const auto& ref = mesh::referenceElement(ft);
  const auto& rule = mesh::quadratureRule(ft, degree);
  std::vector<FacePoint> pts;
  shape.assign(rule.size(), std::vector<double>(fv.size()));
  double g[8];
  for (std::size_t q = 0; q < rule.size(); ++q) {
    ref.values(rule.points[q], shape[q]);
    ref.gradients(rule.points[q], std::span<double>(g, fv.size() * ref.dim));
    Point x = Point::Zero(), ds = Point::Zero(), dt = Point::Zero();
    for (std::size_t i = 0; i < fv.size(); ++i) {
      const Point& xi = m.vertex(fv[i]);
      x += shape[q][i] * xi;
      ds += g[i * ref.dim] * xi;
      if (ref.dim == 2) dt += g[i * ref.dim + 1] * xi;
    }
    Point n = ref.dim == 1 ? Point(ds[1], -ds[0], 0) : Point(ds.cross(dt));
    const double J = n.norm();
    if (!(J > 0)) throw Error("boundary face with vertices " + std::to_string(fv[0]) + ", " +
                              std::to_string(fv[1]) + ", ... is degenerate");
    pts.push_back({x, J * rule.weights[q], n / J});
  }
  return pts;
}

/// +1 if the face's vertex order gives the outward normal of the adjacent cell, else -1.
double outwardSign(const mesh::Mesh& m, std::span<const Index> fv, const mesh::VertexCells& around,
                   const Point& normal) {
  for (const Index c : around.cellsOf(fv[0])) {
    const auto cv = m.cellVertices(c);
    const bool containsFace = std::all_of(fv.begin(), fv.end(), [&](Index v) {
      return std::find(cv.begin(), cv.end(), v) != cv.end();
    });
    if (!containsFace) continue;
    Point cc = Point::Zero(), fc = Point::Zero();
    for (Index v : cv) cc += m.vertex(v);
    for (Index v : fv) fc += m.vertex(v);
    cc /= static_cast<double>(cv.size());
    fc /= static_cast<double>(fv.size());
    return normal.dot(fc - cc) >= 0 ? 1.0 : -1.0;
  }
  throw Error("boundary face with first vertex " + std::to_string(fv[0]) +
              " is not a face of any cell");
}

}  // namespace

namespace {

/// The stiffness rows of one mesh, written into its rows of a (possibly stacked) pattern: the mesh's
/// vertex v is row offset + v there, and the rows hold the mesh's vertex pairs (shifted by offset).
template <int d>
class MeshStiffness {
public:
  using Block = typename BlockSparseMatrix<d>::Block;

  MeshStiffness(const mesh::Mesh& mesh, const Material& material, Index offset)
      : mesh_(mesh), offset_(offset), around_(mesh::vertexCells(mesh)), failed_(mesh.numCells()) {
    if (mesh.dimension() != d) throw Error("assembleStiffness: mesh dimension mismatch");
    mu_ = material.mu();
    // B-bar (docs/theory.md#b-bar): lambda/2 (div u)^2 = kappa/2 (div u)^2 - mu/3 (div u)^2, and the
    // kappa part takes the cell mean of div u: K_e = int [2 mu eps:eps - 2 mu/3 div div]
    // + kappa/|e| (int div phi_i)(int div phi_j). Standard: the lambda part pointwise.
    bbar_ = material.formulation == VolumetricFormulation::BBar;
    pointwise_ = bbar_ ? -2 * mu_ / 3 : material.lambda();
    kappa_ = material.bulkModulus();
  }
  MeshStiffness(const MeshStiffness&) = delete;

  const mesh::VertexCells& around() const { return around_; }

  /// Adds the blocks of the mesh's rows [first, last) (local numbering) to `out`, where out[0] is
  /// the block at position rowStart[offset + first] of the target pattern.
  ///
  /// A range takes the cells around its vertices in ascending order and adds their blocks of its
  /// rows, so every block is the sum over its cells in cell order, whatever the ranges and the
  /// thread count. A degenerate cell is skipped here and remembered; throwIfFailed() computes the
  /// first one again to throw its error, as a sequential loop over the cells would.
  void fill(Index first, Index last, Block* out, std::span<const Index> rowStart, std::span<const Index> columns) const {
    const Index base = rowStart[offset_ + first];
    std::vector<Index> cells;
    for (Index v = first; v < last; ++v) {
      const auto of = around_.cellsOf(v);
      cells.insert(cells.end(), of.begin(), of.end());
    }
    std::sort(cells.begin(), cells.end());
    cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
    Kind general(kStiffnessDegree), simplex(kSimplexStiffnessDegree);
    for (const Index c : cells) {
      const mesh::CellType type = mesh_.cellType(c);
      const auto verts = mesh_.cellVertices(c);
      const int n = static_cast<int>(verts.size());
      Kind& kind = type == mesh::CellType::Triangle || type == mesh::CellType::Tetrahedron ? simplex : general;
      try {
        const bool translate = kind.cv.reinit(mesh_, c);
        if (!(translate && kind.valid)) {
          kind.valid = false;
          computeMatrix(kind.cv, n, kind.K);
          kind.valid = true;
        }
      } catch (const Error&) {
        kind.valid = false;
        for (Index seen = failed_.load(); c < seen && !failed_.compare_exchange_weak(seen, c);) {
        }
        continue;
      }
      // the cell's vertices in ascending order; its blocks of each of its rows in the range found by
      // one forward scan of the (sorted) row
      int order[kMax];
      for (int j = 0; j < n; ++j) {
        int k = j;
        for (; k > 0 && verts[order[k - 1]] > verts[j]; --k) order[k] = order[k - 1];
        order[k] = j;
      }
      for (int i = 0; i < n; ++i) {
        if (verts[i] < first || verts[i] >= last) continue;
        Index k = rowStart[offset_ + verts[i]];
        for (int t = 0; t < n; ++t) {
          const Index w = offset_ + verts[order[t]];
          while (columns[k] < w) ++k;  // w is in the row: the pattern holds every cell's vertex pairs
          out[k - base] += kind.K.block[i][order[t]];
        }
      }
    }
  }

  /// Throws the obs::Error of the first cell that could not be assembled, if any.
  void throwIfFailed() const {
    const Index c = failed_.load();
    if (c >= mesh_.numCells()) return;
    const mesh::CellType type = mesh_.cellType(c);
    Kind kind(type == mesh::CellType::Triangle || type == mesh::CellType::Tetrahedron ? kSimplexStiffnessDegree
                                                                                      : kStiffnessDegree);
    kind.cv.reinit(mesh_, c);  // throws its obs::Error
    computeMatrix(kind.cv, static_cast<int>(mesh_.cellVertices(c).size()), kind.K);
    throw Error("assembleStiffness: cell " + std::to_string(c) + " could not be assembled");
  }

private:
  using Vec = Eigen::Matrix<double, d, 1>;
  static constexpr int kMax = 8;  // vertices per cell
  struct CellMatrix {
    CellMatrix() {}  // not value-initialised
    Block block[kMax][kMax];
  };
  // One CellValues per quadrature (simplices need one point) with the matrix of the last cell it
  // computed. CellValues::reinit tells when a cell is a translate of the previous one (the same type
  // and bitwise the same vertex differences: most cells of generated and red-refined grids); its
  // matrix is bitwise that cell's, and is reused (docs/performance.md#assembly).
  struct Kind {
    CellValues<d> cv;
    CellMatrix K;
    bool valid = false;
    explicit Kind(int degree) : cv(degree) {}
  };

  /// The matrix of a cell (cv reinitialised on it, n vertices).
  void computeMatrix(const CellValues<d>& cv, int n, CellMatrix& K) const {
    Vec meanGradient[kMax];
    for (int i = 0; i < n; ++i) {
      meanGradient[i].setZero();
      for (int j = i; j < n; ++j) K.block[i][j].setZero();
    }
    double volume = 0;
    for (int q = 0; q < cv.numPoints(); ++q) {
      const double w = cv.JxW(q);
      volume += w;
      for (int i = 0; i < n; ++i) {
        const auto& gi = cv.gradient(q, i);
        if (bbar_) meanGradient[i] += w * gi;
        for (int j = i; j < n; ++j) {  // the upper half; K_ji = K_ij' (below)
          const auto& gj = cv.gradient(q, j);
          // K_ij[a][b] = lambda d_a phi_i d_b phi_j + mu (delta_ab grad phi_i . grad phi_j
          //              + d_b phi_i d_a phi_j)
          K.block[i][j].noalias() += w * (pointwise_ * gi * gj.transpose() + mu_ * gj * gi.transpose());
          K.block[i][j].diagonal().array() += w * mu_ * gi.dot(gj);
        }
      }
    }
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) {
        if (bbar_) K.block[i][j].noalias() += (kappa_ / volume) * meanGradient[i] * meanGradient[j].transpose();
        if (j > i) K.block[j][i] = K.block[i][j].transpose();
      }
    // the diagonal blocks exactly symmetric too (their two off-diagonal triangles are rounded apart)
    for (int i = 0; i < n; ++i) K.block[i][i] = 0.5 * (K.block[i][i] + K.block[i][i].transpose()).eval();
  }

  const mesh::Mesh& mesh_;
  Index offset_;
  double mu_ = 0, pointwise_ = 0, kappa_ = 0;
  bool bbar_ = false;
  mesh::VertexCells around_;
  mutable std::atomic<Index> failed_;
};

}  // namespace

template <int d>
BlockSparseMatrix<d> assembleStiffness(const mesh::Mesh& mesh, const Material& material) {
  const mesh::Mesh* meshes[] = {&mesh};
  const Material* materials[] = {&material};
  return assembleStackedStiffness<d>(meshes, materials, {}, {});
}

template <int d>
BlockSparseMatrix<d> assembleStackedStiffness(std::span<const mesh::Mesh* const> meshes,
                                              std::span<const Material* const> materials,
                                              const std::function<void(typename BlockSparseMatrix<d>::Pattern&)>& widen,
                                              std::span<const char> skip) {
  if (meshes.empty() || meshes.size() != materials.size() || (!skip.empty() && skip.size() != meshes.size()))
    throw Error("assembleStackedStiffness: " + std::to_string(meshes.size()) + " meshes, " +
                std::to_string(materials.size()) + " materials and " + std::to_string(skip.size()) + " skip flags");
  using Block = typename BlockSparseMatrix<d>::Block;
  const auto skipped = [&](std::size_t i) { return !skip.empty() && skip[i] != 0; };
  std::vector<std::unique_ptr<MeshStiffness<d>>> parts;  // null for a skipped mesh
  std::vector<Index> first;                              // each mesh's first stacked row
  Index n = 0;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    if (meshes[i]->dimension() != d) throw Error("assembleStiffness: mesh dimension mismatch");
    parts.push_back(skipped(i) ? nullptr : std::make_unique<MeshStiffness<d>>(*meshes[i], *materials[i], n));
    first.push_back(n);
    n += meshes[i]->numVertices();
  }
  // each mesh's pattern: the vertex adjacency, or the diagonal of a skipped mesh
  const auto patternOf = [&](std::size_t i) {
    if (parts[i]) return BlockSparseMatrix<d>::meshPattern(*meshes[i], parts[i]->around());
    typename BlockSparseMatrix<d>::Pattern p;
    const Index m = meshes[i]->numVertices();
    p.rowStart.resize(static_cast<std::size_t>(m) + 1);
    p.columns.resize(static_cast<std::size_t>(m));
    for (Index v = 0; v <= m; ++v) p.rowStart[static_cast<std::size_t>(v)] = v;
    for (Index v = 0; v < m; ++v) p.columns[static_cast<std::size_t>(v)] = v;
    return p;
  };
  // the stacked pattern: the meshes' patterns, shifted along the diagonal
  typename BlockSparseMatrix<d>::Pattern pattern;
  if (parts.size() == 1) {
    pattern = patternOf(0);
  } else {
    std::vector<typename BlockSparseMatrix<d>::Pattern> each;
    std::size_t blocks = 0;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      each.push_back(patternOf(i));
      blocks += each.back().columns.size();
    }
    pattern.rowStart.resize(static_cast<std::size_t>(n) + 1);
    pattern.rowStart[0] = 0;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      const auto& p = each[i];
      const Index base = pattern.rowStart[first[i]];
      for (Index r = 0; r + 1 < static_cast<Index>(p.rowStart.size()); ++r)
        pattern.rowStart[first[i] + r + 1] = base + p.rowStart[r + 1];
    }
    pattern.columns.resize(blocks);
    for (std::size_t i = 0; i < parts.size(); ++i) {
      const auto& p = each[i];
      const Index base = pattern.rowStart[first[i]], offset = first[i];
      const auto count = static_cast<Index>(p.columns.size());
      forRanges(count, [&](Index begin, Index end) {
        for (Index k = begin; k < end; ++k) pattern.columns[base + k] = offset + p.columns[k];
      });
      each[i] = {};
    }
  }
  if (widen) widen(pattern);
  // fromRowRanges takes the pattern's vectors over by moving them: their elements stay where they are
  const std::span<const Index> rowStart = pattern.rowStart, columns = pattern.columns;
  // The rows are filled range by range (BlockSparseMatrix::fromRowRanges, which shares the repeated
  // blocks as they come); a range that spans meshes is split at their first rows. A skipped mesh's
  // blocks stay zero.
  const auto fill = [&](Index from, Index to, Block* out) {
    const Index base = rowStart[from];
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (!parts[i]) continue;
      const Index end = i + 1 < parts.size() ? first[i + 1] : n;
      const Index a = std::max(from, first[i]), b = std::min(to, end);
      if (a < b) parts[i]->fill(a - first[i], b - first[i], out + (rowStart[a] - base), rowStart, columns);
    }
  };
  BlockSparseMatrix<d> A = BlockSparseMatrix<d>::fromRowRanges(std::move(pattern), fill);
  for (const auto& part : parts)
    if (part) part->throwIfFailed();
  return A;
}

template <int d>
Eigen::VectorXd assembleLoad(const mesh::Mesh& mesh, const BoundaryConditions& bc) {
  Eigen::VectorXd b = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(mesh.numVertices()) * d);
  if (bc.bodyForce) {
    CellValues<d> cv(kLoadDegree);
    for (Index c = 0; c < mesh.numCells(); ++c) {
      cv.reinit(mesh, c);
      const auto verts = mesh.cellVertices(c);
      for (int q = 0; q < cv.numPoints(); ++q) {
        Point x = Point::Zero();
        x.template head<d>() = cv.point(q);
        const Eigen::Matrix<double, d, 1> f = bc.bodyForce(x).template head<d>();
        for (int i = 0; i < cv.numVertices(); ++i)
          b.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d) += cv.JxW(q) * cv.value(q, i) * f;
      }
    }
  }
  if (bc.neumann.empty()) return b;

  const mesh::VertexCells around = mesh::vertexCells(mesh);  // to orient pressure loads outward
  std::vector<std::vector<double>> shape;
  for (const NeumannCondition& nc : bc.neumann) {
    if (!nc.traction && !nc.pressure) continue;
    for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
      if (mesh.boundaryFaceId(f) != nc.boundaryId) continue;
      const auto fv = mesh.boundaryFaceVertices(f);
      const auto pts = faceQuadrature(mesh, fv, kLoadDegree, shape);
      const double sign = nc.traction ? 1.0 : outwardSign(mesh, fv, around, pts[0].normal);
      for (std::size_t q = 0; q < pts.size(); ++q) {
        const Eigen::Vector3d t =
            nc.traction ? nc.traction(pts[q].x) : Eigen::Vector3d(-nc.pressure(pts[q].x) * sign * pts[q].normal);
        for (std::size_t i = 0; i < fv.size(); ++i)
          b.template segment<d>(static_cast<Eigen::Index>(fv[i]) * d) +=
              pts[q].weight * shape[q][i] * t.template head<d>();
      }
    }
  }
  return b;
}

long long DirichletValues::count() const {
  return std::count_if(constrained.begin(), constrained.end(), [](char c) { return c != 0; });
}

DirichletValues collectDirichlet(const mesh::Mesh& mesh, const std::vector<DirichletCondition>& dirichlet) {
  const int d = mesh.dimension();
  DirichletValues g;
  g.constrained.assign(static_cast<std::size_t>(mesh.numVertices()) * d, 0);
  g.values = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(mesh.numVertices()) * d);
  std::vector<char> seen(mesh.numVertices());
  for (const DirichletCondition& dc : dirichlet) {
    const auto prescribe = [&](Index v) {
      const Eigen::Vector3d value = dc.value(mesh.vertex(v));
      for (int c = 0; c < d; ++c)
        if (dc.fixed[c]) {
          g.constrained[static_cast<std::size_t>(v) * d + c] = 1;
          g.values[static_cast<Eigen::Index>(v) * d + c] = value[c];
        }
    };
    if (dc.everywhere) {
      for (Index v = 0; v < mesh.numVertices(); ++v) prescribe(v);
      continue;
    }
    std::fill(seen.begin(), seen.end(), 0);
    for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
      if (mesh.boundaryFaceId(f) != dc.boundaryId) continue;
      for (Index v : mesh.boundaryFaceVertices(f)) {
        if (seen[v]) continue;
        seen[v] = 1;
        prescribe(v);
      }
    }
    for (const auto& [v, id] : mesh.boundaryVertices())  // vertices whose faces the mesh lacks
      if (id == dc.boundaryId && !seen[v]) {
        seen[v] = 1;
        prescribe(v);
      }
  }
  return g;
}

template <int d>
void applyDirichlet(BlockSparseMatrix<d>& A, Eigen::VectorXd& b, const DirichletValues& g) {
  // b -= A g restricted to free rows (g is zero on free components)
  Eigen::VectorXd gv = g.values;
  for (std::size_t k = 0; k < g.constrained.size(); ++k)
    if (!g.constrained[k]) gv[static_cast<Eigen::Index>(k)] = 0;
  b -= A * gv;
  // rows on threads (BlockSparseMatrix::modifyBlocks, which keeps shared blocks shared); blocks
  // coupling two vertices without a constrained component are left as they are without looking at
  // their entries
  const Index n = A.rows();
  std::vector<char> fixedVertex(static_cast<std::size_t>(n), 0);
  for (Index i = 0; i < n; ++i)
    for (int a = 0; a < d; ++a) fixedVertex[static_cast<std::size_t>(i)] |= g.constrained[static_cast<std::size_t>(i) * d + a] ? 1 : 0;
  A.modifyBlocks([&](Index i, Index k, typename BlockSparseMatrix<d>::Block& B) {
    const Index j = A.column(k);
    if (!fixedVertex[static_cast<std::size_t>(i)] && !fixedVertex[static_cast<std::size_t>(j)]) return false;
    for (int a = 0; a < d; ++a)
      for (int c = 0; c < d; ++c) {
        const bool ra = g.constrained[static_cast<std::size_t>(i) * d + a];
        const bool cc = g.constrained[static_cast<std::size_t>(j) * d + c];
        if (ra || cc) B(a, c) = (i == j && a == c) ? 1.0 : 0.0;
      }
    return true;
  });
  for (std::size_t k = 0; k < g.constrained.size(); ++k)
    if (g.constrained[k]) b[static_cast<Eigen::Index>(k)] = g.values[static_cast<Eigen::Index>(k)];
}

template BlockSparseMatrix<2> assembleStiffness<2>(const mesh::Mesh&, const Material&);
template BlockSparseMatrix<3> assembleStiffness<3>(const mesh::Mesh&, const Material&);
template BlockSparseMatrix<2> assembleStackedStiffness<2>(std::span<const mesh::Mesh* const>,
                                                          std::span<const Material* const>,
                                                          const std::function<void(BlockSparseMatrix<2>::Pattern&)>&,
                                                          std::span<const char>);
template BlockSparseMatrix<3> assembleStackedStiffness<3>(std::span<const mesh::Mesh* const>,
                                                          std::span<const Material* const>,
                                                          const std::function<void(BlockSparseMatrix<3>::Pattern&)>&,
                                                          std::span<const char>);
template Eigen::VectorXd assembleLoad<2>(const mesh::Mesh&, const BoundaryConditions&);
template Eigen::VectorXd assembleLoad<3>(const mesh::Mesh&, const BoundaryConditions&);
template void applyDirichlet<2>(BlockSparseMatrix<2>&, Eigen::VectorXd&, const DirichletValues&);
template void applyDirichlet<3>(BlockSparseMatrix<3>&, Eigen::VectorXd&, const DirichletValues&);

}  // namespace obs
