// Building mesh::FaceTable (every distinct face of a mesh with its one or two cells), the table the
// residual estimators build at every estimate (docs/performance.md#face-table): nanoseconds per
// cell face on box meshes of tetrahedra and hexahedra and on a grid refined adaptively towards a
// point (the cell order of an adaptive leaf view), on 1 and 2 threads; the best of R builds. The
// tables of the two thread counts must be identical (checked: face keys, sides, cell faces).
//
//   build/bench/face_table [OUT.md] [--repeat R]
// Writes the block "face_table" of OUT.md (MarkdownBlock.hpp), or standard output.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "MarkdownBlock.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"

using namespace obs::mesh;
using Clock = std::chrono::steady_clock;

namespace {

double bestSeconds(int repeat, const Mesh& m, int threads) {
  double best = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    const FaceTable t(m, threads);
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
    if (t.numFaces() == 0) std::abort();  // keep the build
  }
  return best;
}

bool sameTable(const Mesh& m, const FaceTable& a, const FaceTable& b) {
  if (a.numFaces() != b.numFaces()) return false;
  for (Index f = 0; f < a.numFaces(); ++f) {
    if (a.key(f) != b.key(f) || a.numCells(f) != b.numCells(f)) return false;
    for (int k = 0; k < 2; ++k)
      if (a.side(f, k).cell != b.side(f, k).cell || a.side(f, k).localFace != b.side(f, k).localFace) return false;
  }
  for (Index c = 0; c < m.numCells(); ++c)
    for (int f = 0; f < static_cast<int>(localFaces(m.cellType(c)).size()); ++f)
      if (a.face(c, f) != b.face(c, f)) return false;
  return true;
}

/// A tetrahedral grid refined `cycles` times around the point (0.5, 0.5, 0) (red-green closure).
Mesh adaptiveTetrahedra(int cycles) {
  Grid grid(boxMesh(CellType::Tetrahedron, 8));
  grid.refineUniformly();
  for (int k = 0; k < cycles; ++k) {
    const GridView leaf = grid.leafView();
    for (Index c = 0; c < leaf.mesh.numCells(); ++c) {
      Point centre = Point::Zero();
      for (Index v : leaf.mesh.cellVertices(c)) centre += leaf.mesh.vertex(v);
      centre /= static_cast<double>(leaf.mesh.cellVertices(c).size());
      if ((centre - Point(0.5, 0.5, 0.0)).norm() < 0.3 * std::pow(0.6, k)) grid.mark(leaf.elements[c]);
    }
    grid.adapt();
  }
  return grid.leafView().mesh;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  int repeat = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeat" && i + 1 < argc) repeat = std::atoi(argv[++i]);
    else if (!a.empty() && a[0] != '-') out = a;
    else {
      std::cerr << "usage: face_table [OUT.md] [--repeat R]\n";
      return 2;
    }
  }
  struct Case {
    std::string name;
    Mesh mesh;
  };
  std::vector<Case> cases;
  cases.push_back({"tetrahedra, box 16^3", boxMesh(CellType::Tetrahedron, 16)});
  cases.push_back({"tetrahedra, box 48^3", boxMesh(CellType::Tetrahedron, 48)});
  cases.push_back({"hexahedra, box 64^3", boxMesh(CellType::Hexahedron, 64)});
  cases.push_back({"tetrahedra, adaptive (5 cycles)", adaptiveTetrahedra(5)});

  std::ostringstream md;
  md << "`build/bench/face_table --repeat " << repeat << "`: building mesh::FaceTable, best of " << repeat
     << " builds; ns per cell face (slot).\n\n"
     << "| mesh | cells | faces | 1 thread: ms | ns per cell face | 2 threads: ms | speed-up | same table |\n"
     << "|---|---:|---:|---:|---:|---:|---:|:---:|\n";
  for (const Case& c : cases) {
    const Mesh& m = c.mesh;
    Index slots = 0;
    for (Index e = 0; e < m.numCells(); ++e) slots += static_cast<Index>(localFaces(m.cellType(e)).size());
    const double t1 = bestSeconds(repeat, m, 1), t2 = bestSeconds(repeat, m, 2);
    const bool same = sameTable(m, FaceTable(m, 1), FaceTable(m, 2));
    md << "| " << c.name << " | " << m.numCells() << " | " << FaceTable(m).numFaces() << " | "
       << obs::bench::fixed(t1 * 1e3, 2) << " | " << obs::bench::fixed(t1 * 1e9 / slots, 1) << " | "
       << obs::bench::fixed(t2 * 1e3, 2) << " | " << obs::bench::fixed(t1 / t2, 2) << " | "
       << (same ? "yes" : "NO") << " |\n";
    std::cerr << "face_table: " << c.name << " done\n";
    if (!same) {
      std::cerr << "face_table: the tables of 1 and 2 threads differ on " << c.name << "\n";
      return 1;
    }
  }
  return obs::bench::emitMarkdownBlock(out, "face_table", md.str());
}
