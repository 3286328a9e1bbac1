#include "RunCheckpoint.hpp"

#include <algorithm>
#include <cstring>
#include <sstream>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Parallel.hpp"

namespace obs::drivers {

namespace {

volatile std::sig_atomic_t gSignal = 0;

extern "C" void onInterrupt(int signal) {
  if (gSignal == 0) gSignal = signal;
}

std::string overridesText(const std::vector<std::string>& overrides) {
  std::string s;
  for (const std::string& o : overrides) s += "\n--set " + o;
  return s;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

/// "a dynamic", "an adaptive"
std::string article(const std::string& word) {
  return (!word.empty() && std::string("aeiou").find(word[0]) != std::string::npos ? "an " : "a ") + word;
}

std::string quoted(std::string s) {
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return "'" + s + "'";
}

}  // namespace

std::uint64_t vertexKey(std::size_t body, const mesh::Point& x) {
  const std::uint64_t b = body;
  return fnv1a(x.data(), sizeof(double) * 3, fnv1a(&b, sizeof b));
}

std::string sceneHash(const Scene& scene) {
  const std::string o = overridesText(scene.overrides);
  return hexHash(fnv1a(o.data(), o.size(), fnv1a(scene.text.data(), scene.text.size())));
}

namespace {

std::uint64_t gridChecksum(const mesh::Mesh& leaf, std::uint64_t h = kFnvOffset) {
  for (const mesh::Point& x : leaf.vertices()) h = fnv1a(x.data(), sizeof(double) * 3, h);
  for (mesh::Index c = 0; c < leaf.numCells(); ++c) {
    const auto v = leaf.cellVertices(c);
    h = fnv1a(v.data(), v.size_bytes(), h);
  }
  return h;
}

/// The stacked leaf grid of the bodies: vertices, cells, checksum (one body: its own).
struct GridIdentity {
  long long vertices = 0, cells = 0;
  std::uint64_t checksum = kFnvOffset;
};

/// One body's grid: its counts and checksum, by the leaf's numbering or (keyed) by its vertex keys
/// over the ranks (collective with comm).
GridIdentity bodyIdentity(const RunBody& b) {
  const mesh::Mesh& leaf = *b.leaf;
  if (!b.keyed) return {leaf.numVertices(), leaf.numCells(), gridChecksum(leaf)};
  const mesh::Index vertices = b.comm ? b.ownedVertices : leaf.numVertices();
  const mesh::Index cells = b.comm ? b.ownedCells : leaf.numCells();
  std::uint64_t sum = 0;  // of the keys, modulo 2^64: independent of the order
  for (mesh::Index v = 0; v < vertices; ++v) sum += vertexKey(b.index, leaf.vertex(v));
  GridIdentity g{vertices, cells, 0};
  if (b.comm) {
    long long bits = 0;
    std::memcpy(&bits, &sum, sizeof sum);
    sum = 0;
    for (long long x : b.comm->allGather(bits)) {
      std::uint64_t y = 0;
      std::memcpy(&y, &x, sizeof y);
      sum += y;
    }
    g.vertices = b.comm->sum(static_cast<long long>(vertices));
    g.cells = b.comm->sum(static_cast<long long>(cells));
  }
  g.checksum = fnv1a(&sum, sizeof sum, fnv1a(&g.cells, sizeof g.cells));
  return g;
}

GridIdentity gridIdentity(const std::vector<RunBody>& bodies) {
  GridIdentity g;
  for (const RunBody& b : bodies) {
    const GridIdentity own = bodyIdentity(b);
    g.vertices += own.vertices;
    g.cells += own.cells;
    g.checksum = b.keyed ? fnv1a(&own.checksum, sizeof own.checksum, g.checksum) : gridChecksum(*b.leaf, g.checksum);
  }
  return g;
}

std::string bodyGroup(std::size_t b) { return "bodies/" + std::to_string(b) + "/"; }

/// "2 bodies ('lower', 'upper')"
std::string bodyList(const std::vector<std::string>& names) {
  std::string s = std::to_string(names.size()) + (names.size() == 1 ? " body (" : " bodies (");
  for (std::size_t b = 0; b < names.size(); ++b) s += (b ? ", '" : "'") + names[b] + "'";
  return s + ")";
}

std::string gridMismatch(long long nv, long long nc, const GridIdentity& now) {
  return "written for a grid of " + std::to_string(nv) + " vertices / " + std::to_string(nc) + " cells, this run has " +
         std::to_string(now.vertices) + " / " + std::to_string(now.cells) + " (another --refine?)";
}

}  // namespace

void storeRunIdentity(CheckpointRecord& r, const Scene& scene, const std::vector<RunBody>& bodies) {
  r.set("scene/text", scene.text, "the scene file as read (TOML)");
  r.set("scene/overrides", overridesText(scene.overrides), "the obs run --set overrides, one '--set ...' per line");
  r.set("scene/hash", sceneHash(scene), "FNV-1a 64 of scene/text followed by scene/overrides");
  r.set("run/threads", static_cast<long long>(threads()),
        "obs run --threads of the run (Gauss-Seidel sweeps in an order that depends on it: a restart with "
        "another count would not continue bitwise)");
  if (!bodies.empty() && bodies.front().keyed)
    r.set("run/ranks", static_cast<long long>(bodies.front().comm ? bodies.front().comm->size() : 1),
          "MPI ranks of the run (a restart on another number continues within the solver tolerance, on the same "
          "number and threads bit for bit)");
  const GridIdentity g = gridIdentity(bodies);
  if (!scene.multiBody()) {
    r.set("grid/leaf_vertices", g.vertices, "vertices of the leaf mesh");
    r.set("grid/leaf_cells", g.cells, "cells of the leaf mesh");
    r.set("grid/leaf_checksum", hexHash(g.checksum),
          bodies.front().keyed ? "FNV-1a 64 of the cell count and the sum of the vertex keys (rows/keys; the grid is "
                                 "rebuilt from the scene, on any number of ranks)"
                               : "FNV-1a 64 of the leaf vertex coordinates and cell vertex lists (the grid is rebuilt "
                                 "from the scene)");
    return;
  }
  r.set("grid/leaf_vertices", g.vertices, "vertices of the leaf meshes of all bodies (the stacked problem)");
  r.set("grid/leaf_cells", g.cells, "cells of the leaf meshes of all bodies");
  r.set("grid/leaf_checksum", hexHash(g.checksum),
        "FNV-1a 64 of the leaf vertex coordinates and cell vertex lists of the bodies in stacked order (the "
        "grids are rebuilt from the scene)");
  r.set("bodies/count", static_cast<long long>(bodies.size()),
        "bodies ([[body]] sections), stacked in this order in the scheme/ and run/ vectors");
  long long offset = 0;
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const GridIdentity own = bodyIdentity(bodies[b]);
    const std::string g0 = bodyGroup(b);
    r.set(g0 + "name", bodies[b].name, "the [[body]] name");
    r.set(g0 + "vertex_offset", offset,
          "first stacked vertex of the body: its entries of a scheme/ vector are [offset * d, (offset + "
          "leaf_vertices) * d)");
    r.set(g0 + "leaf_vertices", own.vertices, "vertices of the body's leaf mesh");
    r.set(g0 + "leaf_cells", own.cells, "cells of the body's leaf mesh");
    r.set(g0 + "leaf_checksum", hexHash(own.checksum),
          bodies[b].keyed ? "FNV-1a 64 of the body's cell count and the sum of its vertex keys"
                          : "FNV-1a 64 of the body's leaf vertex coordinates and cell vertex lists");
    offset += own.vertices;
  }
}

void checkRunScene(const CheckpointRecord& r, const std::filesystem::path& file, const std::string& kind,
                   const Scene& scene, const std::vector<std::string>& bodyNames) {
  const std::string where = file.string() + ": ";
  if (r.kind != kind)
    throw Error(where + "a checkpoint of " + article(r.kind.empty() ? "unknown" : r.kind) + " run, this is " +
                article(kind) + " run");
  try {
    // the bodies first: one body against several, their number and names
    std::vector<std::string> stored, now;
    if (r.has("bodies/count"))
      for (long long b = 0; b < r.integer("bodies/count"); ++b)
        stored.push_back(r.text(bodyGroup(static_cast<std::size_t>(b)) + "name"));
    if (scene.multiBody()) now = bodyNames;
    if (stored.empty() != now.empty())
      throw Error(stored.empty() ? "a checkpoint of a one-body run, " + scene.fileName + " is a multi-body scene with " +
                                       bodyList(now)
                                 : "a checkpoint of a multi-body run with " + bodyList(stored) + ", " + scene.fileName +
                                       " is a one-body scene");
    if (stored.size() != now.size())
      throw Error("a checkpoint of " + bodyList(stored) + ", " + scene.fileName + " has " + bodyList(now));
    for (std::size_t b = 0; b < stored.size(); ++b)
      if (stored[b] != now[b])
        throw Error("body " + std::to_string(b + 1) + " is '" + stored[b] + "' in the checkpoint, '" + now[b] + "' in " +
                    scene.fileName + " (checkpoint: " + bodyList(stored) + ", scene: " + bodyList(now) + ")");
    const std::string hash = sceneHash(scene);
    if (r.text("scene/hash") != hash) {
      std::string what;
      const std::vector<std::string> a = lines(r.text("scene/text")), b = lines(scene.text);
      for (std::size_t i = 0; i < std::max(a.size(), b.size()) && what.empty(); ++i) {
        const std::string x = i < a.size() ? a[i] : "(end of file)", y = i < b.size() ? b[i] : "(end of file)";
        if (x != y)
          what = "line " + std::to_string(i + 1) + " is " + quoted(y) + " in " + scene.fileName + ", " + quoted(x) +
                 " in the checkpoint's scene";
      }
      if (what.empty()) {  // the first override that differs (one line: the texts hold one per line)
        auto list = [](const std::string& text) {
          std::vector<std::string> out;
          for (const std::string& l : lines(text))
            if (!l.empty()) out.push_back(l);
          return out;
        };
        const std::vector<std::string> a = list(r.text("scene/overrides")), b = list(overridesText(scene.overrides));
        std::size_t i = 0;
        while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
        what = "the --set overrides differ: " + (i < b.size() ? quoted(b[i]) : std::string("none")) + " now, " +
               (i < a.size() ? quoted(a[i]) : std::string("none")) + " in the checkpoint (override " +
               std::to_string(i + 1) + ")";
      }
      throw Error("written for another scene (scene hash " + r.text("scene/hash") + ", " + scene.fileName +
                  " has " + hash + "): " + what);
    }
    const long long written = r.has("run/threads") ? r.integer("run/threads") : 1;
    if (written != threads())
      throw Error("written by a run with " + std::to_string(written) + " thread(s), this run has " +
                  std::to_string(threads()) + ": restart with --threads " + std::to_string(written) +
                  " (the sweep order depends on the thread count; the continued run would not be the "
                  "uninterrupted one bit for bit)");
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
}

void checkRunIdentity(const CheckpointRecord& r, const std::filesystem::path& file, const std::string& kind,
                      const Scene& scene, const std::vector<RunBody>& bodies) {
  std::vector<std::string> names;
  for (const RunBody& b : bodies) names.push_back(b.name);
  checkRunScene(r, file, kind, scene, names);
  const std::string where = file.string() + ": ";
  try {
    if (r.has("bodies/count")) {  // several bodies: the grid of each
      for (std::size_t b = 0; b < bodies.size(); ++b) {
        const GridIdentity own = bodyIdentity(bodies[b]);
        const std::string g0 = bodyGroup(b);
        const long long nv = r.integer(g0 + "leaf_vertices"), nc = r.integer(g0 + "leaf_cells");
        if (nv != own.vertices || nc != own.cells)
          throw Error("body '" + bodies[b].name + "' " + gridMismatch(nv, nc, own));
        if (r.text(g0 + "leaf_checksum") != hexHash(own.checksum))
          throw Error("body '" + bodies[b].name + "': the grid checksum differs (" + r.text(g0 + "leaf_checksum") +
                      " in the checkpoint, " + hexHash(own.checksum) + " now): the mesh was built differently");
      }
    }
    const GridIdentity g = gridIdentity(bodies);
    const long long nv = r.integer("grid/leaf_vertices"), nc = r.integer("grid/leaf_cells");
    if (nv != g.vertices || nc != g.cells) {
      if (bodies.size() == 1) throw Error(gridMismatch(nv, nc, g));
      throw Error("written for grids of " + std::to_string(nv) + " vertices / " + std::to_string(nc) +
                  " cells in all, this run has " + std::to_string(g.vertices) + " / " + std::to_string(g.cells));
    }
    if (r.text("grid/leaf_checksum") != hexHash(g.checksum))
      throw Error("the grid checksum differs (" + r.text("grid/leaf_checksum") + " in the checkpoint, " +
                  hexHash(g.checksum) + " now): the mesh was built differently");
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
}

void storeInitialGrid(CheckpointRecord& r, const std::vector<RunBody>& bodies) {
  const GridIdentity g = gridIdentity(bodies);
  r.set("initial_grid/leaf_vertices", g.vertices, "vertices of the initial leaf meshes (all bodies), before any refinement");
  r.set("initial_grid/leaf_cells", g.cells, "cells of the initial leaf meshes (all bodies)");
  r.set("initial_grid/leaf_checksum", hexHash(g.checksum),
        "FNV-1a 64 of the initial leaf vertex coordinates and cell vertex lists (bodies in stacked order): the "
        "grids the refinement history is replayed on");
}

void checkInitialGrid(const CheckpointRecord& r, const std::filesystem::path& file, const std::vector<RunBody>& bodies) {
  const std::string where = file.string() + ": ";
  try {
    const GridIdentity g = gridIdentity(bodies);
    const long long nv = r.integer("initial_grid/leaf_vertices"), nc = r.integer("initial_grid/leaf_cells");
    if (nv != g.vertices || nc != g.cells)
      throw Error("written for an initial grid of " + std::to_string(nv) + " vertices / " + std::to_string(nc) +
                  " cells, this run starts from " + std::to_string(g.vertices) + " / " + std::to_string(g.cells) +
                  " (another --refine?)");
    if (r.text("initial_grid/leaf_checksum") != hexHash(g.checksum))
      throw Error("the initial grid's checksum differs (" + r.text("initial_grid/leaf_checksum") +
                  " in the checkpoint, " + hexHash(g.checksum) + " now): the mesh was built differently");
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
}

bool CheckpointSchedule::due(int step) const {
  if (!spec_) return false;
  if (spec_->every && step % *spec_->every == 0) return true;
  return spec_->seconds && secondsSince(last_) >= *spec_->seconds;
}

InterruptGuard::InterruptGuard() {
  gSignal = 0;
  struct sigaction a {};
  a.sa_handler = onInterrupt;
  sigemptyset(&a.sa_mask);
  a.sa_flags = SA_RESETHAND;  // a second signal: the default action (terminate)
  sigaction(SIGINT, &a, &oldInt_);
  sigaction(SIGTERM, &a, &oldTerm_);
}

InterruptGuard::~InterruptGuard() {
  sigaction(SIGINT, &oldInt_, nullptr);
  sigaction(SIGTERM, &oldTerm_, nullptr);
}

bool InterruptGuard::requested() { return gSignal != 0; }

std::string InterruptGuard::signalName() {
  return gSignal == SIGINT ? "SIGINT" : gSignal == SIGTERM ? "SIGTERM" : "signal " + std::to_string(gSignal);
}

}  // namespace obs::drivers
