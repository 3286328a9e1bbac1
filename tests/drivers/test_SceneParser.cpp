// Scene files: a valid scene parses to the expected Scene, every data/scenes/*.toml parses and
// validates, and every kind of invalid input gives one obs::Error line naming the file, the line
// and the key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "obs/drivers/SceneParser.hpp"
#include "obs/drivers/SceneSetup.hpp"
#include "obs/mesh/Error.hpp"

namespace fs = std::filesystem;
using namespace obs::drivers;

namespace {

const fs::path kTmp = fs::path(OBS_TEST_TMP_DIR) / "scene_parser";

/// Writes `text` to <tmp>/<name>.toml (unique per test, so tests may run in parallel).
fs::path writeScene(const std::string& name, const std::string& text) {
  fs::create_directories(kTmp);
  const fs::path p = kTmp / (name + ".toml");
  std::ofstream(p) << text;
  return p;
}

/// parse + build mesh + validate, as `obs run` does before solving.
void load(const fs::path& p) {
  const Scene scene = parseScene(p);
  if (scene.multiBody()) {  // every body, and the pairs' couplings
    checkMultiBodyScene(scene);
    return;
  }
  const obs::mesh::Mesh mesh = buildMesh(scene);
  validateScene(scene, mesh);
}

/// The message of the obs::Error that loading the scene throws ("" if none).
std::string errorOf(const std::string& name, const std::string& text) {
  try {
    load(writeScene(name, text));
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "";
}

const std::string kMesh2D = R"([mesh]
generator = "box"
type = "quadrilateral"
cells = [4, 2]
lower = [0, 0]
upper = [2, 1]
)";
const std::string kMaterial = R"(
[material]
E = 1000
nu = 0.3
)";
const std::string kClamp = R"(
[[dirichlet]]
boundary = "left"
)";

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

/// The error names the file (with a line number where one is given) and the key, in one line.
#define EXPECT_SCENE_ERROR(name, text, ...)                                         \
  do {                                                                              \
    const std::string msg = errorOf(name, text);                                    \
    ASSERT_FALSE(msg.empty()) << "no error for scene " << name;                     \
    EXPECT_TRUE(contains(msg, std::string(name) + ".toml")) << msg;                 \
    EXPECT_FALSE(contains(msg, "\n")) << msg;                                       \
    for (const char* part : {__VA_ARGS__}) EXPECT_TRUE(contains(msg, part)) << msg; \
  } while (false)

}  // namespace

// --- valid scenes
// ---------------------------------------------------------------------------------

TEST(SceneParser, ValidSceneParsesToExpectedScene) {
  const fs::path p = writeScene("valid_full", R"(# a scene using every key
[mesh]
generator = "box"
type = "triangle"
cells = [8, 4]
lower = [0, -1]
upper = [4.0, 1]
refine = 1

[material]
E = 2.5e3
nu = 0.25

[[dirichlet]]
boundary = "left"

[[dirichlet]]
boundary = "right"
components = ["x"]
value = "0.01*y"

[[dirichlet]]
boundary = 3
components = ["y", "x"]
value = [0, "-0.001*x"]

[[neumann]]
boundary = "top"
traction = [0, "-10*x"]

[[neumann]]
boundary = "bottom"
pressure = 2

[body_force]
value = [0, -9.81]

[output]
directory = "out/somewhere"
vtk = false
csv = "runs.csv"
)");
  const Scene s = parseScene(p);
  EXPECT_EQ(s.fileName, p.string());
  EXPECT_EQ(s.name, "valid_full");
  EXPECT_EQ(s.mesh.source, MeshSpec::Source::Box);
  EXPECT_EQ(s.mesh.cellType, obs::mesh::CellType::Triangle);
  EXPECT_EQ(s.mesh.cells, (std::array<int, 3>{8, 4, 1}));
  EXPECT_EQ(s.mesh.lower, obs::mesh::Point(0, -1, 0));
  EXPECT_EQ(s.mesh.upper, obs::mesh::Point(4, 1, 0));
  EXPECT_EQ(s.mesh.refine, 1);
  EXPECT_EQ(s.mesh.refineLine, 8);
  EXPECT_EQ(s.mesh.line, 2);
  EXPECT_DOUBLE_EQ(s.material.youngsModulus, 2500.0);
  EXPECT_DOUBLE_EQ(s.material.poissonRatio, 0.25);

  ASSERT_EQ(s.dirichlet.size(), 3u);
  EXPECT_EQ(s.dirichlet[0].boundary.name, "left");
  EXPECT_TRUE(s.dirichlet[0].components.empty());
  EXPECT_TRUE(s.dirichlet[0].value.entries.empty());
  EXPECT_EQ(s.dirichlet[0].line, 14);
  EXPECT_EQ(s.dirichlet[1].components, std::vector<int>{0});
  ASSERT_EQ(s.dirichlet[1].value.entries.size(), 1u);
  EXPECT_EQ(s.dirichlet[1].value.entries[0].text(), "0.01*y");
  EXPECT_DOUBLE_EQ(s.dirichlet[1].value.entries[0](0, 2, 0), 0.02);
  EXPECT_EQ(s.dirichlet[2].boundary.id, 3);
  EXPECT_TRUE(s.dirichlet[2].boundary.name.empty());
  EXPECT_EQ(s.dirichlet[2].components, (std::vector<int>{1, 0}));
  ASSERT_EQ(s.dirichlet[2].value.entries.size(), 2u);
  EXPECT_DOUBLE_EQ(s.dirichlet[2].value.entries[1](2, 0, 0), -0.002);

  ASSERT_EQ(s.neumann.size(), 2u);
  EXPECT_EQ(s.neumann[0].boundary.name, "top");
  ASSERT_TRUE(s.neumann[0].traction);
  EXPECT_EQ(s.neumann[0].traction->entries.size(), 2u);
  EXPECT_DOUBLE_EQ(s.neumann[0].traction->entries[1](3, 0, 0), -30.0);
  EXPECT_FALSE(s.neumann[0].pressure);
  ASSERT_TRUE(s.neumann[1].pressure);
  EXPECT_DOUBLE_EQ(s.neumann[1].pressure->value(), 2.0);

  ASSERT_TRUE(s.bodyForce);
  EXPECT_DOUBLE_EQ(s.bodyForce->entries[1].value(), -9.81);
  EXPECT_EQ(s.output.directory, fs::path("out/somewhere"));
  EXPECT_FALSE(s.output.vtk);
  EXPECT_EQ(s.output.csv, fs::path("runs.csv"));

  // and it is valid against its mesh; the boundary conditions evaluate the expressions
  const obs::mesh::Mesh mesh = buildMesh(s);
  EXPECT_EQ(mesh.numCells(), 8 * 4 * 2 * 4);
  EXPECT_NO_THROW(validateScene(s, mesh));
  const obs::BoundaryConditions bc = makeBoundaryConditions(s, mesh);
  ASSERT_EQ(bc.dirichlet.size(), 3u);
  EXPECT_EQ(bc.dirichlet[1].boundaryId, 2);  // right
  EXPECT_TRUE(bc.dirichlet[1].fixed[0]);
  EXPECT_FALSE(bc.dirichlet[1].fixed[1]);
  EXPECT_DOUBLE_EQ(bc.dirichlet[1].value(obs::mesh::Point(4, 0.5, 0))[0], 0.005);
  EXPECT_DOUBLE_EQ(bc.dirichlet[1].value(obs::mesh::Point(4, 0.5, 0))[1], 0.0);
  EXPECT_DOUBLE_EQ(bc.dirichlet[2].value(obs::mesh::Point(2, -1, 0))[1], -0.002);
  ASSERT_EQ(bc.neumann.size(), 2u);
  ASSERT_TRUE(bc.neumann[0].traction);
  EXPECT_DOUBLE_EQ(bc.neumann[0].traction(obs::mesh::Point(1, 1, 0))[1], -10.0);
  ASSERT_TRUE(bc.neumann[1].pressure);
  EXPECT_DOUBLE_EQ(bc.neumann[1].pressure(obs::mesh::Point(1, -1, 0)), 2.0);
  ASSERT_TRUE(bc.bodyForce);
  EXPECT_DOUBLE_EQ(bc.bodyForce(obs::mesh::Point(0, 0, 0))[1], -9.81);
}

TEST(SceneParser, DefaultsAndOptionalSections) {
  const Scene s = parseScene(writeScene("valid_minimal", kMesh2D + kMaterial + kClamp));
  EXPECT_FALSE(s.bodyForce);
  EXPECT_TRUE(s.neumann.empty());
  EXPECT_EQ(s.mesh.refine, 0);
  EXPECT_EQ(s.output.directory, fs::path("out") / "valid_minimal");
  EXPECT_TRUE(s.output.vtk);
  EXPECT_EQ(s.output.csv, fs::path("runs.csv"));  // a CSV row per run by default
  EXPECT_NO_THROW(load(writeScene("valid_minimal", kMesh2D + kMaterial + kClamp)));
}

TEST(SceneParser, MeshFileIsRelativeToTheScene) {
  const fs::path p =
      writeScene("valid_gmsh", R"([mesh]
file = ")" +
                                   (fs::path(OBS_DATA_DIR) / "meshes" / "square_triangles.msh")
                                       .lexically_relative(kTmp)
                                       .string() +
                                   R"("
[material]
E = 1
nu = 0
[[dirichlet]]
boundary = "left"
)");
  const Scene s = parseScene(p);
  EXPECT_EQ(s.mesh.source, MeshSpec::Source::File);
  EXPECT_TRUE(
      fs::equivalent(s.mesh.file, fs::path(OBS_DATA_DIR) / "meshes" / "square_triangles.msh"));
  EXPECT_NO_THROW(load(p));
}

TEST(SceneParser, EveryDataSceneParsesAndValidates) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(OBS_DATA_DIR) / "scenes")) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    EXPECT_NO_THROW(load(entry.path()));
    ++count;
  }
  EXPECT_GE(count, 3);
}

// --- structure: sections, keys, types, missing entries -------------------------------------------

TEST(SceneValidation, UnknownSection) {
  EXPECT_SCENE_ERROR("bad_section", kMesh2D + kMaterial + kClamp + "\n[solvers]\ntype = \"cg\"\n",
                     "unknown section [solvers]",
                     "allowed sections: mesh, material, dirichlet, neumann, body_force, contact, "
                     "solver, output");
}

TEST(SceneValidation, UnknownTopLevelKey) {
  EXPECT_SCENE_ERROR("bad_toplevel", "title = \"x\"\n" + kMesh2D + kMaterial + kClamp,
                     "bad_toplevel.toml:1:", "unknown key 'title'");
}

TEST(SceneValidation, UnknownKeys) {
  EXPECT_SCENE_ERROR(
      "bad_key_material", kMesh2D + "\n[material]\nE = 1\nnu = 0.3\nrho = 7\n" + kClamp,
      "bad_key_material.toml:11:", "[material] unknown key 'rho'", "allowed keys: E, nu");
  EXPECT_SCENE_ERROR(
      "bad_key_mesh",
      "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncels = [2, 2]\n" + kMaterial,
      "bad_key_mesh.toml:4:", "[mesh] unknown key 'cels'");
  EXPECT_SCENE_ERROR("bad_key_dirichlet",
                     kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\nvalues = [0, 0]\n",
                     "[[dirichlet]] unknown key 'values'");
  EXPECT_SCENE_ERROR(
      "bad_key_neumann",
      kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"top\"\nforce = [0, 1]\n",
      "[[neumann]] unknown key 'force'");
  EXPECT_SCENE_ERROR("bad_key_output", kMesh2D + kMaterial + kClamp + "[output]\nvtu = true\n",
                     "[output] unknown key 'vtu'");
  EXPECT_SCENE_ERROR("bad_key_body",
                     kMesh2D + kMaterial + kClamp + "[body_force]\nvalue = [0, 1]\nscale = 2\n",
                     "[body_force] unknown key 'scale'");
  EXPECT_SCENE_ERROR("bad_subtable", kMesh2D + kMaterial + kClamp + "[output.extra]\na = 1\n",
                     "[output] unknown key 'extra'");
}

TEST(SceneValidation, WrongTypes) {
  EXPECT_SCENE_ERROR("bad_type_E", kMesh2D + "\n[material]\nE = \"stiff\"\nnu = 0.3\n" + kClamp,
                     "bad_type_E.toml:9:", "[material] E must be a number, got a string");
  EXPECT_SCENE_ERROR("bad_type_cells",
                     "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = 4\n" + kMaterial,
                     "[mesh] cells must be an array");
  EXPECT_SCENE_ERROR(
      "bad_type_cell_entry",
      "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = [4, 2.5]\n" + kMaterial,
      "[mesh] cells[1] must be an integer");
  EXPECT_SCENE_ERROR("bad_type_refine", kMesh2D + "refine = 1.5\n" + kMaterial + kClamp,
                     "[mesh] refine must be an integer");
  EXPECT_SCENE_ERROR("bad_type_vtk", kMesh2D + kMaterial + kClamp + "[output]\nvtk = \"yes\"\n",
                     "[output] vtk must be true or false");
  EXPECT_SCENE_ERROR("bad_type_boundary", kMesh2D + kMaterial + "[[dirichlet]]\nboundary = [1]\n",
                     "[[dirichlet]] boundary must be a boundary name");
  EXPECT_SCENE_ERROR(
      "bad_type_traction",
      kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"top\"\ntraction = 5\n",
      "[[neumann]] traction must be an array");
  EXPECT_SCENE_ERROR(
      "bad_type_traction_entry",
      kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"top\"\ntraction = [0, true]\n",
      "[[neumann]] traction[1] must be a number or an expression string");
  EXPECT_SCENE_ERROR("bad_type_material", "material = 3\n" + kMesh2D + kClamp,
                     "bad_type_material.toml:1:", "[material] must be a table, got an integer");
  EXPECT_SCENE_ERROR("bad_single_dirichlet",
                     kMesh2D + kMaterial + "[dirichlet]\nboundary = \"left\"\n",
                     "[[dirichlet]] must be an array of tables");
  EXPECT_SCENE_ERROR(
      "bad_components",
      kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\ncomponents = [\"w\"]\n",
      "[[dirichlet]] components", "\"w\"");
  EXPECT_SCENE_ERROR(
      "bad_components_twice",
      kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\ncomponents = [\"x\", \"x\"]\n",
      "[[dirichlet]] components", "twice");
}

TEST(SceneValidation, MissingEntries) {
  EXPECT_SCENE_ERROR("missing_mesh", kMaterial + kClamp, "[mesh] section is missing");
  EXPECT_SCENE_ERROR("missing_material", kMesh2D + kClamp, "[material] section is missing");
  EXPECT_SCENE_ERROR("missing_E", kMesh2D + "\n[material]\nnu = 0.3\n" + kClamp,
                     "missing_E.toml:8:", "[material] E is missing");
  EXPECT_SCENE_ERROR("missing_nu", kMesh2D + "\n[material]\nE = 1\n" + kClamp,
                     "[material] nu is missing");
  EXPECT_SCENE_ERROR("missing_generator", "[mesh]\nrefine = 1\n" + kMaterial + kClamp,
                     "missing_generator.toml:1:", "[mesh] needs generator");
  EXPECT_SCENE_ERROR("missing_type",
                     "[mesh]\ngenerator = \"box\"\ncells = [2, 2]\n" + kMaterial + kClamp,
                     "[mesh] type is missing");
  EXPECT_SCENE_ERROR("missing_cells",
                     "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\n" + kMaterial + kClamp,
                     "[mesh] cells is missing");
  EXPECT_SCENE_ERROR("missing_boundary",
                     kMesh2D + kMaterial + "[[dirichlet]]\ncomponents = [\"x\"]\n",
                     "[[dirichlet]] boundary is missing");
  EXPECT_SCENE_ERROR("missing_load",
                     kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"top\"\n",
                     "[[neumann]] needs traction", "or pressure");
  EXPECT_SCENE_ERROR("missing_body_value", kMesh2D + kMaterial + kClamp + "[body_force]\n",
                     "[body_force] value is missing");
}

// --- values --------------------------------------------------------------------------------------

TEST(SceneValidation, MaterialRanges) {
  // the exact message format of docs/scenes.md
  EXPECT_EQ(errorOf("bad_nu", kMesh2D + "\n[material]\nE = 1000\nnu = 0.7\n" + kClamp),
            (kTmp / "bad_nu.toml").string() + ":10: [material] nu = 0.7 must lie in [0, 0.5)");
  EXPECT_SCENE_ERROR("bad_nu_half", kMesh2D + "\n[material]\nE = 1000\nnu = 0.5\n" + kClamp,
                     "[material] nu = 0.5 must lie in [0, 0.5)");
  EXPECT_SCENE_ERROR("bad_nu_negative", kMesh2D + "\n[material]\nE = 1000\nnu = -0.1\n" + kClamp,
                     "[material] nu = -0.1 must lie");
  EXPECT_SCENE_ERROR("bad_E_zero", kMesh2D + "\n[material]\nE = 0\nnu = 0.3\n" + kClamp,
                     "bad_E_zero.toml:9:", "[material] E = 0 must be positive");
  EXPECT_SCENE_ERROR("bad_E_negative", kMesh2D + "\n[material]\nE = -2e5\nnu = 0.3\n" + kClamp,
                     "[material] E = -2e5 must be positive");
  EXPECT_SCENE_ERROR("bad_E_inf", kMesh2D + "\n[material]\nE = inf\nnu = 0.3\n" + kClamp,
                     "[material] E = inf must be finite");
}

TEST(SceneValidation, MeshValues) {
  EXPECT_SCENE_ERROR(
      "bad_cell_type",
      "[mesh]\ngenerator = \"box\"\ntype = \"hexa\"\ncells = [2, 2, 2]\n" + kMaterial,
      "bad_cell_type.toml:3:", "[mesh] type = \"hexa\" is not a cell type", "hexahedron");
  EXPECT_SCENE_ERROR("bad_generator", "[mesh]\ngenerator = \"sphere\"\n" + kMaterial,
                     "[mesh] generator = \"sphere\" is unknown", "box, ball, rounded_block");
  EXPECT_SCENE_ERROR(
      "bad_cells_length",
      "[mesh]\ngenerator = \"box\"\ntype = \"hexahedron\"\ncells = [2, 2]\n" + kMaterial,
      "[mesh] cells", "must have 3 entries");
  EXPECT_SCENE_ERROR(
      "bad_cells_zero",
      "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = [0, 2]\n" + kMaterial,
      "[mesh] cells[0] = 0 must be at least 1");
  EXPECT_SCENE_ERROR(
      "bad_lower_length",
      "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = [2, 2]\nlower = [0, 0, 0]\n" +
          kMaterial,
      "[mesh] lower", "must have 2 entries");
  EXPECT_SCENE_ERROR("bad_upper",
                     "[mesh]\ngenerator = \"box\"\ntype = \"triangle\"\ncells = [2, 2]\nlower = "
                     "[0, 0]\nupper = [1, 0]\n" +
                         kMaterial,
                     "[mesh] upper must exceed lower");
  EXPECT_SCENE_ERROR("bad_refine_negative", kMesh2D + "refine = -1\n" + kMaterial + kClamp,
                     "bad_refine_negative.toml:7:", "[mesh] refine = -1 must lie in [0, 12]");
  EXPECT_SCENE_ERROR("bad_refine_huge", kMesh2D + "refine = 100\n" + kMaterial + kClamp,
                     "[mesh] refine = 100 must lie");
  // within the syntactic range, but far too many cells
  EXPECT_SCENE_ERROR("bad_refine_cells", kMesh2D + "refine = 12\n" + kMaterial + kClamp,
                     "bad_refine_cells.toml:7:", "[mesh] refine = 12 would give about");
  EXPECT_SCENE_ERROR("bad_mesh_file", "[mesh]\nfile = \"no/such.msh\"\n" + kMaterial + kClamp,
                     "bad_mesh_file.toml:2:", "[mesh] file = \"no/such.msh\": no such file");
  EXPECT_SCENE_ERROR("bad_mesh_both", "[mesh]\ngenerator = \"box\"\nfile = \"a.msh\"\n" + kMaterial,
                     "[mesh] file cannot be combined with generator");
}

TEST(SceneValidation, RefineOverrideIsChecked) {
  const Scene s = parseScene(writeScene("refine_override", kMesh2D + kMaterial + kClamp));
  EXPECT_EQ(buildMesh(s, 1).numCells(), 4 * 2 * 4);
  try {
    buildMesh(s, 12);
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_TRUE(contains(e.what(), "--refine 12 would give about")) << e.what();
  }
  EXPECT_THROW(buildMesh(s, -1), obs::Error);
}

TEST(SceneValidation, BoundaryNames) {
  EXPECT_SCENE_ERROR(
      "bad_boundary", kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"lft\"\n",
      "bad_boundary.toml:12:", "[[dirichlet]] boundary = \"lft\" does not exist in the mesh",
      "available boundaries: left, right, bottom, top");
  EXPECT_SCENE_ERROR(
      "bad_boundary_neumann",
      kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"front\"\npressure = 1\n",
      "[[neumann]] boundary = \"front\" does not exist");
  EXPECT_SCENE_ERROR("bad_boundary_id", kMesh2D + kMaterial + "[[dirichlet]]\nboundary = 7\n",
                     "[[dirichlet]] boundary = 7 does not exist");
}

TEST(SceneValidation, RigidMotions) {
  EXPECT_SCENE_ERROR("rigid_none", kMesh2D + kMaterial,
                     "[[dirichlet]]: the Dirichlet conditions leave 3 rigid motion(s) free");
  EXPECT_SCENE_ERROR(
      "rigid_roller",
      kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\ncomponents = [\"x\"]\n",
      "[[dirichlet]]: the Dirichlet conditions leave 1 rigid motion(s) free");
  EXPECT_SCENE_ERROR("rigid_3d",
                     "[mesh]\ngenerator = \"box\"\ntype = \"hexahedron\"\ncells = [2, 2, 2]\n" +
                         kMaterial + "[[dirichlet]]\nboundary = \"bottom\"\ncomponents = [\"z\"]\n",
                     "leave 3 rigid motion(s) free");
}

TEST(SceneValidation, VectorLengths) {
  EXPECT_SCENE_ERROR(
      "bad_traction_length",
      kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"top\"\ntraction = [0, -1, 0]\n",
      "bad_traction_length.toml:16:", "[[neumann]] traction has 3 entries, expected 2");
  EXPECT_SCENE_ERROR("bad_body_length",
                     kMesh2D + kMaterial + kClamp + "[body_force]\nvalue = [1]\n",
                     "[body_force] value has 1 entry, expected 2");
  EXPECT_SCENE_ERROR(
      "bad_dirichlet_length",
      kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\nvalue = [0, 0, 0]\n",
      "[[dirichlet]] value has 3 entries, expected 2");
  EXPECT_SCENE_ERROR(
      "bad_component_z",
      kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\ncomponents = [\"z\"]\n",
      "[[dirichlet]] components: \"z\" does not exist in a 2D mesh");
}

TEST(SceneValidation, BadExpressions) {
  EXPECT_SCENE_ERROR("bad_expr",
                     kMesh2D + kMaterial + kClamp +
                         "[[neumann]]\nboundary = \"top\"\ntraction = [\"0.01*x+\", 0]\n",
                     "bad_expr.toml:16:", "[[neumann]] traction[0] = \"0.01*x+\"", "position 8");
  EXPECT_SCENE_ERROR(
      "bad_expr_pressure",
      kMesh2D + kMaterial + kClamp + "[[neumann]]\nboundary = \"top\"\npressure = \"sinn(x)\"\n",
      "[[neumann]] pressure = \"sinn(x)\"", "unknown function 'sinn'", "position 1");
  EXPECT_SCENE_ERROR("bad_expr_dirichlet",
                     kMesh2D + kMaterial + "[[dirichlet]]\nboundary = \"left\"\nvalue = \"2*q\"\n",
                     "[[dirichlet]] value = \"2*q\"", "unknown variable 'q'");
}

TEST(SceneValidation, NonFiniteValuesAreReported) {
  const fs::path p = writeScene(
      "nonfinite", kMesh2D + kMaterial + kClamp + "[body_force]\nvalue = [\"log(x)\", 0]\n");
  const Scene s = parseScene(p);
  const obs::mesh::Mesh mesh = buildMesh(s);
  const obs::BoundaryConditions bc = makeBoundaryConditions(s, mesh);
  try {
    bc.bodyForce(obs::mesh::Point(0, 0.5, 0));
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_TRUE(
        contains(e.what(), "nonfinite.toml:15: [body_force] value is not finite at (0, 0.5)"))
        << e.what();
  }
}

TEST(SceneValidation, TomlSyntaxErrorIsOneLine) {
  EXPECT_SCENE_ERROR("bad_syntax", "[mesh]\ngenerator = \"box\" \"x\"\n",
                     "bad_syntax.toml:2:", "TOML syntax error");
  EXPECT_SCENE_ERROR("bad_syntax_array", "[mesh]\ncells = [1,\n",
                     "bad_syntax_array.toml:", "TOML syntax error");
  EXPECT_SCENE_ERROR("bad_syntax_duplicate", "[material]\nE = 1\nE = 2\n",
                     "bad_syntax_duplicate.toml:3:", "TOML syntax error");
}

TEST(SceneValidation, MissingSceneFile) {
  try {
    parseScene(kTmp / "does_not_exist.toml");
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    EXPECT_TRUE(contains(e.what(), "does_not_exist.toml: cannot open")) << e.what();
  }
}
