#pragma once
/// \file Marking.hpp
/// Marking strategies: which cells to refine given the indicators eta_e of an EstimatorResult
/// (docs/architecture.md#libestimators). All return the marked cell numbers in increasing order; they are
/// deterministic (ties are broken by the lower cell number); when every indicator is zero nothing is
/// marked. Indicators must be finite and non-negative, else obs::Error.
///
///   mean      (thesis Sec. 4.1.1, docs/theory.md#marking, the thesis' choice, theta = 1.1):
///             mark e  iff  eta_e^2 >= theta^2 * (1/N) sum_e' eta_e'^2,             theta >= 0
///   doerfler  (bulk criterion, Doerfler 1996), theta in [0, 1], default 0.5: the smallest set M with
///             sum_{e in M} eta_e^2 >= theta * sum_e eta_e^2, taken greedily by decreasing eta_e
///             (equal indicators in increasing cell order); a set of minimal size.
///   maximum   mark e  iff  eta_e >= theta * max_e' eta_e',                   theta in [0, 1], 0.5
///   fraction  the ceil(theta * N) cells with the largest indicators (ties as for doerfler),
///             theta in [0, 1], default 0.2 (ceil with a relative tolerance of 1e-12, so that
///             0.3 * 10 marks 3).
///
/// One implementation for one process and for ranks: markOwned() marks among the cells of all
/// ranks of a communicator; MarkingStrategy::mark() and the functions below are markOwned() on
/// Communicator::self() with the cell numbers as keys. Every strategy orders the cells by
/// decreasing indicator, equal indicators by a key per cell that is the same on every rank that
/// holds the cell (one process: the cell number). markOwned() computes the strategy's thresholds by reductions: the mean and the
/// maximum directly; for `fraction` and `doerfler` the indicator value at which the greedy selection
/// stops, by bisection over the ordered bit patterns of the non-negative doubles (64 reductions of
/// counts or sums), then the cells of that value it takes by bisection over the keys. The marked
/// set is therefore the one-process set of the same indicators and keys, whatever the rank count,
/// up to the rounding of sums over ranks (another order than one process's): a cell within
/// rounding of the mean threshold, or a doerfler greedy sum within rounding of its goal, can be
/// decided the other way.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "obs/mesh/Mesh.hpp"
#include "obs/obs/Communicator.hpp"

namespace obs::estimators {

using mesh::Index;

/// `mean`: the cells with eta_e^2 >= theta^2 mean(eta^2) (see the file comment).
std::vector<Index> markMeanValue(std::span<const double> indicators, double theta = 1.1);
/// `doerfler`: the smallest set of largest cells with sum eta_e^2 >= theta eta^2.
std::vector<Index> markDoerfler(std::span<const double> indicators, double theta = 0.5);
/// `maximum`: the cells with eta_e >= theta max eta.
std::vector<Index> markMaximum(std::span<const double> indicators, double theta = 0.5);
/// `fraction`: the ceil(fraction N) cells with the largest indicators.
std::vector<Index> markFixedFraction(std::span<const double> indicators, double fraction = 0.2);

/// One flag per cell (1 = marked) from a list of marked cells.
std::vector<char> markedFlags(std::span<const Index> marked, Index numCells);

/// A marking strategy selected by name ("mean", "doerfler", "maximum", "fraction") with its
/// parameter theta (the strategy's default if not given). Scene files and drivers use this.
class MarkingStrategy {
public:
  /// A strategy as listed by available().
  struct Info {
    std::string name;         ///< "mean", "doerfler", ...
    std::string description;  ///< one line
    double defaultParameter;  ///< theta when none is given
  };

  /// Throws obs::Error "unknown marking strategy '<name>' (known: doerfler, fraction, maximum,
  /// mean)" for unknown names, and for a parameter outside the strategy's range.
  explicit MarkingStrategy(const std::string& name, std::optional<double> parameter = {});

  /// The strategy's name.
  const std::string& name() const { return name_; }
  /// theta (the given one or the default).
  double parameter() const { return parameter_; }
  /// The marked cells, in increasing order (see the file comment).
  std::vector<Index> mark(std::span<const double> indicators) const;

  /// The available strategies, sorted by name.
  static std::vector<Info> available();

private:
  std::string name_;
  double parameter_;
};

/// The owned cells (indices into `indicators`, ascending) that `strategy` marks among the cells of
/// all ranks, `indicators` and `keys` this rank's owned cells' (see the file comment: ties by
/// increasing key). Collective. Throws obs::Error on every rank for sizes that differ or an
/// indicator that is not finite and non-negative on any rank.
std::vector<Index> markOwned(const MarkingStrategy& strategy, std::span<const double> indicators,
                             std::span<const std::uint64_t> keys, const Communicator& comm);

}  // namespace obs::estimators
