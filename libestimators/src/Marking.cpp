#include "obs/estimators/Marking.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

void checkRange(const char* strategy, double theta, double lo, double hi) {
  if (!(theta >= lo && theta <= hi))
    throw Error(std::string("marking '") + strategy + "': parameter " + std::to_string(theta) +
                " outside [" + std::to_string(lo) + ", " +
                (std::isinf(hi) ? std::string("inf") : std::to_string(hi)) + "]");
}

/// The bit pattern of a non-negative double, ordered as the values (-0 as +0).
std::uint64_t bitsOf(double x) { return x == 0 ? 0 : std::bit_cast<std::uint64_t>(x); }

/// Selection over the cells of all ranks, each cell (bits of eta, key): counts and sums by
/// reductions, the searches by 16-way bisection (one reduction of 15 values per round, so 16
/// rounds over 64 bits).
class Selection {
public:
  Selection(std::span<const double> eta, std::span<const std::uint64_t> keys, const Communicator& comm)
      : eta_(eta), keys_(keys), comm_(comm) {
    for (double x : eta) bits_.push_back(bitsOf(x));
    // the bit patterns ascending, and the sums of eta^2 from the largest down (as the greedy sum)
    sortedBits_ = bits_;
    std::sort(sortedBits_.begin(), sortedBits_.end());
    fromTop_.assign(sortedBits_.size() + 1, 0.0);
    for (std::size_t i = sortedBits_.size(); i-- > 0;) {
      const double x = std::bit_cast<double>(sortedBits_[i]);
      fromTop_[i] = fromTop_[i + 1] + x * x;
    }
  }

  /// The last x in [lo, hi] with test(F(x)) true, where test(F(lo)) is true and test(F(x)) is
  /// true up to some x and false after it; F(x) is the sum over the ranks of local(x).
  template <class Local, class Test>
  std::uint64_t lastTrue(std::uint64_t lo, std::uint64_t hi, Local local, Test test) const {
    constexpr std::uint64_t kWays = 16;
    while (lo < hi) {
      const std::uint64_t step = (hi - lo) / kWays + 1;
      std::vector<std::uint64_t> pivots;
      for (std::uint64_t j = 1; j < kWays && j * step <= hi - lo; ++j) pivots.push_back(lo + j * step);
      std::vector<double> values;
      for (std::uint64_t x : pivots) values.push_back(local(x));
      comm_.sum(values);
      std::uint64_t next = hi;  // the last x that may still be true
      for (std::size_t j = 0; j < pivots.size(); ++j)
        if (test(values[j])) {
          lo = pivots[j];
        } else {
          next = pivots[j] - 1;
          break;
        }
      hi = next;
    }
    return lo;
  }
  /// This rank's cells with bits >= b, and the sum of their eta^2.
  double countFrom(std::uint64_t b) const {
    return static_cast<double>(sortedBits_.end() - std::lower_bound(sortedBits_.begin(), sortedBits_.end(), b));
  }
  double squaresFrom(std::uint64_t b) const {
    return fromTop_[static_cast<std::size_t>(std::lower_bound(sortedBits_.begin(), sortedBits_.end(), b) -
                                              sortedBits_.begin())];
  }
  /// Marks the cells above the tie value b (bits > b) and the m cells of value b of smallest keys.
  std::vector<Index> above(std::uint64_t b, long long m) const {
    // the smallest K with m ties of key <= K: the last x with fewer than m ties of key < x
    std::vector<std::uint64_t> tieKeys;
    for (std::size_t e = 0; e < bits_.size(); ++e)
      if (bits_[e] == b) tieKeys.push_back(keys_[e]);
    std::sort(tieKeys.begin(), tieKeys.end());
    const std::uint64_t K =
        m <= 0 ? 0
               : lastTrue(
                     0, std::numeric_limits<std::uint64_t>::max(),
                     [&](std::uint64_t x) {
                       return static_cast<double>(std::lower_bound(tieKeys.begin(), tieKeys.end(), x) - tieKeys.begin());
                     },
                     [&](double n) { return n < static_cast<double>(m); });
    std::vector<Index> marked;
    for (std::size_t e = 0; e < bits_.size(); ++e)
      if (bits_[e] > b || (m > 0 && bits_[e] == b && keys_[e] <= K)) marked.push_back(static_cast<Index>(e));
    return marked;
  }

  /// Global count and sum of squares of the cells with bits >= b.
  double globalCount(std::uint64_t b) const { return comm_.sum(countFrom(b)); }
  double globalSquares(std::uint64_t b) const { return comm_.sum(squaresFrom(b)); }

  /// The k cells first in the order (eta decreasing, key increasing).
  std::vector<Index> first(long long k, std::uint64_t top) const {
    if (k <= 0) return {};
    const auto goal = static_cast<double>(k);
    const std::uint64_t b = lastTrue(0, top, [&](std::uint64_t x) { return countFrom(x); },
                                     [&](double n) { return n >= goal; });
    return above(b, k - static_cast<long long>(globalCount(b + 1)));
  }

private:
  std::span<const double> eta_;
  std::span<const std::uint64_t> keys_;
  const Communicator& comm_;
  std::vector<std::uint64_t> bits_, sortedBits_;
  std::vector<double> fromTop_;  ///< fromTop_[i]: sum of eta^2 over sortedBits_[i..]
};

/// The cells 0, 1, ..., n - 1 of one process as their own keys.
std::vector<std::uint64_t> cellKeys(std::size_t n) {
  std::vector<std::uint64_t> keys(n);
  std::iota(keys.begin(), keys.end(), std::uint64_t(0));
  return keys;
}

}  // namespace

std::vector<Index> markMeanValue(std::span<const double> eta, double theta) {
  return MarkingStrategy("mean", theta).mark(eta);
}

std::vector<Index> markDoerfler(std::span<const double> eta, double theta) {
  return MarkingStrategy("doerfler", theta).mark(eta);
}

std::vector<Index> markMaximum(std::span<const double> eta, double theta) {
  return MarkingStrategy("maximum", theta).mark(eta);
}

std::vector<Index> markFixedFraction(std::span<const double> eta, double fraction) {
  return MarkingStrategy("fraction", fraction).mark(eta);
}

std::vector<Index> markOwned(const MarkingStrategy& strategy, std::span<const double> eta,
                             std::span<const std::uint64_t> keys, const Communicator& comm) {
  const std::string& name = strategy.name();
  const double theta = strategy.parameter();
  double local = 0;  // this rank's largest indicator
  comm.collective([&] {
    if (eta.size() != keys.size())
      throw Error("marking '" + name + "': " + std::to_string(eta.size()) + " indicators and " +
                  std::to_string(keys.size()) + " cell keys");
    double largest = 0;
    for (std::size_t e = 0; e < eta.size(); ++e) {
      const double x = eta[e];
      if (!(x >= 0) || !std::isfinite(x))
        throw Error("marking '" + name + "': indicator of cell " + std::to_string(e) + " is " + std::to_string(x) +
                    " (must be finite and >= 0)");
      largest = std::max(largest, x);
    }
    local = largest;
  });
  const std::uint64_t top = bitsOf(comm.max(local));  // the largest indicator of all ranks
  if (top == 0) return {};                            // every indicator zero: nothing marked
  std::vector<Index> marked;
  if (name == "mean") {
    std::vector<double> sums{0, static_cast<double>(eta.size())};
    for (double x : eta) sums[0] += x * x;
    comm.sum(sums);
    const double threshold = theta * theta * sums[0] / sums[1];
    for (std::size_t e = 0; e < eta.size(); ++e)
      if (eta[e] * eta[e] >= threshold) marked.push_back(static_cast<Index>(e));
  } else if (name == "maximum") {
    const double largest = std::bit_cast<double>(top);
    for (std::size_t e = 0; e < eta.size(); ++e)
      if (eta[e] >= theta * largest) marked.push_back(static_cast<Index>(e));
  } else if (name == "fraction") {
    const Selection s(eta, keys, comm);
    const double n = theta * static_cast<double>(comm.sum(static_cast<long long>(eta.size())));
    marked = s.first(static_cast<long long>(std::ceil(n * (1 - 1e-12))), top);
  } else if (name == "doerfler") {
    const Selection s(eta, keys, comm);
    const double goal = theta * s.globalSquares(0);
    if (goal <= 0) return {};
    // the value at which the greedy sum reaches the goal, then how many cells of that value it takes
    const std::uint64_t b = s.lastTrue(0, top, [&](std::uint64_t x) { return s.squaresFrom(x); },
                                       [&](double sum) { return sum >= goal; });
    const double before = s.globalSquares(b + 1), v = std::bit_cast<double>(b);
    const auto ties = static_cast<long long>(s.globalCount(b) - s.globalCount(b + 1));
    const auto m = static_cast<long long>(std::ceil((goal - before) / (v * v)));
    marked = s.above(b, std::clamp(m, 1LL, ties));
  } else {
    throw Error("marking '" + name + "': unknown strategy");
  }
  return marked;
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
  double lo, hi;  ///< the range of theta
};

const StrategyRow kStrategies[] = {
    {"doerfler", "smallest set holding the fraction theta of eta^2 (bulk criterion)", 0.5, 0, 1},
    {"fraction", "the fraction theta of the cells with the largest indicators", 0.2, 0, 1},
    {"maximum", "cells with eta_e >= theta * max eta_e", 0.5, 0, 1},
    {"mean", "cells with eta_e^2 >= theta^2 * mean eta_e^2 (thesis Sec. 4.1.1)", 1.1, 0, INFINITY},
};
}  // namespace

MarkingStrategy::MarkingStrategy(const std::string& name, std::optional<double> parameter) {
  for (const StrategyRow& row : kStrategies)
    if (name == row.name) {
      name_ = name;
      parameter_ = parameter.value_or(row.defaultParameter);
      checkRange(row.name, parameter_, row.lo, row.hi);
      return;
    }
  std::string known;
  for (const StrategyRow& row : kStrategies) known += (known.empty() ? "" : ", ") + std::string(row.name);
  throw Error("unknown marking strategy '" + name + "' (known: " + known + ")");
}

std::vector<Index> MarkingStrategy::mark(std::span<const double> indicators) const {
  return markOwned(*this, indicators, cellKeys(indicators.size()), Communicator::self());
}

std::vector<MarkingStrategy::Info> MarkingStrategy::available() {
  std::vector<Info> info;
  for (const StrategyRow& row : kStrategies)
    info.push_back({row.name, row.description, row.defaultParameter});
  return info;
}

}  // namespace obs::estimators
