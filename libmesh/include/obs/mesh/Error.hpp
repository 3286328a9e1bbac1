#pragma once
/// \file Error.hpp
/// The exception type of obs. Every error that a user can cause (bad input file, bad scene, a
/// solver that fails) is reported as an obs::Error whose message says what was wrong and where.
/// Drivers print the message as one line on stderr and exit with a non-zero code.
#include <stdexcept>
#include <string>

namespace obs {

class Error : public std::runtime_error {
public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace obs
