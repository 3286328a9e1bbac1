// Threads: what obs gains from a second core, and why (docs/performance.md#threads).
//
//   build/bench/threads OUT.md [--threads T] [--level L] [--repeat R] [--obs build/drivers/obs]
//                              [--baseline OLD_OBS] [--only SECTIONS]
//
// Side by side in one run, for 1..T threads (obs::setThreads):
//  1. the machine: STREAM-like triad bandwidth a = b + 3c over 3 x 512 MB (what a memory-bound loop
//     can gain from more threads on this machine), and the throughput of T threads on a compute-bound
//     loop in units of one thread (what a compute-bound loop can gain; 2 on two cores of its own,
//     less when the virtual CPUs share a core with other work of the host);
//  2. the kernels on the step-42 grid (unit cube of hexahedra, coarse 2^3, L levels: 64^3 cells for
//     L = 5): stiffness assembly, y = A x, two products in one pass, one truncated linear
//     Gauss-Seidel sweep (the V-cycle's smoother), one nonsmooth block Gauss-Seidel sweep (TNNMG's
//     fine smoother); best of R, the thread counts alternating run by run;
//     each with one block per entry and with the repeated blocks shared (the storage of obs' solves,
//     BlockSparseMatrix::shareRepeatedBlocks); the sweep orders; the coarse operators of every level
//     (MultigridHierarchy::setFineOperator: Galerkin patterns and products, TNNMG's set-up);
//  2b. the schedule of the row loops (T > 1): y = A x on the shared matrix, its rows in T fixed ranges
//     against chunks of kRowChunk rows handed out as the threads ask (obs' schedule), alternating,
//     20 R products each: best, quartiles, median, worst;
//  3. TNNMG on the step-42 problem: iterations, solve seconds (the fastest of max(2, R) solves and
//     every solve), energy, and its V-cycles by level; the solves of a thread count (the thread
//     counts alternating) must give bitwise the same solution (reproducibility for a fixed thread
//     count);
//  3b. one V(3,3) cycle of the linear correction on the step-42 operator, level by level: smoothing,
//     defect, transfers and the coarse solve (LinearMultigrid::levelSeconds), the thread counts
//     alternating;
//  4. with --obs: the whole `obs run data/scenes/step42.toml --refine 4` per thread count (wall and
//     CPU seconds, peak memory, from /usr/bin/time; the mesh, assembly, solve and output phases
//     from summary.json, and the set-up within the solve where summary.json has TNNMG's phases; the
//     size of the .vtu file; after every run on T > 1 threads the compute throughput of T threads,
//     measured again); with --baseline also another obs binary (an older version, say), the two
//     alternating run by run, with the solver's correction of each.
// --only machine,kernels,schedule,tnnmg,vcycles,obs (any of them, comma-separated) runs and writes only those
// sections (experiments; write to a scratch file, not the docs).
// Writes the tables between the bench/threads markers of OUT.md (MarkdownBlock.hpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "MarkdownBlock.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/MultigridHierarchy.hpp"
#include "obs/obs/Obstacle.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"
#include "obs/obs/TNNMG.hpp"
#include "obs/obs/TruncatedGaussSeidel.hpp"

using namespace obs;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

template <class F>
double best(int repeat, F&& f) {
  double b = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    f();
    b = std::min(b, since(t0));
  }
  return b;
}

std::string fmt(double v, int digits = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

/// a = b + 3 c on `threads` threads (the loop of OpenMP's static schedule); returns GB/s.
double triad(int threads, std::vector<double>& a, const std::vector<double>& b, const std::vector<double>& c) {
  const long n = static_cast<long>(a.size());
  const auto t0 = Clock::now();
#pragma omp parallel for schedule(static) num_threads(threads)
  for (long i = 0; i < n; ++i) a[i] = b[i] + 3.0 * c[i];
  return 3.0 * 8.0 * static_cast<double>(n) / since(t0) / 1e9;
}

/// Seconds of a compute-bound loop (8 independent multiply-add chains in registers, no memory
/// traffic) run by `threads` threads at once, each thread the whole loop.
double spin(int threads, long iterations) {
  const auto t0 = Clock::now();
  double sink = 0;
#pragma omp parallel num_threads(threads) reduction(+ : sink)
  {
    double x[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    for (long i = 0; i < iterations; ++i)
      for (double& v : x) v = v * 0.999999999 + 1e-9;
    for (double v : x) sink += v;
  }
  const double seconds = since(t0);
  if (!(sink > 0)) std::cerr << "";  // keeps the loop
  return seconds;
}

/// The machine's throughput for compute-bound work on `threads` threads, in units of one thread:
/// threads x (time of one thread alone) / (time of `threads` threads doing the same each). 2 on two
/// cores of its own; less when the virtual CPUs share a core or the host runs other work on them.
double computeCapacity(int threads) {
  constexpr long kIterations = 100'000'000;
  const double alone = spin(1, kIterations);
  return threads * alone / spin(threads, kIterations);
}

/// Rows of the V-cycle phases by level (finest first): per thread count the smoothing, defect,
/// transfers (restriction to and prolongation from the level below) and coarse solve, in
/// milliseconds after dividing by `cycles`, with the ratio against one thread; a last row with the
/// totals.
void levelTable(std::ostringstream& md, const std::vector<Index>& vertices,
                const std::vector<std::vector<LinearMultigrid<3>::LevelSeconds>>& byThreads, long long cycles) {
  const auto ms = [&](double sec) { return fmt(1e3 * sec / static_cast<double>(cycles)); };
  const auto cell = [&](double sec, double one, bool ratio) {
    return ms(sec) + (ratio && one > 0 && sec > 0 ? " (" + fmt(one / sec, 2) + "x)" : std::string());
  };
  md << "| level | vertices |";
  for (std::size_t t = 1; t <= byThreads.size(); ++t) md << " smoothing, " << t << " th. | defect | transfers | coarse solve |";
  md << "\n|---:|---:|";
  for (std::size_t t = 1; t <= byThreads.size(); ++t) md << "---:|---:|---:|---:|";
  md << "\n";
  std::vector<double> totals(byThreads.size(), 0.0);
  for (int l = static_cast<int>(vertices.size()) - 1; l >= 0; --l) {
    md << "| " << l << " | " << vertices[static_cast<std::size_t>(l)] << " |";
    const auto& one = byThreads[0][static_cast<std::size_t>(l)];
    for (std::size_t t = 0; t < byThreads.size(); ++t) {
      const auto& b = byThreads[t][static_cast<std::size_t>(l)];
      const bool ratio = t > 0;
      md << " " << cell(b.smoothing, one.smoothing, ratio) << " | " << cell(b.defect, one.defect, ratio) << " | "
         << cell(b.restriction + b.prolongation, one.restriction + one.prolongation, ratio) << " | "
         << cell(b.coarseSolve, one.coarseSolve, ratio) << " |";
      totals[t] += b.smoothing + b.defect + b.restriction + b.prolongation + b.coarseSolve;
    }
    md << "\n";
  }
  md << "| all | |";
  for (std::size_t t = 0; t < byThreads.size(); ++t)
    md << " " << cell(totals[t], totals[0], t > 0) << " | | | |";
  md << "\n";
}

std::vector<Index> levelVertices(const MultigridHierarchy<3>& h) {
  std::vector<Index> n;
  for (int l = 0; l <= h.maxLevel(); ++l) n.push_back(h.numVertices(l));
  return n;
}

struct Step42 {
  mesh::Grid grid;
  mesh::Mesh mesh;
  Material material{2e5, 0.3};
  BoundaryConditions bc;
  BallObstacle ball{Point(0.5, 0.5, 1.59), 0.6, Point::UnitZ()};
  explicit Step42(int level) : grid(mesh::boxMesh(mesh::CellType::Hexahedron, 2)) {
    for (int l = 0; l < level; ++l) grid.refineUniformly();
    mesh = grid.leafView().mesh;
    const auto fixed = [](const Point&) { return Point::Zero(); };
    bc.dirichlet.push_back({mesh::kBottom, {true, true, true}, fixed});
    for (int side : {mesh::kLeft, mesh::kRight, mesh::kFront, mesh::kBack})
      bc.dirichlet.push_back({side, {true, true, false}, fixed});
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]).starts_with("-")) {
    std::cerr << "usage: threads OUT.md [--threads T] [--level L] [--repeat R] [--obs OBS] [--baseline OLD_OBS]\n"
                 "               [--only machine,kernels,schedule,tnnmg,vcycles,obs]\n";
    return 2;
  }
  const std::filesystem::path out = argv[1];
  int maxThreads = 2, level = 5, repeat = 3;
  std::string obsBinary, baselineBinary, only;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "threads: " << a << " needs a value\n";
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--threads") maxThreads = std::stoi(v);
    else if (a == "--level") level = std::stoi(v);
    else if (a == "--repeat") repeat = std::stoi(v);
    else if (a == "--obs") obsBinary = v;
    else if (a == "--baseline") baselineBinary = v;
    else if (a == "--only") only = v;
    else {
      std::cerr << "threads: unknown option " << a << "\n";
      return 2;
    }
  }
  if (maxThreads < 1 || level < 1 || repeat < 1) {
    std::cerr << "threads: --threads, --level and --repeat must be positive\n";
    return 2;
  }
  if (!baselineBinary.empty() && obsBinary.empty()) {
    std::cerr << "threads: --baseline needs --obs\n";
    return 2;
  }
  // --only: a comma-separated list of the sections to run (all without it)
  const auto want = [&](const std::string& section) {
    return only.empty() || ("," + only + ",").find("," + section + ",") != std::string::npos;
  };
  for (std::size_t b = 0; !only.empty() && b <= only.size();) {
    const std::size_t e = std::min(only.find(',', b), only.size());
    const std::string name = only.substr(b, e - b);
    if (name != "machine" && name != "kernels" && name != "schedule" && name != "tnnmg" && name != "vcycles" &&
        name != "obs") {
      std::cerr << "threads: --only takes a comma-separated list of machine, kernels, schedule, tnnmg, vcycles, obs\n";
      return 2;
    }
    b = e + 1;
  }
  std::ostringstream md;
  Step42 s(level);
  const Index nv = s.mesh.numVertices();
  const auto T = static_cast<std::size_t>(maxThreads);

  // 1. the machine's memory bandwidth
  if (want("machine")) {
    md << "Memory bandwidth (triad a = b + 3c, 3 x 512 MB, best of " << repeat << "):\n\n| threads | GB/s |\n|---:|---:|\n";
    {
      const std::size_t n = std::size_t(1) << 26;
      std::vector<double> a(n, 1.0), b(n, 2.0), c(n, 3.0);
      for (int t = 1; t <= maxThreads; ++t) {
        double bw = 0;
        for (int r = 0; r < repeat; ++r) bw = std::max(bw, triad(t, a, b, c));
        md << "| " << t << " | " << fmt(bw) << " |\n";
        std::cerr << "triad, " << t << " threads: " << fmt(bw) << " GB/s\n";
      }
    }
    // the compute throughput of more threads: measured R times, since it changes with what the host
    // runs on the other virtual CPU
    md << "\nCompute throughput (a loop of multiply-adds in registers, run alone and by T threads at once, each "
          "the whole loop; in units of one thread, "
       << repeat << " measurements):\n\n| threads | best | median | worst |\n|---:|---:|---:|---:|\n";
    for (int t = 2; t <= maxThreads; ++t) {
      std::vector<double> c;
      for (int r = 0; r < repeat; ++r) c.push_back(computeCapacity(t));
      std::sort(c.begin(), c.end());
      md << "| " << t << " | " << fmt(c.back(), 3) << " | " << fmt(c[c.size() / 2], 3) << " | " << fmt(c.front(), 3)
         << " |\n";
      std::cerr << "compute throughput, " << t << " threads: " << fmt(c.back(), 3) << " best\n";
    }
  }

  // 2. kernels
  if (want("kernels")) {
    md << "\nKernels on the step-42 grid (" << s.mesh.numCells() << " hexahedra, " << nv * 3
       << " unknowns), seconds, best of " << repeat
       << " (assembly, products and sweeps: the thread counts alternating run by run):\n\n"
       << "| threads | blocks | assembly, shared as it goes (sharing a copy with one block per entry) | y = A x | two products in one pass | linear GS sweep | nonsmooth GS sweep | sweep order "
          "(METIS, fine graph) | interface vertices (of them on one thread) | sweep order (carried from the base level) | interface vertices (carried) | coarse operators (Galerkin) |\n"
       << "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    // Assembly, products and sweeps with the thread counts alternating repeat by repeat, so that a
    // change of the machine's state between the measurements enters every thread count alike. Each
    // thread count has its own matrices (the sweep order is kept per matrix for threads() parts).
    std::vector<BlockSparseMatrix<3>> plainA(T), sharedA(T);
    std::vector<double> assemblyBest(T, 1e300);
    for (int rep = 0; rep < repeat; ++rep)
      for (int t = 1; t <= maxThreads; ++t) {
        setThreads(t);
        const auto t0 = Clock::now();
        plainA[t - 1] = assembleStiffness<3>(s.mesh, s.material);
        assemblyBest[t - 1] = std::min(assemblyBest[t - 1], since(t0));
        plainA[t - 1].unshareBlocks();  // the assembly shares as it goes; the first rows are one block per entry
      }
    // per thread count and storage: y = A x, y, y2 = A x, A x2 (TNNMG's A w, A (w - w^k)), one linear
    // and one nonsmooth sweep
    struct Kernels {
      const BlockSparseMatrix<3>* matrix = nullptr;
      TruncatedGaussSeidel<3> linear;
      std::unique_ptr<BlockGaussSeidelSweep<3>> nonsmooth;
      std::vector<double> best = std::vector<double>(4, 1e300);
    };
    std::vector<Kernels> kernelSets(2 * T);  // [2 (t - 1)]: one block per entry, [2 (t - 1) + 1]: shared
    Eigen::VectorXd x = Eigen::VectorXd::Ones(nv * 3), y, r = Eigen::VectorXd::Ones(nv * 3);
    Eigen::VectorXd x2 = Eigen::VectorXd::Constant(nv * 3, 0.5), y2;
    for (int t = 1; t <= maxThreads; ++t) {
      setThreads(t);
      sharedA[t - 1] = plainA[t - 1];
      if (!sharedA[t - 1].shareRepeatedBlocks()) std::cerr << "threads: the step-42 matrix did not share its blocks\n";
      for (int k = 0; k < 2; ++k) {
        Kernels& K = kernelSets[2 * (t - 1) + k];
        K.matrix = k == 0 ? &plainA[t - 1] : &sharedA[t - 1];
        K.linear.setMatrix(*K.matrix);
        K.nonsmooth = std::make_unique<BlockGaussSeidelSweep<3>>(*K.matrix, std::vector<double>(static_cast<std::size_t>(nv), 0.0));
        K.linear.sweep(r, x);  // the sweep orders for t parts, outside the timings
        K.nonsmooth->sweep(r, x);
      }
    }
    for (int rep = 0; rep < repeat; ++rep)
      for (int t = 1; t <= maxThreads; ++t) {
        setThreads(t);
        for (int k = 0; k < 2; ++k) {
          Kernels& K = kernelSets[2 * (t - 1) + k];
          const auto time = [&](int cell, auto&& f) {
            const auto t0 = Clock::now();
            f();
            K.best[static_cast<std::size_t>(cell)] = std::min(K.best[static_cast<std::size_t>(cell)], since(t0));
          };
          time(0, [&] { K.matrix->multiply(x, y); });
          time(1, [&] { K.matrix->multiply(x, y, x2, y2); });
          time(2, [&] { K.linear.sweep(r, x); });
          time(3, [&] { K.nonsmooth->sweep(r, x); });
        }
      }
    std::vector<double> base;
    double galerkinBase = 0;
    for (int t = 1; t <= maxThreads; ++t) {
      setThreads(t);
      const BlockSparseMatrix<3>& A = plainA[t - 1];
      const double assembly = assemblyBest[t - 1];
      const std::vector<double>& plain = kernelSets[2 * (t - 1)].best;
      const std::vector<double>& sharedKernels = kernelSets[2 * (t - 1) + 1].best;
      BlockSparseMatrix<3> S;
      double sharing = 1e300;  // the sharing alone, not the copy before it
      for (int rep = 0; rep < repeat; ++rep) {
        S = A;
        const auto t0 = Clock::now();
        if (!S.shareRepeatedBlocks()) std::cerr << "threads: the step-42 matrix did not share its blocks\n";
        sharing = std::min(sharing, since(t0));
      }
      const SweepOrder metis(A.rowStarts(), A.columns(), t);
      const double partition = best(repeat, [&] { const SweepOrder o(A.rowStarts(), A.columns(), t); });
      // the fine order carried from the base level (LinearMultigrid's default on threads: METIS on
      // the lowest level that sweeps on threads), timed on matrices of A's pattern without an order;
      // the coarse levels get their orders in the first repetition only, so the best time is METIS
      // on the base level and the carrying
      MultigridHierarchy<3> hierarchy(s.grid);
      // the coarse operators of every level: Galerkin patterns and products (TNNMG's set-up)
      const double galerkin = best(repeat, [&] { hierarchy.setFineOperator(A, {}, {}); });
      // interface vertices, and those of them one thread sweeps (the interface rest, SweepOrder)
      const auto face = [](const SweepOrder& o) {
        return o.sequential() ? std::string("0")
                              : std::to_string(o.interface().size()) + " (" + std::to_string(o.interfaceRest().size()) + ")";
      };
      std::string carriedInterface = "0";
      double carried = 1e300;
      for (int rep = 0; rep < repeat; ++rep) {
        const BlockSparseMatrix<3> B(std::vector<Index>(A.rowStarts().begin(), A.rowStarts().end()),
                                     std::vector<Index>(A.columns().begin(), A.columns().end()));
        const auto t0 = Clock::now();
        const bool set = carrySweepPartition(hierarchy, B);
        carried = std::min(carried, since(t0));
        if (set) carriedInterface = face(B.sweepOrder());
      }
      std::vector<double> row{assembly};
      row.insert(row.end(), plain.begin(), plain.end());
      if (t == 1) {
        base = row;
        galerkinBase = galerkin;
      }
      const auto cells = [&](const std::vector<double>& r, bool first) {
        for (std::size_t k = first ? 0 : 1; k < r.size(); ++k)
          md << " | " << fmt(r[k]) << (t > 1 || !first ? " (" + fmt(base[k] / r[k], 2) + "x)" : std::string());
      };
      md << "| " << t << " | one per entry";
      cells(row, true);
      md << " | " << (t > 1 ? fmt(partition) : std::string("-")) << " | " << face(metis)
         << " | " << (t > 1 ? fmt(carried) : std::string("-")) << " | " << carriedInterface << " | " << fmt(galerkin)
         << (t > 1 ? " (" + fmt(galerkinBase / galerkin, 2) + "x)" : std::string()) << " |\n";
      std::vector<double> sharedRow{0.0};
      sharedRow.insert(sharedRow.end(), sharedKernels.begin(), sharedKernels.end());
      md << "| " << t << " | shared (" << S.storedBlocks() << " distinct of " << S.nonZeroBlocks() << ") | (" << fmt(sharing) << ")";
      cells(sharedRow, false);
      md << " | - | - | - | - | - |\n";
      std::cerr << "kernels, " << t << " threads done\n";
    }
  }

  // 2b. the schedule of the row loops: y = A x on the shared step-42 matrix, its rows in T fixed
  // ranges (OpenMP static, the loops before kRowChunk) against chunks of kRowChunk rows handed out
  // as the threads ask (dynamic, BlockSparseMatrix::multiply), alternating, 20 R products each
  if (want("schedule") && maxThreads > 1) {
    setThreads(maxThreads);
    BlockSparseMatrix<3> A = assembleStiffness<3>(s.mesh, s.material);
    if (!A.shared() && !A.shareRepeatedBlocks()) std::cerr << "threads: the step-42 matrix did not share its blocks\n";
    const Index n = A.rows();
    const Eigen::VectorXd x = Eigen::VectorXd::Ones(n * 3);
    Eigen::VectorXd yStatic(n * 3), yDynamic(n * 3);
    const auto fixedRanges = [&] {
      A.withBlocks([&](const auto blocks) {
#pragma omp parallel for schedule(static) num_threads(maxThreads)
        for (Index i = 0; i < n; ++i) {
          Eigen::Vector3d sum = Eigen::Vector3d::Zero();
          for (Index k = A.rowBegin(i); k < A.rowEnd(i); ++k)
            sum.noalias() += blocks[k] * x.segment<3>(static_cast<Eigen::Index>(A.column(k)) * 3);
          yStatic.segment<3>(static_cast<Eigen::Index>(i) * 3) = sum;
        }
      });
    };
    std::vector<double> fixed, chunks;
    for (int r = 0; r < 20 * repeat; ++r) {
      auto t0 = Clock::now();
      fixedRanges();
      fixed.push_back(since(t0));
      t0 = Clock::now();
      A.multiply(x, yDynamic);
      chunks.push_back(since(t0));
    }
    if (yStatic != yDynamic) std::cerr << "threads: the two schedules gave different products\n";
    std::sort(fixed.begin(), fixed.end());
    std::sort(chunks.begin(), chunks.end());
    const auto q = [](const std::vector<double>& v, double f) { return v[static_cast<std::size_t>(f * (v.size() - 1))]; };
    md << "\nThe schedule of the row loops: y = A x on the shared step-42 matrix (" << n << " rows), " << maxThreads
       << " threads, its rows in " << maxThreads << " fixed ranges (static) or in chunks of " << kRowChunk
       << " rows handed out as the threads ask (dynamic, BlockSparseMatrix::multiply); " << 20 * repeat
       << " products each, alternating; milliseconds:\n\n| schedule | best | quartile | median | quartile | worst | same bits |\n"
       << "|---|---:|---:|---:|---:|---:|---|\n";
    for (int k = 0; k < 2; ++k) {
      const std::vector<double>& v = k == 0 ? fixed : chunks;
      md << "| " << (k == 0 ? "fixed ranges" : "chunks") << " | " << fmt(1e3 * v.front()) << " | " << fmt(1e3 * q(v, 0.25))
         << " | " << fmt(1e3 * q(v, 0.5)) << " | " << fmt(1e3 * q(v, 0.75)) << " | " << fmt(1e3 * v.back()) << " | "
         << (yStatic == yDynamic ? "yes" : "no") << " |\n";
    }
    std::cerr << "schedule done\n";
  }

  // 3. TNNMG
  if (want("tnnmg")) {
    const int solves = std::max(2, repeat);
    md << "\nTNNMG on the step-42 problem (tolerance 1e-10; the solve from zero, hierarchy set-up included; the "
          "fastest of "
       << solves
       << " solves per thread count, the thread counts alternating; every solve of a thread count must repeat the bits "
          "of its first):\n\n"
       << "| threads | iterations | solve s (every solve) | set-up | nonsmooth sweeps | operator updates | V-cycles | other | "
          "energy | bitwise equal in every solve |\n|---:|---:|---|---:|---:|---:|---:|---:|---:|---|\n";
    std::vector<Eigen::VectorXd> first(T);
    std::vector<std::string> tnnmgRows(T);
    std::vector<std::vector<LinearMultigrid<3>::LevelSeconds>> tnnmgLevels(T);
    std::vector<double> fastest(T, 1e300);
    std::vector<std::string> every(T);
    std::vector<char> same(T, 1);
    std::vector<int> tnnmgIterations(T, 0);
    long long tnnmgCycles = 1;
    std::vector<Index> vertices;
    for (int run = 0; run < solves; ++run)
      for (int t = 1; t <= maxThreads; ++t) {
        setThreads(t);
        const auto ti = static_cast<std::size_t>(t - 1);
        const ContactSet set(s.mesh, mesh::kTop, s.ball);
        const ContactProblem<3> problem(s.mesh, s.material, s.bc, set);
        TNNMG<3>::Options o;
        o.tolerance = 1e-10;
        auto multigrid = std::make_unique<LinearMultigrid<3>>(s.grid, o.multigrid);
        const LinearMultigrid<3>& mg = *multigrid;
        TNNMG<3> solver(s.grid, o, std::move(multigrid));
        Eigen::VectorXd u;
        const auto t0 = Clock::now();
        const ContactResult res = solver.solve(problem, u);
        const double sec = since(t0);
        every[ti] += (run > 0 ? ", " : "") + fmt(sec);
        if (run == 0) first[ti] = u;
        else if (u.size() != first[ti].size() || std::memcmp(u.data(), first[ti].data(), sizeof(double) * u.size()) != 0)
          same[ti] = 0;
        std::cerr << "TNNMG, " << t << " threads: " << res.iterations << " iterations, " << fmt(sec) << " s\n";
        if (sec >= fastest[ti]) continue;
        fastest[ti] = sec;
        tnnmgLevels[ti] = mg.levelSeconds();
        tnnmgCycles = mg.vcycles();
        vertices = levelVertices(mg.hierarchy());
        const auto& st = solver.statistics();
        std::ostringstream row;
        row << " | " << fmt(st.setupSeconds) << " | " << fmt(st.smoothingSeconds) << " | " << fmt(st.updateSeconds) << " | "
            << fmt(st.correctionSeconds) << " | " << fmt(st.otherSeconds) << " | " << fmt(problem.energy(u), 12) << " | ";
        tnnmgIterations[ti] = res.iterations;
        tnnmgRows[ti] = row.str();  // from the set-up on
      }
    for (int t = 1; t <= maxThreads; ++t) {  // the solve column: fastest (ratio) and every solve
      const auto ti = static_cast<std::size_t>(t - 1);
      const std::string solve = fmt(fastest[ti]) + (t > 1 ? " (" + fmt(fastest[0] / fastest[ti], 2) + "x)" : "") + "; " + every[ti];
      tnnmgRows[ti] = "| " + std::to_string(t) + " | " + std::to_string(tnnmgIterations[ti]) + " | " + solve +
                      tnnmgRows[ti] + (same[ti] ? "yes" : "**no**") + " |\n";
    }
    for (const std::string& row : tnnmgRows) md << row;
    md << "\nThe V-cycles of the fastest solves by level (milliseconds per cycle, " << tnnmgCycles
       << " cycles in a solve; LinearMultigrid::levelSeconds):\n\n";
    levelTable(md, vertices, tnnmgLevels, tnnmgCycles);
  }

  // 3b. where a V-cycle's time goes, level by level: the linear multigrid of TNNMG's correction on the
  // step-42 operator (rotated at the contact vertices, truncated at the Dirichlet components; shared
  // blocks, as in obs' solves) alone, kCycles V-cycles per measurement, the thread counts
  // alternating; the measurement with the least total time per thread count
  if (want("vcycles")) {
    constexpr int kCycles = 10;
    md << "\nOne V(3,3) cycle of the linear correction alone, by level (the step-42 operator with shared blocks, "
          "truncated at the Dirichlet components; milliseconds per cycle, the best of "
       << repeat << " measurements of " << kCycles << " cycles, the thread counts alternating):\n\n";
    struct Cycles {
      std::unique_ptr<ContactProblem<3>> problem;
      std::unique_ptr<LinearMultigrid<3>> mg;
      std::vector<LinearMultigrid<3>::LevelSeconds> best;
      double bestTotal = 1e300;
    };
    std::vector<Cycles> cycles(T);
    const ContactSet set(s.mesh, mesh::kTop, s.ball);
    for (int t = 1; t <= maxThreads; ++t) {
      setThreads(t);
      Cycles& C = cycles[t - 1];
      C.problem = std::make_unique<ContactProblem<3>>(s.mesh, s.material, s.bc, set);
      C.mg = std::make_unique<LinearMultigrid<3>>(s.grid);
      C.mg->setOperator(C.problem->rotatedMatrix(), problemRotations(*C.problem), C.problem->dirichlet().constrained);
    }
    const Eigen::VectorXd rhs = cycles[0].problem->rhs();
    Eigen::VectorXd c;
    for (int rep = 0; rep <= repeat; ++rep)  // rep 0 warms up (sweep orders, buffers)
      for (int t = 1; t <= maxThreads; ++t) {
        setThreads(t);
        Cycles& C = cycles[t - 1];
        C.mg->resetLevelSeconds();
        const auto t0 = Clock::now();
        for (int k = 0; k < kCycles; ++k) C.mg->vcycle(rhs, c);
        const double total = since(t0);
        if (rep > 0 && total < C.bestTotal) {
          C.bestTotal = total;
          C.best = C.mg->levelSeconds();
        }
      }
    std::vector<std::vector<LinearMultigrid<3>::LevelSeconds>> byThreads;
    for (const Cycles& C : cycles) byThreads.push_back(C.best);
    levelTable(md, levelVertices(cycles[0].mg->hierarchy()), byThreads, kCycles);
    std::cerr << "V-cycles by level done\n";
  }

  // 4. the whole program, and a baseline binary alternating with it
  if (want("obs") && !obsBinary.empty()) {
    std::vector<std::pair<std::string, std::string>> binaries;  // label, path
    if (!baselineBinary.empty()) binaries.emplace_back("baseline", baselineBinary);
    binaries.emplace_back(baselineBinary.empty() ? "" : "this", obsBinary);
    const bool two = binaries.size() > 1;
    md << "\nThe whole `obs run data/scenes/step42.toml --refine 4 --threads T` (64^3 hexahedra, 823,875 unknowns; "
          "/usr/bin/time; the thread counts"
       << (two ? " and the binaries (baseline: the --baseline binary, this: the --obs binary)" : std::string())
       << " alternate, best wall time of " << repeat << " runs, its CPU time, memory and phases):\n\n"
       << (two ? "| binary " : "")
       << "| threads | wall s | CPU s | peak MB | mesh s | assembly s | solve s | of it set-up s | output s | .vtu MB | "
          "wall s of every run | solve s of every run | compute throughput after every run | correction |\n"
       << (two ? "|---" : "") << "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|\n";
    struct Run {
      double wall = 1e300, cpu = 0, mb = 0, mesh = 0, assembly = 0, solve = 0, setup = 0, output = 0, fileMb = 0;
      std::string all, solves, capacities, correction;
    };
    std::vector<Run> runs(binaries.size() * static_cast<std::size_t>(maxThreads));
    for (int rep = 0; rep < repeat; ++rep)
      for (int t = 1; t <= maxThreads; ++t)
        for (std::size_t bin = 0; bin < binaries.size(); ++bin) {
          const std::string dir = "/tmp/obs_bench_threads_" + std::to_string(bin) + "_" + std::to_string(t);
          const std::string timing = dir + ".time";
          const std::string cmd = "OPENBLAS_NUM_THREADS=1 /usr/bin/time -f '%e %U %S %M' -o " + timing + " " +
                                  binaries[bin].second + " run data/scenes/step42.toml --refine 4 --quiet --threads " +
                                  std::to_string(t) + " --output " + dir;
          if (std::system(cmd.c_str()) != 0) {
            std::cerr << "threads: failed: " << cmd << "\n";
            return 1;
          }
          double wall = 0, user = 0, sys = 0, kb = 0;
          std::ifstream(timing) >> wall >> user >> sys >> kb;
          std::ifstream summary(dir + "/summary.json");
          std::stringstream ss;
          ss << summary.rdbuf();
          const std::string js = ss.str();
          const auto number = [&](const std::string& key) {
            const auto p = js.find("\"" + key + "\":");
            return p == std::string::npos ? std::nan("") : std::strtod(js.c_str() + p + key.size() + 3, nullptr);
          };
          char correction[32];
          std::snprintf(correction, sizeof correction, "%.17g", number("correction"));
          Run& r = runs[bin * static_cast<std::size_t>(maxThreads) + static_cast<std::size_t>(t - 1)];
          r.all += (r.all.empty() ? "" : ", ") + fmt(wall);
          r.solves += (r.solves.empty() ? "" : ", ") + fmt(number("solve_s"));
          // what T threads could gain right then (a second, short measurement; see the table above)
          if (t > 1) r.capacities += (r.capacities.empty() ? "" : ", ") + fmt(computeCapacity(t), 3);
          std::error_code noFile;
          const auto bytes = std::filesystem::file_size(dir + "/step42.vtu", noFile);
          const double fileMb = noFile ? std::nan("") : static_cast<double>(bytes) / 1e6;
          if (wall < r.wall)
            r = Run{wall,           user + sys,       kb / 1024,          number("mesh_s"), number("assembly_s"),
                    number("solve_s"), number("setup_s"), number("output_s"), fileMb,           r.all,
                    r.solves,          r.capacities,     correction};
          std::cerr << "obs run" << (two ? " (" + binaries[bin].first + ")" : std::string()) << ", " << t
                    << " threads: " << fmt(wall) << " s wall\n";
        }
    for (std::size_t bin = 0; bin < binaries.size(); ++bin)
      for (int t = 1; t <= maxThreads; ++t) {
        const Run* row = &runs[bin * static_cast<std::size_t>(maxThreads)];
        const Run& r = row[t - 1];
        md << (two ? "| " + binaries[bin].first + " " : std::string()) << "| " << t << " | " << fmt(r.wall)
           << (t > 1 ? " (" + fmt(row[0].wall / r.wall, 3) + "x)" : "") << " | " << fmt(r.cpu) << " | " << fmt(r.mb, 4)
           << " | " << fmt(r.mesh) << " | " << fmt(r.assembly) << " | " << fmt(r.solve) << " | "
           << (std::isnan(r.setup) ? std::string("-") : fmt(r.setup)) << " | " << fmt(r.output) << " | " << fmt(r.fileMb, 4)
           << " | " << r.all << " | " << r.solves << " | " << (t > 1 ? r.capacities : std::string("-")) << " | "
           << r.correction << " |\n";
      }
  }
  if (!bench::writeMarkdownBlock(out, "threads", md.str())) {
    std::cerr << "threads: cannot write " << out << "\n";
    return 1;
  }
  std::cout << md.str();
  return 0;
}
