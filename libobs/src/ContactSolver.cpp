#include "obs/obs/ContactSolver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "obs/mesh/Error.hpp"

namespace obs {
namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

}  // namespace

IterationMonitor::IterationMonitor(std::string solver, const ContactSolverOptions& options, double initialEnergy)
    : solver_(std::move(solver)), options_(options), start_(std::chrono::steady_clock::now()),
      initialEnergy_(initialEnergy), minEnergy_(initialEnergy), previousEnergy_(initialEnergy),
      lastEnergy_(initialEnergy), bestCorrection_(std::numeric_limits<double>::infinity()) {
  if (!std::isfinite(initialEnergy))
    throw Error(solver_ + ": the energy of the start vector is " + num(initialEnergy) +
                " (NaN or Inf in the problem data or the start?)");
  if (!(options.tolerance >= 0) || options.maxIterations < 0 || options.stagnationIterations < 1 ||
      !(options.divergenceFactor > 0))
    throw Error(solver_ + ": invalid options (tolerance >= 0, maxIterations >= 0, stagnationIterations >= 1, "
                "divergenceFactor > 0 required)");
}

bool IterationMonitor::record(double energy, double correction, Index activeSetSize, Index truncationChanges,
                              double errorBound) {
  ++iteration_;
  const std::string at = solver_ + ", iteration " + std::to_string(iteration_) + ": ";
  if (!std::isfinite(energy) || !std::isfinite(correction))
    throw Error(at + "NaN or Inf in the iterate (energy " + num(energy) + ", correction " + num(correction) + ")");
  const double scale = std::max({std::abs(initialEnergy_), std::abs(minEnergy_), 1e-300});
  if (energy > initialEnergy_ + options_.divergenceFactor * scale)
    throw Error(at + "diverged: energy " + num(energy) + " against " + num(initialEnergy_) + " at the start");

  bool progress = false;
  if (energy < minEnergy_ - 1e-14 * scale) {
    minEnergy_ = energy;
    progress = true;
  }
  if (correction < (1 - 1e-6) * bestCorrection_) {
    bestCorrection_ = correction;
    progress = true;
  }
  sinceProgress_ = progress ? 0 : sinceProgress_ + 1;
  const bool converged = correction < options_.tolerance || errorBound < options_.tolerance;  // NaN: false
  if (!converged && sinceProgress_ >= options_.stagnationIterations)
    throw Error(at + "stagnated: no decrease of energy or correction in " +
                std::to_string(options_.stagnationIterations) + " iterations (correction " + num(correction) +
                ", tolerance " + num(options_.tolerance) + ")");

  if (iteration_ == 1) firstCorrection_ = correction;
  previousEnergy_ = lastEnergy_;
  lastEnergy_ = energy;
  lastCorrection_ = correction;
  lastErrorBound_ = errorBound;
  const IterationRecord record{iteration_, energy, correction, activeSetSize, truncationChanges, errorBound};
  if (options_.recordHistory) history_.push_back(record);
  if (options_.onIteration) options_.onIteration(record);
  return converged;
}

void IterationMonitor::requireMonotone(double scale) const {
  if (lastEnergy_ > previousEnergy_ + 1e-10 * std::max(scale, 1e-300))
    throw Error(solver_ + ", iteration " + std::to_string(iteration_) + ": the energy increased from " +
                num(previousEnergy_) + " to " + num(lastEnergy_) +
                " (the method is monotone: is the matrix symmetric positive definite?)");
}

ContactResult IterationMonitor::finish(bool converged, Index activeSetSize) {
  ContactResult r;
  r.solver = solver_;
  r.iterations = iteration_;
  r.converged = converged;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  r.correction = lastCorrection_;
  r.errorBound = lastErrorBound_;
  r.energy = lastEnergy_;
  r.activeSetSize = activeSetSize;
  if (iteration_ >= 2 && firstCorrection_ > 0 && lastCorrection_ > 0)
    r.convergenceRate = std::pow(lastCorrection_ / firstCorrection_, 1.0 / (iteration_ - 1));
  r.history = std::move(history_);
  return r;
}

}  // namespace obs
