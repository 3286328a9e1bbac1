#include "obs/estimators/DistributedEstimation.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs::estimators {
namespace {

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
  /// The bit pattern of the largest indicator of all ranks.
  std::uint64_t top() const {
    double m = 0;
    for (double x : eta_) m = std::max(m, x);
    return bitsOf(comm_.max(m));
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

}  // namespace

EstimatorResult estimateOwned(const Estimator& estimator, const EstimatorInput& input, Index ownedCells,
                              const Communicator& comm) {
  EstimatorResult r;
  comm.collective([&] {
    if (ownedCells < 0 || ownedCells > input.mesh.numCells())
      throw Error("estimator '" + estimator.name() + "' on ranks: " + std::to_string(ownedCells) +
                  " owned cells of a local mesh of " + std::to_string(input.mesh.numCells()));
    r = estimator.estimate(input);
    for (const Contribution& c : r.contributions)
      if (!r.cellFields.count(c.name))
        throw Error("estimator '" + estimator.name() + "' gives no cell values of its contribution '" + c.name +
                    "', so it cannot be summed over the ranks");
  });
  const auto owned = static_cast<std::size_t>(ownedCells);
  r.indicators.resize(owned);
  std::vector<double> squares;  // per contribution, then the total
  for (const Contribution& c : r.contributions) {
    std::vector<double>& field = r.cellFields.at(c.name);
    field.resize(owned);
    double s = 0;
    for (double x : field) s += x * x;
    squares.push_back(s);
  }
  for (auto& [name, field] : r.cellFields) field.resize(owned);
  double total = 0;
  for (double x : r.indicators) total += x * x;
  squares.push_back(total);
  comm.sum(squares);
  for (std::size_t k = 0; k < r.contributions.size(); ++k) r.contributions[k].value = std::sqrt(squares[k]);
  r.total = std::sqrt(squares.back());
  return r;
}

std::vector<Index> markOwned(const MarkingStrategy& strategy, std::span<const double> eta,
                             std::span<const std::uint64_t> keys, const Communicator& comm) {
  const std::string& name = strategy.name();
  const double theta = strategy.parameter();
  comm.collective([&] {
    if (eta.size() != keys.size())
      throw Error("marking '" + name + "' on ranks: " + std::to_string(eta.size()) + " indicators and " +
                  std::to_string(keys.size()) + " cell keys");
    for (std::size_t e = 0; e < eta.size(); ++e)
      if (!(eta[e] >= 0) || !std::isfinite(eta[e]))
        throw Error("marking '" + name + "': indicator of owned cell " + std::to_string(e) + " is " +
                    std::to_string(eta[e]) + " (must be finite and >= 0)");
  });
  const Selection s(eta, keys, comm);
  const std::uint64_t top = s.top();
  if (top == 0) return {};  // every indicator zero: nothing marked
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
    const double n = theta * static_cast<double>(comm.sum(static_cast<long long>(eta.size())));
    marked = s.first(static_cast<long long>(std::ceil(n * (1 - 1e-12))), top);
  } else if (name == "doerfler") {
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
    throw Error("marking '" + name + "' is not available on ranks");
  }
  return marked;
}

}  // namespace obs::estimators
