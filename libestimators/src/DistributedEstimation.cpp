#include "obs/estimators/DistributedEstimation.hpp"

#include <cmath>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs::estimators {
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

}  // namespace obs::estimators
