#include "obs/obs/LinearElasticity.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "obs/mesh/Error.hpp"
#include "obs/obs/CellValues.hpp"
#include "obs/obs/CholmodSolver.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Cell-mean stresses and their volume-weighted average at the vertices. The cells are independent
/// and run on threads() threads; the vertex averages are summed in cell order on one thread, so the
/// result does not depend on the thread count. On triangles and tetrahedra the stress is constant:
/// one quadrature point gives its mean.
template <int d>
void recoverStressesOf(const mesh::Mesh& mesh, const Material& mat, ElasticitySolution& s) {
  const double lambda = mat.lambda(), mu = mat.mu();
  const bool bbar = mat.formulation == VolumetricFormulation::BBar;
  const Index cells = mesh.numCells();
  s.cellStress.assign(cells, Stress::Zero());
  s.vertexStress.assign(mesh.numVertices(), Stress::Zero());
  std::vector<double> volume(static_cast<std::size_t>(cells), 0.0);
  const auto cellStress = [&](CellValues<d>& cv, Index c) {
    cv.reinit(mesh, c);
    const auto verts = mesh.cellVertices(c);
    auto gradientAt = [&](int q) {
      Eigen::Matrix<double, d, d> grad = Eigen::Matrix<double, d, d>::Zero();  // du_a/dx_b
      for (int i = 0; i < cv.numVertices(); ++i)
        grad += s.displacement.template segment<d>(static_cast<Eigen::Index>(verts[i]) * d) *
                cv.gradient(q, i).transpose();
      return grad;
    };
    // B-bar: sigma = 2 mu eps + (kappa mean(div u) - 2 mu/3 div u) I (docs/theory.md#b-bar)
    double vol = 0, meanDivergence = 0;
    for (int q = 0; q < cv.numPoints(); ++q) {
      vol += cv.JxW(q);
      if (bbar) meanDivergence += cv.JxW(q) * gradientAt(q).trace();
    }
    meanDivergence /= vol;
    Stress sum = Stress::Zero();
    for (int q = 0; q < cv.numPoints(); ++q) {
      const Eigen::Matrix<double, d, d> grad = gradientAt(q);
      const Eigen::Matrix<double, d, d> eps = 0.5 * (grad + grad.transpose());
      const double volumetric = bbar ? mat.bulkModulus() * meanDivergence - 2 * mu / 3 * eps.trace()
                                     : lambda * eps.trace();
      Stress sigma = Stress::Zero();
      sigma.template topLeftCorner<d, d>() = 2 * mu * eps;
      sigma.diagonal().array() += volumetric;  // plane strain: sigma_zz = the volumetric part
      sum += cv.JxW(q) * sigma;
    }
    s.cellStress[c] = sum / vol;
    volume[static_cast<std::size_t>(c)] = vol;
  };
  // no exception may leave a parallel region: the first degenerate cell is found on the threads and
  // its error thrown again afterwards, as the sequential loop would have thrown it
  const int nt = cells >= kParallelMinRows ? threads() : 1;
  Index failed = cells;
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    CellValues<d> general(2), simplex(1);
#pragma omp for schedule(dynamic, kRowChunk) reduction(min : failed)
    for (Index c = 0; c < cells; ++c) {
      const mesh::CellType t = mesh.cellType(c);
      try {
        cellStress(t == mesh::CellType::Triangle || t == mesh::CellType::Tetrahedron ? simplex : general, c);
      } catch (const Error&) {
        failed = std::min(failed, c);
      }
    }
  }
  if (failed < cells) {
    CellValues<d> any(2);
    cellStress(any, failed);  // throws its obs::Error
  }
  std::vector<double> weight(mesh.numVertices(), 0.0);
  for (Index c = 0; c < cells; ++c)
    for (Index v : mesh.cellVertices(c)) {
      s.vertexStress[v] += volume[static_cast<std::size_t>(c)] * s.cellStress[c];
      weight[v] += volume[static_cast<std::size_t>(c)];
    }
  for (Index v = 0; v < mesh.numVertices(); ++v)
    if (weight[v] > 0) s.vertexStress[v] /= weight[v];
}

template <int d>
ElasticitySolution solve(const mesh::Mesh& mesh, const Material& material, const BoundaryConditions& bc) {
  material.validate();
  ElasticitySolution s;
  s.dimension = d;
  auto t0 = Clock::now();
  auto A = assembleStiffness<d>(mesh, material);
  Eigen::VectorXd b = assembleLoad<d>(mesh, bc);
  const DirichletValues g = collectDirichlet(mesh, bc.dirichlet);
  applyDirichlet(A, b, g);
  s.assemblySeconds = since(t0);
  s.dofs = static_cast<long long>(mesh.numVertices()) * d;
  s.freeDofs = s.dofs - g.count();

  t0 = Clock::now();
  CholmodSolver solver(A);
  s.displacement = solver.solve(b);
  s.solveSeconds = since(t0);
  s.factorNonZeros = solver.factorNonZeros();
  if (!s.displacement.allFinite())
    throw Error("linear elasticity: the solution contains NaN or Inf (ill-posed problem?)");
  recoverStressesOf<d>(mesh, material, s);
  return s;
}

}  // namespace

ElasticitySolution solveLinearElasticity(const mesh::Mesh& mesh, const Material& material,
                                         const BoundaryConditions& bc) {
  return mesh.dimension() == 2 ? solve<2>(mesh, material, bc) : solve<3>(mesh, material, bc);
}

void recoverStresses(const mesh::Mesh& mesh, const Material& material, ElasticitySolution& solution) {
  if (solution.displacement.size() != static_cast<Eigen::Index>(mesh.numVertices()) * mesh.dimension())
    throw Error("recoverStresses: the displacement has " + std::to_string(solution.displacement.size()) +
                " entries, the mesh " + std::to_string(mesh.numVertices()) + " vertices in " +
                std::to_string(mesh.dimension()) + "D");
  solution.dimension = mesh.dimension();
  if (mesh.dimension() == 2)
    recoverStressesOf<2>(mesh, material, solution);
  else
    recoverStressesOf<3>(mesh, material, solution);
}

double vonMises(const Stress& s) {
  const double a = s(0, 0) - s(1, 1), b = s(1, 1) - s(2, 2), c = s(2, 2) - s(0, 0);
  const double shear = s(0, 1) * s(0, 1) + s(1, 2) * s(1, 2) + s(0, 2) * s(0, 2);
  return std::sqrt(0.5 * (a * a + b * b + c * c) + 3 * shear);
}

}  // namespace obs
