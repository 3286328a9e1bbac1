#include "obs/drivers/Scene.hpp"

namespace obs::drivers {

std::string BoundaryRef::describe() const {
  return name.empty() ? std::to_string(id) : "\"" + name + "\"";
}

std::string Scene::where(int line) const {
  return line > 0 ? fileName + ":" + std::to_string(line) + ": " : fileName + ": ";
}

std::string Scene::solverType() const {
  if (!solver.type.empty()) return solver.type;
  return contact || multiBody() ? "tnnmg" : "direct";
}

std::vector<const Scene*> Scene::bodyScenes() const {
  if (bodies.empty()) return {this};
  std::vector<const Scene*> out;
  for (const Scene& b : bodies) out.push_back(&b);
  return out;
}

bool Scene::frictional() const {
  if (contact && contact->friction) return true;
  for (const Scene& b : bodies)
    if (b.contact && b.contact->friction) return true;
  for (const MortarPairSpec& p : pairs)
    if (p.friction) return true;
  return false;
}

}  // namespace obs::drivers
