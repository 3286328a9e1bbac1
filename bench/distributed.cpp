// bench/distributed: the step-42 problem (data/scenes/step42.toml: unit cube of hexahedra, coarse
// 4^3, clamped at the bottom, sides on rollers, a rigid ball of radius 0.6 centred at
// (0.5, 0.5, 1.59) pressed into the top) on a DistributedGrid and solved by distributed TNNMG, on
// as many ranks as the launch has (docs/performance.md#distributed).
//
//   mpirun -np P build/bench/distributed OUT.tsv --refine K [--cells-per-part C] [--cells NX,NY,NZ]
//                                        [--partition-level L]
//
// --partition-level 0 distributes the coarse level too (no replicated level; the coarse problem by
// hypre's CG + BoomerAMG, DistributedCoarseSolver); by default the coarsest level with C cells per
// rank, at least level 1, is the partition level and the levels below it are replicated.
// Rank 0 appends one row to OUT.tsv (written with a header if new): ranks, refinement, unknowns,
// partition level, the wall seconds of building the grid, assembling and solving (maxima over the
// ranks), TNNMG iterations, active set, contact load, peak memory per rank (largest and sum, MB),
// the leaves the largest rank holds against the whole grid's, ghost vertices, rank colours, and the
// halo messages and values of one fine-level update (largest rank), V-cycles and operator updates,
// and the communication of the solve, setup included (Communicator::counts(), largest rank):
// neighbour exchanges, messages and bytes sent, reductions and the values reduced, other
// collectives; the CG iterations of a distributed coarse level (0 when it is replicated). scripts/distributed_bench.sh
// runs 1 and 2 ranks side by side and writes the table of docs/performance.md#distributed.
#include <sys/resource.h>

#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/BoundaryConditions.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/ContactSet.hpp"
#include "obs/obs/DistributedGrid.hpp"
#include "obs/obs/Material.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/TNNMG.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using obs::mesh::Point;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double peakMemoryMB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // ru_maxrss in KB on Linux
}

/// step-42 on the box [0, X] x [0, Y] x [0, Z]: the ball (radius 0.6) 0.59 above the centre of the
/// top face (X = Y = Z = 1: the unit cube of step-42 itself).
obs::ContactProblem<3> step42(const obs::mesh::Mesh& m, const Point& size) {
  obs::BoundaryConditions bc;
  const auto zero = [](const Point&) { return Point::Zero().eval(); };
  bc.dirichlet.push_back({obs::mesh::kBottom, {true, true, true}, zero});
  for (int side : {obs::mesh::kLeft, obs::mesh::kRight, obs::mesh::kFront, obs::mesh::kBack})
    bc.dirichlet.push_back({side, {true, true, false}, zero});
  const obs::BallObstacle ball(Point(0.5 * size[0], 0.5 * size[1], size[2] + 0.59), 0.6, Point::UnitZ());
  const obs::ContactSet contact(m, obs::mesh::kTop, ball, true);
  return obs::ContactProblem<3>(m, obs::Material{2e5, 0.3}, bc, contact);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  const obs::Communicator comm = obs::Communicator::world();
  if (argc < 2) {
    if (comm.rank() == 0) std::cerr << "usage: mpirun -np P distributed OUT.tsv [--refine K]\n";
    return 2;
  }
  const std::filesystem::path out = argv[1];
  int refine = 3;
  obs::ForestPartitionOptions partition;
  std::array<int, 3> cells{4, 4, 4};
  for (int i = 2; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--cells") {
      char comma = 0;
      std::istringstream in(argv[i + 1]);
      in >> cells[0] >> comma >> cells[1] >> comma >> cells[2];
    }
    if (std::string(argv[i]) == "--refine") refine = std::stoi(argv[i + 1]);
    if (std::string(argv[i]) == "--cells-per-part") partition.cellsPerPart = std::stoi(argv[i + 1]);
    if (std::string(argv[i]) == "--partition-level") partition.level = std::stoi(argv[i + 1]);
  }
  try {
    auto t = Clock::now();
    // coarse cells of size 1/4: --cells 8,4,4 is a box twice as long (weak scaling)
    const Point size(cells[0] / 4.0, cells[1] / 4.0, cells[2] / 4.0);
    const obs::DistributedGrid dg(
        obs::mesh::Grid(obs::mesh::boxMesh(obs::mesh::CellType::Hexahedron, cells, Point::Zero(), size)), refine, comm,
        partition);
    const obs::DistributedView leaf = dg.view();
    const double build = comm.max(since(t));
    t = Clock::now();
    std::optional<obs::ContactProblem<3>> problem;
    comm.collective([&] { problem.emplace(step42(leaf.local, size)); });
    const double assembly = comm.max(since(t));
    t = Clock::now();
    obs::Communicator::resetCounts();  // the communication of the solve (setup included)
    obs::TNNMG<3> solver(dg);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(problem->numDofs());
    const obs::ContactResult result = solver.solve(*problem, u);
    const obs::CommunicationCounts traffic = obs::Communicator::counts();
    const double solve = comm.max(since(t));
    // the contact load: the owned vertices' nodal contact forces, summed over the ranks
    const Eigen::VectorXd mu = problem->multipliers(u);
    double load = 0;
    for (std::size_t k = 0; k < problem->constraints().size(); ++k)
      if (problem->constraint(static_cast<obs::Index>(k)).vertex < leaf.halo.numOwned()) load += mu[static_cast<Eigen::Index>(k)];
    load = comm.sum(load);
    const double memory = peakMemoryMB();
    const double memoryMax = comm.max(memory), memorySum = comm.sum(memory);
    // counts as integers (exact as doubles below 2^53)
    const auto largest = [&](long long x) { return static_cast<long long>(comm.max(static_cast<double>(x))); };
    const long long leaves = largest(dg.grid().numLeafElements());
    const long long ghosts = largest(leaf.halo.numLocal() - leaf.halo.numOwned());
    const long long messages = largest(leaf.halo.sendNeighbours() + leaf.halo.receiveNeighbours());
    const long long values = largest(static_cast<long long>(leaf.halo.sentValues()) + leaf.halo.receivedValues());
    const long long ownedMax = largest(leaf.halo.numOwned()), ownedMin = -largest(-leaf.halo.numOwned());
    const long long exchanges = largest(traffic.neighbourExchanges), sent = largest(traffic.messagesSent);
    const long long bytes = largest(traffic.bytesSent), reductions = largest(traffic.reductions);
    const long long reduced = largest(traffic.reducedValues), collectives = largest(traffic.otherCollectives);
    const obs::DistributedSweep sweep(problem->rotatedMatrix().rowStarts(), problem->rotatedMatrix().columns(),
                                      problem->rotatedMatrix().sweepOrder(), leaf.halo);
    if (comm.rank() == 0) {
      const bool fresh = !std::filesystem::exists(out);
      std::ofstream f(out, std::ios::app);
      if (fresh)
        f << "ranks\trefine\tunknowns\tpartition_level\tbuild_s\tassembly_s\tsolve_s\titerations\tconverged\tactive\tload\t"
             "memory_max_mb\tmemory_sum_mb\tleaves_max\tleaves_global\tghosts_max\tcolours\tmessages_max\tvalues_max\t"
             "owned_max\towned_min\tcells\tvcycles\toperator_updates\texchanges\tmessages_sent_max\tbytes_sent_max\t"
             "reductions\treduced_values_max\tother_collectives\tcoarse_iterations\n";
      f << comm.size() << '\t' << refine << '\t' << 3LL * leaf.globalVertices() << '\t' << dg.partition().level << '\t'
        << build << '\t' << assembly << '\t' << solve << '\t' << result.iterations << '\t' << (result.converged ? 1 : 0)
        << '\t' << result.activeSetSize << '\t' << std::setprecision(9) << load << std::setprecision(6) << '\t'
        << memoryMax << '\t' << memorySum << '\t' << leaves << '\t' << dg.globalLeaves() << '\t' << ghosts << '\t'
        << sweep.colours() << '\t' << messages << '\t' << values << '\t' << ownedMax << '\t' << ownedMin << '\t'
        << cells[0] << ',' << cells[1] << ',' << cells[2] << '\t' << solver.statistics().vcycles << '\t'
        << solver.statistics().operatorUpdates << '\t' << exchanges << '\t' << sent << '\t' << bytes << '\t'
        << reductions << '\t' << reduced << '\t' << collectives << '\t' << solver.statistics().coarseIterations << '\n';
      if (!f) throw obs::Error(out.string() + ": cannot write");
      std::cout << comm.size() << " ranks, refine " << refine << ": " << 3LL * leaf.globalVertices() << " unknowns, solve "
                << solve << " s, " << result.iterations << " iterations, load " << std::setprecision(9) << load
                << std::setprecision(6) << ", memory " << memoryMax << " MB per rank (largest)\n";
    }
  } catch (const std::exception& e) {
    if (comm.rank() == 0) std::cerr << "distributed: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
