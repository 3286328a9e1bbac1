#pragma once
/// \file EstimatorRegistry.hpp
/// Name -> factory registry of estimators (docs/architecture.md#libestimators; like DUNE's solver registry),
/// so that scene files and the command line select estimators by name and embedding code or
/// plugins add their own.
///
/// Built-ins are registered explicitly by registerBuiltinEstimators(), which global() calls on first
/// use; there are no static registration objects (their initialisation order and the linker dropping
/// unreferenced objects of static libraries make self-registration fragile).
///
/// Plugins: a shared library that defines
///     extern "C" void obs_register_estimators(obs::estimators::EstimatorRegistry& registry) {
///       registry.add("my-estimator", "what it does", [] { return std::make_unique<My>(); });
///     }
/// is loaded with loadPlugin(path) (`obs estimators --plugin path.so`). It must be built against the
/// same obs headers and link obs::estimators; see libestimators/examples/ExamplePlugin.cpp.
/// Loaded libraries are never unloaded (the factories live in them).
///
/// Not thread-safe: register and load plugins before estimating in parallel.
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "obs/estimators/Estimator.hpp"

namespace obs::estimators {

/// The registry (see the file comment).
class EstimatorRegistry {
public:
  /// Creates a new estimator.
  using Factory = std::function<std::unique_ptr<Estimator>()>;

  /// One registered estimator.
  struct Entry {
    std::string name;         ///< registry name
    std::string description;  ///< one line, for `obs estimators`
    Factory factory;          ///< creates it
    std::string origin;  ///< "built-in", "plugin <path>" or "" (added by embedding code)
  };

  /// An empty registry (no built-ins; call registerBuiltinEstimators to add them).
  EstimatorRegistry() = default;
  EstimatorRegistry(const EstimatorRegistry&) = delete;
  EstimatorRegistry& operator=(const EstimatorRegistry&) = delete;

  /// The process-wide registry, holding the built-ins from its first use on.
  static EstimatorRegistry& global();

  /// Registers a factory. Throws obs::Error for an empty name, a name with whitespace, a missing
  /// factory, or a name that is already registered (saying where the existing one came from).
  void add(const std::string& name, const std::string& description, Factory factory);

  /// Whether `name` is registered.
  bool contains(const std::string& name) const;
  /// Registered names, sorted.
  std::vector<std::string> names() const;
  /// Entries sorted by name.
  std::vector<Entry> entries() const;
  /// Description of a registered estimator; throws like create() when unknown.
  const std::string& description(const std::string& name) const;

  /// A new estimator. Throws obs::Error "unknown estimator '<name>' (registered: a, b, ...)" for
  /// unknown names, and if the factory returns null.
  std::unique_ptr<Estimator> create(const std::string& name) const;

  /// dlopen()s the shared library at `path` and calls its obs_register_estimators(*this). Loading a
  /// library that was already loaded into this registry does nothing. Throws obs::Error with the
  /// path and dlerror() if the library cannot be loaded or lacks the entry point, and with the path
  /// prepended if the registration function throws.
  void loadPlugin(const std::filesystem::path& path);

  /// Origin string used for the estimators of registerBuiltinEstimators().
  static constexpr const char* kBuiltin = "built-in";

private:
  friend void registerBuiltinEstimators(EstimatorRegistry& registry);
  const Entry& find(const std::string& name) const;

  std::vector<Entry> entries_;
  std::vector<void*> handles_;
  std::string origin_;  ///< origin recorded by add() (set while a plugin registers)
};

/// Name of the entry point a plugin library must export (extern "C").
inline constexpr const char* kPluginEntryPoint = "obs_register_estimators";
/// Signature of the entry point.
using PluginEntryPoint = void (*)(EstimatorRegistry&);

/// Adds the built-in estimators ("contact-residual", "residual") to a registry.
void registerBuiltinEstimators(EstimatorRegistry& registry);

}  // namespace obs::estimators
