// The adaptive loop's state in a checkpoint record (AdaptiveLoop.hpp storeAdaptiveState /
// loadAdaptiveState; the entries are listed in docs/checkpoint.md#adaptive-runs).
//
// The step records are stored as columns: one dataset per field, one value per step (per step and
// body, per step and coupling, ...). Each record type has one list of its fields (the *Fields
// functions below) that both directions walk, so what is stored and what is loaded cannot drift
// apart.
#include <map>
#include <string>
#include <vector>

#include "obs/estimators/AdaptiveLoop.hpp"
#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

const std::string kPrefix = "adaptivity/";

template <class S, class F>
void stepFields(S& s, F& f) {
  f("step", "k", s.step);
  f("cells", "cells of the leaf views (all bodies)", s.cells);
  f("vertices", "vertices of the leaf views (all bodies)", s.vertices);
  f("unknowns", "d * vertices", s.unknowns);
  f("potential_contact", "potential contact vertices N^C", s.potentialContact);
  f("actual_contact", "actual contact vertices", s.actualContact);
  f("semi_contact", "semi contact vertices", s.semiContact);
  f("full_contact", "full contact vertices", s.fullContact);
  f("eta", "the estimate eta (NaN: not estimated)", s.eta);
  f("eoc", "experimental order of convergence against the previous step (NaN: none)", s.eoc);
  f("solver", "the solver of the step (one name per line)", s.solver);
  f("solver_iterations", "iterations of the solver", s.solverIterations);
  f("solver_tolerance", "relative tolerance the step was solved to", s.solverTolerance);
  f("converged", "1 if the solver reached its tolerance", s.converged);
  f("kkt", "max KKT residual of the solution", s.kkt);
  f("load", "sum of the contact multipliers mu_p", s.load);
  f("assembly_seconds", "wall time of the assembly", s.assemblySeconds);
  f("solver_seconds", "wall time of the solve", s.solverSeconds);
  f("estimator_seconds", "wall time of the estimate", s.estimatorSeconds);
  f("refinement_seconds", "wall time of marking and refinement after the step", s.refinementSeconds);
  f("transfer_seconds", "wall time of building the step's start vector", s.transferSeconds);
  f("marked", "cells marked after the step (all bodies)", s.marked);
  f("refined_red", "elements refined red after the step (all bodies)", s.refinedRed);
  f("closure_red", "of these, the ones only the marking closure refined", s.closureRed);
  f("green_closed", "elements given a green closure after the step", s.greenClosed);
}

template <class S, class F>
void referenceFields(S& r, F& f) {
  f("load", "computed load P", r.load);
  f("pressure_error", "relative L2 error of the pressure", r.pressureError);
  f("radius", "measured contact radius", r.radius);
  f("exact_radius", "exact contact radius b(P)", r.exactRadius);
  f("radius_error", "|radius - b| / b", r.radiusError);
  f("centre_vertex", "leaf vertex nearest to the centre", r.centreVertex);
  f("centre_pressure", "s_c", r.centrePressure);
  f("exact_centre_pressure", "p(x_c, P)", r.exactCentrePressure);
  f("centre_error", "|s_c - p(x_c)| / p(x_c)", r.centreError);
}

template <class S, class F>
void bodyFields(S& b, F& f) {
  f("cells", "cells of the body's leaf view", b.cells);
  f("vertices", "vertices of the body's leaf view", b.vertices);
  f("eta", "the body's estimate (NaN: none)", b.eta);
  f("marked", "the body's cells marked after the step", b.marked);
}

template <class S, class F>
void couplingFields(S& c, F& f) {
  f("label", "the coupling's label (one per line)", c.label);
  f("mortar", "1 for a mortar pair, 0 for an obstacle", c.mortar);
  f("slave_body", "the constrained body", c.slaveBody);
  f("master_body", "the master body (-1 for obstacles)", c.masterBody);
  f("slave_vertices", "vertices of the constrained boundary", c.slaveVertices);
  f("potential_vertices", "constrained nodes", c.potentialVertices);
  f("actual_vertices", "nodes in actual contact", c.actualVertices);
  f("force_slave", "total force on the constrained body (x, y, z per entry)", c.forceSlave);
  f("force_master", "total force on the master body (x, y, z per entry)", c.forceMaster);
  f("load", "sum of the multipliers mu_p", c.load);
  f("pressure_min", "smallest pressure over the actual contact nodes", c.pressureMin);
  f("pressure_max", "largest pressure over the actual contact nodes", c.pressureMax);
  f("area", "measure of the faces in contact", c.area);
  f("max_violation", "max (nu_p'x_p - g_p)^+", c.maxViolation);
  f("segments", "mortar segments", c.segments);
  f("uncovered", "slave nodes not covered by the master", c.uncovered);
  f("mortar_seconds", "wall time of the mortar assembly", c.mortarSeconds);
}

/// Collects one column per field over the items it is applied to, then stores them.
class ColumnWriter {
public:
  ColumnWriter(std::string group, std::string of) : group_(std::move(group)), of_(std::move(of)) {}
  void operator()(const char* name, const char* what, const double& x) { reals(name, what).push_back(x); }
  void operator()(const char* name, const char* what, const int& x) { integers(name, what).push_back(x); }
  void operator()(const char* name, const char* what, const bool& x) { integers(name, what).push_back(x ? 1 : 0); }
  void operator()(const char* name, const char* what, const Eigen::Vector3d& x) {
    for (int i = 0; i < 3; ++i) reals(name, what).push_back(x[i]);
  }
  void operator()(const char* name, const char* what, const std::string& x) {
    if (x.find('\n') != std::string::npos) throw Error("adaptive checkpoint: '" + x + "' contains a line break");
    std::string& t = text(name, what);
    t += (count_[name]++ ? "\n" : "") + x;
  }
  void store(CheckpointRecord& r) const {
    for (const auto& [name, c] : reals_) {
      Eigen::VectorXd v(static_cast<Eigen::Index>(c.values.size()));
      for (std::size_t i = 0; i < c.values.size(); ++i) v[static_cast<Eigen::Index>(i)] = c.values[i];
      r.set(group_ + name, std::move(v), c.what + ", " + of_);
    }
    for (const auto& [name, c] : integers_) r.set(group_ + name, c.values, c.what + ", " + of_);
    for (const auto& [name, c] : texts_) r.set(group_ + name, c.values, c.what + ", " + of_);
  }

private:
  template <class T>
  struct Column {
    T values{};
    std::string what;
  };
  std::vector<double>& reals(const char* name, const char* what) { return entry(reals_, name, what).values; }
  std::vector<long long>& integers(const char* name, const char* what) { return entry(integers_, name, what).values; }
  std::string& text(const char* name, const char* what) { return entry(texts_, name, what).values; }
  template <class M>
  static typename M::mapped_type& entry(M& m, const char* name, const char* what) {
    auto& c = m[name];
    c.what = what;
    return c;
  }
  std::string group_, of_;
  std::map<std::string, Column<std::vector<double>>> reals_;
  std::map<std::string, Column<std::vector<long long>>> integers_;
  std::map<std::string, Column<std::string>> texts_;
  std::map<std::string, std::size_t> count_;
};

/// Reads item `at` of the columns a ColumnWriter stored under `group` (obs::Error naming a missing
/// entry or a column too short for the items).
class ColumnReader {
public:
  ColumnReader(const CheckpointRecord& r, std::string group, std::size_t items)
      : r_(r), group_(std::move(group)), items_(items) {}
  std::size_t at = 0;
  void operator()(const char* name, const char*, double& x) { x = real(name, 1)[static_cast<Eigen::Index>(at)]; }
  void operator()(const char* name, const char*, int& x) { x = static_cast<int>(integer(name)[at]); }
  void operator()(const char* name, const char*, bool& x) { x = integer(name)[at] != 0; }
  void operator()(const char* name, const char*, Eigen::Vector3d& x) {
    x = real(name, 3).segment<3>(static_cast<Eigen::Index>(3 * at));
  }
  void operator()(const char* name, const char*, std::string& x) {
    auto it = lines_.find(name);
    if (it == lines_.end()) {
      std::vector<std::string> lines;
      const std::string& text = r_.text(group_ + name);
      for (std::size_t from = 0;;) {
        const std::size_t end = text.find('\n', from);
        lines.push_back(text.substr(from, end == std::string::npos ? std::string::npos : end - from));
        if (end == std::string::npos) break;
        from = end + 1;
      }
      if (lines.size() != items_) mismatch(name, lines.size(), items_);
      it = lines_.emplace(name, std::move(lines)).first;
    }
    x = it->second[at];
  }

private:
  const Eigen::VectorXd& real(const char* name, std::size_t width) {
    const Eigen::VectorXd& v = r_.vector(group_ + name);
    if (static_cast<std::size_t>(v.size()) != width * items_) mismatch(name, static_cast<std::size_t>(v.size()), width * items_);
    return v;
  }
  const std::vector<long long>& integer(const char* name) {
    const std::vector<long long>& v = r_.integers(group_ + name);
    if (v.size() != items_) mismatch(name, v.size(), items_);
    return v;
  }
  [[noreturn]] void mismatch(const char* name, std::size_t has, std::size_t expected) const {
    throw Error("checkpoint entry '" + group_ + name + "' has " + std::to_string(has) + " values, expected " +
                std::to_string(expected));
  }
  const CheckpointRecord& r_;
  std::string group_;
  std::size_t items_ = 0;
  std::map<std::string, std::vector<std::string>> lines_;
};

std::size_t total(const std::vector<long long>& counts) {
  long long n = 0;
  for (long long c : counts) {
    if (c < 0) throw Error("adaptive checkpoint: a negative count");
    n += c;
  }
  return static_cast<std::size_t>(n);
}

}  // namespace

void storeAdaptiveState(CheckpointRecord& r, const AdaptiveLoopState& state) {
  const std::size_t n = state.steps.size();
  if (state.refinements.size() != n || state.nextStep != static_cast<int>(n))
    throw Error("adaptive checkpoint: the state before step " + std::to_string(state.nextStep) + " has " +
                std::to_string(n) + " records and " + std::to_string(state.refinements.size()) + " refinements");
  r.set(kPrefix + "next_step", static_cast<long long>(state.nextStep),
        "the step the restarted loop continues with (k + 1 after step k)");
  const std::size_t nb = n ? state.refinements.front().size() : 0;
  r.set(kPrefix + "body_count", static_cast<long long>(nb), "bodies of the loop (the per-body columns hold steps * bodies values)");

  // the refinement history
  std::vector<long long> counts, cells;
  for (const auto& step : state.refinements) {
    if (step.size() != nb) throw Error("adaptive checkpoint: the refinements have different numbers of bodies");
    for (const auto& marked : step) {
      counts.push_back(static_cast<long long>(marked.size()));
      cells.insert(cells.end(), marked.begin(), marked.end());
    }
  }
  r.set(kPrefix + "refinement/marked_counts", counts,
        "cells of body b's leaf view marked after step j, at j * body_count + b (uniform refinement: 0, every cell "
        "is refined)");
  r.set(kPrefix + "refinement/marked_cells", cells,
        "the marked cells (indices into the step's leaf view of the body, as in the .vtu), step by step, body by "
        "body; replayed with Grid::mark + Grid::adapt on the scene's initial grids");

  r.set(kPrefix + "start", state.start,
        "start vector of step next_step: the last solution interpolated to the refined leaf views, stacked over "
        "the bodies, vertex-major (empty: cold start)");
  r.set(kPrefix + "transfer_seconds", state.transferSeconds, "wall time of building the start vector");
  r.set(kPrefix + "inexact/last_rate", state.lastRate,
        "convergence rate of the last contact solve (input of the next inexact tolerance)");
  r.set(kPrefix + "inexact/last_energy_norm", state.lastEnergyNorm,
        "energy norm of the last solution (input of the next inexact tolerance)");

  // the step records
  ColumnWriter steps(kPrefix + "steps/", "one value per step");
  ColumnWriter bodies(kPrefix + "steps/bodies/", "per step and body (step * body_count + body)");
  ColumnWriter references(kPrefix + "steps/reference/", "per step with has_reference = 1");
  ColumnWriter couplings(kPrefix + "steps/couplings/", "per step and coupling (coupling_counts per step)");
  ColumnWriter contributions(kPrefix + "steps/contributions/", "per step and contribution (contribution_counts)");
  std::vector<long long> hasReference, couplingCounts, contributionCounts;
  for (const AdaptiveStep& s : state.steps) {
    stepFields(s, steps);
    if (s.bodies.size() != nb) throw Error("adaptive checkpoint: a step record with another number of bodies");
    for (const BodyRecord& b : s.bodies) bodyFields(b, bodies);
    hasReference.push_back(s.reference ? 1 : 0);
    if (s.reference) referenceFields(*s.reference, references);
    couplingCounts.push_back(static_cast<long long>(s.couplings.size()));
    for (const CouplingRecord& c : s.couplings) couplingFields(c, couplings);
    contributionCounts.push_back(static_cast<long long>(s.contributions.size()));
    for (const Contribution& c : s.contributions) {
      contributions("name", "the contribution's name", c.name);
      contributions("value", "eta_k", c.value);
    }
  }
  // (a column no item has is not stored; the reader reads no column for zero items)
  steps.store(r);
  bodies.store(r);
  references.store(r);
  couplings.store(r);
  contributions.store(r);
  r.set(kPrefix + "steps/has_reference", hasReference, "1 if the step has reference errors (steps/reference/...)");
  r.set(kPrefix + "steps/coupling_counts", couplingCounts, "couplings recorded per step");
  r.set(kPrefix + "steps/contribution_counts", contributionCounts, "estimator contributions per step");
}

AdaptiveLoopState loadAdaptiveState(const CheckpointRecord& r) {
  AdaptiveLoopState state;
  state.nextStep = static_cast<int>(r.integer(kPrefix + "next_step"));
  const long long nbl = r.integer(kPrefix + "body_count");
  if (state.nextStep < 1 || nbl < 1)
    throw Error("adaptive checkpoint: next_step " + std::to_string(state.nextStep) + " and body_count " +
                std::to_string(nbl) + " must be positive");
  const std::size_t n = static_cast<std::size_t>(state.nextStep), nb = static_cast<std::size_t>(nbl);

  const std::vector<long long>& counts = r.integers(kPrefix + "refinement/marked_counts");
  const std::vector<long long>& cells = r.integers(kPrefix + "refinement/marked_cells");
  if (counts.size() != n * nb || total(counts) != cells.size())
    throw Error("adaptive checkpoint: the refinement history (" + std::to_string(counts.size()) + " counts, " +
                std::to_string(cells.size()) + " cells) does not fit " + std::to_string(n) + " steps of " +
                std::to_string(nb) + " bodies");
  std::size_t at = 0;
  state.refinements.assign(n, std::vector<std::vector<Index>>(nb));
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t b = 0; b < nb; ++b)
      for (long long c = 0; c < counts[j * nb + b]; ++c) state.refinements[j][b].push_back(static_cast<Index>(cells[at++]));

  state.start = r.vector(kPrefix + "start");
  state.transferSeconds = r.real(kPrefix + "transfer_seconds");
  state.lastRate = r.real(kPrefix + "inexact/last_rate");
  state.lastEnergyNorm = r.real(kPrefix + "inexact/last_energy_norm");

  const std::vector<long long> hasReference = r.integers(kPrefix + "steps/has_reference");
  const std::vector<long long> couplingCounts = r.integers(kPrefix + "steps/coupling_counts");
  const std::vector<long long> contributionCounts = r.integers(kPrefix + "steps/contribution_counts");
  if (hasReference.size() != n || couplingCounts.size() != n || contributionCounts.size() != n)
    throw Error("adaptive checkpoint: the per-step counts do not have " + std::to_string(n) + " entries");
  ColumnReader steps(r, kPrefix + "steps/", n);
  ColumnReader bodies(r, kPrefix + "steps/bodies/", n * nb);
  ColumnReader references(r, kPrefix + "steps/reference/", total(hasReference));
  ColumnReader couplings(r, kPrefix + "steps/couplings/", total(couplingCounts));
  ColumnReader contributions(r, kPrefix + "steps/contributions/", total(contributionCounts));
  for (std::size_t j = 0; j < n; ++j) {
    AdaptiveStep s;
    steps.at = j;
    stepFields(s, steps);
    s.bodies.resize(nb);
    for (BodyRecord& b : s.bodies) {
      bodyFields(b, bodies);
      ++bodies.at;
    }
    if (hasReference[j]) {
      s.reference.emplace();
      referenceFields(*s.reference, references);
      ++references.at;
    }
    s.couplings.resize(static_cast<std::size_t>(couplingCounts[j]));
    for (CouplingRecord& c : s.couplings) {
      couplingFields(c, couplings);
      ++couplings.at;
    }
    s.contributions.resize(static_cast<std::size_t>(contributionCounts[j]));
    for (Contribution& c : s.contributions) {
      contributions("name", "", c.name);
      contributions("value", "", c.value);
      ++contributions.at;
    }
    state.steps.push_back(std::move(s));
  }
  return state;
}

}  // namespace obs::estimators
