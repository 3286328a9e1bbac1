#include "obs/drivers/ObstacleFactory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/SurfaceMesh.hpp"
#include "obs/obs/SurfaceObstacle.hpp"

namespace obs::drivers {

namespace {

using Kind = ObstacleParameter::Kind;
using Range = ObstacleParameter::Range;

constexpr ObstacleParameter kDirection{"direction", Kind::Direction, false};

std::vector<ObstacleType> makeTypes() {
  return {
      {"plane", 0, false, {{"point", Kind::Point, true}, kDirection}},
      {"strip",
       0,
       false,
       {{"point", Kind::Point, true},
        {"half_width", Kind::Number, true, Range::Positive},
        kDirection,
        {"across", Kind::Point, false},
        {"outside_gap", Kind::Number, false}}},
      {"wedge",
       2,
       false,
       {{"apex", Kind::Point, true}, {"slope", Kind::Number, true, Range::NonNegative}, kDirection}},
      {"pyramid",
       3,
       false,
       {{"apex", Kind::Point, true}, {"slope", Kind::Number, true, Range::NonNegative}, kDirection}},
      {"hat",
       0,
       false,
       {{"centre", Kind::Point, true},
        {"height", Kind::Number, true},
        {"radius", Kind::Number, true, Range::Positive},
        kDirection}},
      {"sine-wave",
       0,
       false,
       {{"point", Kind::Point, true},
        {"amplitude", Kind::Number, true},
        {"wavelength", Kind::Number, true, Range::Positive},
        kDirection}},
      {"ball",
       3,
       true,
       {{"centre", Kind::Point, true}, {"radius", Kind::Number, true, Range::Positive}, kDirection}},
      {"disk",
       2,
       true,
       {{"centre", Kind::Point, true}, {"radius", Kind::Number, true, Range::Positive}, kDirection}},
      {"expression", 0, false, {{"gap", Kind::Expression, true}, kDirection}},
      {"surface",
       0,
       true,
       {{"file", Kind::File, true}, kDirection, {"reverse", Kind::Boolean, false}}},
      {"smiley",
       3,
       false,
       {{"centre", Kind::Point, true},
        {"radius", Kind::Number, true, Range::Positive},
        {"slope", Kind::Number, true, Range::NonNegative},
        kDirection}},
  };
}

std::string formatPoint(const Point& p, int dim) {
  std::ostringstream os;
  os << "(" << p[0] << ", " << p[1];
  if (dim == 3) os << ", " << p[2];
  os << ")";
  return os.str();
}

std::string vectorText(const std::vector<double>& v) {
  std::ostringstream os;
  os << "[";
  for (std::size_t i = 0; i < v.size(); ++i) os << (i ? ", " : "") << v[i];
  os << "]";
  return os.str();
}

/// Reads the parameters of a [contact] section for a mesh of dimension dim.
class ContactParameters {
public:
  ContactParameters(const Scene& scene, int dim) : scene_(scene), c_(*scene.contact), dim_(dim) {}

  [[noreturn]] void fail(int line, const std::string& key, const std::string& message) const {
    throw Error(scene_.where(line > 0 ? line : c_.line) + "[contact] " + key + " " + message);
  }

  Point point(const std::string& key, const Point& fallback = Point::Zero()) const {
    const auto it = c_.vectors.find(key);
    if (it == c_.vectors.end()) return fallback;
    const auto& v = it->second;
    if (static_cast<int>(v.values.size()) != dim_)
      fail(v.line, key,
           "= " + vectorText(v.values) + " has " + std::to_string(v.values.size()) +
               " entries, expected " + std::to_string(dim_) + " (one per coordinate of the " +
               std::to_string(dim_) + "D mesh)");
    Point p = Point::Zero();
    for (int i = 0; i < dim_; ++i) p[i] = v.values[i];
    return p;
  }

  Point direction(const std::string& key, const Point& fallback) const {
    const Point p = point(key, fallback);
    if (!(p.norm() > 0)) fail(c_.vectors.at(key).line, key, "must be a non-zero vector");
    return p;
  }

  double number(const std::string& key, double fallback = 0) const {
    const auto it = c_.numbers.find(key);
    return it == c_.numbers.end() ? fallback : it->second.value;
  }

private:
  const Scene& scene_;
  const ContactSpec& c_;
  int dim_;
};

}  // namespace

const std::vector<ObstacleType>& obstacleTypes() {
  static const std::vector<ObstacleType> types = makeTypes();
  return types;
}

const ObstacleType* findObstacleType(const std::string& name) {
  for (const ObstacleType& t : obstacleTypes())
    if (name == t.name) return &t;
  return nullptr;
}

std::string obstacleTypeNames() {
  std::string s;
  for (const ObstacleType& t : obstacleTypes()) s += (s.empty() ? "" : ", ") + std::string(t.name);
  return s;
}

const std::vector<std::string>& contactKeys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> k{"boundary", "obstacle", "friction"};
    for (const ObstacleType& t : obstacleTypes())
      for (const ObstacleParameter& p : t.parameters)
        if (std::find(k.begin(), k.end(), p.key) == k.end()) k.push_back(p.key);
    return k;
  }();
  return keys;
}

std::unique_ptr<Obstacle> makeObstacle(const Scene& scene, int dim) {
  if (!scene.contact) throw Error(scene.fileName + ": the scene has no [contact] section");
  const ContactSpec& c = *scene.contact;
  const ObstacleType* type = findObstacleType(c.obstacle);
  if (!type)
    throw Error(scene.where(c.obstacleLine) + "[contact] obstacle = \"" + c.obstacle +
                "\" is unknown (known obstacles: " + obstacleTypeNames() + ")");
  if (type->dimension != 0 && type->dimension != dim)
    throw Error(scene.where(c.obstacleLine) + "[contact] obstacle = \"" + c.obstacle +
                "\" is a " + std::to_string(type->dimension) + "D obstacle, the mesh is " +
                std::to_string(dim) + "D" +
                (c.obstacle == "ball" ? " (use \"disk\" in 2D)"
                 : c.obstacle == "disk" ? " (use \"ball\" in 3D)"
                                        : std::string()));
  const ContactParameters p(scene, dim);
  const Point down = dim == 2 ? Point(-Point::UnitY()) : Point(-Point::UnitZ());
  const Point nu = c.normalDirection ? down : p.direction("direction", down);
  const std::string& name = c.obstacle;
  try {
    if (name == "plane") return std::make_unique<PlaneObstacle>(p.point("point"), nu);
    if (name == "strip")
      return std::make_unique<StripObstacle>(
          p.point("point"), p.number("half_width"), nu, p.direction("across", Point::UnitX()),
          p.number("outside_gap", std::numeric_limits<double>::infinity()));
    if (name == "wedge") return std::make_unique<WedgeObstacle>(p.point("apex"), p.number("slope"), nu);
    if (name == "pyramid")
      return std::make_unique<PyramidObstacle>(p.point("apex"), p.number("slope"), nu);
    if (name == "hat")
      return std::make_unique<HatObstacle>(p.point("centre"), p.number("height"), p.number("radius"), nu);
    if (name == "sine-wave")
      return std::make_unique<SineWaveObstacle>(p.point("point"), p.number("amplitude"),
                                                p.number("wavelength"), nu);
    if (name == "smiley")
      return std::make_unique<SmileyObstacle>(p.point("centre"), p.number("radius"), p.number("slope"), nu);
    const auto mode = c.normalDirection ? BallObstacle::Direction::Normal : BallObstacle::Direction::Fixed;
    if (name == "ball")
      return std::make_unique<BallObstacle>(p.point("centre"), p.number("radius"), nu, mode);
    if (name == "disk")
      return std::make_unique<DiskObstacle>(p.point("centre"), p.number("radius"), nu, mode);
    if (name == "surface") {
      const ContactSpec::File& file = c.files.at("file");
      const mesh::SurfaceMesh surface = mesh::readSurfaceMesh(file.path);
      if (surface.dimension != dim)
        throw Error(scene.where(file.line) + "[contact] file = \"" + file.text + "\" is a " +
                    (surface.dimension == 2 ? "2D surface (segments)" : "3D surface (triangles, quadrilaterals)") +
                    ", the mesh is " + std::to_string(dim) + "D");
      const auto flag = c.flags.find("reverse");
      const bool reverse = flag != c.flags.end() && flag->second.value;
      if (c.normalDirection)
        return std::make_unique<SurfaceObstacle>(surface, SurfaceObstacle::ClosestPoint{}, reverse);
      return std::make_unique<SurfaceObstacle>(surface, nu, reverse);
    }
    if (name == "expression") {
      if (!c.gap) throw Error(scene.where(c.line) + "[contact] obstacle = \"expression\" needs gap");
      const std::string what = scene.where(c.gapLine) + "[contact] gap = \"" + c.gap->text() + "\"";
      const Point unit = nu.normalized();
      return std::make_unique<FunctionObstacle>(
          [g = *c.gap, what, dim](const Point& x) {
            const double v = g(x);
            if (!std::isfinite(v)) throw Error(what + " is not finite at " + formatPoint(x, dim));
            return v;
          },
          [unit](const Point&) { return unit; }, "expression", 0);
    }
  } catch (const Error& e) {
    // parameter checks of libobs ("obstacle 'strip': parameter 'halfWidth' ...")
    const std::string msg = e.what();
    if (msg.rfind(scene.fileName, 0) == 0) throw;
    throw Error(scene.where(c.line) + "[contact] " + msg);
  }
  throw Error(scene.where(c.obstacleLine) + "[contact] obstacle = \"" + name + "\" is not implemented");
}

}  // namespace obs::drivers
