#include "DynamicsParser.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Newmark.hpp"

namespace obs::drivers {

namespace {

/// An array of `count` finite numbers (count 0: 2 or 3).
std::vector<double> numberArray(const TomlSection& s, const toml::value& v, const std::string& label,
                                int count) {
  if (!v.is_array()) s.failAt(v, label, "must be an array of numbers, got " + typeNameOf(v));
  const auto& a = v.as_array();
  const bool ok = count > 0 ? static_cast<int>(a.size()) == count : (a.size() == 2 || a.size() == 3);
  if (!ok)
    s.failAt(v, label,
             "= " + literalOf(v) + " must have " +
                 (count > 0 ? std::to_string(count) : std::string("2 or 3")) +
                 " entries (one per coordinate), got " + std::to_string(a.size()));
  return finiteNumberEntries(s, v, label);
}

double positive(const TomlSection& s, const std::string& key) {
  const double x = s.number(key);
  if (!(x > 0)) s.fail(key, "= " + literalOf(s.at(key)) + " must be positive");
  return x;
}

std::string schemeNames() {
  std::string names;
  for (NewmarkScheme k : allNewmarkSchemes()) names += (names.empty() ? "" : ", ") + std::string(name(k));
  return names;
}

/// Checks a scheme name; `v` is the TOML value for the message.
std::string schemeName(const TomlSection& s, const toml::value& v, const std::string& label) {
  if (!v.is_string()) s.failAt(v, label, "must be a scheme name (string), got " + typeNameOf(v));
  checkOneLine(s, v, label);
  const std::string n = v.as_string().str;
  for (NewmarkScheme k : allNewmarkSchemes())
    if (name(k) == n) return n;
  s.failAt(v, label, "= \"" + n + "\" is unknown (known schemes: " + schemeNames() + ")");
}

}  // namespace

const std::vector<std::string>& curvedMeshKeys() {
  static const std::vector<std::string> keys = {"centre", "radius", "width", "height", "depth",
                                                "arc_radius"};
  return keys;
}

bool isCurvedGenerator(const std::string& generator) {
  return generator == "ball" || generator == "rounded_block" || generator == "disk" || generator == "half_disk" ||
         generator == "half_ball";
}

void parseCurvedMesh(const TomlSection& s, MeshSpec& spec) {
  const std::string generator = s.string("generator");
  // ball-like generators: centre, radius and one cell count (ball 3D; disk, half disk 2D)
  const bool ball = generator == "ball" || generator == "disk" || generator == "half_disk" || generator == "half_ball";
  spec.source = generator == "ball"      ? MeshSpec::Source::Ball
                : generator == "half_ball" ? MeshSpec::Source::HalfBall
                : generator == "disk"    ? MeshSpec::Source::Disk
                : generator == "half_disk" ? MeshSpec::Source::HalfDisk
                                         : MeshSpec::Source::RoundedBlock;
  const std::vector<std::string> own =
      ball ? std::vector<std::string>{"centre", "radius"}
           : std::vector<std::string>{"width", "height", "depth", "arc_radius"};
  for (const std::string& key : {std::string("lower"), std::string("upper")})
    if (s.has(key)) s.fail(key, "only applies to generator = \"box\", not to \"" + generator + "\"");
  for (const std::string& key : curvedMeshKeys())
    if (s.has(key) && std::find(own.begin(), own.end(), key) == own.end())
      s.fail(key, "does not apply to generator = \"" + generator + "\" (its keys: type, cells, " +
                      (ball ? std::string("centre, radius") : std::string("width, height, depth, arc_radius")) +
                      ")");

  const std::string type = s.string("type");
  std::optional<mesh::CellType> cellType;
  for (mesh::CellType t : mesh::kVolumeCellTypes)
    if (mesh::name(t) == type) cellType = t;
  if (!cellType)
    s.fail("type", "= \"" + type +
                       "\" is not a cell type (known: triangle, quadrilateral, tetrahedron, "
                       "hexahedron, prism, pyramid)");
  spec.cellType = *cellType;
  const int dim = mesh::dimension(*cellType);
  const bool ball3D = generator == "ball" || generator == "half_ball";
  if (ball3D && dim != 3)
    s.fail("type", "= \"" + type + "\": generator = \"" + generator + "\" needs a 3D cell type (tetrahedron, "
                                   "hexahedron, prism, pyramid)");
  if (ball && !ball3D && dim != 2)
    s.fail("type", "= \"" + type + "\": generator = \"" + generator + "\" needs a 2D cell type (triangle, quadrilateral)");

  // cells
  const toml::value& cells = s.at("cells");
  std::vector<long long> n;
  if (cells.is_integer()) {
    n.push_back(cells.as_integer());
  } else if (cells.is_array()) {
    for (const toml::value& c : cells.as_array()) {
      if (!c.is_integer()) s.failAt(c, "cells", "entries must be integers, got " + typeNameOf(c));
      n.push_back(c.as_integer());
    }
  } else {
    s.fail("cells", "must be an integer or an array of integers, got " + typeNameOf(cells));
  }
  const std::size_t expected = ball ? 1 : static_cast<std::size_t>(dim);
  if (n.size() != expected)
    s.fail("cells", "= " + literalOf(cells) + " must have " + std::to_string(expected) +
                        (ball ? " entry (cells per direction of the inner cube)"
                              : " entries for " + type + " cells") +
                        ", got " + std::to_string(n.size()));
  spec.cells = {1, 1, 1};
  long long total = 1;
  for (std::size_t i = 0; i < n.size(); ++i) {
    if (n[i] < 1 || n[i] > 1000)
      s.fail("cells", "= " + literalOf(cells) + ": every entry must lie in [1, 1000]");
    spec.cells[i] = static_cast<int>(n[i]);
    total *= n[i];
  }
  if (total > 10'000'000) s.fail("cells", "= " + literalOf(cells) + " asks for too many cells");

  if (ball) {
    spec.centre = mesh::Point::Zero();
    if (s.has("centre")) {
      const auto c = numberArray(s, s.at("centre"), "centre", dim);
      spec.centre = mesh::Point(c[0], c[1], dim == 3 ? c[2] : 0.0);
    }
    spec.radius = s.has("radius") ? positive(s, "radius") : 1.0;
  } else {
    spec.width = positive(s, "width");
    spec.height = positive(s, "height");
    if (dim == 3)
      spec.depth = positive(s, "depth");
    else if (s.has("depth"))
      s.fail("depth", "does not apply to a 2D rounded block (" + type + " cells)");
    spec.arcRadius = positive(s, "arc_radius");
    if (spec.arcRadius < spec.width / 2)
      s.fail("arc_radius", "= " + literalOf(s.at("arc_radius")) +
                               " must be at least width / 2 (the arc spans the width)");
  }
}

DynamicsSpec parseDynamics(const Scene& scene, const toml::value& table) {
  const TomlSection s(scene.fileName, "[dynamics]", table,
                      {"scheme", "tau", "end_time", "steps", "initial_velocity",
                       "initial_displacement", "mass", "tracked", "output_stride", "compare", "inexact",
                       "warm_start", "redistribution_moments"});
  DynamicsSpec spec;
  spec.line = s.line();
  if (s.has("scheme")) {
    spec.scheme = schemeName(s, s.at("scheme"), "scheme");
    spec.schemeLine = s.line("scheme");
  }
  spec.timeStep = s.number("tau");
  spec.timeStepLine = s.line("tau");
  if (!(spec.timeStep > 0)) s.fail("tau", "= " + literalOf(s.at("tau")) + " must be positive");

  if (s.has("end_time") && s.has("steps"))
    s.fail(s.line("end_time") > s.line("steps") ? "end_time" : "steps",
           "cannot be combined with " +
               std::string(s.line("end_time") > s.line("steps") ? "steps" : "end_time") +
               " (give one of them)");
  if (s.has("end_time")) {
    const double T = s.number("end_time");
    if (!(T > 0)) s.fail("end_time", "= " + literalOf(s.at("end_time")) + " must be positive");
    if (T / spec.timeStep > 1e8)
      s.fail("end_time", "= " + literalOf(s.at("end_time")) + " would need more than 1e8 steps of tau");
    spec.endTime = T;
    spec.lengthLine = s.line("end_time");
  } else if (s.has("steps")) {
    const long long n = s.integer("steps");
    if (n < 1 || n > 100'000'000)
      s.fail("steps", "= " + literalOf(s.at("steps")) + " must lie in [1, 100000000]");
    spec.steps = static_cast<int>(n);
    spec.lengthLine = s.line("steps");
  } else {
    throw Error(scene.where(spec.line) + "[dynamics] needs end_time = T or steps = N");
  }

  if (s.has("initial_velocity")) {
    spec.initialVelocity = s.vector("initial_velocity").entries;
    spec.initialVelocityLine = s.line("initial_velocity");
  }
  if (s.has("initial_displacement")) {
    spec.initialDisplacement = s.vector("initial_displacement").entries;
    spec.initialDisplacementLine = s.line("initial_displacement");
  }
  if (s.has("mass")) {
    const std::string m = s.string("mass");
    if (m != "lumped" && m != "consistent")
      s.fail("mass", "= \"" + m + "\" must be \"lumped\" or \"consistent\"");
    spec.consistentMass = m == "consistent";
    spec.massLine = s.line("mass");
    if (spec.consistentMass) {
      const NewmarkScheme k = newmarkSchemeFromName(spec.scheme);
      if (k == NewmarkScheme::ContactStabilized || k == NewmarkScheme::ImprovedContactStabilized ||
          k == NewmarkScheme::AlphaHalf || k == NewmarkScheme::AlphaOneZero)
        s.fail("mass", "= \"consistent\" is not available for scheme = \"" + spec.scheme +
                           "\" (its predictor is a node-wise projection with the lumped mass; "
                           "consistent mass: classical, contact-implicit, laursen-chawla and the "
                           "redistributed schemes)");
    }
  }
  if (s.has("tracked")) {
    const toml::value& v = s.at("tracked");
    if (!v.is_array())
      s.fail("tracked", "must be an array of points, e.g. [[0, 0, -1]], got " + typeNameOf(v));
    const auto& a = v.as_array();
    for (std::size_t i = 0; i < a.size(); ++i) {
      const auto p = numberArray(s, a[i], "tracked[" + std::to_string(i) + "]", 0);
      spec.tracked.emplace_back(p[0], p[1], p.size() > 2 ? p[2] : 0.0);
      spec.trackedDimensions.push_back(static_cast<int>(p.size()));
    }
    spec.trackedLine = s.line("tracked");
  }
  if (s.has("output_stride")) {
    const long long k = s.integer("output_stride");
    if (k < 1 || k > 1'000'000'000)
      s.fail("output_stride", "= " + literalOf(s.at("output_stride")) + " must be at least 1");
    spec.outputStride = static_cast<int>(k);
    spec.outputStrideLine = s.line("output_stride");
  }
  if (s.has("compare")) {
    const toml::value& v = s.at("compare");
    spec.compareLine = s.line("compare");
    if (v.is_string()) {
      if (v.as_string().str != "all")
        s.fail("compare", "= " + literalOf(v) + " must be \"all\" or an array of scheme names");
      for (NewmarkScheme k : allNewmarkSchemes()) spec.compare.emplace_back(name(k));
    } else if (v.is_array()) {
      for (std::size_t i = 0; i < v.as_array().size(); ++i) {
        const std::string n = schemeName(s, v.as_array()[i], "compare[" + std::to_string(i) + "]");
        if (std::find(spec.compare.begin(), spec.compare.end(), n) != spec.compare.end())
          s.failAt(v.as_array()[i], "compare", "lists \"" + n + "\" twice");
        spec.compare.push_back(n);
      }
    } else {
      s.fail("compare", "must be \"all\" or an array of scheme names, got " + typeNameOf(v));
    }
  }
  if (s.has("inexact")) {
    const double f = s.number("inexact");
    if (!(f >= 0 && f < 1))
      s.fail("inexact", "= " + literalOf(s.at("inexact")) +
                            " must lie in [0, 1) (the fraction of the time-error estimate; 0: off)");
    spec.inexact = f;
    spec.inexactLine = s.line("inexact");
  }
  if (s.has("warm_start")) {
    const std::string w = s.string("warm_start");
    if (w != "predictor" && w != "previous-increment")
      s.fail("warm_start", "= \"" + w + "\" must be \"predictor\" or \"previous-increment\"");
    spec.warmStart = w;
  }
  if (s.has("redistribution_moments")) {
    const long long k = s.integer("redistribution_moments");
    if (k < 0 || k > 2)
      s.fail("redistribution_moments", "= " + literalOf(s.at("redistribution_moments")) +
                                           " must be 0 (none: the contact rows zeroed, nothing moved), 1 (mass and "
                                           "centre of gravity) or 2 (also the second moments)");
    spec.redistributionMoments = static_cast<int>(k);
  }
  return spec;
}

void checkDynamicScene(const Scene& scene) {
  const DynamicsSpec& d = *scene.dynamics;
  if (scene.multiBody()) {
    // every body needs its density; the contact is the [[contact]] pairs (and obstacles of bodies)
    for (const Scene& b : scene.bodies)
      if (b.densityLine == 0)
        throw Error(scene.where(b.materialLine ? b.materialLine : b.bodyLine) + "[[body]] '" + b.name +
                    "': [material] density is missing: a scene with [dynamics] (line " + std::to_string(d.line) +
                    ") needs the mass density rho > 0 of every body");
    if (!scene.solver.type.empty() && scene.solver.type != "tnnmg")
      throw Error(scene.where(scene.solver.line) + "[solver] type = \"" + scene.solver.type +
                  "\" is not available with [dynamics] (the time steppers solve every step with tnnmg)");
    return;
  }
  if (scene.densityLine == 0)
    throw Error(scene.where(scene.materialLine) +
                "[material] density is missing: a scene with [dynamics] (line " +
                std::to_string(d.line) + ") needs the mass density rho > 0");
  if (!scene.contact)
    throw Error(scene.where(d.line) +
                "[dynamics] needs a [contact] section (the time steppers integrate contact with a "
                "rigid obstacle)");
  if (!scene.solver.type.empty() && scene.solver.type != "tnnmg")
    throw Error(scene.where(scene.solver.line) + "[solver] type = \"" + scene.solver.type +
                "\" is not available with [dynamics] (the time steppers solve every step with tnnmg)");
}

}  // namespace obs::drivers
