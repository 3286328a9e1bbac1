// The Newmark time stepper's state in a checkpoint record (Newmark.hpp: storeNewmarkState,
// loadNewmarkState), beside the stepper as the adaptive loop's is beside the loop.
#include "obs/obs/Newmark.hpp"

#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Checkpoint.hpp"

namespace obs {

void storeNewmarkState(CheckpointRecord& r, const NewmarkSchemeState& s) {
  r.set("scheme/name", s.scheme, "time stepping scheme (Newmark family, docs/dynamics.md)");
  r.set("scheme/step", static_cast<long long>(s.state.step), "time step index n of the state");
  r.set("scheme/time", s.state.time, "time t^n of the state");
  r.set("scheme/displacement", s.state.u, "u^n, vertex-major (x, y[, z] per leaf vertex)");
  r.set("scheme/velocity", s.state.v, "v^n, vertex-major");
  r.set("scheme/acceleration", s.state.a, "a^n, vertex-major (khenous-laborde-renard; empty otherwise)");
  r.set("scheme/multiplier", s.multiplier,
        "nodal contact multiplier lambda of the last step (c' tau^2 M F_con), vertex-major");
  r.set("scheme/previous_multiplier", s.previousMultiplier,
        "classical scheme: lambda^n entering the next right-hand side (zero for the other schemes)");
  r.set("scheme/last_step_counters",
        std::vector<long long>{s.activePredictor, s.predictorOnly, s.solutionOnly, s.solverIterations},
        "last step: nodes active in the predictor, in the predictor only, in the solution only; TNNMG iterations");
  if (s.previousVelocity.size() > 0 || s.nextSolverTolerance > 0) {  // inexact solves only
    r.set("scheme/previous_velocity", s.previousVelocity, "inexact solves: v^{n-1}, vertex-major (time-error estimate)");
    r.set("scheme/next_solver_tolerance", s.nextSolverTolerance,
          "inexact solves: TNNMG tolerance of the next step (0: the solver tolerance)");
  }
  if (s.previousIncrement.size() > 0)  // warm start from the previous increment only
    r.set("scheme/previous_increment", s.previousIncrement,
          "warm start previous-increment: the last step's increment u^n - base^{n-1} in the problem unknowns");
  if (s.frictionDissipation > 0)  // friction only
    r.set("scheme/friction_dissipation", s.frictionDissipation, "energy dissipated by friction up to t^n");
}

NewmarkSchemeState loadNewmarkState(const CheckpointRecord& r) {
  NewmarkSchemeState s;
  s.scheme = r.text("scheme/name");
  s.state.step = static_cast<int>(r.integer("scheme/step"));
  s.state.time = r.real("scheme/time");
  s.state.u = r.vector("scheme/displacement");
  s.state.v = r.vector("scheme/velocity");
  s.state.a = r.vector("scheme/acceleration");
  s.multiplier = r.vector("scheme/multiplier");
  s.previousMultiplier = r.vector("scheme/previous_multiplier");
  const std::vector<long long>& c = r.integers("scheme/last_step_counters");
  if (c.size() != 4) throw Error("checkpoint: entry 'scheme/last_step_counters' must hold 4 integers");
  s.activePredictor = static_cast<Index>(c[0]);
  s.predictorOnly = static_cast<Index>(c[1]);
  s.solutionOnly = static_cast<Index>(c[2]);
  s.solverIterations = static_cast<int>(c[3]);
  if (r.has("scheme/previous_velocity")) {
    s.previousVelocity = r.vector("scheme/previous_velocity");
    s.nextSolverTolerance = r.real("scheme/next_solver_tolerance");
  }
  if (r.has("scheme/previous_increment")) s.previousIncrement = r.vector("scheme/previous_increment");
  if (r.has("scheme/friction_dissipation")) s.frictionDissipation = r.real("scheme/friction_dissipation");
  return s;
}

}  // namespace obs
