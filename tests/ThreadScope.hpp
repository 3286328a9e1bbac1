#pragma once
/// \file ThreadScope.hpp
/// Test helper: obs::setThreads(n) for one scope, back to one thread at its end (also when an
/// assertion leaves the scope early; the count is global).
#include "obs/obs/Parallel.hpp"

namespace obs::test {

struct ThreadScope {
  explicit ThreadScope(int n) { setThreads(n); }
  ~ThreadScope() { setThreads(1); }
  ThreadScope(const ThreadScope&) = delete;
  ThreadScope& operator=(const ThreadScope&) = delete;
};

}  // namespace obs::test
