// Grid refinement benchmark: uniform red refinement of 3D hexahedral and tetrahedral grids to more
// than 1e6 leaf elements, and 15 cycles of local refinement along a circle in 2D (triangles and
// quadrilaterals, red + green closure). Reports elements created per second of adapt() time and
// bytes per element: the peak resident memory of the case (each case runs in its own forked
// process, measured with wait4) above the process' size at the fork, divided by all elements the
// grid holds (every level), as a markdown table. With --threads T every case runs on one thread and
// on T (Grid::adapt(T): the red refinement on threads, the same grid), one after the other.
//
// Sample run (about a minute; writes the table of docs/performance.md):
//   build/bench/grid_refinement bench-grid.md --threads 2
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <vector>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"

using namespace obs::mesh;

namespace {

using Clock = std::chrono::steady_clock;

/// Current resident set size in bytes (/proc/self/statm).
double currentRssBytes() {
  long pages = 0, resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE));
}

/// Runs `body` in a forked child; the child writes its table row (with a %BYTES% placeholder for
/// the bytes per element, computed from `elements` it returns) to a pipe.
template <class Body>
std::string isolated(Body body) {
  int fd[2];
  if (pipe(fd) != 0) return "| pipe failed |\n";
  const double base = currentRssBytes();
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    const auto [row, elements] = body();
    const std::string msg = std::to_string(elements) + "\n" + row;
    if (write(fd[1], msg.data(), msg.size()) < 0) _exit(1);
    _exit(0);
  }
  close(fd[1]);
  std::string msg;
  char buf[512];
  for (ssize_t n; (n = read(fd[0], buf, sizeof buf)) > 0;) msg.append(buf, static_cast<std::size_t>(n));
  close(fd[0]);
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  const auto nl = msg.find('\n');
  if (nl == std::string::npos) return "| case failed |\n";
  const double elements = std::stod(msg.substr(0, nl));
  std::string row = msg.substr(nl + 1);
  const double bytes = (static_cast<double>(usage.ru_maxrss) * 1024.0 - base) / elements;
  row.replace(row.find("%BYTES%"), 7, std::to_string(static_cast<long>(bytes)));
  return row;
}

/// Uniform refinement until the leaf view has at least `target` elements.
std::pair<std::string, double> uniform(CellType type, std::array<int, 3> cells, Index target, int threads) {
  Grid grid(boxMesh(type, cells, Point(0, 0, 0), Point(1, 1, 1)));
  int step = 0;
  double total = 0;
  Index created = 0;
  while (grid.numLeafElements() < target) {
    const auto t0 = Clock::now();
    const AdaptResult r = grid.refineUniformly(threads);
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    total += s;
    created += grid.numElements() - r.firstNewElement;
    ++step;
    std::cerr << name(type) << " step " << step << ": " << grid.numLeafElements() << " leaves, " << s
              << " s\n";
  }
  char line[256];
  std::snprintf(line, sizeof line, "| %s | uniform | %d | %d | %d | %d | %.2f | %.3g | %%BYTES%% |\n",
                std::string(name(type)).c_str(), threads, step, grid.numLeafElements(), grid.numVertices(),
                total, created / total);
  return {line, static_cast<double>(grid.numElements())};
}

/// `cycles` cycles of local refinement of the unit square along the circle |x - (1/2, 1/2)| = 0.3
/// (a free-boundary-like curve): leaves whose centroid is within their own size of the circle are
/// marked, so every cycle about doubles the elements along the curve.
std::pair<std::string, double> local(CellType type, int n, int cycles, int threads) {
  Grid grid(boxMesh(type, {n, n, 1}, Point(0, 0, 0), Point(1, 1, 0)));
  double total = 0;
  Index created = 0;
  for (int c = 0; c < cycles; ++c) {
    for (Index e : grid.leafElements()) {
      Point centre = Point::Zero();
      for (Index v : grid.vertices(e)) centre += grid.vertex(v);
      centre /= static_cast<double>(grid.vertices(e).size());
      const double h = 1.0 / (n << grid.level(e));
      if (std::abs((centre - Point(0.5, 0.5, 0)).norm() - 0.3) < h) grid.mark(e);
    }
    const auto t0 = Clock::now();
    const AdaptResult r = grid.adapt(threads);
    total += std::chrono::duration<double>(Clock::now() - t0).count();
    created += grid.numElements() - r.firstNewElement;
  }
  char line[256];
  std::snprintf(line, sizeof line, "| %s | %d local cycles | %d | %d | %d | %d | %.2f | %.3g | %%BYTES%% |\n",
                std::string(name(type)).c_str(), cycles, threads, grid.maxLevel(), grid.numLeafElements(),
                grid.numVertices(), total, created / total);
  return {line, static_cast<double>(grid.numElements())};
}

}  // namespace

int main(int argc, char** argv) {
  std::string output;
  int threads = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--threads" && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (!a.starts_with("-") && output.empty()) {
      output = a;
    } else {
      threads = 0;
      break;
    }
  }
  if (threads < 1) {
    std::cerr << "usage: grid_refinement [OUTPUT.md] [--threads T]   (default: standard output, one thread)\n";
    return 2;
  }
  std::ostringstream md;
  md << "| cell type | refinement | threads | steps / levels | leaf elements | vertices | adapt time [s] | "
        "elements/s | bytes/element |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
  const std::vector<int> counts = threads > 1 ? std::vector<int>{1, threads} : std::vector<int>{1};
  for (int t : counts) md << isolated([t] { return uniform(CellType::Hexahedron, {4, 4, 4}, 1'000'000, t); });
  for (int t : counts) md << isolated([t] { return uniform(CellType::Tetrahedron, {4, 4, 4}, 1'000'000, t); });
  for (int t : counts) md << isolated([t] { return local(CellType::Triangle, 4, 15, t); });
  for (int t : counts) md << isolated([t] { return local(CellType::Quadrilateral, 4, 15, t); });
  if (!output.empty()) {
    std::ofstream out(output);
    if (!out) {
      std::cerr << "grid_refinement: cannot write " << output << "\n";
      return 1;
    }
    out << md.str();
  } else {
    std::cout << md.str();
  }
  return 0;
}
