// TNNMG against one linear multigrid solve on the same adaptively refined grid (issue 12: "TNNMG / one
// linear multigrid solve on the same adaptive grid <= 1.5"). Runs the adaptive loop of the Hertz
// example (data/scenes/example3b.toml / example3a.toml: unit cube, E = 3e5, nu = 0.25, top pressed
// down by 0.005 onto a ball of radius 0.75, contact-residual estimator, marking mean with theta = 1.1,
// TNNMG to 1e-10) and, after every step, solves on the step's grid the linear problem without contact:
// the same top displacement with the contact boundary clamped (the lower bound a contact solver can
// hope for, as bench/contact_solvers). Both times include building the multigrid hierarchy; the
// linear solve uses the same V(3,3)-cycle (with the same local smoothing) to the same tolerance.
// Writes the markdown block "adaptive_multigrid" (MarkdownBlock.hpp) of OUTPUT.md, or standard output.
//
//   build/bench/adaptive_multigrid docs/performance.md --type tetrahedron --refine 1 --steps 8
// Options: --type tetrahedron|hexahedron (may repeat; default both), --refine N (uniform refinements
// of the 4 x 4 x 4 box before the loop, default 1), --steps N (solves, default 7).
#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "MarkdownBlock.hpp"
#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/LinearMultigrid.hpp"
#include "obs/obs/Obstacle.hpp"

namespace {

using namespace obs;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Row {
  long long unknowns = 0;
  int levels = 0, tnnmgIterations = 0, mgIterations = 0;
  double tnnmgSeconds = 0, mgSeconds = 0;
  bool mgConverged = false;
  long long blocks = 0, storedBlocks = 0;  ///< of the linear operator (shareRepeatedBlocks)
  double coarseMB = 0, coarsePlainMB = 0;  ///< the coarse operators as stored, and with one block per entry
};

std::vector<Row> run(mesh::CellType type, int refine, int steps) {
  mesh::Grid grid(mesh::boxMesh(type, 4));
  for (int r = 0; r < refine; ++r) grid.refineUniformly();
  const Material material{3e5, 0.25};
  BoundaryConditions bc;
  bc.dirichlet.push_back({mesh::kTop, {true, true, true}, [](const Point&) { return Point(0, 0, -0.005); }});
  const BallObstacle ball(Point(0.5, 0.5, -0.75), 0.75, -Point::UnitZ());
  estimators::AdaptiveLoopOptions o;
  o.maxSteps = steps;
  o.markingParameter = 1.1;
  o.solver.tolerance = 1e-10;
  estimators::AdaptiveLoop loop(grid, material, bc, o);
  loop.setContact(ball, mesh::kBottom);
  std::vector<Row> rows;
  loop.setCallback([&](const estimators::AdaptiveStepView& s) {
    Row r;
    r.unknowns = static_cast<long long>(s.record.unknowns);
    r.levels = s.grid.maxLevel();
    r.tnnmgIterations = s.record.solverIterations;
    r.tnnmgSeconds = s.record.solverSeconds;
    // the linear problem on the same grid: top pressed, contact boundary clamped
    BoundaryConditions linear = bc;
    linear.dirichlet.push_back({mesh::kBottom, {true, true, true}, [](const Point&) { return Point::Zero(); }});
    const mesh::Mesh& m = s.view.mesh;
    BlockSparseMatrix<3> A = assembleStiffness<3>(m, material);
    Eigen::VectorXd b = assembleLoad<3>(m, linear);
    const DirichletValues g = collectDirichlet(m, linear.dirichlet);
    applyDirichlet(A, b, g);
    A.shareRepeatedBlocks();  // as the contact problem of the TNNMG solve (not timed there either)
    r.blocks = A.nonZeroBlocks();
    r.storedBlocks = A.storedBlocks();
    const auto t = Clock::now();
    LinearMultigridOptions mo;
    mo.tolerance = 1e-10;
    LinearMultigrid<3> mg(s.grid, mo);
    mg.setOperator(A);
    mg.truncate(g.constrained);
    Eigen::VectorXd x;
    const LinearSolverResult res = mg.solve(b, x);
    r.mgSeconds = since(t);
    for (int l = 0; l < mg.hierarchy().maxLevel(); ++l) {
      const BlockSparseMatrix<3>& C = mg.hierarchy().coarseOperator(l);
      r.coarseMB += static_cast<double>(C.memoryBytes()) / 1e6;
      r.coarsePlainMB += static_cast<double>((C.rows() + 1 + C.nonZeroBlocks()) * sizeof(Index) +
                                             C.nonZeroBlocks() * sizeof(BlockSparseMatrix<3>::Block)) / 1e6;
    }
    r.mgIterations = res.iterations;
    r.mgConverged = res.converged;
    rows.push_back(r);
    std::cerr << "adaptive_multigrid: " << mesh::name(type) << " step " << s.record.step << ": " << r.unknowns
              << " unknowns, TNNMG " << r.tnnmgSeconds << " s, MG " << r.mgSeconds << " s\n";
  });
  loop.run();
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  std::string page;
  std::vector<mesh::CellType> types;
  int refine = 1, steps = 7;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool hasValue = i + 1 < argc;
    try {
      if (a == "--type" && hasValue) {
        const std::string t = argv[++i];
        if (t == "tetrahedron") types.push_back(mesh::CellType::Tetrahedron);
        else if (t == "hexahedron") types.push_back(mesh::CellType::Hexahedron);
        else throw std::invalid_argument(t);
      } else if (a == "--refine" && hasValue) {
        refine = std::stoi(argv[++i]);
      } else if (a == "--steps" && hasValue) {
        steps = std::stoi(argv[++i]);
      } else if (!a.starts_with("-") && page.empty()) {
        page = a;
      } else {
        throw std::invalid_argument(a);
      }
    } catch (const std::exception&) {
      std::cerr << "usage: adaptive_multigrid [OUTPUT.md] [--type tetrahedron|hexahedron] [--refine N] [--steps N]\n";
      return 2;
    }
  }
  if (refine < 0 || steps < 1) {
    std::cerr << "adaptive_multigrid: --refine >= 0 and --steps >= 1 required\n";
    return 2;
  }
  if (types.empty()) types = {mesh::CellType::Tetrahedron, mesh::CellType::Hexahedron};
  std::ostringstream md;
  md << "`build/bench/adaptive_multigrid --refine " << refine << " --steps " << steps
     << "`: the Hertz example's adaptive loop (contact-residual, mean, theta = 1.1); per step the TNNMG solve "
        "of the loop and one linear multigrid solve of the same grid with the contact boundary clamped, both to "
        "1e-10 and including the hierarchy set-up (wall seconds, one core). Blocks: of the linear operator (Dirichlet "
        "rows eliminated), and the distinct ones it stores if it shares them (BlockSparseMatrix::shareRepeatedBlocks). "
        "Coarse MB: the coarse operators of the linear solve's hierarchy as stored (shared where their blocks repeat), "
        "and as they would be with one block per entry.\n";
  char line[256];
  for (const mesh::CellType type : types) {
    const std::vector<Row> rows = run(type, refine, steps);
    md << "\n" << mesh::name(type) << " (4 x 4 x 4 box, " << refine << " uniform refinement(s) first):\n\n"
       << "| step | unknowns | levels | TNNMG it. | TNNMG s | MG it. | MG s | TNNMG / MG | blocks | stored blocks | "
          "coarse MB | coarse MB, one block per entry |\n"
          "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Row& r = rows[k];
      std::snprintf(line, sizeof line, "| %zu | %lld | %d | %d | %.3f | %d%s | %.3f | %.2f | %lld | %lld | %.1f | %.1f |\n", k,
                    r.unknowns, r.levels, r.tnnmgIterations, r.tnnmgSeconds, r.mgIterations,
                    r.mgConverged ? "" : " (not conv.)", r.mgSeconds, r.mgSeconds > 0 ? r.tnnmgSeconds / r.mgSeconds : 0.0,
                    r.blocks, r.storedBlocks, r.coarseMB, r.coarsePlainMB);
      md << line;
    }
  }
  md << "\n";
  return obs::bench::emitMarkdownBlock(page, "adaptive_multigrid", md.str());
}
