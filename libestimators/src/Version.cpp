#include "obs/estimators/Version.hpp"

namespace obs::estimators {
const char* version() { return "0.1.0"; }
}  // namespace obs::estimators
