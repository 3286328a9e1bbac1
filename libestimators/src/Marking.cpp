#include "obs/estimators/Marking.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

/// Throws unless every indicator is finite and >= 0; returns the largest one.
double checkIndicators(std::span<const double> eta, const char* strategy) {
  double largest = 0;
  for (std::size_t e = 0; e < eta.size(); ++e) {
    if (!(eta[e] >= 0) || !std::isfinite(eta[e]))
      throw Error(std::string("marking '") + strategy + "': indicator of cell " + std::to_string(e) +
                  " is " + std::to_string(eta[e]) + " (must be finite and >= 0)");
    largest = std::max(largest, eta[e]);
  }
  return largest;
}

void checkRange(const char* strategy, double theta, double lo, double hi) {
  if (!(theta >= lo && theta <= hi))
    throw Error(std::string("marking '") + strategy + "': parameter " + std::to_string(theta) +
                " outside [" + std::to_string(lo) + ", " +
                (std::isinf(hi) ? std::string("inf") : std::to_string(hi)) + "]");
}

/// Cell numbers by decreasing indicator, equal indicators by increasing cell number.
std::vector<Index> byDecreasingIndicator(std::span<const double> eta) {
  std::vector<Index> order(eta.size());
  std::iota(order.begin(), order.end(), Index(0));
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return eta[a] > eta[b]; });
  return order;
}

std::vector<Index> sorted(std::vector<Index> v) {
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

std::vector<Index> markMeanValue(std::span<const double> eta, double theta) {
  checkRange("mean", theta, 0, INFINITY);
  if (checkIndicators(eta, "mean") == 0) return {};
  double sum = 0;
  for (double x : eta) sum += x * x;
  const double threshold = theta * theta * sum / static_cast<double>(eta.size());
  std::vector<Index> marked;
  for (std::size_t e = 0; e < eta.size(); ++e)
    if (eta[e] * eta[e] >= threshold) marked.push_back(static_cast<Index>(e));
  return marked;
}

std::vector<Index> markDoerfler(std::span<const double> eta, double theta) {
  checkRange("doerfler", theta, 0, 1);
  if (checkIndicators(eta, "doerfler") == 0) return {};
  double total = 0;
  for (double x : eta) total += x * x;
  const double goal = theta * total;
  std::vector<Index> marked;
  double sum = 0;
  for (Index e : byDecreasingIndicator(eta)) {
    if (sum >= goal) break;
    marked.push_back(e);
    sum += eta[e] * eta[e];
  }
  return sorted(std::move(marked));
}

std::vector<Index> markMaximum(std::span<const double> eta, double theta) {
  checkRange("maximum", theta, 0, 1);
  const double largest = checkIndicators(eta, "maximum");
  if (largest == 0) return {};
  std::vector<Index> marked;
  for (std::size_t e = 0; e < eta.size(); ++e)
    if (eta[e] >= theta * largest) marked.push_back(static_cast<Index>(e));
  return marked;
}

std::vector<Index> markFixedFraction(std::span<const double> eta, double fraction) {
  checkRange("fraction", fraction, 0, 1);
  if (checkIndicators(eta, "fraction") == 0) return {};
  const double n = fraction * static_cast<double>(eta.size());
  const auto count = static_cast<std::size_t>(std::ceil(n * (1 - 1e-12)));
  std::vector<Index> order = byDecreasingIndicator(eta);
  order.resize(std::min(count, order.size()));
  return sorted(std::move(order));
}

std::vector<char> markedFlags(std::span<const Index> marked, Index numCells) {
  std::vector<char> flags(static_cast<std::size_t>(numCells), 0);
  for (Index e : marked) {
    if (e < 0 || e >= numCells)
      throw Error("marked cell " + std::to_string(e) + " outside [0, " + std::to_string(numCells) +
                  ")");
    flags[static_cast<std::size_t>(e)] = 1;
  }
  return flags;
}

// --- MarkingStrategy --------------------------------------------------------------------------------

namespace {
struct StrategyRow {
  const char* name;
  const char* description;
  double defaultParameter;
  std::vector<Index> (*mark)(std::span<const double>, double);
};

const StrategyRow kStrategies[] = {
    {"doerfler", "smallest set holding the fraction theta of eta^2 (bulk criterion)", 0.5,
     &markDoerfler},
    {"fraction", "the fraction theta of the cells with the largest indicators", 0.2,
     &markFixedFraction},
    {"maximum", "cells with eta_e >= theta * max eta_e", 0.5, &markMaximum},
    {"mean", "cells with eta_e^2 >= theta^2 * mean eta_e^2 (thesis Sec. 4.1.1)", 1.1,
     &markMeanValue},
};
}  // namespace

MarkingStrategy::MarkingStrategy(const std::string& name, std::optional<double> parameter) {
  for (const StrategyRow& row : kStrategies)
    if (name == row.name) {
      name_ = name;
      parameter_ = parameter.value_or(row.defaultParameter);
      mark_ = row.mark;
      // validate the parameter now rather than at the first mark() call
      mark_(std::span<const double>(), parameter_);
      return;
    }
  std::string known;
  for (const StrategyRow& row : kStrategies) known += (known.empty() ? "" : ", ") + std::string(row.name);
  throw Error("unknown marking strategy '" + name + "' (known: " + known + ")");
}

std::vector<Index> MarkingStrategy::mark(std::span<const double> indicators) const {
  return mark_(indicators, parameter_);
}

std::vector<MarkingStrategy::Info> MarkingStrategy::available() {
  std::vector<Info> info;
  for (const StrategyRow& row : kStrategies)
    info.push_back({row.name, row.description, row.defaultParameter});
  return info;
}

}  // namespace obs::estimators
