#include "obs/estimators/EstimatorRegistry.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cctype>

#include "obs/estimators/ContactResidualEstimator.hpp"
#include "obs/estimators/ResidualEstimator.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

std::string dlError() {
  const char* e = dlerror();
  return e ? std::string(e) : std::string("unknown dynamic loader error");
}

/// Restores the registry's origin string on scope exit.
struct OriginGuard {
  std::string& target;
  std::string saved;
  OriginGuard(std::string& t, std::string value) : target(t), saved(std::move(t)) {
    target = std::move(value);
  }
  ~OriginGuard() { target = std::move(saved); }
};

}  // namespace

EstimatorRegistry& EstimatorRegistry::global() {
  static EstimatorRegistry* registry = [] {
    auto* r = new EstimatorRegistry;  // never destroyed: plugin factories may outlive statics
    registerBuiltinEstimators(*r);
    return r;
  }();
  return *registry;
}

void registerBuiltinEstimators(EstimatorRegistry& registry) {
  OriginGuard origin(registry.origin_, EstimatorRegistry::kBuiltin);
  registry.add("residual", ResidualEstimator().description(),
               [] { return std::make_unique<ResidualEstimator>(); });
  registry.add("contact-residual", ContactResidualEstimator().description(),
               [] { return std::make_unique<ContactResidualEstimator>(); });
}

void EstimatorRegistry::add(const std::string& name, const std::string& description,
                            Factory factory) {
  if (name.empty()) throw Error("cannot register an estimator with an empty name");
  if (std::any_of(name.begin(), name.end(), [](unsigned char c) { return std::isspace(c); }))
    throw Error("cannot register estimator '" + name + "': the name contains whitespace");
  if (!factory) throw Error("cannot register estimator '" + name + "': no factory given");
  for (const Entry& e : entries_)
    if (e.name == name)
      throw Error("estimator '" + name + "' is already registered" +
                  (e.origin.empty() ? std::string() : " (" + e.origin + ")"));
  entries_.push_back({name, description, std::move(factory), origin_});
}

bool EstimatorRegistry::contains(const std::string& name) const {
  return std::any_of(entries_.begin(), entries_.end(),
                     [&](const Entry& e) { return e.name == name; });
}

std::vector<std::string> EstimatorRegistry::names() const {
  std::vector<std::string> n;
  for (const Entry& e : entries_) n.push_back(e.name);
  std::sort(n.begin(), n.end());
  return n;
}

std::vector<EstimatorRegistry::Entry> EstimatorRegistry::entries() const {
  std::vector<Entry> sorted = entries_;
  std::sort(sorted.begin(), sorted.end(),
            [](const Entry& a, const Entry& b) { return a.name < b.name; });
  return sorted;
}

const EstimatorRegistry::Entry& EstimatorRegistry::find(const std::string& name) const {
  for (const Entry& e : entries_)
    if (e.name == name) return e;
  std::string known;
  for (const std::string& n : names()) known += (known.empty() ? "" : ", ") + n;
  throw Error("unknown estimator '" + name + "' (registered: " +
              (known.empty() ? std::string("none") : known) + ")");
}

const std::string& EstimatorRegistry::description(const std::string& name) const {
  return find(name).description;
}

std::unique_ptr<Estimator> EstimatorRegistry::create(const std::string& name) const {
  const Entry& e = find(name);
  std::unique_ptr<Estimator> estimator = e.factory();
  if (!estimator) throw Error("the factory of estimator '" + name + "' returned no estimator");
  return estimator;
}

void EstimatorRegistry::loadPlugin(const std::filesystem::path& path) {
  const std::string where = "estimator plugin '" + path.string() + "'";
  if (path.empty()) throw Error("estimator plugin: empty path");
  // an existing file is opened by its absolute path (so "plugin.so" means ./plugin.so); other names
  // are left to the dynamic loader's search (LD_LIBRARY_PATH, ...)
  std::filesystem::path file = path;
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) {
    const std::filesystem::path absolute = std::filesystem::absolute(path, ec);
    if (!ec) file = absolute;
  }
  dlerror();  // clear
  void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) throw Error(where + ": cannot load: " + dlError());
  if (std::find(handles_.begin(), handles_.end(), handle) != handles_.end()) {
    dlclose(handle);  // drop the extra reference; already registered
    return;
  }
  dlerror();
  void* symbol = dlsym(handle, kPluginEntryPoint);
  if (!symbol) {
    const std::string message = dlError();
    dlclose(handle);
    throw Error(where + ": no entry point '" + std::string(kPluginEntryPoint) +
                "' (declare it extern \"C\"): " + message);
  }
  const auto entry = reinterpret_cast<PluginEntryPoint>(symbol);
  handles_.push_back(handle);  // never closed: registered factories point into the library
  OriginGuard origin(origin_, "plugin " + path.string());
  try {
    entry(*this);
  } catch (const std::exception& e) {
    throw Error(where + ": registration failed: " + e.what());
  }
}

}  // namespace obs::estimators
