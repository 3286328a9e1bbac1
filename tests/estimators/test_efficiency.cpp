// The residual estimator on the manufactured plane-wave solution (Verification.hpp), solved with
// solveLinearElasticity on three uniformly refined (distorted, hence non-affine) box meshes of each
// cell type: eta decreases like h, and the efficiency index eta / ||u - u_h||_a (energy norm) stays
// in a narrow band (measured: 148-168 triangles, 230-262 quadrilaterals, 151-170 tetrahedra,
// 390-467 hexahedra, 233-276 prisms, 311-339 pyramids, for E = 100; the index scales with sqrt(E)).
// The indices are printed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numeric>

#include "obs/estimators/ResidualEstimator.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/RedRefinement.hpp"
#include "obs/obs/CellValues.hpp"
#include "obs/obs/LinearElasticity.hpp"
#include "obs/obs/Verification.hpp"

using namespace obs;
using namespace obs::estimators;
using mesh::CellType;

namespace {

/// ||u - u_h||_a = (int sigma(e) : eps(e))^{1/2}, e = u - u_h.
template <int d>
double energyError(const mesh::Mesh& m, const Eigen::VectorXd& uh, const PlaneWaveSolution& u,
                   const Material& mat) {
  CellValues<d> cv(5);
  double sum = 0;
  for (Index c = 0; c < m.numCells(); ++c) {
    cv.reinit(m, c);
    const auto verts = m.cellVertices(c);
    for (int q = 0; q < cv.numPoints(); ++q) {
      Eigen::Matrix<double, d, d> G = Eigen::Matrix<double, d, d>::Zero();
      for (int i = 0; i < cv.numVertices(); ++i)
        G += uh.template segment<d>(verts[i] * d) * cv.gradient(q, i).transpose();
      Point x = Point::Zero();
      x.template head<d>() = cv.point(q);
      const Eigen::Matrix<double, d, d> E = u.gradient(x).template topLeftCorner<d, d>() - G;
      const Eigen::Matrix<double, d, d> eps = 0.5 * (E + E.transpose());
      sum += cv.JxW(q) * (2 * mat.mu() * eps.squaredNorm() + mat.lambda() * eps.trace() * eps.trace());
    }
  }
  return std::sqrt(sum);
}

struct Level {
  Index cells;
  double eta, error;
};

Level runLevel(const mesh::Mesh& m, const Material& mat) {
  const int d = m.dimension();
  const PlaneWaveSolution u(d, mat);
  BoundaryConditions bc;
  bc.bodyForce = [&u](const Point& x) { return u.bodyForce(x); };
  for (int id = 1; id <= 2 * d; ++id) {
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[id <= 2 ? 0 : id <= 4 ? d - 1 : 1] = id % 2 == 0 ? 1.0 : -1.0;
    if (id % 2 == 1)
      bc.dirichlet.push_back({id, {true, true, true}, [&u](const Point& x) { return u.value(x); }});
    else
      bc.neumann.push_back({id, [&u, n](const Point& x) { return u.traction(x, n); }, {}});
  }
  const auto s = solveLinearElasticity(m, mat, bc);
  const auto r = ResidualEstimator().estimate(EstimatorInput(m, mat, bc, s.displacement));
  // sum identity on a realistic field
  const double byCells = std::accumulate(r.indicators.begin(), r.indicators.end(), 0.0,
                                         [](double a, double e) { return a + e * e; });
  double byContribution = 0;
  for (const Contribution& c : r.contributions) byContribution += c.value * c.value;
  EXPECT_NEAR(byCells, byContribution, 1e-12 * byContribution);
  EXPECT_EQ(r.contribution("eta_4"), 0.0);
  const double err = d == 2 ? energyError<2>(m, s.displacement, u, mat)
                            : energyError<3>(m, s.displacement, u, mat);
  return {m.numCells(), r.total, err};
}

class Efficiency : public ::testing::TestWithParam<CellType> {};

TEST_P(Efficiency, EstimatorDecreasesLikeHAndIsEfficient) {
  const CellType t = GetParam();
  const Material mat{100.0, 0.3};
  const int n0 = mesh::dimension(t) == 2 ? 4 : 3;
  auto m = mesh::boxMesh(t, n0);
  distortUnitBox(m, 0.08);  // non-affine cells; refinement keeps the coarse geometry
  std::vector<Level> levels;
  for (int l = 0; l < 3; ++l) {
    if (l > 0) m = mesh::refineUniformly(m);
    levels.push_back(runLevel(m, mat));
  }
  double lo = 1e300, hi = 0;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const double index = levels[l].eta / levels[l].error;
    lo = std::min(lo, index);
    hi = std::max(hi, index);
    std::printf("[ efficiency ] %-13s level %zu: %6d cells  eta = %.4e  ||e||_a = %.4e  "
                "eta/||e||_a = %.3f%s\n",
                std::string(mesh::name(t)).c_str(), l, levels[l].cells, levels[l].eta,
                levels[l].error, index,
                l > 0 ? (" rate " + std::to_string(std::log2(levels[l - 1].eta / levels[l].eta)))
                            .c_str()
                      : "");
    if (l > 0) {
      // eta ~ h: rates log2(eta_{l-1}/eta_l) near 1. The coarse 3D levels are pre-asymptotic
      // (measured 0.76 ... 1.0; a fourth level gives 0.96 for hexahedra and prisms, with the
      // efficiency index settling at 478 and 283)
      const double rate = std::log2(levels[l - 1].eta / levels[l].eta);
      EXPECT_GT(rate, 0.7) << mesh::name(t) << " level " << l;
      EXPECT_LT(rate, 1.2) << mesh::name(t) << " level " << l;
    }
  }
  EXPECT_LT(hi / lo, 1.3) << "efficiency index band [" << lo << ", " << hi << "]";
  // eta / ||e||_a scales like sqrt(E) (here 10) times a mesh-shape constant: measured 148 ... 467
  EXPECT_GT(lo, 50.0);
  EXPECT_LT(hi, 1000.0);
}

INSTANTIATE_TEST_SUITE_P(AllCellTypes, Efficiency, ::testing::ValuesIn(mesh::kVolumeCellTypes),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

}  // namespace
