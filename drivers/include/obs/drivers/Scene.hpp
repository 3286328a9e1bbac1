#pragma once
/// \file Scene.hpp
/// A scene: everything a static linear-elastic run needs, as read from a scene file (TOML, see
/// docs/scenes.md). The structs mirror the file's sections; every entry remembers the line it came
/// from so that checks needing the mesh (boundary names, vector lengths, rigid motions) can still
/// name the file, line and key.
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/Expression.hpp"
#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"
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

/// [mesh]: a generated box or a Gmsh file, then `refine` uniform refinements.
struct MeshSpec {
  enum class Source { Box, File };
  Source source = Source::Box;
  // generator = "box"
  mesh::CellType cellType = mesh::CellType::Quadrilateral;
  std::array<int, 3> cells{1, 1, 1};
  mesh::Point lower = mesh::Point::Zero();
  mesh::Point upper = mesh::Point::Ones();
  // file = "..."
  std::filesystem::path file;  ///< resolved against the scene file's directory
  int refine = 0;
  int line = 0;        ///< line of [mesh]
  int refineLine = 0;  ///< line of refine (0: not given)
};

/// One [[dirichlet]] entry: prescribed displacement components on a boundary.
struct DirichletSpec {
  BoundaryRef boundary;
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

/// [output]
struct OutputSpec {
  std::filesystem::path directory;  ///< relative to the working directory; default out/<scene name>
  bool vtk = true;                  ///< write <scene name>.vtu
  std::filesystem::path csv = "runs.csv";  ///< empty: no CSV; relative paths are inside `directory`
};

struct Scene {
  std::string fileName;             ///< the scene path as given (used in messages)
  std::filesystem::path directory;  ///< directory of the scene file
  std::string name;                 ///< file stem, e.g. "cantilever"

  MeshSpec mesh;
  Material material;
  int materialLine = 0;
  std::vector<DirichletSpec> dirichlet;
  std::vector<NeumannSpec> neumann;
  std::optional<VectorValue> bodyForce;
  OutputSpec output;

  /// "file:line: " (or "file: " when line is 0), the prefix of every message about this scene.
  std::string where(int line) const;
};

}  // namespace obs::drivers
