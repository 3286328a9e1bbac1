// A distributed operator product under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks): every rank
// partitions the same grid (ForestPartition.hpp), takes its part, fills its ghost vertices by the
// halo exchange (HaloExchange.hpp), assembles the stiffness on its owned and ghost cells and
// multiplies. Its owned rows must equal the serial product's, and the reduced energy x'Ax the
// serial one (docs/architecture.md#halo).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/ForestPartition.hpp"
#include "obs/obs/HaloExchange.hpp"
#include "obs/obs/Material.hpp"

namespace {

using obs::Index;
using obs::mesh::CellType;

double field(Index global, int component) { return std::sin(0.37 * global + 1.3 * component) + 0.1 * component; }

template <int d>
void expectDistributedProduct(CellType type, int cells, int levels) {
  SCOPED_TRACE(std::string(obs::mesh::name(type)));
  const obs::Communicator comm = obs::Communicator::world();
  obs::mesh::Grid grid(obs::mesh::boxMesh(type, cells));
  for (int l = 0; l < levels; ++l) grid.refineUniformly();
  const obs::ForestPartition p = obs::partitionForest(grid, comm.size());
  const obs::mesh::GridView view = grid.leafView();
  const obs::ViewNumbering numbering = obs::numberView(grid, view, p);
  const obs::PartView part = obs::partView(grid, view, p, numbering, comm.rank());
  const obs::HaloExchange halo(numbering, part, comm);

  // owned values from the global numbering, ghosts from the exchange
  Eigen::VectorXd x = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(halo.numLocal()) * d, -1e300);
  for (Index i = 0; i < halo.numOwned(); ++i)
    for (int c = 0; c < d; ++c) x[i * d + c] = field(numbering.global[halo.viewVertices()[i]], c);
  halo.update(x, d);
  for (Index i = halo.numOwned(); i < halo.numLocal(); ++i)
    for (int c = 0; c < d; ++c) ASSERT_EQ(x[i * d + c], field(numbering.global[halo.viewVertices()[i]], c));

  // the local product on the owned rows against the serial one
  const obs::Material material{1.0, 0.3};
  const obs::mesh::Mesh local = obs::localMesh(view, part, halo);
  const Eigen::VectorXd y = obs::assembleStiffness<d>(local, material) * x;
  const Index n = view.mesh.numVertices();
  Eigen::VectorXd xs(static_cast<Eigen::Index>(n) * d);
  for (Index v = 0; v < n; ++v)
    for (int c = 0; c < d; ++c) xs[v * d + c] = field(numbering.global[v], c);
  const Eigen::VectorXd ys = obs::assembleStiffness<d>(view.mesh, material) * xs;
  const double scale = ys.cwiseAbs().maxCoeff();
  double energy = 0;
  for (Index i = 0; i < halo.numOwned(); ++i) {
    const Index v = halo.viewVertices()[i];
    for (int c = 0; c < d; ++c) {
      EXPECT_NEAR(y[i * d + c], ys[v * d + c], 1e-12 * scale) << "vertex " << v;
      energy += x[i * d + c] * y[i * d + c];
    }
  }
  const double serial = xs.dot(ys);
  EXPECT_NEAR(comm.sum(energy), serial, 1e-12 * std::abs(serial));
  // every vertex owned exactly once over the ranks
  EXPECT_EQ(comm.sum(static_cast<long long>(halo.numOwned())), static_cast<long long>(n));
  EXPECT_EQ(static_cast<long long>(halo.receivedValues()), static_cast<long long>(part.ghostVertices.size()));
  EXPECT_EQ(comm.sum(static_cast<long long>(halo.sentValues())), comm.sum(static_cast<long long>(halo.receivedValues())));
  // messages only between neighbouring parts: every message sent is received
  EXPECT_LE(halo.sendNeighbours(), comm.size() - 1);
  EXPECT_EQ(comm.sum(static_cast<long long>(halo.sendNeighbours())), comm.sum(static_cast<long long>(halo.receiveNeighbours())));
  if (comm.size() > 1) {
    EXPECT_GE(halo.receiveNeighbours(), 1);
  }
}

// update(x, d, from): the ghosts owned by marked ranks take their owners' values, the others keep
// theirs; the counters see one round with a message per marked neighbour; marks of the wrong
// length are refused on every rank.
TEST(HaloExchange, UpdateFromMarkedOwnersOnly) {
  const obs::Communicator comm = obs::Communicator::world();
  obs::mesh::Grid grid(obs::mesh::boxMesh(CellType::Quadrilateral, 4));
  grid.refineUniformly();
  const obs::ForestPartition p = obs::partitionForest(grid, comm.size());
  const obs::mesh::GridView view = grid.leafView();
  const obs::ViewNumbering numbering = obs::numberView(grid, view, p);
  const obs::PartView part = obs::partView(grid, view, p, numbering, comm.rank());
  const obs::HaloExchange halo(numbering, part, comm);
  std::vector<char> odd(static_cast<std::size_t>(comm.size()), 0);
  for (int r = 1; r < comm.size(); r += 2) odd[static_cast<std::size_t>(r)] = 1;
  Eigen::VectorXd x = Eigen::VectorXd::Constant(halo.numLocal(), -1.0);
  for (Index i = 0; i < halo.numOwned(); ++i) x[i] = numbering.global[halo.viewVertices()[i]];
  obs::Communicator::resetCounts();
  halo.update(x, 1, odd);
  long long expectedMessages = odd[static_cast<std::size_t>(comm.rank())] ? halo.sendNeighbours() : 0;
  for (Index i = halo.numOwned(); i < halo.numLocal(); ++i) {
    const Index v = halo.viewVertices()[i];
    EXPECT_EQ(x[i], odd[static_cast<std::size_t>(numbering.owner[v])] ? numbering.global[v] : -1.0) << "ghost " << i;
  }
  EXPECT_EQ(obs::Communicator::counts().messagesSent, comm.size() > 1 ? expectedMessages : 0);
  EXPECT_THROW(halo.update(x, 1, std::vector<char>(static_cast<std::size_t>(comm.size()) + 1, 1)), obs::Error);
}

TEST(HaloExchange, DistributedProductEqualsTheSerialOne2D) { expectDistributedProduct<2>(CellType::Triangle, 4, 3); }
TEST(HaloExchange, DistributedProductEqualsTheSerialOne3D) { expectDistributedProduct<3>(CellType::Hexahedron, 2, 2); }

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
