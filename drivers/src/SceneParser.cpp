#include "obs/drivers/SceneParser.hpp"

#include <toml.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "DynamicsParser.hpp"
#include "SceneExtensions.hpp"
#include "TomlSection.hpp"
#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

namespace {

namespace fs = std::filesystem;

constexpr const char* kSections =
    "mesh, material, dirichlet, neumann, body_force, contact, solver, output, adaptivity, dynamics, loading, body";
constexpr int kMaxRefine = 12;
constexpr long long kMaxBoxCells = 100'000'000;

/// toml11 syntax errors span several lines ("[error] toml::parse_table: invalid line format\n
/// --> file\n 2 | x = 1 2\n   |   ^--- expected newline"); condense to
/// "file:2: TOML syntax error: invalid line format (expected newline)".
std::string condense(const toml::syntax_error& e, const std::string& fileName) {
  std::istringstream lines(e.what());
  std::string first, line, detail;
  std::getline(lines, first);
  while (std::getline(lines, line)) {
    for (const char* marker : {"^--- ", "~ "}) {
      const auto at = line.rfind(marker);
      if (at != std::string::npos && line.find(" | ") != std::string::npos) {
        detail = line.substr(at + std::string(marker).size());
        break;
      }
    }
  }
  if (first.rfind("[error]", 0) == 0) first.erase(0, 7);
  if (const auto colon = first.find(": ");
      first.find("toml::") < colon && colon != std::string::npos)
    first.erase(0, colon + 2);
  while (!first.empty() && first.front() == ' ') first.erase(0, 1);
  std::string msg =
      fileName + ":" + std::to_string(e.location().line()) + ": TOML syntax error: " + first;
  if (!detail.empty() && detail != first) msg += " (" + detail + ")";
  return msg;
}

std::vector<double> numbers(const TomlSection& s, const std::string& key, int count) {
  const toml::value& v = s.at(key);
  if (!v.is_array())
    s.fail(key, "must be an array of " + std::to_string(count) + " numbers, got " + typeNameOf(v));
  const auto& a = v.as_array();
  if (static_cast<int>(a.size()) != count)
    s.fail(key, "= " + literalOf(v) + " must have " + std::to_string(count) + " entries, got " +
                    std::to_string(a.size()));
  return finiteNumberEntries(s, v, key);
}

std::optional<mesh::CellType> cellTypeByName(const std::string& name) {
  for (mesh::CellType t : mesh::kVolumeCellTypes)
    if (mesh::name(t) == name) return t;
  return std::nullopt;
}

void parseBox(const TomlSection& s, MeshSpec& spec) {
  const std::string generator = s.string("generator");
  if (generator != "box")
    s.fail("generator", "= \"" + generator + "\" is unknown (known generators: box, ball, rounded_block, half_ball, disk, half_disk)");
  const std::string type = s.string("type");
  const auto cellType = cellTypeByName(type);
  if (!cellType)
    s.fail("type", "= \"" + type +
                       "\" is not a cell type (known: triangle, quadrilateral, tetrahedron, "
                       "hexahedron, prism, pyramid)");
  spec.cellType = *cellType;
  const int dim = mesh::dimension(*cellType);

  const toml::value& cells = s.at("cells");
  if (!cells.is_array())
    s.fail("cells",
           "must be an array of " + std::to_string(dim) + " integers, got " + typeNameOf(cells));
  const auto& a = cells.as_array();
  if (static_cast<int>(a.size()) != dim)
    s.fail("cells", "= " + literalOf(cells) + " must have " + std::to_string(dim) +
                        " entries for " + type + " cells, got " + std::to_string(a.size()));
  long long total = 1;
  spec.cells = {1, 1, 1};
  for (int i = 0; i < dim; ++i) {
    const std::string label = "cells[" + std::to_string(i) + "]";
    if (!a[i].is_integer()) s.failAt(a[i], label, "must be an integer, got " + typeNameOf(a[i]));
    const long long n = a[i].as_integer();
    if (n < 1 || n > kMaxBoxCells)
      s.failAt(a[i], label, "= " + literalOf(a[i]) + " must be at least 1");
    spec.cells[i] = static_cast<int>(n);
    total *= n;
    if (total > kMaxBoxCells)
      s.fail("cells", "= " + literalOf(cells) + " asks for more than " +
                          std::to_string(kMaxBoxCells) + " boxes");
  }

  spec.lower = mesh::Point::Zero();
  spec.upper = mesh::Point::Zero();
  for (int i = 0; i < dim; ++i) spec.upper[i] = 1.0;
  if (s.has("lower")) {
    const auto v = numbers(s, "lower", dim);
    for (int i = 0; i < dim; ++i) spec.lower[i] = v[i];
  }
  if (s.has("upper")) {
    const auto v = numbers(s, "upper", dim);
    for (int i = 0; i < dim; ++i) spec.upper[i] = v[i];
  }
  for (int i = 0; i < dim; ++i)
    if (!(spec.lower[i] < spec.upper[i])) {
      std::ostringstream os;
      os << "must exceed lower in every coordinate ("
         << "xyz"[i] << ": lower " << spec.lower[i] << ", upper " << spec.upper[i] << ")";
      s.fail(s.has("upper") ? "upper" : "lower", os.str());
    }
}

/// A point or direction of 2 or 3 finite numbers (the mesh dimension is known only when it is built).
mesh::Point pointOf(const TomlSection& s, const std::string& key) {
  const toml::value& v = s.at(key);
  if (!v.is_array() || (v.as_array().size() != 2 && v.as_array().size() != 3))
    s.fail(key, "= " + literalOf(v) + " must be an array of 2 or 3 numbers");
  const auto x = finiteNumberEntries(s, v, key);
  mesh::Point p = mesh::Point::Zero();
  for (std::size_t i = 0; i < x.size(); ++i) p[static_cast<Eigen::Index>(i)] = x[i];
  return p;
}

ProjectionSpec parseProjection(const Scene& scene, const toml::value& table) {
  const TomlSection s(scene.fileName, "[mesh] projection", table, {"boundary", "shape", "centre", "radius", "axis", "normal"});
  ProjectionSpec p;
  p.line = s.line();  // 0 for an inline table: parseMesh gives it the line of projection
  p.boundary = s.boundary("boundary");
  const std::string shape = s.string("shape");
  if (shape == "sphere" || shape == "circle") p.shape = ProjectionSpec::Shape::Sphere;
  else if (shape == "cylinder") p.shape = ProjectionSpec::Shape::Cylinder;
  else if (shape == "plane") p.shape = ProjectionSpec::Shape::Plane;
  else s.fail("shape", "= \"" + shape + "\" is unknown (known: \"sphere\", \"circle\", \"cylinder\", \"plane\")");
  p.centre = pointOf(s, "centre");
  const bool round = p.shape != ProjectionSpec::Shape::Plane;
  if (round) {
    p.radius = s.number("radius");
    if (!(p.radius > 0)) s.fail("radius", "= " + literalOf(s.at("radius")) + " must be positive");
  } else if (s.has("radius")) {
    s.fail("radius", "does not apply to shape = \"plane\"");
  }
  const char* dirKey = p.shape == ProjectionSpec::Shape::Cylinder ? "axis" : "normal";
  for (const char* key : {"axis", "normal"})
    if (s.has(key) && std::string(key) != dirKey)
      s.fail(key, std::string("does not apply to shape = \"") + shape + "\"" +
                      (p.shape == ProjectionSpec::Shape::Sphere ? "" : std::string(" (it takes ") + dirKey + ")"));
  if (p.shape != ProjectionSpec::Shape::Sphere) {
    p.direction = pointOf(s, dirKey);
    if (!(p.direction.norm() > 0)) s.fail(dirKey, "must not be the zero vector");
    p.direction.normalize();
  }
  return p;
}

MeshSpec parseMesh(const Scene& scene, const toml::value& table) {
  std::vector<std::string> keys = {"generator", "type", "cells", "lower", "upper", "file", "physical", "refine",
                                   "projection"};
  keys.insert(keys.end(), curvedMeshKeys().begin(), curvedMeshKeys().end());
  const TomlSection s(scene.fileName, "[mesh]", table, keys);
  MeshSpec spec;
  spec.line = s.line();
  if (s.has("generator") && s.has("file"))
    s.fail("file", "cannot be combined with generator (give one of them)");
  if (s.has("physical") && !s.has("file"))
    s.fail("physical", "needs file = \"mesh.msh\": it selects the cells of one physical group of a Gmsh file");
  if (s.has("file")) {
    for (const char* key : {"type", "cells", "lower", "upper"})
      if (s.has(key)) s.fail(key, "only applies to generator = \"box\", not to a mesh file");
    for (const std::string& key : curvedMeshKeys())
      if (s.has(key)) s.fail(key, "only applies to a mesh generator, not to a mesh file");
    const std::string file = s.string("file");
    if (file.empty()) s.fail("file", "must not be empty");
    fs::path path(file);
    if (path.is_relative()) path = scene.directory / path;
    path = path.lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(path, ec))
      s.fail("file", "= \"" + file + "\": no such file (looked for " + path.string() + ")");
    spec.source = MeshSpec::Source::File;
    spec.file = path;
    if (s.has("physical")) {
      const toml::value& p = s.at("physical");
      spec.physicalLine = s.line("physical");
      if (p.is_string()) {
        spec.physicalName = s.string("physical");
        if (spec.physicalName->empty()) s.fail("physical", "must not be empty (a physical group name or tag)");
      } else if (p.is_integer()) {
        const long long tag = p.as_integer();
        if (tag < std::numeric_limits<int>::min() || tag > std::numeric_limits<int>::max())
          s.fail("physical", "= " + literalOf(p) + " is not a physical tag (out of range)");
        spec.physicalTag = static_cast<int>(tag);
      } else {
        s.fail("physical", "must be a physical group name (string) or tag (integer), got " + typeNameOf(p));
      }
    }
  } else if (s.has("generator") && isCurvedGenerator(s.string("generator"))) {
    parseCurvedMesh(s, spec);
  } else if (s.has("generator")) {
    for (const std::string& key : curvedMeshKeys())
      if (s.has(key)) s.fail(key, "does not apply to generator = \"box\" (only ball, half_ball, rounded_block, disk, half_disk)");
    spec.source = MeshSpec::Source::Box;
    parseBox(s, spec);
  } else {
    throw Error(
        scene.where(spec.line) +
        "[mesh] needs generator = \"box\" (with type, cells, lower, upper) or file = \"mesh.msh\"");
  }
  if (s.has("projection")) {
    const toml::value& v = s.at("projection");
    if (v.is_table()) {
      spec.projections.push_back(parseProjection(scene, v));
    } else if (v.is_array()) {
      for (const toml::value& e : v.as_array()) {
        if (!e.is_table()) s.failAt(e, "projection", "entries must be tables { boundary = ..., shape = ..., ... }");
        spec.projections.push_back(parseProjection(scene, e));
      }
    } else {
      s.fail("projection", "must be a table { boundary = ..., shape = ..., ... } or an array of them, got " +
                               typeNameOf(v));
    }
    for (ProjectionSpec& p : spec.projections)
      if (p.line == 0) p.line = s.line("projection");
  }
  if (s.has("refine")) {
    const long long r = s.integer("refine");
    if (r < 0 || r > kMaxRefine)
      s.fail("refine", "= " + literalOf(s.at("refine")) + " must lie in [0, " +
                           std::to_string(kMaxRefine) + "]");
    spec.refine = static_cast<int>(r);
    spec.refineLine = s.line("refine");
  }
  return spec;
}

void parseMaterial(Scene& scene, const toml::value& table) {
  const TomlSection s(scene.fileName, "[material]", table, {"E", "nu", "density", "formulation"});
  scene.materialLine = s.line();
  const double E = s.number("E");
  if (E <= 0) s.fail("E", "= " + literalOf(s.at("E")) + " must be positive");
  const double nu = s.number("nu");
  if (nu < 0 || nu >= 0.5) s.fail("nu", "= " + literalOf(s.at("nu")) + " must lie in [0, 0.5)");
  scene.material.youngsModulus = E;
  scene.material.poissonRatio = nu;
  if (s.has("density")) {
    const double rho = s.number("density");
    if (!(rho > 0)) s.fail("density", "= " + literalOf(s.at("density")) + " must be positive");
    scene.material.density = rho;
    scene.densityLine = s.line("density");
  }
  if (s.has("formulation")) {
    const std::string f = s.string("formulation");
    scene.formulationLine = s.line("formulation");
    if (f == "bbar")
      scene.material.formulation = VolumetricFormulation::BBar;
    else if (f != "standard")
      s.fail("formulation", "= \"" + f + "\" is unknown (known: \"standard\", \"bbar\")");
  }
}

/// The entries of an array-of-tables section ([[name]] or name = [{...}, ...]).
const toml::array& entries(const Scene& scene, const toml::value& v, const std::string& name) {
  if (!v.is_array())
    throw Error(whereOf(scene.fileName, v) + "[[" + name +
                "]] must be an array of tables: write [[" + name +
                "]] (double brackets) before each condition");
  return v.as_array();
}

DirichletSpec parseDirichlet(const Scene& scene, const toml::value& table) {
  const TomlSection s(scene.fileName, "[[dirichlet]]", table, {"boundary", "everywhere", "value", "components"});
  DirichletSpec spec;
  spec.line = s.line();
  spec.everywhere = s.has("everywhere") && s.boolean("everywhere");
  if (spec.everywhere && s.has("boundary"))
    s.fail("everywhere", "prescribes every vertex of the body: remove the boundary (or set everywhere = false)");
  if (!spec.everywhere) spec.boundary = s.boundary("boundary");
  if (s.has("components")) {
    const toml::value& v = s.at("components");
    if (!v.is_array() || v.as_array().empty())
      s.fail("components", "must be a non-empty array of \"x\", \"y\", \"z\"");
    for (const toml::value& c : v.as_array()) {
      const std::string name = c.is_string() ? c.as_string().str : std::string();
      const auto at = std::string_view("xyz").find(name);
      if (name.size() != 1 || at == std::string_view::npos)
        s.failAt(c, "components", "entry " + literalOf(c) + " must be \"x\", \"y\" or \"z\"");
      const int comp = static_cast<int>(at);
      if (std::find(spec.components.begin(), spec.components.end(), comp) != spec.components.end())
        s.failAt(c, "components", "lists \"" + name + "\" twice");
      spec.components.push_back(comp);
    }
    spec.componentsLine = s.line("components");
  }
  if (s.has("value")) {
    if (s.at("value").is_array()) {
      spec.value = s.vector("value");
    } else {
      spec.value.entries = {s.expression("value")};
      spec.value.line = s.line("value");
    }
  }
  return spec;
}

NeumannSpec parseNeumann(const Scene& scene, const toml::value& table) {
  const TomlSection s(scene.fileName, "[[neumann]]", table, {"boundary", "traction", "pressure"});
  NeumannSpec spec;
  spec.line = s.line();
  spec.boundary = s.boundary("boundary");
  if (s.has("traction") && s.has("pressure"))
    s.fail("pressure", "cannot be combined with traction in one [[neumann]] entry");
  if (s.has("traction")) {
    spec.traction = s.vector("traction");
  } else if (s.has("pressure")) {
    spec.pressure = s.expression("pressure");
    spec.pressureLine = s.line("pressure");
  } else {
    throw Error(scene.where(spec.line) +
                "[[neumann]] needs traction = [tx, ty(, tz)] or pressure = p");
  }
  return spec;
}

/// An array of 2 or 3 finite numbers (a point or a direction; its length is checked against the
/// mesh dimension by makeObstacle).
ContactSpec::Vector contactVector(const TomlSection& s, const std::string& key) {
  const toml::value& v = s.at(key);
  if (!v.is_array())
    s.fail(key, "must be an array of 2 or 3 numbers, got " + typeNameOf(v));
  const auto& a = v.as_array();
  if (a.size() < 2 || a.size() > 3)
    s.fail(key, "= " + literalOf(v) + " must have 2 or 3 entries (one per coordinate), got " +
                    std::to_string(a.size()));
  ContactSpec::Vector out;
  out.line = s.line(key);
  out.values = numbers(s, key, static_cast<int>(a.size()));
  return out;
}

/// friction = { law = "coulomb", mu = m } or { law = "tresca", bound = g } (m, g >= 0 and finite).
FrictionSpec parseFriction(const Scene& scene, const TomlSection& s, const std::string& title) {
  const toml::value& v = s.at("friction");
  if (!v.is_table())
    s.fail("friction", "must be a table { law = \"coulomb\", mu = ... } or { law = \"tresca\", bound = ... }, got " +
                           typeNameOf(v));
  const TomlSection t(scene.fileName, title + " friction", v, {"law", "mu", "bound"});
  FrictionSpec f;
  f.line = s.line("friction");
  const std::string law = t.string("law");
  const std::string key = law == "coulomb" ? "mu" : "bound";
  if (law == "coulomb") f.law.type = FrictionLaw::Type::Coulomb;
  else if (law == "tresca") f.law.type = FrictionLaw::Type::Tresca;
  else t.fail("law", "= \"" + law + "\" is unknown (known: coulomb, tresca)");
  const std::string other = law == "coulomb" ? "bound" : "mu";
  if (t.has(other)) t.fail(other, "does not apply to law = \"" + law + "\" (it takes " + key + ")");
  f.law.value = t.number(key);
  if (!(f.law.value >= 0) || !std::isfinite(f.law.value))
    t.fail(key, "= " + literalOf(t.at(key)) + " must be a finite number >= 0");
  return f;
}

ContactSpec parseContact(const Scene& scene, const toml::value& table) {
  const TomlSection s(scene.fileName, "[contact]", table, contactKeys());
  ContactSpec spec;
  spec.line = s.line();
  spec.boundary = s.boundary("boundary");
  spec.obstacle = s.string("obstacle");
  spec.obstacleLine = s.line("obstacle");
  const ObstacleType* type = findObstacleType(spec.obstacle);
  if (!type)
    s.fail("obstacle", "= \"" + spec.obstacle + "\" is unknown (known obstacles: " +
                           obstacleTypeNames() + ")");
  std::string keys;
  for (const ObstacleParameter& p : type->parameters)
    keys += (keys.empty() ? "" : ", ") + std::string(p.key);
  // keys of other obstacle types, first in file order
  std::string stray;
  int strayLine = 0;
  for (const std::string& key : contactKeys()) {
    if (key == "boundary" || key == "obstacle" || key == "friction" || !s.has(key)) continue;
    const bool own = std::any_of(type->parameters.begin(), type->parameters.end(),
                                 [&](const ObstacleParameter& p) { return key == p.key; });
    if (!own && (stray.empty() || s.line(key) < strayLine)) {
      stray = key;
      strayLine = s.line(key);
    }
  }
  if (!stray.empty())
    s.fail(stray, "does not apply to obstacle = \"" + spec.obstacle + "\" (its parameters: " +
                      keys + ")");

  for (const ObstacleParameter& p : type->parameters) {
    const std::string key = p.key;
    if (!s.has(key)) {
      if (p.required)
        throw Error(scene.where(spec.line) + "[contact] obstacle = \"" + spec.obstacle +
                    "\" needs " + key + " (its parameters: " + keys + ")");
      continue;
    }
    switch (p.kind) {
      case ObstacleParameter::Kind::Number: {
        const double v = s.number(key);
        if (p.range == ObstacleParameter::Range::Positive && !(v > 0))
          s.fail(key, "= " + literalOf(s.at(key)) + " must be positive");
        if (p.range == ObstacleParameter::Range::NonNegative && !(v >= 0))
          s.fail(key, "= " + literalOf(s.at(key)) + " must not be negative");
        spec.numbers[key] = {v, s.line(key)};
        break;
      }
      case ObstacleParameter::Kind::Point:
        spec.vectors[key] = contactVector(s, key);
        break;
      case ObstacleParameter::Kind::Direction: {
        spec.directionLine = s.line(key);
        const toml::value& v = s.at(key);
        if (v.is_string()) {
          if (v.as_string().str != "normal")
            s.fail(key, "= " + literalOf(v) + " must be \"normal\" or a vector");
          if (!type->normalDirection)
            s.fail(key, "= \"normal\" is not available for obstacle = \"" + spec.obstacle +
                            "\" (only ball, disk and surface); give a vector");
          spec.normalDirection = true;
        } else {
          spec.vectors[key] = contactVector(s, key);
          const auto& d = spec.vectors[key].values;
          if (std::all_of(d.begin(), d.end(), [](double x) { return x == 0.0; }))
            s.fail(key, "= " + literalOf(v) + " must be a non-zero vector");
        }
        break;
      }
      case ObstacleParameter::Kind::Expression:
        spec.gap = s.expression(key);
        spec.gapLine = s.line(key);
        break;
      case ObstacleParameter::Kind::File: {
        const std::string file = s.string(key);
        if (file.empty()) s.fail(key, "must not be empty");
        fs::path path(file);
        if (path.is_relative()) path = scene.directory / path;
        path = path.lexically_normal();
        std::error_code ec;
        if (!fs::is_regular_file(path, ec))
          s.fail(key, "= \"" + file + "\": no such file (looked for " + path.string() + ")");
        spec.files[key] = {path, file, s.line(key)};
        break;
      }
      case ObstacleParameter::Kind::Boolean:
        spec.flags[key] = {s.boolean(key), s.line(key)};
        break;
    }
  }
  if (s.has("friction")) spec.friction = parseFriction(scene, s, "[contact]");
  return spec;
}

SolverSpec parseSolver(const Scene& scene, const toml::value& table, bool contact) {
  const TomlSection s(scene.fileName, "[solver]", table,
                      {"type", "tolerance", "max_iterations", "pre_smoothing", "post_smoothing", "smoother",
                       "krylov_steps", "linear_smoothing", "local_smoothing", "cycle"});
  SolverSpec spec;
  spec.line = s.line();
  if (s.has("type")) {
    spec.type = s.string("type");
    const bool contactType = spec.type == "tnnmg" || spec.type == "pdas" || spec.type == "pgs";
    const bool linearType = spec.type == "direct" || spec.type == "multigrid";
    if (!contactType && !linearType)
      s.fail("type", "= \"" + spec.type +
                         "\" is unknown (known solvers: tnnmg, pdas, pgs for scenes with [contact]; "
                         "direct, multigrid for scenes without)");
    if (contact && linearType)
      s.fail("type", "= \"" + spec.type +
                         "\" solves linear problems only; a scene with [contact] needs tnnmg, pdas "
                         "or pgs");
    if (!contact && contactType)
      s.fail("type", "= \"" + spec.type +
                         "\" is a contact solver and needs a [contact] section (without it: direct "
                         "or multigrid)");
  }
  const std::string type = spec.type.empty() ? (contact ? "tnnmg" : "direct") : spec.type;
  auto notFor = [&](const char* key, const std::string& why) {
    if (s.has(key)) s.fail(key, "does not apply to type = \"" + type + "\" (" + why + ")");
  };
  if (type == "direct") {
    notFor("tolerance", "a direct solve");
    notFor("max_iterations", "a direct solve");
  }
  if (type == "pdas")
    notFor("tolerance", "the active set method stops when the active set repeats");
  if (type != "tnnmg") {
    notFor("pre_smoothing", "only tnnmg has smoothing steps");
    notFor("post_smoothing", "only tnnmg has smoothing steps");
  }
  if (type != "tnnmg" && type != "multigrid") {
    notFor("smoother", "only tnnmg and multigrid have a linear multigrid smoother");
    notFor("krylov_steps", "only tnnmg and multigrid run V-cycles");
    notFor("linear_smoothing", "only tnnmg and multigrid run V-cycles");
    notFor("local_smoothing", "only tnnmg and multigrid run V-cycles");
    notFor("cycle", "only tnnmg and multigrid run multigrid cycles");
  }
  if (s.has("local_smoothing")) spec.localSmoothing = s.boolean("local_smoothing");
  if (s.has("cycle")) {
    const std::string c = s.string("cycle");
    if (c != "V" && c != "W") s.fail("cycle", "= \"" + c + "\" must be \"V\" or \"W\"");
    spec.cycleIndex = c == "V" ? 1 : 2;
  }
  if (s.has("linear_smoothing")) {
    const long long n = s.integer("linear_smoothing");
    if (n < 1 || n > 100)
      s.fail("linear_smoothing", "= " + literalOf(s.at("linear_smoothing")) + " must lie in [1, 100]");
    spec.linearSmoothing = static_cast<int>(n);
  }
  if (s.has("smoother")) {
    spec.smoother = s.string("smoother");
    if (spec.smoother != "gauss-seidel" && spec.smoother != "vertex-patch")
      s.fail("smoother", "= \"" + spec.smoother + "\" is unknown (known smoothers: gauss-seidel, vertex-patch)");
  }
  if (s.has("krylov_steps")) {
    const long long n = s.integer("krylov_steps");
    if (n < 0 || n > 100) s.fail("krylov_steps", "= " + literalOf(s.at("krylov_steps")) + " must lie in [0, 100]");
    spec.krylovSteps = static_cast<int>(n);
  }
  if (s.has("tolerance")) {
    const double t = s.number("tolerance");
    if (!(t > 0 && t < 1)) s.fail("tolerance", "= " + literalOf(s.at("tolerance")) + " must lie in (0, 1)");
    spec.tolerance = t;
  }
  if (s.has("max_iterations")) {
    const long long n = s.integer("max_iterations");
    if (n < 1 || n > 100'000'000)
      s.fail("max_iterations",
             "= " + literalOf(s.at("max_iterations")) + " must lie in [1, 100000000]");
    spec.maxIterations = static_cast<int>(n);
  }
  for (const char* key : {"pre_smoothing", "post_smoothing"}) {
    if (!s.has(key)) continue;
    const long long n = s.integer(key);
    if (n < 0 || n > 100) s.fail(key, "= " + literalOf(s.at(key)) + " must lie in [0, 100]");
    (std::string(key) == "pre_smoothing" ? spec.preSmoothing : spec.postSmoothing) = static_cast<int>(n);
  }
  if (spec.preSmoothing.value_or(3) + spec.postSmoothing.value_or(0) < 1)
    s.fail(s.has("pre_smoothing") ? "pre_smoothing" : "post_smoothing",
           "leaves no smoothing step: pre_smoothing + post_smoothing must be at least 1");
  return spec;
}

/// [output] checkpoint = { every = N, seconds = S } (Scene.hpp CheckpointSpec).
CheckpointSpec parseCheckpoint(const TomlSection& output) {
  const toml::value& v = output.at("checkpoint");
  if (!v.is_table())
    output.fail("checkpoint", "must be a table, e.g. { every = 100 } (steps) or { seconds = 3600 }, got " +
                                  typeNameOf(v));
  const TomlSection s(output.fileName(), "[output] checkpoint", v, {"every", "seconds"});
  CheckpointSpec spec;
  spec.line = output.line("checkpoint");
  if (s.has("every")) {
    const long long n = s.integer("every");
    if (n < 1 || n > 1000000000) s.fail("every", "= " + literalOf(s.at("every")) + " must be a number of steps >= 1");
    spec.every = static_cast<int>(n);
  }
  if (s.has("seconds")) {
    const double t = s.number("seconds");
    if (!(t > 0)) s.fail("seconds", "= " + literalOf(s.at("seconds")) + " must be positive");
    spec.seconds = t;
  }
  if (!spec.every && !spec.seconds)
    output.fail("checkpoint", "needs every = N (steps) and/or seconds = S (wall time)");
  return spec;
}

OutputSpec parseOutput(const Scene& scene, const toml::value* table) {
  OutputSpec out;
  out.directory = fs::path("out") / scene.name;
  if (!table) return out;
  const TomlSection s(scene.fileName, "[output]", *table, {"directory", "vtk", "csv", "plots", "checkpoint"});
  if (s.has("checkpoint")) out.checkpoint = parseCheckpoint(s);
  if (s.has("directory")) {
    const std::string d = s.string("directory");
    if (d.empty()) s.fail("directory", "must not be empty");
    out.directory = d;
  }
  if (s.has("vtk")) out.vtk = s.boolean("vtk");
  if (s.has("plots")) out.plots = s.boolean("plots");
  if (s.has("csv")) {
    const std::string c = s.string("csv");
    if (c.empty() || c.back() == '/') s.fail("csv", "must name a file, e.g. \"results.csv\"");
    out.csv = c;
  }
  return out;
}

/// Checks of a scene (or a body of a multi-body scene) with [adaptivity]: the estimators use the
/// standard stress, and an adaptive run is static (`dynamics`: the scene's [dynamics] table, if any).
void checkAdaptiveScene(const Scene& scene, const toml::value* dynamics) {
  if (scene.material.formulation != VolumetricFormulation::Standard)
    throw Error(scene.where(scene.formulationLine) +
                "[material] formulation = \"bbar\" is not supported by the estimators of [adaptivity] yet "
                "(their residuals use the standard stress); use it in static or dynamic runs");
  if (dynamics)
    throw Error(scene.where(scene.adaptivity->line) +
                "[adaptivity] and [dynamics] cannot be combined (adaptive runs are static; remove one of them)");
}

}  // namespace

/// The sections that describe one body (top level of a one-body scene, or one [[body]] entry):
/// mesh, material, dirichlet, neumann, body_force. `prefix` is "" or "body." for messages.
void parseBodySections(Scene& scene, const toml::table& t, const std::string& prefix, int line) {
  auto find = [&](const char* key) -> const toml::value* {
    const auto it = t.find(key);
    return it == t.end() ? nullptr : &it->second;
  };
  for (const char* required : {"mesh", "material"})
    if (!find(required))
      throw Error(scene.where(line) + "[" + prefix + std::string(required) + "] section is missing" +
                  (prefix.empty() ? "" : " in [[body]] '" + scene.name + "'"));
  scene.mesh = parseMesh(scene, *find("mesh"));
  parseMaterial(scene, *find("material"));
  if (const toml::value* d = find("dirichlet"))
    for (const toml::value& e : entries(scene, *d, prefix + "dirichlet"))
      scene.dirichlet.push_back(parseDirichlet(scene, e));
  if (const toml::value* n = find("neumann"))
    for (const toml::value& e : entries(scene, *n, prefix + "neumann"))
      scene.neumann.push_back(parseNeumann(scene, e));
  if (const toml::value* b = find("body_force")) {
    const TomlSection s(scene.fileName, "[" + prefix + "body_force]", *b, {"value"});
    scene.bodyForce = s.vector("value");
  }
}

/// [[body]] entries and the [[contact]] pairs of a multi-body scene.
void parseMultiBody(Scene& scene, const toml::value& bodies, const toml::value* contact) {
  if (!bodies.is_array() || bodies.as_array().empty() || !bodies.as_array().front().is_table())
    throw Error(whereOf(scene.fileName, bodies) + "[[body]] must be an array of tables: write [[body]] (double "
                "brackets) before each body");
  for (const toml::value& b : bodies.as_array()) {
    const TomlSection s(scene.fileName, "[[body]]", b,
                        {"name", "mesh", "material", "dirichlet", "neumann", "body_force", "initial_velocity",
                         "initial_displacement"});
    Scene body;
    body.fileName = scene.fileName;
    body.directory = scene.directory;
    body.name = s.string("name");
    body.bodyLine = s.line();
    if (body.name.empty() || body.name.find_first_of(" /\\:") != std::string::npos)
      s.fail("name", "= \"" + body.name + "\" must be a non-empty name without spaces, slashes or colons");
    for (const Scene& other : scene.bodies)
      if (other.name == body.name)
        s.fail("name", "= \"" + body.name + "\" is used by the body of line " + std::to_string(other.bodyLine));
    parseBodySections(body, b.as_table(), "body.", s.line());
    if (s.has("initial_velocity")) {
      body.bodyInitialVelocity = s.vector("initial_velocity").entries;
      body.bodyInitialVelocityLine = s.line("initial_velocity");
    }
    if (s.has("initial_displacement")) {
      body.bodyInitialDisplacement = s.vector("initial_displacement").entries;
      body.bodyInitialDisplacementLine = s.line("initial_displacement");
    }
    scene.bodies.push_back(std::move(body));
  }
  if (scene.bodies.size() < 2)
    throw Error(scene.where(scene.bodies.front().bodyLine) +
                "[[body]] a multi-body scene needs at least two bodies (a single body is described by the "
                "top-level [mesh] and [material] sections)");
  if (!contact)
    throw Error(scene.fileName + ": a multi-body scene needs [[contact]] pairs (slave and master boundaries)");
  if (!contact->is_array())
    throw Error(whereOf(scene.fileName, *contact) +
                "[contact] in a multi-body scene must be [[contact]] entries (double brackets) with slave and master");
  auto bodyIndex = [&](const TomlSection& side, const std::string& name) {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)
      if (scene.bodies[i].name == name) return static_cast<int>(i);
    std::string known;
    for (const Scene& b : scene.bodies) known += (known.empty() ? "" : ", ") + b.name;
    side.fail("body", "= \"" + name + "\" is not a body of this scene (bodies: " + known + ")");
  };
  for (const toml::value& c : contact->as_array()) {
    if (c.is_table() && c.as_table().count("body")) {
      // a rigid obstacle for one body: the keys of [contact] plus body = "name"
      const toml::value& b = c.as_table().at("body");
      if (!b.is_string())
        throw Error(whereOf(scene.fileName, b) + "[[contact]] body must be a string (a body name), got " + typeNameOf(b));
      int index = -1;
      for (std::size_t i = 0; i < scene.bodies.size(); ++i)
        if (scene.bodies[i].name == b.as_string()) index = static_cast<int>(i);
      if (index < 0)
        throw Error(whereOf(scene.fileName, b) + "[[contact]] body = \"" + std::string(b.as_string()) +
                    "\" is not a body of this scene");
      Scene& body = scene.bodies[index];
      if (body.contact)
        throw Error(whereOf(scene.fileName, c) + "[[contact]] body '" + body.name +
                    "' already has a rigid obstacle (line " + std::to_string(body.contact->line) + "); one per body");
      toml::value rest = c;
      rest.as_table().erase("body");
      body.contact = parseContact(body, rest);
      continue;
    }
    const TomlSection s(scene.fileName, "[[contact]]", c, {"slave", "master", "min_coverage", "search_distance", "type", "friction"});
    MortarPairSpec pair;
    pair.line = s.line();
    if (s.has("type") && s.string("type") != "mortar")
      s.fail("type", "= \"" + s.string("type") + "\" is unknown (two-body contact: \"mortar\")");
    for (const char* side : {"slave", "master"}) {
      const toml::value& v = s.at(side);
      if (!v.is_table())
        s.fail(side, "must be a table { body = \"name\", boundary = \"name\" or id }");
      const TomlSection t(scene.fileName, "[[contact]] " + std::string(side), v, {"body", "boundary"});
      const std::string name = t.string("body");
      const int index = bodyIndex(t, name);
      (std::string(side) == "slave" ? pair.slaveBody : pair.masterBody) = name;
      (std::string(side) == "slave" ? pair.slaveIndex : pair.masterIndex) = index;
      (std::string(side) == "slave" ? pair.slave : pair.master) = t.boundary("boundary");
    }
    if (pair.slaveIndex == pair.masterIndex)
      s.fail("master", "is on the slave's body '" + pair.slaveBody +
                           "' (self-contact is not supported: slave and master must belong to different bodies)");
    if (s.has("min_coverage")) {
      pair.minCoverage = s.number("min_coverage");
      if (!(pair.minCoverage > 0 && pair.minCoverage <= 1))
        s.fail("min_coverage", "= " + literalOf(s.at("min_coverage")) + " must lie in (0, 1]");
    }
    if (s.has("search_distance")) {
      pair.searchDistance = s.number("search_distance");
      if (!(pair.searchDistance > 0))
        s.fail("search_distance", "= " + literalOf(s.at("search_distance")) + " must be positive");
    }
    if (s.has("friction")) pair.friction = parseFriction(scene, s, "[[contact]]");
    scene.pairs.push_back(std::move(pair));
  }
}

/// [loading] steps = N (1 <= N <= 10000), for static contact scenes only.
void parseLoading(Scene& scene, const toml::value* table) {
  if (!table) return;
  const TomlSection s(scene.fileName, "[loading]", *table, {"steps"});
  LoadingSpec spec;
  spec.line = s.line();
  const long long n = s.integer("steps");
  if (n < 1 || n > 10000) s.fail("steps", "= " + std::to_string(n) + " must lie in [1, 10000]");
  spec.steps = static_cast<int>(n);
  if (scene.dynamics || scene.adaptivity)
    throw Error(scene.where(spec.line) + "[loading] applies to static runs only (not with " +
                (scene.dynamics ? "[dynamics]" : "[adaptivity]") + ")");
  if (!scene.hasContact())
    throw Error(scene.where(spec.line) + "[loading] needs contact ([contact] or [[contact]]): a linear problem "
                "does not depend on the loading path");
  scene.loading = spec;
}

Scene parseSceneString(const std::string& text, const std::string& fileName,
                       const std::filesystem::path& directory,
                       const std::vector<std::string>& overrides) {
  toml::value root;
  checkTomlNesting(text, fileName);
  try {
    std::istringstream is(text);
    root = toml::parse(is, fileName);
  } catch (const toml::syntax_error& e) {
    throw Error(condense(e, fileName));
  } catch (const toml::exception& e) {
    throw Error(fileName + ":" + std::to_string(e.location().line()) + ": " + e.what());
  } catch (const std::exception& e) {
    throw Error(fileName + ": " + e.what());
  }

  {  // --set overrides may address every section of kSections
    std::vector<std::string> sections;
    std::istringstream names(kSections);
    for (std::string n; std::getline(names >> std::ws, n, ',');) sections.push_back(n);
    applyOverrides(root, overrides, fileName, sections);
  }

  Scene scene;
  scene.fileName = fileName;
  scene.directory = directory;
  scene.name = fs::path(fileName).stem().string();
  scene.text = text;
  scene.overrides = overrides;

  // Unknown top-level entries, first in file order.
  const toml::value* unknown = nullptr;
  std::string unknownKey;
  for (const auto& [key, value] : root.as_table()) {
    const bool known = key == "mesh" || key == "material" || key == "dirichlet" ||
                       key == "neumann" || key == "body_force" || key == "contact" ||
                       key == "solver" || key == "output" || key == "adaptivity" ||
                       key == "dynamics" || key == "loading" || key == "body";
    if (!known && (!unknown || value.location().line() < unknown->location().line())) {
      unknown = &value;
      unknownKey = key;
    }
  }
  if (unknown) {
    if (unknown->is_table() || unknown->is_array())
      throw Error(whereOf(fileName, *unknown) + "unknown section [" + unknownKey +
                  "] (allowed sections: " + kSections + ")");
    throw Error(whereOf(fileName, *unknown) + "unknown key '" + unknownKey +
                "' outside any section (allowed sections: " + kSections + ")");
  }

  const auto& t = root.as_table();
  auto find = [&](const char* key) -> const toml::value* {
    const auto it = t.find(key);
    return it == t.end() ? nullptr : &it->second;
  };
  if (const toml::value* bodies = find("body")) {
    for (const char* key : {"mesh", "material", "dirichlet", "neumann", "body_force"})
      if (const toml::value* v = find(key))
        throw Error(whereOf(fileName, *v) + "[" + std::string(key) +
                    "] at the top level cannot be combined with [[body]] entries (put it inside the body: [body." +
                    key + "])");
    parseMultiBody(scene, *bodies, find("contact"));
    if (const toml::value* sv = find("solver")) scene.solver = parseSolver(scene, *sv, true);
    scene.output = parseOutput(scene, find("output"));
    if (const toml::value* a = find("adaptivity")) {
      scene.adaptivity = parseAdaptivity(scene, *a, true);
      checkAdaptiveScene(scene, find("dynamics"));
      if (!scene.adaptivity->reference.empty())
        throw Error(scene.where(scene.adaptivity->referenceLine) + "[adaptivity] reference = \"" +
                    scene.adaptivity->reference +
                    "\" is a one-body solution (a body against a rigid obstacle); a multi-body scene has none");
      for (const Scene& b : scene.bodies) checkAdaptiveScene(b, nullptr);
    }
    if (const toml::value* dy = find("dynamics")) {
      scene.dynamics = parseDynamics(scene, *dy);
      checkDynamicScene(scene);
      for (Scene& b : scene.bodies) b.dynamics = scene.dynamics;  // bodies are dynamic (e.g. may move freely)
    } else {
      for (const Scene& b : scene.bodies)
        if (b.bodyInitialVelocityLine || b.bodyInitialDisplacementLine)
          throw Error(scene.where(b.bodyInitialVelocityLine ? b.bodyInitialVelocityLine : b.bodyInitialDisplacementLine) +
                      "[[body]] '" + b.name + "': initial_velocity / initial_displacement need a [dynamics] section");
    }
    if (scene.output.checkpoint && !scene.dynamics && !scene.adaptivity)
      throw Error(scene.where(scene.output.checkpoint->line) +
                  "[output] checkpoint applies to [dynamics] and [adaptivity] scenes only (static runs write none)");
    parseLoading(scene, find("loading"));
    return scene;
  }
  parseBodySections(scene, t, "", 0);
  if (const toml::value* c = find("contact")) scene.contact = parseContact(scene, *c);
  if (const toml::value* sv = find("solver"))
    scene.solver = parseSolver(scene, *sv, scene.contact.has_value());
  scene.output = parseOutput(scene, find("output"));
  if (const toml::value* a = find("adaptivity")) {
    scene.adaptivity = parseAdaptivity(scene, *a, scene.contact.has_value());
    checkAdaptiveScene(scene, find("dynamics"));
  }
  if (const toml::value* dy = find("dynamics")) {
    scene.dynamics = parseDynamics(scene, *dy);
    checkDynamicScene(scene);
  }
  if (scene.output.checkpoint && !scene.dynamics && !scene.adaptivity)
    throw Error(scene.where(scene.output.checkpoint->line) +
                "[output] checkpoint applies to [dynamics] and [adaptivity] scenes only (static runs write none)");
  parseLoading(scene, find("loading"));
  return scene;
}

Scene parseScene(const std::filesystem::path& file, const std::vector<std::string>& overrides) {
  const std::string name = file.string();
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw Error(name + ": is a directory, not a scene file");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(name + ": cannot open the scene file");
  std::ostringstream text;
  text << in.rdbuf();
  fs::path dir = file.parent_path();
  if (dir.empty()) dir = ".";
  return parseSceneString(text.str(), name, dir, overrides);
}

}  // namespace obs::drivers
