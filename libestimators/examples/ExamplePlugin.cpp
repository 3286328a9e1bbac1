// Example estimator plugin: a shared library that adds the estimator "example-uniform" to obs.
//
// It shows the whole plugin protocol (EstimatorRegistry.hpp): implement obs::estimators::Estimator,
// export `extern "C" void obs_register_estimators(EstimatorRegistry&)` and register a factory.
// The estimator itself is trivial: every cell gets the same indicator 1/sqrt(N), so eta = 1 and
// every marking strategy that marks anything marks all cells (uniform refinement).
//
// Sample run (from the build directory):
//   drivers/obs estimators --plugin libestimators/libobs_example_estimator_plugin.so
//     example-uniform  equal indicators on every cell (example plugin)
//     residual         standard residual estimator: element residuals, stress jumps, ...
#include <cmath>
#include <memory>

#include "obs/estimators/EstimatorRegistry.hpp"

namespace {

class UniformEstimator : public obs::estimators::Estimator {
public:
  std::string name() const override { return "example-uniform"; }
  std::string description() const override {
    return "equal indicators on every cell (example plugin)";
  }
  obs::estimators::EstimatorResult estimate(
      const obs::estimators::EstimatorInput& input) const override {
    obs::estimators::validateInput(input, name());
    obs::estimators::EstimatorResult r;
    r.estimator = name();
    r.stamp = obs::estimators::meshStamp(input.mesh, input.meshRevision);
    const auto n = static_cast<std::size_t>(input.mesh.numCells());
    const double value = n > 0 ? 1.0 / std::sqrt(static_cast<double>(n)) : 0.0;
    r.indicators.assign(n, value);
    r.cellFields["uniform"] = r.indicators;
    r.total = n > 0 ? 1.0 : 0.0;
    r.contributions.push_back({"uniform", r.total});
    r.vertexFields["uniform"] = Eigen::VectorXd::Constant(input.mesh.numVertices(), value);
    return r;
  }
};

}  // namespace

extern "C" void obs_register_estimators(obs::estimators::EstimatorRegistry& registry) {
  registry.add("example-uniform", UniformEstimator().description(),
               [] { return std::make_unique<UniformEstimator>(); });
}
