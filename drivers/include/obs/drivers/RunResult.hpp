#pragma once
/// \file RunResult.hpp
/// Figures of one `obs run`: problem size, cost (times, memory), solution extremes, the solver's
/// report and, for contact scenes, the contact quantities. Written to summary.json (Summary.hpp)
/// and as a CSV row (CsvWriter.hpp).
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "obs/obs/ContactModel.hpp"
#include "obs/obs/KktResiduals.hpp"

namespace obs::drivers {

/// Where the time of a TNNMG solve went (TNNMG::Statistics; docs/scenes.md, summary.json).
struct TnnmgPhases {
  double setup = 0;      ///< rotated operator, smoother, the coarse operators of every level
  double nonsmooth = 0;  ///< nonsmooth Gauss-Seidel sweeps
  double updates = 0;    ///< coarse operators recomputed when the truncation changed
  double vcycles = 0;    ///< the linear corrections
  double other = 0;      ///< products, residuals, line search, stopping test
  int operatorUpdates = 0;
};

/// The outer iteration of a scene with friction (docs/theory.md#friction-coulomb; Friction.hpp
/// CoulombResult): Tresca solves, whether the bounds stopped changing and whether the changes
/// decreased. One solve without a Coulomb coupling.
struct FrictionIterationReport {
  int iterations = 0;
  bool converged = false;
  bool contracting = true;
  std::vector<double> changes;  ///< relative change of the slip bounds after each solve
  long long innerIterations = 0;
};

/// How the discrete problem was solved.
struct SolverReport {
  std::string type;         ///< "direct", "multigrid", "tnnmg", "pdas" or "pgs"
  int iterations = 0;       ///< 1 for a direct solve; V-cycles of multigrid; contact iterations
  bool converged = true;
  double seconds = 0;       ///< solve time (the same as RunResult::solveSeconds)
  double tolerance = 0;     ///< stopping tolerance (0: direct, or pdas' exact stopping rule)
  double correction = 0;    ///< last relative energy-norm correction (iterative solvers)
  double convergenceRate = 0;  ///< geometric mean of the correction ratios (iterative solvers)
  long long vcycles = -1;   ///< tnnmg, multigrid: V-cycles run (-1: not reported)
  /// distributed runs: the coarse level's solver, "cholmod" (replicated) or "hypre" (partition
  /// level 0), and hypre's CG iterations over the solve (-1: not reported)
  std::string coarseSolver;
  long long coarseIterations = -1;
  std::optional<TnnmgPhases> phases;  ///< static tnnmg solves
  std::optional<KktResiduals> kkt;  ///< contact solvers: KKT residuals of the solution
  std::optional<FrictionIterationReport> friction;  ///< scenes with friction
};

/// One load increment of [loading] steps = N (summary.json "increments", increments.csv): the load
/// parameter, the solver's work and the contact state after it, summed over every coupling.
struct IncrementReport {
  int step = 0;
  double t = 0;                  ///< i / N
  long long iterations = 0;      ///< solver iterations of this increment (over its Tresca solves)
  bool converged = true;
  std::array<double, 3> force{};            ///< sum of the normal forces mu_p nu_p (ContactOutputs::force)
  std::array<double, 3> tangentialForce{};  ///< sum of the tangential forces f_T
  long long contactVertices = 0, stickVertices = 0, slipVertices = 0;
};

/// The friction of one contact (summary.json "friction" of "contact" or of a "pairs" entry).
struct FrictionReport {
  std::string law;   ///< "tresca" or "coulomb"
  double value = 0;  ///< the slip bound (tresca) or mu (coulomb)
  std::array<double, 3> tangentialForce{};  ///< sum of the tangential nodal forces f_T (ContactOutputs)
  long long stickVertices = 0, slipVertices = 0;
  double stickArea = 0;    ///< measure of the faces all of whose vertices stick (2D: a width)
  double stickRadius = 0;  ///< 3D: sqrt(stickArea / pi); 2D: stickArea / 2 (as the contact radius)
};

/// Contact quantities of a solution (docs/theory.md#signorini, computeContactOutputs in ContactProblem.hpp).
struct ContactReport {
  std::string obstacle;           ///< obstacle type
  std::string boundary;           ///< the contact boundary as written in the scene
  long long boundaryVertices = 0; ///< vertices of the contact boundary
  long long potentialVertices = 0;///< of these, with a finite gap (constrained)
  long long actualVertices = 0;   ///< in actual contact (g - u.nu <= 1e-8 relative)
  std::array<double, 3> force{};  ///< sum_p mu_p nu_p: the force of the body on the obstacle
  double load = 0;                ///< P = sum_p mu_p = integral of s_m over Gamma_C
  double area = 0;  ///< measure of the contact faces with all vertices in contact (2D: width)
  double radius = 0;       ///< 3D: sqrt(area / pi) (disc of the same area); 2D: width / 2
  double radiusNodes = 0;  ///< max tangential distance of a contact vertex from the force centre
  double maxViolation = 0; ///< max_p (nu_p.u_p - g_p)^+
  std::optional<FrictionReport> friction;  ///< [contact] friction = {...}
};

/// One coupling of a scene reported per coupling (summary.json "pairs"): the model's record
/// (ContactModel.hpp CouplingRecord: nodes, forces on both sides, load, pressure range, area,
/// violation, mortar statistics) with the side labels and the radius of the contact zone.
struct PairReport : CouplingRecord {
  std::string slave, master;  ///< "body:boundary" as written, or "obstacle <type>"
  double radius = 0;          ///< 3D: sqrt(area / pi); 2D: area / 2
  std::optional<FrictionReport> friction;  ///< couplings with friction
};

/// One body of a multi-body scene.
struct BodyReport {
  std::string name;
  long long vertices = 0, cells = 0;
  double maxDisplacement = 0, maxVonMises = 0;
};

struct RunResult {
  std::string scene;  ///< scene file as given
  int dimension = 0;
  long long vertices = 0;
  long long cells = 0;
  std::array<long long, 7> cellsPerType{};  ///< indexed by static_cast<int>(mesh::CellType)
  int refine = 0;                           ///< uniform refinements applied
  long long dofs = 0;
  long long freeDofs = 0;

  // wall times in seconds
  double meshSeconds = 0;      ///< build or read the mesh, refine, validate
  double assemblySeconds = 0;  ///< matrix and load assembly
  double solveSeconds = 0;     ///< factorise and solve
  double outputSeconds = 0;    ///< .vtu and CSV
  double totalSeconds = 0;     ///< from reading the scene until summary.json is written

  double peakMemoryMB = 0;     ///< getrusage ru_maxrss of the process
  double maxDisplacement = 0;  ///< max over vertices of |u|
  double maxVonMises = 0;      ///< max over cells of the von Mises stress of the cell mean

  SolverReport solver;
  std::optional<ContactReport> contact;  ///< scenes with [contact] only
  std::vector<BodyReport> bodies;  ///< multi-body scenes: per body
  std::vector<PairReport> pairs;   ///< multi-body scenes: per [[contact]] pair
  std::vector<IncrementReport> increments;  ///< [loading] scenes: per load increment
  /// Mass matrices assembled (one per time stepper of a [dynamics] scene; 0 for static scenes,
  /// which never build one — docs/architecture.md#build-what-is-needed).
  int massAssemblies = 0;

  std::vector<std::filesystem::path> outputFiles;  ///< everything written, summary.json last
};

}  // namespace obs::drivers
