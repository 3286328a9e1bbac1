#include "obs/obs/ElasticityAssembly.hpp"

#include <algorithm>

#ifdef _OPENMP
#include <omp.h>
#endif

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
double outwardSign(const mesh::Mesh& m, std::span<const Index> fv, const std::vector<Index>& cellStart,
                   const std::vector<Index>& cellsOf, const Point& normal) {
  for (Index k = cellStart[fv[0]]; k < cellStart[fv[0] + 1]; ++k) {
    const Index c = cellsOf[k];
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

template <int d>
BlockSparseMatrix<d> assembleStiffness(const mesh::Mesh& mesh, const Material& material) {
  if (mesh.dimension() != d) throw Error("assembleStiffness: mesh dimension mismatch");
  auto A = BlockSparseMatrix<d>::withMeshPattern(mesh);
  const double mu = material.mu();
  // B-bar (docs/theory.md#b-bar): lambda/2 (div u)^2 = kappa/2 (div u)^2 - mu/3 (div u)^2, and the
  // kappa part takes the cell mean of div u: K_e = int [2 mu eps:eps - 2 mu/3 div div]
  // + kappa/|e| (int div phi_i)(int div phi_j). Standard: the lambda part pointwise.
  const bool bbar = material.formulation == VolumetricFormulation::BBar;
  const double pointwise = bbar ? -2 * mu / 3 : material.lambda();
  const double kappa = material.bulkModulus();
  using Block = typename BlockSparseMatrix<d>::Block;
  using Vec = Eigen::Matrix<double, d, 1>;
  constexpr int kMax = 8;  // vertices per cell
  // Per cell of a chunk: where its blocks go, and which cell's matrix it takes. The matrices live
  // apart (CellMatrix), written only for the cells whose matrix is computed, so that a chunk of
  // translates touches a few kilobytes of them, not the 4.6 KB of a hexahedron's matrix per cell.
  // Neither is value-initialised (no zeroing of megabytes per call).
  struct Local {
    Local() {}
    Index pos[kMax][kMax];
    int n;
    int source;  // the local (in this chunk) whose matrix is this cell's: itself, or a translate's
  };
  struct CellMatrix {
    CellMatrix() {}
    Block block[kMax][kMax];
  };
  // cell matrices of a chunk of cells on threads() threads, added to A in cell order (below): the
  // same sums in the same order as a sequential loop, whatever the thread count
  struct Values {
    // one CellValues per quadrature (simplices need one point) and, for each, the local (in this
    // chunk) of the last cell whose matrix it computed (-1: none). CellValues::reinit tells when a
    // cell is a translate of the previous one (the same type and bitwise the same vertex differences:
    // most cells of generated and red-refined grids); its matrix is bitwise that cell's, and is reused.
    CellValues<d> general{kStiffnessDegree}, simplex{kSimplexStiffnessDegree};
    int computedGeneral = -1, computedSimplex = -1;
  };
  const auto cellMatrix = [&](Values& values, Index c, std::vector<Local>& chunkLocals,
                              std::vector<CellMatrix>& chunkMatrices, int self) {
    Local& out = chunkLocals[static_cast<std::size_t>(self)];
    CellMatrix& K = chunkMatrices[static_cast<std::size_t>(self)];
    const mesh::CellType type = mesh.cellType(c);
    const auto verts = mesh.cellVertices(c);
    const int n = static_cast<int>(verts.size());
    out.n = n;
    // positions of the blocks: the cell's vertices in ascending order, found by one forward scan of
    // each of their (sorted) rows
    int order[kMax];
    for (int j = 0; j < n; ++j) {
      int k = j;
      for (; k > 0 && verts[order[k - 1]] > verts[j]; --k) order[k] = order[k - 1];
      order[k] = j;
    }
    for (int i = 0; i < n; ++i) {
      Index k = A.rowBegin(verts[i]);
      for (int t = 0; t < n; ++t) {
        const Index w = verts[order[t]];
        while (A.column(k) < w) ++k;  // w is in the row: the pattern holds every cell's vertex pairs
        out.pos[i][order[t]] = k;
      }
    }
    const bool isSimplex = type == mesh::CellType::Triangle || type == mesh::CellType::Tetrahedron;
    CellValues<d>& cv = isSimplex ? values.simplex : values.general;
    int& computed = isSimplex ? values.computedSimplex : values.computedGeneral;
    computed = cv.reinit(mesh, c) ? computed : -1;  // a translate keeps the last cell's matrix, if any
    if (computed >= 0) {
      out.source = computed;
      return;
    }
    out.source = self;
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
        if (bbar) meanGradient[i] += w * gi;
        for (int j = i; j < n; ++j) {  // the upper half; K_ji = K_ij' (below)
          const auto& gj = cv.gradient(q, j);
          // K_ij[a][b] = lambda d_a phi_i d_b phi_j + mu (delta_ab grad phi_i . grad phi_j
          //              + d_b phi_i d_a phi_j)
          K.block[i][j].noalias() += w * (pointwise * gi * gj.transpose() + mu * gj * gi.transpose());
          K.block[i][j].diagonal().array() += w * mu * gi.dot(gj);
        }
      }
    }
    for (int i = 0; i < n; ++i)
      for (int j = i; j < n; ++j) {
        if (bbar) K.block[i][j].noalias() += (kappa / volume) * meanGradient[i] * meanGradient[j].transpose();
        if (j > i) K.block[j][i] = K.block[i][j].transpose();
      }
    // the diagonal blocks exactly symmetric too (their two off-diagonal triangles are rounded apart)
    for (int i = 0; i < n; ++i) K.block[i][i] = 0.5 * (K.block[i][i] + K.block[i][i].transpose()).eval();
    computed = self;
  };
  const Index cells = mesh.numCells();
  const int nt = cells >= kParallelMinRows ? threads() : 1;
  const Index chunk = std::min<Index>(cells, 4096);
  std::vector<Local> locals(static_cast<std::size_t>(std::max<Index>(chunk, 1)));
  std::vector<CellMatrix> matrices(locals.size());
  std::vector<Values> values(static_cast<std::size_t>(nt));
  // The chunk's matrices are added to A by nt threads, each owning a range of block rows (about the
  // same number of blocks each) and visiting the cells in order: every block gets its sums in cell
  // order, as in the sequential loop. A cell's row i lies in one range (its blocks pos[i][*] do).
  std::vector<Index> ownedFrom(static_cast<std::size_t>(nt) + 1, A.nonZeroBlocks());
  const auto starts = A.rowStarts();
  for (int t = 0; t < nt; ++t) {
    const Index target = static_cast<Index>((static_cast<long long>(A.nonZeroBlocks()) * t) / nt);
    ownedFrom[static_cast<std::size_t>(t)] = *std::lower_bound(starts.begin(), starts.end(), target);
  }
  const auto addChunk = [&](Index first, Index last, Index from, Index to) {
    for (Index c = first; c < last; ++c) {
      const Local& l = locals[static_cast<std::size_t>(c - first)];
      const CellMatrix& K = matrices[static_cast<std::size_t>(l.source)];
      for (int i = 0; i < l.n; ++i) {
        if (l.pos[i][0] < from || l.pos[i][0] >= to) continue;
        for (int j = 0; j < l.n; ++j) A.blockAt(l.pos[i][j]) += K.block[i][j];
      }
    }
  };
  for (Index first = 0; first < cells; first += chunk) {
    const Index last = std::min(cells, first + chunk);
    for (Values& v : values) v.computedGeneral = v.computedSimplex = -1;  // the last chunk's locals are gone
    // no exception may leave a parallel region: the first bad cell (a degenerate one) is found on
    // the threads and its error thrown again afterwards, as the sequential loop would have thrown it
    Index failed = last;
#pragma omp parallel for schedule(static) num_threads(nt) reduction(min : failed) if (nt > 1)
    for (Index c = first; c < last; ++c) {
#ifdef _OPENMP
      Values& cv = values[static_cast<std::size_t>(omp_get_thread_num())];
#else
      Values& cv = values.front();
#endif
      try {
        cellMatrix(cv, c, locals, matrices, static_cast<int>(c - first));
      } catch (const Error&) {
        failed = std::min(failed, c);
      }
    }
    if (failed < last) {  // throws its obs::Error
      Values fresh;
      cellMatrix(fresh, failed, locals, matrices, static_cast<int>(failed - first));
    }
#pragma omp parallel for schedule(static, 1) num_threads(nt) if (nt > 1)
    for (int t = 0; t < nt; ++t)
      addChunk(first, last, ownedFrom[static_cast<std::size_t>(t)], ownedFrom[static_cast<std::size_t>(t) + 1]);
  }
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

  // vertex -> cells, to orient pressure loads along the outward normal
  std::vector<Index> cellStart(mesh.numVertices() + 1, 0), cellsOf;
  for (Index c = 0; c < mesh.numCells(); ++c)
    for (Index v : mesh.cellVertices(c)) ++cellStart[v + 1];
  for (Index v = 0; v < mesh.numVertices(); ++v) cellStart[v + 1] += cellStart[v];
  cellsOf.resize(cellStart.back());
  {
    std::vector<Index> fill(cellStart.begin(), cellStart.end() - 1);
    for (Index c = 0; c < mesh.numCells(); ++c)
      for (Index v : mesh.cellVertices(c)) cellsOf[fill[v]++] = c;
  }

  std::vector<std::vector<double>> shape;
  for (const NeumannCondition& nc : bc.neumann) {
    if (!nc.traction && !nc.pressure) continue;
    for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
      if (mesh.boundaryFaceId(f) != nc.boundaryId) continue;
      const auto fv = mesh.boundaryFaceVertices(f);
      const auto pts = faceQuadrature(mesh, fv, kLoadDegree, shape);
      const double sign = nc.traction ? 1.0 : outwardSign(mesh, fv, cellStart, cellsOf, pts[0].normal);
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
    std::fill(seen.begin(), seen.end(), 0);
    for (Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
      if (mesh.boundaryFaceId(f) != dc.boundaryId) continue;
      for (Index v : mesh.boundaryFaceVertices(f)) {
        if (seen[v]) continue;
        seen[v] = 1;
        const Eigen::Vector3d value = dc.value(mesh.vertex(v));
        for (int c = 0; c < d; ++c)
          if (dc.fixed[c]) {
            g.constrained[static_cast<std::size_t>(v) * d + c] = 1;
            g.values[static_cast<Eigen::Index>(v) * d + c] = value[c];
          }
      }
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
  // rows on threads (each writes its own blocks); blocks coupling two vertices without a
  // constrained component are left as they are without looking at their entries
  const Index n = A.rows();
  std::vector<char> fixedVertex(static_cast<std::size_t>(n), 0);
  for (Index i = 0; i < n; ++i)
    for (int a = 0; a < d; ++a) fixedVertex[static_cast<std::size_t>(i)] |= g.constrained[static_cast<std::size_t>(i) * d + a] ? 1 : 0;
  const int nt = n >= kParallelMinRows ? threads() : 1;
  A.unshareBlocks();  // written on threads below
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (Index i = 0; i < n; ++i)
    for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k) {
      const Index j = A.column(k);
      if (!fixedVertex[static_cast<std::size_t>(i)] && !fixedVertex[static_cast<std::size_t>(j)]) continue;
      auto& B = A.blockAt(k);
      for (int a = 0; a < d; ++a)
        for (int c = 0; c < d; ++c) {
          const bool ra = g.constrained[static_cast<std::size_t>(i) * d + a];
          const bool cc = g.constrained[static_cast<std::size_t>(j) * d + c];
          if (ra || cc) B(a, c) = (i == j && a == c) ? 1.0 : 0.0;
        }
    }
  for (std::size_t k = 0; k < g.constrained.size(); ++k)
    if (g.constrained[k]) b[static_cast<Eigen::Index>(k)] = g.values[static_cast<Eigen::Index>(k)];
}

template BlockSparseMatrix<2> assembleStiffness<2>(const mesh::Mesh&, const Material&);
template BlockSparseMatrix<3> assembleStiffness<3>(const mesh::Mesh&, const Material&);
template Eigen::VectorXd assembleLoad<2>(const mesh::Mesh&, const BoundaryConditions&);
template Eigen::VectorXd assembleLoad<3>(const mesh::Mesh&, const BoundaryConditions&);
template void applyDirichlet<2>(BlockSparseMatrix<2>&, Eigen::VectorXd&, const DirichletValues&);
template void applyDirichlet<3>(BlockSparseMatrix<3>&, Eigen::VectorXd&, const DirichletValues&);

}  // namespace obs
