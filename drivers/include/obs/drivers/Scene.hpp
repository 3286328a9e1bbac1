#pragma once
/// \file Scene.hpp
/// A scene: everything a static run (linear elasticity or Signorini contact) needs, as read from a scene file (TOML, see
/// docs/scenes.md). The structs mirror the file's sections; every entry remembers the line it came
/// from so that checks needing the mesh (boundary names, vector lengths, rigid motions) can still
/// name the file, line and key.
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/DynamicsSpec.hpp"
#include "obs/drivers/AdaptivitySpec.hpp"
#include "obs/drivers/Expression.hpp"
#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"
#include "obs/obs/FrictionLaw.hpp"
#include "obs/obs/Material.hpp"

namespace obs::drivers {

/// A vector given in the scene file, one expression per entry as written (its length is checked
/// against the mesh dimension by validateScene).
struct VectorValue {
  std::vector<Expression> entries;
  int line = 0;  ///< line of the key in the scene file (0: unknown)
};

/// A boundary addressed by name (`boundary = "left"`) or by integer id (`boundary = 3`).
struct BoundaryRef {
  std::string name;  ///< empty when addressed by id
  int id = -1;
  int line = 0;
  std::string describe() const;  ///< "\"left\"" or "3", as written in the scene
};

/// One entry of [mesh] projection: the vertices that refinement creates on the faces of `boundary`
/// are moved onto an exact shape (mesh::Grid::setBoundaryProjection), so that the refined surface of
/// an imported mesh converges to the curved geometry instead of staying the coarse polygon.
struct ProjectionSpec {
  enum class Shape { Sphere, Cylinder, Plane };  ///< sphere (a circle in 2D), cylinder (3D), plane
  BoundaryRef boundary;
  Shape shape = Shape::Sphere;
  mesh::Point centre = mesh::Point::Zero();  ///< sphere centre, a point of the cylinder axis or the plane
  mesh::Point direction = mesh::Point::UnitZ();  ///< cylinder axis or plane normal (unit)
  double radius = 0;                           ///< sphere and cylinder
  int line = 0;
};

/// [mesh]: a generated box, ball, rounded block, disk or half disk, or a Gmsh file (or one physical
/// group of its cells), then `refine` uniform
/// refinements (new vertices on curved boundaries are projected onto the exact surface: by the
/// generators on their curved boundaries, by `projection` entries on any boundary).
struct MeshSpec {
  enum class Source { Box, File, Ball, RoundedBlock, Disk, HalfDisk, HalfBall };
  Source source = Source::Box;
  // generator = "box"
  mesh::CellType cellType = mesh::CellType::Quadrilateral;
  std::array<int, 3> cells{1, 1, 1};
  mesh::Point lower = mesh::Point::Zero();
  mesh::Point upper = mesh::Point::Ones();
  // generator = "ball" (mesh::ballMesh: centre, radius, cells = cells[0] per direction of the
  // inner cube) and "rounded_block" (mesh::roundedBlockMesh: width, height, depth, arc_radius, cells)
  mesh::Point centre = mesh::Point::Zero();
  double radius = 1, width = 1, height = 1, depth = 1, arcRadius = 1;
  // file = "..."
  std::filesystem::path file;  ///< resolved against the scene file's directory
  /// physical = "name" or tag: only the cells of this physical group of the mesh dimension
  /// (mesh::extractCellGroup; docs/scenes.md#gmsh-bodies). Unset: every cell of the file.
  std::optional<std::string> physicalName;
  std::optional<int> physicalTag;
  int physicalLine = 0;  ///< line of physical (0: not given)
  std::vector<ProjectionSpec> projections;  ///< projection = {...} or [{...}, ...]
  int refine = 0;
  int line = 0;        ///< line of [mesh]
  int refineLine = 0;  ///< line of refine (0: not given)
};

/// One [[dirichlet]] entry: prescribed displacement components on a boundary.
struct DirichletSpec {
  BoundaryRef boundary;  ///< unset (line 0) with `everywhere`
  /// Every vertex of the body, interior ones included, instead of a boundary (a rigid or driven body).
  bool everywhere = false;
  /// Empty: zero. One entry: the same value for every fixed component. Otherwise one entry per
  /// coordinate direction (length = dimension); entries of free components are ignored.
  VectorValue value;
  /// Fixed components (0 = x, 1 = y, 2 = z) in the order written; empty: all components.
  std::vector<int> components;
  int componentsLine = 0;
  int line = 0;  ///< line of [[dirichlet]]
};

/// One [[neumann]] entry: a traction vector or a pressure (acting against the outward normal).
struct NeumannSpec {
  BoundaryRef boundary;
  std::optional<VectorValue> traction;
  std::optional<Expression> pressure;
  int pressureLine = 0;
  int line = 0;  ///< line of [[neumann]]
};

/// [loading]: quasi-static load increments (docs/scenes.md#loading).
struct LoadingSpec {
  int steps = 1;  ///< N >= 1
  int line = 0;   ///< line of [loading]
};

/// friction = { law = "coulomb", mu = ... } or { law = "tresca", bound = ... } of a [contact] or a
/// [[contact]] pair (docs/scenes.md#friction).
struct FrictionSpec {
  FrictionLaw law;
  int line = 0;
};

/// [contact]: the potential contact boundary Gamma_C and the rigid obstacle (docs/theory.md#signorini). The
/// obstacle's parameters are kept as written; ObstacleFactory.hpp lists them per obstacle type,
/// checks them against the mesh dimension and builds the obs::Obstacle.
struct ContactSpec {
  struct Number {
    double value = 0;
    int line = 0;
  };
  struct Vector {
    std::vector<double> values;  ///< 2 or 3 finite numbers as written
    int line = 0;
  };
  BoundaryRef boundary;
  std::string obstacle;  ///< obstacle type, one of obstacleTypeNames()
  int obstacleLine = 0;
  std::map<std::string, Number> numbers;  ///< scalar parameters given (radius, slope, ...)
  std::map<std::string, Vector> vectors;  ///< points and directions given
  struct File {
    std::filesystem::path path;  ///< resolved against the scene file's directory, exists
    std::string text;            ///< as written
    int line = 0;
  };
  std::map<std::string, File> files;  ///< file parameters given (surface: file)
  struct Flag {
    bool value = false;
    int line = 0;
  };
  std::map<std::string, Flag> flags;  ///< boolean parameters given (surface: reverse)
  bool normalDirection = false;           ///< direction = "normal"
  int directionLine = 0;                  ///< 0: direction not given (the type's default)
  std::optional<Expression> gap;          ///< obstacle = "expression": g(x)
  int gapLine = 0;
  std::optional<FrictionSpec> friction;   ///< friction = {...}; none: frictionless
  int line = 0;  ///< line of [contact]
};

/// [solver]: how the problem is solved. Contact scenes: "tnnmg" (default), "pdas", "pgs"; scenes
/// without [contact]: "direct" (default, CHOLMOD) or "multigrid". Unset options take the
/// defaults of the solver type (see docs/scenes.md).
struct SolverSpec {
  std::string type;  ///< empty: the default of the scene kind
  std::optional<double> tolerance;
  std::optional<int> maxIterations;
  std::optional<int> preSmoothing;
  std::optional<int> postSmoothing;
  std::string smoother;            ///< "gauss-seidel", "vertex-patch"; empty: not given (gauss-seidel)
  std::optional<int> krylovSteps;  ///< CG steps per linear correction (0: plain V-cycles)
  std::optional<int> linearSmoothing;  ///< sweeps before and after the coarse correction of the V-cycle
  std::optional<bool> localSmoothing;  ///< smooth only where a level is new (LinearMultigridOptions)
  std::optional<int> cycleIndex;       ///< cycle = "V" (1) or "W" (2): LinearMultigridOptions::cycleIndex
  int line = 0;  ///< line of [solver] (0: section absent)
};

/// [output] checkpoint = { every = N, seconds = S }: write <output>/checkpoint.h5 every N time
/// steps ([dynamics]) or every N solves ([adaptivity]: after steps N - 1, 2N - 1, ...) and/or when S
/// seconds of wall time have passed since the last one (docs/checkpoint.md). At least one of the
/// two is given.
struct CheckpointSpec {
  std::optional<int> every;        ///< steps, >= 1
  std::optional<double> seconds;   ///< wall-clock seconds, > 0
  int line = 0;                    ///< line of the checkpoint key
};

/// [output]
struct OutputSpec {
  std::filesystem::path directory;  ///< relative to the working directory; default out/<scene name>
  bool vtk = true;                  ///< write <scene name>.vtu
  std::filesystem::path csv = "runs.csv";  ///< empty: no CSV; relative paths are inside `directory`
  bool plots = false;  ///< dynamic scenes: PNG plots by scripts/plot_dynamics.py; [adaptivity]
                       ///< runs: by scripts/plot_adaptivity.py
  std::optional<CheckpointSpec> checkpoint;
};

/// One [[contact]] entry of a multi-body scene: dual-mortar contact between the slave boundary of
/// one body and the master boundary of another (docs/scenes.md, "Multi-body scenes").
struct MortarPairSpec {
  std::string slaveBody, masterBody;  ///< body names as written
  BoundaryRef slave, master;          ///< boundaries of those bodies
  int slaveIndex = -1, masterIndex = -1;  ///< indices into Scene::bodies
  double minCoverage = 0.5;  ///< slave nodes covered less are unconstrained (MortarCoupling.hpp)
  double searchDistance = -1;  ///< potential contact zone (MortarOptions::searchDistance); <= 0: default
  std::optional<FrictionSpec> friction;  ///< friction = {...}; none: frictionless
  int line = 0;              ///< line of [[contact]]
};

struct Scene {
  std::string fileName;             ///< the scene path as given (used in messages)
  std::filesystem::path directory;  ///< directory of the scene file
  std::string name;                 ///< file stem, e.g. "cantilever"
  /// The scene file's text and the `--set` overrides applied to it, as read (checkpoints store them
  /// and their hash; a restart compares them).
  std::string text;
  std::vector<std::string> overrides;

  MeshSpec mesh;
  Material material;
  int materialLine = 0;
  int densityLine = 0;  ///< line of [material] density (0: not given; required by [dynamics])
  int formulationLine = 0;  ///< line of [material] formulation (0: not given: "standard")
  std::vector<DirichletSpec> dirichlet;
  std::vector<NeumannSpec> neumann;
  std::optional<VectorValue> bodyForce;
  std::optional<ContactSpec> contact;
  SolverSpec solver;
  OutputSpec output;
  std::optional<AdaptivitySpec> adaptivity;  ///< [adaptivity]: run the adaptive loop
  std::optional<DynamicsSpec> dynamics;  ///< [dynamics]: time-dependent contact (DynamicScene.hpp)
  /// [loading] steps = N: a static contact scene solved in N load increments, t = i/N in the
  /// boundary conditions' expressions, the friction slip of each measured from the one before
  /// (docs/scenes.md#loading). Unset: one solve at t = 0.
  std::optional<LoadingSpec> loading;

  /// [[body]] entries of a multi-body scene (empty in one-body scenes, whose body is described by
  /// the top-level sections above). Each is a Scene holding that body's mesh, material,
  /// [[dirichlet]], [[neumann]] and body force, with name = the body's name and bodyLine = the
  /// line of its [[body]]; solver, output and contact are those of the enclosing scene.
  std::vector<Scene> bodies;
  int bodyLine = 0;
  /// [[body]] initial_velocity / initial_displacement of a multi-body [dynamics] scene, vector
  /// expressions as in [dynamics] (empty: the [dynamics] values, which then apply to every body).
  std::vector<Expression> bodyInitialVelocity, bodyInitialDisplacement;
  int bodyInitialVelocityLine = 0, bodyInitialDisplacementLine = 0;
  /// [[contact]] pairs of a multi-body scene.
  std::vector<MortarPairSpec> pairs;
  /// True for a file written with [[body]] sections. Its outputs are per body (<scene>_<body>.vtu,
  /// summary.json "bodies" and "pairs"); a one-body file keeps its layout (<scene>.vtu, "contact").
  bool multiBody() const { return !bodies.empty(); }
  /// The bodies every runner works on: the [[body]] entries, or the scene itself for a one-body
  /// file (a list of one, whose name is the scene's and whose [contact] is its obstacle coupling).
  std::vector<const Scene*> bodyScenes() const;
  /// The scene has contact: a one-body [contact], or (multi-body files always) [[contact]] couplings.
  bool hasContact() const { return contact.has_value() || multiBody(); }
  /// Some contact of the scene has friction = {...} (its [contact], a body's obstacle or a pair).
  bool frictional() const;

  /// The solver type to use: solver.type, or "tnnmg" with [contact] and "direct" without.
  std::string solverType() const;

  /// "file:line: " (or "file: " when line is 0), the prefix of every message about this scene.
  std::string where(int line) const;
};

}  // namespace obs::drivers
