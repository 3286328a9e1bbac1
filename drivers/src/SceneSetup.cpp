#include "obs/drivers/SceneSetup.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "obs/drivers/MeshSize.hpp"
#include "obs/drivers/ObstacleFactory.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/CurvedMeshes.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/obs/MortarCoupling.hpp"
#include "obs/obs/Parallel.hpp"
#include "obs/obs/SurfaceObstacle.hpp"
#include "obs/mesh/Gmsh.hpp"
#include "obs/obs/ElasticityAssembly.hpp"

namespace obs::drivers {

namespace {

/// Children per cell of one red refinement (pyramids: 6 pyramids + 4 tetrahedra; an upper bound
/// for later levels, where the tetrahedra give 8).
double refinementFactor(mesh::CellType t) {
  switch (t) {
    case mesh::CellType::Triangle:
    case mesh::CellType::Quadrilateral:
      return 4;
    case mesh::CellType::Pyramid:
      return 10;
    default:
      return 8;
  }
}

std::string entries(std::size_t n) { return std::to_string(n) + (n == 1 ? " entry" : " entries"); }

std::string formatPoint(const Point& p, int dim) {
  std::ostringstream os;
  os << "(" << p[0] << ", " << p[1];
  if (dim == 3) os << ", " << p[2];
  os << ")";
  return os.str();
}

std::string availableBoundaries(const mesh::Mesh& mesh) {
  std::string names;
  for (const auto& [id, name] : mesh.boundaryNames()) names += (names.empty() ? "" : ", ") + name;
  std::set<int> ids;
  for (mesh::Index f = 0; f < mesh.numBoundaryFaces(); ++f) ids.insert(mesh.boundaryFaceId(f));
  std::string idList;
  for (int id : ids) idList += (idList.empty() ? "" : ", ") + std::to_string(id);
  if (!names.empty())
    return "available boundaries: " + names + (idList.empty() ? "" : "; ids: " + idList);
  if (!idList.empty()) return "the mesh has no boundary names; boundary ids: " + idList;
  return "the mesh has no boundary faces";
}

int resolveBoundary(const Scene& scene, const mesh::Mesh& mesh, const BoundaryRef& ref,
                    const std::string& title) {
  if (!ref.name.empty()) {
    if (const auto id = mesh.boundaryId(ref.name)) return *id;
  } else {
    if (mesh.boundaryNames().count(ref.id)) return ref.id;
    for (mesh::Index f = 0; f < mesh.numBoundaryFaces(); ++f)
      if (mesh.boundaryFaceId(f) == ref.id) return ref.id;
  }
  throw Error(scene.where(ref.line) + title + " boundary = " + ref.describe() +
              " does not exist in the mesh (" + availableBoundaries(mesh) + ")");
}

void checkLength(const Scene& scene, const VectorValue& v, int dim, const std::string& what) {
  if (static_cast<int>(v.entries.size()) != dim)
    throw Error(scene.where(v.line) + what + " has " + entries(v.entries.size()) + ", expected " +
                std::to_string(dim) + " (one per coordinate of the " + std::to_string(dim) +
                "D mesh)");
}

/// A vector field from three expressions; throws (naming `what`) on non-finite values.
class ExpressionVectorField {
public:
  ExpressionVectorField(std::array<Expression, 3> e, std::string what, int dim, double t = 0)
      : e_(std::move(e)), what_(std::move(what)), dim_(dim), t_(t) {}
  Eigen::Vector3d operator()(const Point& x) const {
    const Eigen::Vector3d v(e_[0](x, t_), e_[1](x, t_), e_[2](x, t_));
    if (!v.allFinite()) throw Error(what_ + " is not finite at " + formatPoint(x, dim_));
    return v;
  }

private:
  std::array<Expression, 3> e_;
  std::string what_;
  int dim_;
  double t_;  ///< the value of t in the expressions (the load parameter of [loading]; 0 otherwise)
};

std::array<Expression, 3> padded(const VectorValue& v) {
  std::array<Expression, 3> e;
  for (std::size_t i = 0; i < v.entries.size() && i < 3; ++i) e[i] = v.entries[i];
  return e;
}

std::vector<DirichletCondition> dirichletConditions(const Scene& scene, const mesh::Mesh& mesh, double t = 0) {
  const int dim = mesh.dimension();
  std::vector<DirichletCondition> out;
  for (const DirichletSpec& spec : scene.dirichlet) {
    DirichletCondition dc;
    dc.everywhere = spec.everywhere;
    if (!spec.everywhere) dc.boundaryId = resolveBoundary(scene, mesh, spec.boundary, "[[dirichlet]]");
    if (!spec.components.empty()) {
      dc.fixed = {false, false, false};
      for (int c : spec.components) dc.fixed[c] = true;
    }
    for (int c = dim; c < 3; ++c) dc.fixed[c] = false;
    std::array<Expression, 3> e;
    const bool allConstantZero = [&] {
      for (const Expression& x : spec.value.entries)
        if (!x.isConstant() || x.value() != 0.0) return false;
      return true;
    }();
    if (!allConstantZero) {
      if (spec.value.entries.size() == 1) {
        for (int c = 0; c < dim; ++c)
          if (dc.fixed[c]) e[c] = spec.value.entries[0];
      } else {
        e = padded(spec.value);
      }
      for (int c = 0; c < 3; ++c)
        if (!dc.fixed[c]) e[c] = Expression();
      dc.value =
          ExpressionVectorField(e, scene.where(spec.value.line) + "[[dirichlet]] value", dim, t);
    }
    out.push_back(std::move(dc));
  }
  return out;
}

/// The mesh of [mesh] file = "...": the whole file, or with physical = ... the cells of one
/// physical group (docs/scenes.md#gmsh-bodies). Errors in the file name it; errors of the group
/// selection name the scene line and key too.
mesh::Mesh readMeshFile(const Scene& scene) {
  const MeshSpec& spec = scene.mesh;
  if (!spec.physicalName && !spec.physicalTag) return mesh::readGmsh(spec.file);
  const mesh::GmshMesh file = mesh::readGmshGroups(spec.file);
  try {
    return spec.physicalName ? mesh::extractCellGroup(file, *spec.physicalName)
                             : mesh::extractCellGroup(file, *spec.physicalTag);
  } catch (const Error& e) {
    const std::string value =
        spec.physicalName ? "\"" + *spec.physicalName + "\"" : std::to_string(*spec.physicalTag);
    throw Error(scene.where(spec.physicalLine) + "[mesh] physical = " + value + ": " + e.what());
  }
}

/// x moved onto the shape of p (sphere or circle, cylinder, plane); points on the centre or the axis
/// stay where they are.
mesh::Grid::Projection shapeProjection(const ProjectionSpec& p) {
  const mesh::Point c = p.centre, a = p.direction;
  const double r = p.radius;
  switch (p.shape) {
    case ProjectionSpec::Shape::Sphere:
      return [c, r](const mesh::Point& x) -> mesh::Point {
        const mesh::Point y = x - c;
        const double n = y.norm();
        return n > 0 ? mesh::Point(c + (r / n) * y) : x;
      };
    case ProjectionSpec::Shape::Cylinder:
      return [c, a, r](const mesh::Point& x) -> mesh::Point {
        const mesh::Point y = x - c;
        const mesh::Point axial = y.dot(a) * a, radial = y - axial;
        const double n = radial.norm();
        return n > 0 ? mesh::Point(c + axial + (r / n) * radial) : x;
      };
    case ProjectionSpec::Shape::Plane:
    default:
      return [c, a](const mesh::Point& x) -> mesh::Point { return x - (x - c).dot(a) * a; };
  }
}

/// The boundary id of a projection, after checking that the shape fits the mesh: a cylinder needs
/// 3D, and every vertex of the boundary must lie on the shape to 1e-4 of its size (radius, or the
/// boundary's extent for a plane): a projection of a boundary that is not on the shape would move
/// the new vertices away from their neighbours (a wrong centre, radius or boundary).
int projectionBoundary(const Scene& scene, const mesh::Mesh& m, const ProjectionSpec& p) {
  const int id = resolveBoundary(scene, m, p.boundary, "[mesh] projection");
  const char* shape = p.shape == ProjectionSpec::Shape::Sphere     ? (m.dimension() == 2 ? "circle" : "sphere")
                      : p.shape == ProjectionSpec::Shape::Cylinder ? "cylinder"
                                                                   : "plane";
  const std::string what = scene.where(p.line) + "[mesh] projection of boundary " + p.boundary.describe() + " onto the " + shape;
  if (p.shape == ProjectionSpec::Shape::Cylinder && m.dimension() != 3)
    throw Error(what + ": a cylinder needs a 3D mesh (in 2D write shape = \"circle\")");
  if (m.dimension() == 2 && (p.centre[2] != 0 || (p.shape == ProjectionSpec::Shape::Plane && p.direction[2] != 0)))
    throw Error(what + ": the mesh is 2D, give 2 coordinates");
  const auto f = shapeProjection(p);
  Eigen::AlignedBox3d box;
  double worst = 0;
  mesh::Point at = mesh::Point::Zero();
  bool any = false;
  for (mesh::Index k = 0; k < m.numBoundaryFaces(); ++k) {
    if (m.boundaryFaceId(k) != id) continue;
    any = true;
    for (mesh::Index v : m.boundaryFaceVertices(k)) {
      const mesh::Point& x = m.vertex(v);
      box.extend(x);
      const double dist = (f(x) - x).norm();
      if (dist > worst) {
        worst = dist;
        at = x;
      }
    }
  }
  if (!any) throw Error(what + ": the boundary has no faces");
  const double size = p.shape == ProjectionSpec::Shape::Plane ? box.diagonal().norm() : p.radius;
  if (worst > 1e-4 * size) {
    std::ostringstream os;
    os << what << ": its vertex at (" << at[0] << ", " << at[1];
    if (m.dimension() == 3) os << ", " << at[2];
    os << ") is " << worst << " away from the " << shape << " (more than 1e-4 of its size " << size
       << "): check the centre, radius, axis and the boundary";
    throw Error(os.str());
  }
  return id;
}

}  // namespace

mesh::Grid buildGrid(const Scene& scene, std::optional<int> refineOverride) {
  if (scene.multiBody())
    throw Error(scene.fileName + ": the scene has " + std::to_string(scene.bodies.size()) +
                " [[body]] entries; their grids are built per body (Scene::bodies)");
  const MeshSpec& spec = scene.mesh;
  const int refine = refineOverride.value_or(spec.refine);
  const std::string what =
      refineOverride ? "--refine " + std::to_string(refine)
                     : scene.where(spec.refineLine) + "[mesh] refine = " + std::to_string(refine);
  if (refine < 0) throw Error(what + " must not be negative");
  // A generated mesh is sized before it is built: an oversized request must not allocate first.
  if (const double coarse = generatedCoarseCells(spec); coarse > 0) {
    std::ostringstream os;
    if (coarse > static_cast<double>(kMaxCells))
      os << scene.where(spec.line) << "[mesh] asks for " << coarse << " cells (the limit is "
         << static_cast<double>(kMaxCells) << ")";
    else if (const double refined = refinedCells(coarse, spec.cellType, refine);
             refined > static_cast<double>(kMaxCells))
      os << what << " would give about " << refined << " cells (from "
         << static_cast<long long>(coarse) << "; the limit is " << static_cast<double>(kMaxCells) << ")";
    if (!os.str().empty()) throw Error(os.str());
  }
  mesh::CurvedMesh curved;  // generator = "ball" / "rounded_block": mesh + boundary projections
  if (spec.source != MeshSpec::Source::Box && spec.source != MeshSpec::Source::File) {
    const char* generator = spec.source == MeshSpec::Source::Ball   ? "ball"
                            : spec.source == MeshSpec::Source::Disk ? "disk"
                            : spec.source == MeshSpec::Source::HalfDisk ? "half_disk"
                            : spec.source == MeshSpec::Source::HalfBall ? "half_ball"
                                                                        : "rounded_block";
    try {
      switch (spec.source) {
        case MeshSpec::Source::Ball: curved = mesh::ballMesh(spec.centre, spec.radius, spec.cellType, spec.cells[0]); break;
        case MeshSpec::Source::Disk: curved = mesh::diskMesh(spec.centre, spec.radius, spec.cellType, spec.cells[0]); break;
        case MeshSpec::Source::HalfBall:
          curved = mesh::halfBallMesh(spec.centre, spec.radius, spec.cellType, spec.cells[0]);
          break;
        case MeshSpec::Source::HalfDisk:
          curved = mesh::halfDiskMesh(spec.centre, spec.radius, spec.cellType, spec.cells[0]);
          break;
        default:
          curved = mesh::roundedBlockMesh(spec.width, spec.height, spec.depth, spec.arcRadius, spec.cellType, spec.cells);
      }
    } catch (const Error& e) {
      throw Error(scene.where(spec.line) + "[mesh] generator = \"" + generator + "\": " + e.what());
    }
  }
  mesh::Mesh m = spec.source == MeshSpec::Source::Box
                     ? mesh::boxMesh(spec.cellType, spec.cells, spec.lower, spec.upper)
                 : spec.source == MeshSpec::Source::File ? readMeshFile(scene)
                                                         : curved.mesh;
  const auto counts = m.cellCounts();
  double predicted = 0;
  for (mesh::CellType t : mesh::kVolumeCellTypes)
    predicted += counts[static_cast<int>(t)] * std::pow(refinementFactor(t), refine);
  if (predicted > static_cast<double>(kMaxCells)) {
    std::ostringstream os;
    os << what << " would give about " << static_cast<double>(predicted) << " cells (from "
       << m.numCells() << "; the limit is " << static_cast<double>(kMaxCells) << ")";
    throw Error(os.str());
  }
  mesh::Grid grid(m);
  for (const auto& [id, projection] : curved.projections) grid.setBoundaryProjection(id, projection);
  for (const ProjectionSpec& p : spec.projections) grid.setBoundaryProjection(projectionBoundary(scene, m, p), shapeProjection(p));
  for (int k = 0; k < refine; ++k) grid.refineUniformly(threads());
  return grid;
}

mesh::Mesh buildMesh(const Scene& scene, std::optional<int> refineOverride) {
  return buildGrid(scene, refineOverride).leafMesh();
}

int boundaryIdOf(const Scene& scene, const mesh::Mesh& mesh, const BoundaryRef& ref, const std::string& title) {
  return resolveBoundary(scene, mesh, ref, title);
}

int contactBoundaryId(const Scene& scene, const mesh::Mesh& mesh) {
  const ContactSpec& c = *scene.contact;
  const int id = resolveBoundary(scene, mesh, c.boundary, "[contact]");
  for (mesh::Index f = 0; f < mesh.numBoundaryFaces(); ++f)
    if (mesh.boundaryFaceId(f) == id) return id;
  throw Error(scene.where(c.boundary.line) + "[contact] boundary = " + c.boundary.describe() +
              " has no boundary faces: the contact boundary is empty (" +
              availableBoundaries(mesh) + ")");
}

ContactSet makeContactSet(const Scene& scene, const mesh::Mesh& mesh, const Obstacle& obstacle) {
  const int id = contactBoundaryId(scene, mesh);
  const std::string what = scene.where(scene.contact->line) + "[contact] obstacle = \"" +
                           scene.contact->obstacle + "\" on boundary " +
                           scene.contact->boundary.describe() + ": ";
  std::optional<ContactSet> contact;
  try {
    contact.emplace(mesh, id, obstacle);
  } catch (const Error& e) {
    if (std::string(e.what()).rfind(scene.fileName, 0) == 0) throw;  // names its scene line already
    throw Error(what + e.what());
  }
  // A surface mesh that no line from the contact boundary meets from the front is a mistake in the
  // scene (misplaced, or its faces ordered the wrong way round), not an unconstrained problem.
  if (const auto* surface = dynamic_cast<const SurfaceObstacle*>(&obstacle); surface && !surface->closestPointMode()) {
    bool constrained = false, back = false;
    for (Index k = 0; k < contact->size() && !constrained; ++k) {
      constrained = std::isfinite(contact->gap(k));
      back = back || surface->seesOnlyBackFaces(mesh.vertex(contact->vertex(k)));
    }
    if (!constrained && back)
      throw Error(what + "the lines along direction from the contact vertices meet only the backs of "
                  "the faces of " + surface->source() + ": its faces are ordered clockwise seen from "
                  "outside the obstacle; set reverse = true (or reorder them)");
    if (!constrained)
      throw Error(what + "no line along direction from a contact vertex meets " + surface->source() +
                  ": the surface lies beside the body (check its coordinates and direction)");
  }
  return std::move(*contact);
}

void checkDirichletContact(const Scene& scene, const mesh::Mesh& mesh, const ContactSet& contact) {
  const int dim = mesh.dimension();
  const std::vector<DirichletCondition> conditions = dirichletConditions(scene, mesh);
  const DirichletValues g = collectDirichlet(mesh, conditions);
  for (Index k = 0; k < contact.size(); ++k) {
    const double gap = contact.gap(k);
    if (!std::isfinite(gap)) continue;
    const Index v = contact.vertex(k);
    const Point& nu = contact.direction(k);
    double free = 0, shift = 0;
    Point uD = Point::Zero();
    for (int a = 0; a < dim; ++a) {
      const std::size_t i = static_cast<std::size_t>(v) * dim + a;
      if (g.constrained[i]) {
        uD[a] = g.values[static_cast<Eigen::Index>(i)];
        shift += nu[a] * uD[a];
      } else {
        free += nu[a] * nu[a];
      }
    }
    // A free component along nu lets the solution satisfy the constraint (ContactProblem.hpp).
    if (std::sqrt(free) > 1e-12) continue;
    if (shift <= gap + 1e-12 * std::max({1.0, std::abs(gap), std::abs(shift)})) continue;
    // the [[dirichlet]] entry that prescribes the vertex (later entries win, as in collectDirichlet)
    std::string entry;
    for (std::size_t e = 0; e < scene.dirichlet.size(); ++e) {
      if (conditions[e].everywhere) {
        entry = "[[dirichlet]] everywhere = true (line " + std::to_string(scene.dirichlet[e].line) + ")";
        continue;
      }
      for (mesh::Index f = 0; f < mesh.numBoundaryFaces(); ++f) {
        if (mesh.boundaryFaceId(f) != conditions[e].boundaryId) continue;
        const auto fv = mesh.boundaryFaceVertices(f);
        if (std::find(fv.begin(), fv.end(), v) != fv.end()) {
          entry = "[[dirichlet]] boundary = " + scene.dirichlet[e].boundary.describe() + " (line " +
                  std::to_string(scene.dirichlet[e].line) + ")";
          break;
        }
      }
    }
    std::ostringstream os;
    os << scene.where(scene.contact->boundary.line) << "[contact] boundary = "
       << scene.contact->boundary.describe() << ": vertex " << v << " at "
       << formatPoint(mesh.vertex(v), dim) << " has the displacement " << formatPoint(uD, dim)
       << " prescribed by " << entry << ", so u.nu = " << shift << " exceeds the gap " << gap + 0.0  // no "-0"
       << ": the Dirichlet data violate the obstacle constraint u.nu <= g";
    throw Error(os.str());
  }
}

void validateScene(const Scene& scene, const mesh::Mesh& mesh) {
  const int dim = mesh.dimension();
  for (const DirichletSpec& spec : scene.dirichlet) {
    if (!spec.everywhere) resolveBoundary(scene, mesh, spec.boundary, "[[dirichlet]]");
    for (int c : spec.components)
      if (c >= dim)
        throw Error(scene.where(spec.componentsLine) + "[[dirichlet]] components: \"" +
                    std::string(1, "xyz"[c]) + "\" does not exist in a " + std::to_string(dim) +
                    "D mesh");
    const std::size_t n = spec.value.entries.size();
    if (n > 1 && static_cast<int>(n) != dim)
      throw Error(scene.where(spec.value.line) + "[[dirichlet]] value has " + entries(n) +
                  ", expected " + std::to_string(dim) + " (one per coordinate of the " +
                  std::to_string(dim) + "D mesh) or a single value for every fixed component");
  }
  for (const NeumannSpec& spec : scene.neumann) {
    resolveBoundary(scene, mesh, spec.boundary, "[[neumann]]");
    if (spec.traction) checkLength(scene, *spec.traction, dim, "[[neumann]] traction");
  }
  if (scene.bodyForce) checkLength(scene, *scene.bodyForce, dim, "[body_force] value");

  const int free = countFreeRigidMotions(mesh, dirichletConditions(scene, mesh));
  if (free > 0 && !scene.dynamics)  // a dynamic body may move freely (its mass matrix is regular)
    throw Error(scene.fileName + ": [[dirichlet]]: the Dirichlet conditions leave " +
                std::to_string(free) + " rigid motion(s) free (of " +
                std::to_string(dim == 2 ? 3 : 6) + " in " + std::to_string(dim) +
                "D); fix more components or boundaries");

  if (scene.contact) {
    contactBoundaryId(scene, mesh);
    const auto obstacle = makeObstacle(scene, dim);
    checkDirichletContact(scene, mesh, makeContactSet(scene, mesh, *obstacle));
  }
}

BoundaryConditions makeBoundaryConditions(const Scene& scene, const mesh::Mesh& mesh, double t) {
  const int dim = mesh.dimension();
  BoundaryConditions bc;
  bc.dirichlet = dirichletConditions(scene, mesh, t);
  for (const NeumannSpec& spec : scene.neumann) {
    NeumannCondition nc;
    nc.boundaryId = resolveBoundary(scene, mesh, spec.boundary, "[[neumann]]");
    if (spec.traction) {
      nc.traction = ExpressionVectorField(
          padded(*spec.traction), scene.where(spec.traction->line) + "[[neumann]] traction", dim, t);
    } else if (spec.pressure) {
      nc.pressure = [p = *spec.pressure,
                     what = scene.where(spec.pressureLine) + "[[neumann]] pressure",
                     dim, t](const Point& x) {
        const double v = p(x, t);
        if (!std::isfinite(v)) throw Error(what + " is not finite at " + formatPoint(x, dim));
        return v;
      };
    }
    bc.neumann.push_back(std::move(nc));
  }
  if (scene.bodyForce)
    bc.bodyForce = ExpressionVectorField(
        padded(*scene.bodyForce), scene.where(scene.bodyForce->line) + "[body_force] value", dim, t);
  return bc;
}

std::string checkMultiBodyScene(const Scene& scene, std::optional<int> refineOverride) {
  std::vector<mesh::Mesh> meshes;
  for (const Scene& body : scene.bodies) {
    try {
      meshes.push_back(buildMesh(body, refineOverride));
      validateScene(body, meshes.back());
      (void)makeBoundaryConditions(body, meshes.back());
    } catch (const Error& e) {
      throw Error(std::string(e.what()) + " (in [[body]] '" + body.name + "')");
    }
    if (meshes.back().dimension() != meshes.front().dimension())
      throw Error(scene.where(body.bodyLine) + "[[body]] '" + body.name +
                  "' has another dimension than body '" + scene.bodies.front().name + "'");
  }
  std::vector<Index> offsets;
  Index n = 0;
  for (const auto& m : meshes) {
    offsets.push_back(n);
    n += m.numVertices();
  }
  long long cells = 0, constrained = 0;
  for (const auto& m : meshes) cells += m.numCells();
  for (const MortarPairSpec& p : scene.pairs) {
    const Scene& sb = scene.bodies[p.slaveIndex];
    const Scene& mb = scene.bodies[p.masterIndex];
    const int sid = boundaryIdOf(scene, meshes[p.slaveIndex], p.slave, "[[contact]] slave of body '" + sb.name + "':");
    const int mid = boundaryIdOf(scene, meshes[p.masterIndex], p.master, "[[contact]] master of body '" + mb.name + "':");
    MortarOptions o;
    o.minCoverage = p.minCoverage;
    o.searchDistance = p.searchDistance;
    try {
      const MortarCoupling c({&meshes[p.slaveIndex], sid, offsets[p.slaveIndex], "body '" + sb.name + "'"},
                             {&meshes[p.masterIndex], mid, offsets[p.masterIndex], "body '" + mb.name + "'"}, n, o);
      constrained += c.size();
    } catch (const Error& e) {
      throw Error(scene.where(p.line) + "[[contact]] " + e.what());
    }
  }
  return std::to_string(scene.bodies.size()) + " bodies, " + std::to_string(meshes.front().dimension()) + "D, " +
         std::to_string(cells) + " cells, " + std::to_string(n) + " vertices, " + std::to_string(scene.pairs.size()) +
         " mortar pair" + (scene.pairs.size() == 1 ? "" : "s") + " with " + std::to_string(constrained) +
         " constrained slave vertices";
}

SolverConfig solverConfig(const Scene& scene) {
  const SolverSpec& spec = scene.solver;
  SolverConfig c;
  c.kind = contactSolverKindFromName(scene.solverType()).value_or(ContactSolverKind::TNNMG);
  c.tolerance = spec.tolerance.value_or(c.tolerance);
  c.maxIterations = spec.maxIterations;
  c.preSmoothing = spec.preSmoothing.value_or(c.preSmoothing);
  c.postSmoothing = spec.postSmoothing.value_or(c.postSmoothing);
  LinearMultigridOptions& mg = c.multigrid;
  if (spec.smoother == "vertex-patch") mg.smoother = LinearSmoother::VertexPatch;
  mg.krylovSteps = spec.krylovSteps.value_or(mg.krylovSteps);
  if (spec.linearSmoothing) mg.preSmoothing = mg.postSmoothing = *spec.linearSmoothing;
  mg.localSmoothing = spec.localSmoothing.value_or(mg.localSmoothing);
  mg.cycleIndex = spec.cycleIndex.value_or(mg.cycleIndex);
  return c;
}

}  // namespace obs::drivers
