#include "RunCheckpoint.hpp"

#include <algorithm>
#include <sstream>

#include "obs/mesh/Error.hpp"

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

std::string quoted(std::string s) {
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return "'" + s + "'";
}

}  // namespace

std::string sceneHash(const Scene& scene) {
  const std::string o = overridesText(scene.overrides);
  return hexHash(fnv1a(o.data(), o.size(), fnv1a(scene.text.data(), scene.text.size())));
}

namespace {

std::uint64_t gridChecksum(const mesh::Mesh& leaf) {
  std::uint64_t h = kFnvOffset;
  for (const mesh::Point& x : leaf.vertices()) h = fnv1a(x.data(), sizeof(double) * 3, h);
  for (mesh::Index c = 0; c < leaf.numCells(); ++c) {
    const auto v = leaf.cellVertices(c);
    h = fnv1a(v.data(), v.size_bytes(), h);
  }
  return h;
}

}  // namespace

void storeRunIdentity(CheckpointRecord& r, const Scene& scene, const mesh::Mesh& leaf) {
  r.set("scene/text", scene.text, "the scene file as read (TOML)");
  r.set("scene/overrides", overridesText(scene.overrides), "the obs run --set overrides, one '--set ...' per line");
  r.set("scene/hash", sceneHash(scene), "FNV-1a 64 of scene/text followed by scene/overrides");
  r.set("grid/leaf_vertices", static_cast<long long>(leaf.numVertices()), "vertices of the leaf mesh");
  r.set("grid/leaf_cells", static_cast<long long>(leaf.numCells()), "cells of the leaf mesh");
  r.set("grid/leaf_checksum", hexHash(gridChecksum(leaf)),
        "FNV-1a 64 of the leaf vertex coordinates and cell vertex lists (the grid is rebuilt from the scene)");
}

void checkRunIdentity(const CheckpointRecord& r, const std::filesystem::path& file, const std::string& kind,
                      const Scene& scene, const mesh::Mesh& leaf) {
  const std::string where = file.string() + ": ";
  if (r.kind != kind)
    throw Error(where + "a checkpoint of a " + (r.kind.empty() ? "unknown" : r.kind) + " run, this is a " + kind +
                " run");
  try {
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
      if (what.empty()) {
        const std::string o = overridesText(scene.overrides);
        what = "the --set overrides differ (" + quoted(o.empty() ? "none" : o.substr(1)) + " now, " +
               quoted(r.text("scene/overrides").empty() ? "none" : r.text("scene/overrides").substr(1)) +
               " in the checkpoint)";
      }
      throw Error("written for another scene (scene hash " + r.text("scene/hash") + ", " + scene.fileName +
                  " has " + hash + "): " + what);
    }
    const long long nv = r.integer("grid/leaf_vertices"), nc = r.integer("grid/leaf_cells");
    if (nv != leaf.numVertices() || nc != leaf.numCells())
      throw Error("written for a grid of " + std::to_string(nv) + " vertices / " + std::to_string(nc) +
                  " cells, this run has " + std::to_string(leaf.numVertices()) + " / " +
                  std::to_string(leaf.numCells()) + " (another --refine?)");
    if (r.text("grid/leaf_checksum") != hexHash(gridChecksum(leaf)))
      throw Error("the grid checksum differs (" + r.text("grid/leaf_checksum") + " in the checkpoint, " +
                  hexHash(gridChecksum(leaf)) + " now): the mesh was built differently");
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
