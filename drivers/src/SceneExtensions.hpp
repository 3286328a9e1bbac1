#pragma once
/// \file SceneExtensions.hpp
/// Internal to the scene parser: the [adaptivity] section (AdaptivitySpec.hpp) and the
/// `obs run --set section.key=value` overrides applied to the parsed TOML before validation.
#include <toml.hpp>

#include <string>
#include <vector>

#include "obs/drivers/Scene.hpp"

namespace obs::drivers {


/// Applies each override "section.key=value" (value in TOML syntax, e.g. 3, "uniform", [0, -1],
/// true) to the root table of a scene: sets `key` in table `section` (created if absent). Throws
/// obs::Error "<scene>: --set '<text>': ..." for a malformed override, an unknown section, a
/// section that is an array of tables ([[dirichlet]], [[neumann]]) or a value that is not TOML.
void applyOverrides(toml::value& root, const std::vector<std::string>& overrides,
                    const std::string& fileName, const std::vector<std::string>& sections);

/// [adaptivity]: checks keys, types, ranges, the estimator name against the global estimator
/// registry (plugins loaded before parsing count) and the marking name and theta against
/// MarkingStrategy. `contact`: the scene has [contact] (default estimator contact-residual).
AdaptivitySpec parseAdaptivity(const Scene& scene, const toml::value& table, bool contact);

}  // namespace obs::drivers
