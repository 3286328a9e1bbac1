#include "SceneExtensions.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "TomlSection.hpp"
#include "obs/estimators/EstimatorRegistry.hpp"
#include "obs/estimators/Marking.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::drivers {

namespace {

std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

}  // namespace

void applyOverrides(toml::value& root, const std::vector<std::string>& overrides,
                    const std::string& fileName, const std::vector<std::string>& sections) {
  for (const std::string& text : overrides) {
    const std::string where = fileName + ": --set '" + text + "': ";
    const auto eq = text.find('=');
    if (eq == std::string::npos)
      throw Error(where + "expected section.key=value, e.g. --set adaptivity.steps=3");
    const std::string path = trimmed(text.substr(0, eq));
    const std::string valueText = trimmed(text.substr(eq + 1));
    const auto dot = path.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == path.size() ||
        path.find('.', dot + 1) != std::string::npos)
      throw Error(where + "expected section.key=value, e.g. --set adaptivity.steps=3");
    const std::string section = path.substr(0, dot), key = path.substr(dot + 1);
    if (std::find(sections.begin(), sections.end(), section) == sections.end())
      throw Error(where + "unknown section [" + section + "] (allowed sections: " + joined(sections) + ")");
    if (valueText.empty()) throw Error(where + "the value is missing (TOML syntax, e.g. 3, \"uniform\", [0, 1])");
    toml::value parsed;
    checkTomlNesting(valueText, fileName + " (from --set)");
    try {
      std::istringstream is("value = " + valueText + "\n");
      parsed = toml::parse(is, kOverrideSource);
    } catch (const std::exception&) {
      throw Error(where + "the value " + valueText +
                  " is not a TOML value (strings need quotes: --set adaptivity.estimator='\"residual\"')");
    }
    auto& table = root.as_table();
    auto it = table.find(section);
    if (it == table.end()) it = table.emplace(section, toml::table{}).first;
    if (it->second.is_array())
      throw Error(where + "[[" + section + "]] is an array of tables; --set changes single sections only");
    if (!it->second.is_table())
      throw Error(where + "[" + section + "] is not a table in the scene file");
    it->second.as_table()[key] = parsed.as_table().at("value");
  }
}

AdaptivitySpec parseAdaptivity(const Scene& scene, const toml::value& table, bool contact) {
  const TomlSection s(scene.fileName, "[adaptivity]", table,
                      {"refinement", "estimator", "marking", "theta", "steps", "max_vertices",
                       "eta_tolerance", "reference", "reference_load", "pressure", "vtk", "warm_start", "inexact",
                       "closure"});
  AdaptivitySpec spec;
  spec.line = s.line();
  if (s.has("refinement")) {
    const std::string r = s.string("refinement");
    if (r != "adaptive" && r != "uniform")
      s.fail("refinement", "= \"" + r + "\" is unknown (known: adaptive, uniform)");
    spec.uniform = r == "uniform";
  }
  spec.estimator = contact ? "contact-residual" : "residual";
  if (s.has("estimator")) {
    spec.estimator = s.string("estimator");
    const auto names = estimators::EstimatorRegistry::global().names();
    if (std::find(names.begin(), names.end(), spec.estimator) == names.end())
      s.fail("estimator", "= \"" + spec.estimator + "\" is unknown (known estimators: " + joined(names) +
                              "; more with obs run --plugin lib.so)");
  }
  if (s.has("marking")) {
    spec.marking = s.string("marking");
    std::vector<std::string> names;
    for (const auto& info : estimators::MarkingStrategy::available()) names.push_back(info.name);
    if (std::find(names.begin(), names.end(), spec.marking) == names.end())
      s.fail("marking", "= \"" + spec.marking + "\" is unknown (known strategies: " + joined(names) + ")");
  }
  if (s.has("theta")) {
    spec.theta = s.number("theta");
    try {
      estimators::MarkingStrategy(spec.marking, spec.theta);
    } catch (const Error& e) {
      s.fail("theta", "= " + literalOf(s.at("theta")) + " is not valid for marking = \"" + spec.marking +
                          "\" (" + e.what() + ")");
    }
  }
  if (s.has("steps")) {
    const long long n = s.integer("steps");
    if (n < 1 || n > 100) s.fail("steps", "= " + literalOf(s.at("steps")) + " must lie in [1, 100]");
    spec.steps = static_cast<int>(n);
  }
  if (s.has("max_vertices")) {
    const long long n = s.integer("max_vertices");
    if (n < 0) s.fail("max_vertices", "= " + literalOf(s.at("max_vertices")) + " must not be negative (0: off)");
    spec.maxVertices = n;
  }
  if (s.has("eta_tolerance")) {
    const double t = s.number("eta_tolerance");
    if (t < 0) s.fail("eta_tolerance", "= " + literalOf(s.at("eta_tolerance")) + " must not be negative (0: off)");
    spec.etaTolerance = t;
  }
  if (s.has("reference")) {
    spec.reference = s.string("reference");
    if (spec.reference != "punch" && spec.reference != "wedge" && spec.reference != "hertz")
      s.fail("reference", "= \"" + spec.reference + "\" is unknown (known references: " +
                              kAdaptivityReferences + ")");
    if (!contact) s.fail("reference", "needs a [contact] section (the references are contact pressures)");
    spec.referenceLine = s.line("reference");
  }
  if (s.has("reference_load")) {
    const double P = s.number("reference_load");
    if (!(P > 0) || !std::isfinite(P))
      s.fail("reference_load", "= " + literalOf(s.at("reference_load")) + " must be positive and finite");
    if (spec.reference.empty())
      s.fail("reference_load", "needs reference = \"punch\", \"wedge\" or \"hertz\" (it is the load of the reference)");
    spec.referenceLoad = P;
  }
  if (s.has("pressure")) {
    const std::string v = s.string("pressure");
    if (v != "every" && v != "last") s.fail("pressure", "= \"" + v + "\" is unknown (known: every, last)");
    spec.pressureEvery = v == "every";
  }
  if (s.has("vtk")) {
    const std::string v = s.string("vtk");
    if (v == "every")
      spec.vtk = AdaptivitySpec::Vtk::Every;
    else if (v == "last")
      spec.vtk = AdaptivitySpec::Vtk::Last;
    else if (v == "none")
      spec.vtk = AdaptivitySpec::Vtk::None;
    else
      s.fail("vtk", "= \"" + v + "\" is unknown (known: every, last, none)");
  }
  if (s.has("warm_start")) spec.warmStart = s.boolean("warm_start");
  if (s.has("inexact")) {
    const double f = s.number("inexact");
    if (!(f >= 0 && f < 1))
      s.fail("inexact", "= " + literalOf(s.at("inexact")) + " must lie in [0, 1) (the fraction of the estimator; 0: off)");
    if (f > 0 && !contact) s.fail("inexact", "needs a [contact] section (it sets the tolerance of the contact solver)");
    spec.inexact = f;
  }
  if (s.has("closure")) {
    const std::string c = s.string("closure");
    if (c != "half-edges" && c != "all-edges")
      s.fail("closure", "= \"" + c + "\" is unknown (known: half-edges, all-edges)");
    spec.closureAllEdges = c == "all-edges";
  }
  return spec;
}

}  // namespace obs::drivers
