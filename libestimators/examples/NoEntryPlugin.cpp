// A shared library that is NOT a valid estimator plugin: it lacks the extern "C" entry point
// obs_register_estimators (it has a C++-mangled function of that name instead, the usual mistake).
// Built only for the tests of EstimatorRegistry::loadPlugin's error message.
#include "obs/estimators/EstimatorRegistry.hpp"

namespace example {
void obs_register_estimators(obs::estimators::EstimatorRegistry&) {}
}  // namespace example
