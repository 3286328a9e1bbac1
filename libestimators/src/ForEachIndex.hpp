#pragma once
/// \file ForEachIndex.hpp
/// Internal to libestimators (not installed): a loop over indices on obs::threads() threads with a
/// scratch object per thread, for the estimators' cell, face and vertex loops.
#include <algorithm>
#include <exception>

#include "obs/obs/Parallel.hpp"

namespace obs::estimators {

/// body(i, scratch) for i = 0..n-1 on up to threads() threads, each with its own Scratch (one
/// thread below kParallelMinRows indices). If calls throw, the exception of the smallest failing i
/// is rethrown: the error does not depend on the thread count.
template <class Scratch, class Body>
void forEachIndex(Index n, Body&& body) {
  const int nt = n >= kParallelMinRows ? threads() : 1;
  if (nt <= 1) {
    Scratch scratch;
    for (Index i = 0; i < n; ++i) body(i, scratch);
    return;
  }
  Index failed = n;
  std::exception_ptr error;
#pragma omp parallel num_threads(nt)
  {
    Scratch scratch;
#pragma omp for schedule(static)
    for (Index i = 0; i < n; ++i) {
      try {
        body(i, scratch);
      } catch (...) {
#pragma omp critical(obs_estimators_for_each_index)
        if (i < failed) {
          failed = i;
          error = std::current_exception();
        }
      }
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace obs::estimators
