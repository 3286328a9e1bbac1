#pragma once
/// \file Parallel.hpp
/// Threads in obs (docs/performance.md#threads). obs runs its dominant loops on `threads()` threads
/// (OpenMP): products with block matrices, the Gauss-Seidel sweeps of the smoothers (nonsmooth and
/// truncated linear), the prolongations, the cell loop of the stiffness assembly. The default is one
/// thread, which runs exactly the sequential algorithms. With N > 1 threads every result is bitwise
/// reproducible for that N: no loop depends on the scheduling (rows are independent, sums over
/// cells are added in cell order, and the Gauss-Seidel order below depends on the matrix pattern and
/// N only); different N give results that differ in the last bits (the sweep order differs).
#include <algorithm>
#include <array>
#include <span>
#include <vector>

#include "obs/mesh/Mesh.hpp"

namespace obs {

using mesh::Index;

/// Threads of obs's parallel loops (>= 1; default 1).
int threads();
/// Sets the thread count. Throws obs::Error unless 1 <= n <= 1024. Set it before building solvers:
/// a smoother fixes its sweep order for the thread count when it gets its matrix.
void setThreads(int n);
/// Sets the thread count of the BLAS library (OpenBLAS, used by CHOLMOD) to n if it offers
/// openblas_set_num_threads and the user has not chosen one with OPENBLAS_NUM_THREADS; returns
/// whether it did. OpenBLAS otherwise starts a thread per core, whose spinning costs more than it
/// gains on the small coarse-grid solves of multigrid, and competes with obs' own threads. After a
/// call that did, obs also chooses the BLAS threads of every CHOLMOD factorisation and solve by its
/// size (useBlasThreadsFor).
bool setBlasThreads(int n);

/// Unknowns from which a CHOLMOD factorisation or solve uses the BLAS threads of setBlasThreads().
/// Measured with PDAS on step-42 (docs/performance.md#blas-threads): a second BLAS thread made the
/// solve phase 1.2-1.6x faster at 2,187 unknowns and 1.3-1.8x at 14,739 and 107,811, and gained
/// nothing at 375. Below, a threaded BLAS call only wakes OpenBLAS' workers, which then spin in
/// sched_yield for their time-out, taking CPU time from obs' own threads (TNNMG's coarse solve of
/// step-42 has 81 unknowns).
inline constexpr long long kBlasMinUnknowns = 1000;

/// Sets the BLAS threads for a factorisation or solve of `unknowns` unknowns: those of
/// setBlasThreads() from kBlasMinUnknowns on, one below. Does nothing unless setBlasThreads()
/// succeeded, so that obs leaves the BLAS threads of an embedding program alone.
void useBlasThreadsFor(long long unknowns);

/// Rows below which loops and sweeps stay sequential (the fork costs more than the work).
inline constexpr Index kParallelMinRows = 2048;

/// Entries of the fixed chunks of forRanges() and chunkedSums().
inline constexpr Index kVectorChunk = 8192;

/// Rows per chunk of the row loops on threads (products, transfers, the smoothers' diagonal blocks).
/// The chunks are handed out as the threads ask for them (OpenMP dynamic schedule), so a thread
/// that the machine slows (another process on its core) takes fewer of them instead of keeping the
/// other one waiting at the end of the loop (docs/performance.md#dynamic-chunks). The rows are
/// independent: the results do not depend on which thread computed which chunk.
inline constexpr int kRowChunk = 1024;

/// f(begin, end) for the fixed chunks [k C, min(n, (k + 1) C)) of 0..n-1 (C = kVectorChunk), on
/// threads() threads when there are two chunks or more (else on the calling thread), handed out as
/// the threads ask for them (see kRowChunk). For elementwise vector work: the chunks must not depend
/// on each other.
template <class F>
void forRanges(Index n, F&& f) {
  const Index chunks = (n + kVectorChunk - 1) / kVectorChunk;
  [[maybe_unused]] const int nt = chunks >= 2 ? threads() : 1;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt) if (nt > 1)
#endif
  for (Index k = 0; k < chunks; ++k) f(k * kVectorChunk, std::min(n, (k + 1) * kVectorChunk));
}

/// K sums over 0..n-1 that do not depend on the thread count: f(begin, end) returns the K partial
/// sums of a fixed chunk (forRanges' chunks, each summed in index order by f), and the chunks'
/// partial sums are added in chunk order. The same bits on any number of threads.
template <int K, class F>
std::array<double, K> chunkedSums(Index n, F&& f) {
  const Index chunks = (n + kVectorChunk - 1) / kVectorChunk;
  std::vector<std::array<double, K>> partial(static_cast<std::size_t>(chunks));
  forRanges(n, [&](Index begin, Index end) { partial[static_cast<std::size_t>(begin / kVectorChunk)] = f(begin, end); });
  std::array<double, K> sum{};
  for (const auto& s : partial)
    for (int j = 0; j < K; ++j) sum[j] += s[j];
  return sum;
}

/// METIS' partition of the graph of a (symmetric) pattern into `parts` >= 2 parts (fixed seed; the
/// diagonal is ignored): part[p] in [0, parts), balanced in the sum of `weights` or in vertices if
/// weights is empty. `weights` holds ncon >= 1 weights per vertex (vertex-major; ncon = its size
/// over the vertex count): with ncon > 1 every kind of weight is balanced at once (METIS'
/// multi-constraint partitioning). Empty if METIS fails.
std::vector<int> partitionPattern(std::span<const Index> rowStart, std::span<const Index> columns, int parts,
                                  std::span<const Index> weights = {});

/// Interface sizes (vertices) from which SweepOrder splits the interface once more. Below it a
/// second parallel region is assumed (not measured) to cost more than it saves.
inline constexpr Index kInterfaceSplitMinRows = 256;

/// Order of a Gauss-Seidel sweep over the vertices of a (symmetric) matrix pattern that lets
/// `parts` threads sweep at once without changing what a sweep is: a sequence of exact local solves
/// in one fixed order, so every monotonicity property of the sequential sweep holds. METIS splits the
/// matrix graph into `parts` parts; a vertex all of whose neighbours lie in its own part is
/// *interior*, the others are *interface* vertices. Interior vertices of different parts are not
/// coupled, so the parts' interiors are swept concurrently (each in ascending order). The interface
/// (at least kInterfaceSplitMinRows vertices) is split the same way: METIS splits the graph of the
/// interface vertices into `parts` groups, the vertices coupled only to interface vertices of their
/// own group are swept concurrently group by group, and the rest (the *interface rest*) in ascending
/// order by one thread. A backward sweep is the exact reverse. The order depends on the pattern and
/// `parts` only. With one part it is the natural order 0..n-1.
class SweepOrder {
public:
  SweepOrder() = default;
  /// Pattern in compressed rows (rowStart has n + 1 entries, the diagonal may be included); parts
  /// >= 1. Patterns too small to be worth it (below kParallelMinRows rows), or that METIS cannot
  /// split, get the natural order.
  SweepOrder(std::span<const Index> rowStart, std::span<const Index> columns, int parts);
  /// The order of a given partition of the same pattern: part[p] in [0, parts) for every vertex
  /// (e.g. a coarser level's partition carried to this level, LinearMultigrid). Throws obs::Error if
  /// part has the wrong size or a part out of range. Small patterns get the natural order as above.
  SweepOrder(std::span<const Index> rowStart, std::span<const Index> columns, int parts, std::span<const int> part);

  /// The same order restricted to the vertices p with member[p] != 0 (member has one entry per
  /// vertex): each group keeps its members in its order, so the subset sweep is the whole sweep with
  /// the other vertices left out. A subset below kParallelMinRows members is swept by one thread in
  /// ascending order. For forwardFromZero() on a subset the vertices outside it must hold zero.
  SweepOrder subset(std::span<const char> member) const;

  int parts() const { return parts_; }
  /// The `parts` asked for at construction (parts() may be 1 if the pattern was not split).
  int requestedParts() const { return requested_; }
  bool sequential() const { return parts_ <= 1; }
  /// Whether the order visits a list of vertices (a subset()) rather than all of 0..n-1.
  bool listed() const { return listed_; }
  /// The interior of a part (swept by one thread, ascending).
  std::span<const Index> interior(int part) const { return group(part); }
  /// All interface vertices, in sweep order: the interface groups, then the interface rest.
  std::span<const Index> interface() const {
    return {order_.data() + start_[parts_], static_cast<std::size_t>(start_.back() - start_[parts_])};
  }
  /// The groups the interface is split into: `parts` (then interfaceGroup(k) are swept concurrently
  /// before the interface rest), or 0 (the whole interface is the rest).
  int interfaceGroups() const { return faceGroups_; }
  std::span<const Index> interfaceGroup(int k) const { return group(parts_ + k); }
  /// The interface vertices swept by one thread, last (ascending).
  std::span<const Index> interfaceRest() const { return group(parts_ + faceGroups_); }
  bool isInterface(Index p) const { return interface_[p] != 0; }

  /// f(part) for every part, concurrently (one thread per part).
  template <class F>
  void forEachPart(F&& f) const {
#ifdef _OPENMP
#pragma omp parallel for schedule(static, 1) num_threads(parts_)
#endif
    for (int k = 0; k < parts_; ++k) f(k);
  }
  /// visit(p) for the n vertices in sweep order (forward), or in the reverse order.
  template <class Visit>
  void forward(Index n, Visit&& visit) const {
    if (sequential()) {
      if (listed_)
        for (Index p : order_) visit(p);
      else
        for (Index p = 0; p < n; ++p) visit(p);
      return;
    }
    forEachPart([&](int k) {
      for (Index p : interior(k)) visit(p);
    });
    if (faceGroups_ > 0)
      forEachPart([&](int k) {
        for (Index p : interfaceGroup(k)) visit(p);
      });
    for (Index p : interfaceRest()) visit(p);
  }
  /// The first forward sweep on a vector that holds garbage (it is overwritten): row(p, full) in
  /// sweep order, where full = false means that every neighbour with a smaller index has been
  /// swept and every other one holds zero (read only the blocks left of the diagonal), and full =
  /// true that unswept neighbours hold zero (read the whole row). zero(p) sets vertex p to zero; it
  /// is called for the interface before the parts' interiors, whose neighbours lie in their own
  /// part (swept in ascending order) or on the interface (swept last).
  template <class Row, class Zero>
  void forwardFromZero(Index n, Row&& row, Zero&& zero) const {
    if (sequential()) {
      if (listed_)
        for (Index p : order_) row(p, false);
      else
        for (Index p = 0; p < n; ++p) row(p, false);
      return;
    }
    for (Index p : interface()) zero(p);
    forEachPart([&](int k) {
      for (Index p : interior(k)) row(p, false);
    });
    if (faceGroups_ > 0)
      forEachPart([&](int k) {
        for (Index p : interfaceGroup(k)) row(p, true);
      });
    for (Index p : interfaceRest()) row(p, true);
  }
  template <class Visit>
  void backward(Index n, Visit&& visit) const {
    if (sequential()) {
      if (listed_)
        for (auto it = order_.rbegin(); it != order_.rend(); ++it) visit(*it);
      else
        for (Index p = n; p-- > 0;) visit(p);
      return;
    }
    const auto rest = interfaceRest();
    for (auto it = rest.rbegin(); it != rest.rend(); ++it) visit(*it);
    if (faceGroups_ > 0)
      forEachPart([&](int k) {
        const auto in = interfaceGroup(k);
        for (auto it = in.rbegin(); it != in.rend(); ++it) visit(*it);
      });
    forEachPart([&](int k) {
      const auto in = interior(k);
      for (auto it = in.rbegin(); it != in.rend(); ++it) visit(*it);
    });
  }

private:
  void build(std::span<const Index> rowStart, std::span<const Index> columns, int parts, std::span<const int> part);
  void splitInterface(std::span<const Index> rowStart, std::span<const Index> columns);
  std::span<const Index> group(int g) const {
    return {order_.data() + start_[g], static_cast<std::size_t>(start_[g + 1] - start_[g])};
  }

  int parts_ = 1;
  int requested_ = 1;
  int faceGroups_ = 0;   ///< interface groups: parts_ or 0
  bool listed_ = false;  ///< sequential with an explicit vertex list in order_ (a subset)
  /// parts_ + faceGroups_ + 2 offsets into order_: the interiors of the parts, the interface groups,
  /// the interface rest
  std::vector<Index> start_;
  std::vector<Index> order_;
  std::vector<char> interface_;
};

}  // namespace obs
