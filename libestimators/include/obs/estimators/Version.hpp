#pragma once
/// \file Version.hpp
/// Version of obs (the estimators library is the top of the dependency chain).
namespace obs::estimators {
/// "major.minor.patch" of the obs package.
const char* version();
}  // namespace obs::estimators
