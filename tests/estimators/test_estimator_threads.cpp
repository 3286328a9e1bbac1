// The residual estimators on several threads (docs/performance.md#estimator-threads): the cells
// and faces are evaluated concurrently and added to the table in order, so every contribution,
// indicator and field is bitwise the one of a single thread; an error inside the threaded loops is
// the error of one thread.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../GridCheck.hpp"
#include "../ThreadScope.hpp"
#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/Parallel.hpp"

using namespace obs;
using obs::test::ThreadScope;
using namespace obs::estimators;
using mesh::CellType;

namespace {

const Material kMaterial{2e5, 0.3};


/// A smooth, non-polynomial displacement at the vertices (every eta_k is nonzero).
Eigen::VectorXd field(const mesh::Mesh& m, int d) {
  Eigen::VectorXd u(m.numVertices() * d);
  for (Index v = 0; v < m.numVertices(); ++v) {
    const Point x = m.vertex(v);
    const Eigen::Vector3d w(std::sin(3 * x[0] + x[1]) - 0.5 * x[2], std::cos(2 * x[1]) * (1 + x[2]),
                            x[0] * x[1] - std::exp(x[2]) - 0.02 * std::cos(5 * x[0]));
    u.segment(v * d, d) = 1e-3 * w.head(d);
  }
  return u;
}

void expectBitwiseEqual(const EstimatorResult& a, const EstimatorResult& b) {
  EXPECT_EQ(a.total, b.total);
  ASSERT_EQ(a.contributions.size(), b.contributions.size());
  for (std::size_t k = 0; k < a.contributions.size(); ++k)
    EXPECT_EQ(a.contributions[k].value, b.contributions[k].value) << a.contributions[k].name;
  EXPECT_EQ(a.indicators, b.indicators);
  ASSERT_EQ(a.cellFields.size(), b.cellFields.size());
  for (const auto& [name, values] : a.cellFields) EXPECT_EQ(values, b.cellFields.at(name)) << name;
  ASSERT_EQ(a.vertexFields.size(), b.vertexFields.size());
  for (const auto& [name, values] : a.vertexFields)
    EXPECT_EQ((values - b.vertexFields.at(name)).cwiseAbs().maxCoeff(), 0.0) << name;
}

/// Both estimators on one and on two threads, with a body force, a Neumann side, Dirichlet
/// sides and a contact boundary against a plane below the bottom.
template <int d>
void checkThreadCounts(const mesh::Mesh& m) {
  ASSERT_GE(m.numCells(), kParallelMinRows);  // the loops run on threads (cells, faces,
  ASSERT_GE(m.numVertices(), kParallelMinRows);  // and the vertex patches of h)
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point::Zero(); }});
  bc.dirichlet.push_back({mesh::kLeft, {true, false, false}, [](const Point&) { return Point::Zero(); }});
  bc.neumann.push_back({mesh::kRight, [](const Point& x) { return Point(1e2 * x[1], -50, 0); }, {}});
  bc.bodyForce = [](const Point& x) { return Point(x[1], -1e3, 10 * x[0]); };
  Point down = Point::Zero();  // -e_y in 2D, -e_z in 3D: the bottom's outward normal
  down[d - 1] = -1;
  const PlaneObstacle plane(1e-3 * down, down);
  const ContactSet set(m, mesh::kBottom, plane);
  const ContactProblem<d> problem(m, kMaterial, bc, set);
  const Eigen::VectorXd u = field(m, d);
  const ContactOutputs outputs = computeContactOutputs(problem, u);
  const ContactData data{&set, &outputs, &plane};
  EstimatorInput in(m, kMaterial, bc, u);
  in.contact = &data;
  const ResidualEstimator residual;
  const ContactResidualEstimator contact;
  for (const Estimator* e : {static_cast<const Estimator*>(&residual), static_cast<const Estimator*>(&contact)}) {
    const EstimatorResult one = e->estimate(in);
    ASSERT_GT(one.total, 0);
    for (const Contribution& c : one.contributions) {
      if (c.name == "eta_1" || c.name == "eta_2" || c.name == "eta_3" || c.name == "eta_4") {
        EXPECT_GT(c.value, 0) << e->name() << " " << c.name;
      }
    }
    const ThreadScope scope(2);
    expectBitwiseEqual(one, e->estimate(in));
  }
}

}  // namespace

TEST(EstimatorThreads, TrianglesAreBitwiseTheSingleThreadResult) {
  auto m = mesh::boxMesh(CellType::Triangle, 48);
  mesh::perturbInteriorVertices(m, 0.2, 5);
  checkThreadCounts<2>(m);
}

// Hexahedra with the pyramids and tetrahedra of their green closure, distorted: non-affine cells,
// faces between different cell types.
TEST(EstimatorThreads, ClosedHexahedralGridIsBitwiseTheSingleThreadResult) {
  mesh::Grid grid(mesh::boxMesh(CellType::Hexahedron, 8));
  obs::test::refineNear(grid, Point(0.5, 0.5, 0), 0.4, 2, 0.6);
  mesh::Mesh m = grid.leafView().mesh;
  mesh::perturbInteriorVertices(m, 0.15, 3);
  std::array<int, 8> types{};
  for (Index c = 0; c < m.numCells(); ++c) ++types[static_cast<int>(m.cellType(c))];
  EXPECT_GT(types[static_cast<int>(CellType::Pyramid)], 0);
  checkThreadCounts<3>(m);
}

// A degenerate cell: the same obs::Error on two threads as on one.
TEST(EstimatorThreads, DegenerateCellIsTheSameErrorOnThreads) {
  auto m = mesh::boxMesh(CellType::Hexahedron, 14);
  const auto verts = m.cellVertices(m.numCells() / 2);
  m.vertex(verts[0]) = m.vertex(verts[6]);  // collapse the cell
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point::Zero(); }});
  const Eigen::VectorXd u = field(m, 3);
  const EstimatorInput in(m, kMaterial, bc, u);
  auto message = [&] {
    try {
      ResidualEstimator().estimate(in);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string one = message();
  std::string two;
  {
    const ThreadScope scope(2);
    two = message();
  }
  EXPECT_NE(one.find("degenerate or inverted"), std::string::npos) << one;
  EXPECT_EQ(one, two);
}
