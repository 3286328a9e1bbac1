#include "obs/obs/Parallel.hpp"

#include <dlfcn.h>
#include <metis.h>

#include <atomic>
#include <cstdlib>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs {
namespace {
std::atomic<int> threadCount{1};
}  // namespace

int threads() { return threadCount.load(std::memory_order_relaxed); }

void setThreads(int n) {
  if (n < 1 || n > 1024) throw Error("threads: " + std::to_string(n) + " (1 to 1024 expected)");
  threadCount.store(n, std::memory_order_relaxed);
}

namespace {
using BlasSetter = void (*)(int);
BlasSetter blasSetter() {
  static const auto set = reinterpret_cast<BlasSetter>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
  return set;
}
std::atomic<int> blasLimit{0};    // setBlasThreads()' count; 0: obs does not manage the BLAS threads
std::atomic<int> blasCurrent{0};  // the count last given to OpenBLAS
}  // namespace

bool setBlasThreads(int n) {
  if (n < 1) throw Error("BLAS threads: " + std::to_string(n) + " (at least 1 expected)");
  if (const char* env = std::getenv("OPENBLAS_NUM_THREADS"); env && *env) return false;  // the user's choice
  const BlasSetter set = blasSetter();
  if (!set) return false;
  set(n);
  blasCurrent.store(n);
  blasLimit.store(n);
  return true;
}

void useBlasThreadsFor(long long unknowns) {
  const int limit = blasLimit.load();
  if (limit == 0) return;
  const int n = unknowns >= kBlasMinUnknowns ? limit : 1;
  if (blasCurrent.exchange(n) != n) blasSetter()(n);
}

std::vector<int> partitionPattern(std::span<const Index> rowStart, std::span<const Index> columns, int parts,
                                  std::span<const Index> weights) {
  const Index n = rowStart.empty() ? 0 : static_cast<Index>(rowStart.size()) - 1;
  if (parts < 2 || n < 2) return {};
  if (!weights.empty() && (weights.size() % static_cast<std::size_t>(n) != 0 || weights.size() < static_cast<std::size_t>(n)))
    throw Error("partition: " + std::to_string(weights.size()) + " vertex weights for " + std::to_string(n) +
                " vertices");
  // the graph without its diagonal, in METIS' integer type
  std::vector<idx_t> xadj(static_cast<std::size_t>(n) + 1, 0), adjncy, vwgt(weights.begin(), weights.end());
  adjncy.reserve(columns.size());
  for (Index p = 0; p < n; ++p) {
    for (Index k = rowStart[p]; k < rowStart[p + 1]; ++k)
      if (columns[k] != p) adjncy.push_back(static_cast<idx_t>(columns[k]));
    xadj[p + 1] = static_cast<idx_t>(adjncy.size());
  }
  idx_t nvtxs = static_cast<idx_t>(n), nparts = parts, objval = 0;
  idx_t ncon = weights.empty() ? 1 : static_cast<idx_t>(weights.size() / static_cast<std::size_t>(n));
  std::vector<idx_t> part(static_cast<std::size_t>(n), 0);
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 1;  // fixed: the partition, hence the sweep order, is reproducible
  options[METIS_OPTION_NUMBERING] = 0;
  idx_t* w = vwgt.empty() ? nullptr : vwgt.data();
  const int status = parts == 2 ? METIS_PartGraphRecursive(&nvtxs, &ncon, xadj.data(), adjncy.data(), w, nullptr,
                                                            nullptr, &nparts, nullptr, nullptr, options, &objval,
                                                            part.data())
                                : METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), w, nullptr,
                                                      nullptr, &nparts, nullptr, nullptr, options, &objval,
                                                      part.data());
  if (status != METIS_OK) return {};
  return std::vector<int>(part.begin(), part.end());
}

SweepOrder::SweepOrder(std::span<const Index> rowStart, std::span<const Index> columns, int parts) {
  if (parts < 1) throw Error("sweep order: " + std::to_string(parts) + " parts");
  requested_ = parts;
  const Index n = rowStart.empty() ? 0 : static_cast<Index>(rowStart.size()) - 1;
  if (parts == 1 || n < kParallelMinRows) return;
  const std::vector<int> part = partitionPattern(rowStart, columns, parts);
  if (part.empty()) return;  // the natural order is always valid
  build(rowStart, columns, parts, part);
}

SweepOrder::SweepOrder(std::span<const Index> rowStart, std::span<const Index> columns, int parts,
                       std::span<const int> part) {
  if (parts < 1) throw Error("sweep order: " + std::to_string(parts) + " parts");
  requested_ = parts;
  const Index n = rowStart.empty() ? 0 : static_cast<Index>(rowStart.size()) - 1;
  if (part.size() != static_cast<std::size_t>(n))
    throw Error("sweep order: a partition of " + std::to_string(part.size()) + " vertices for " + std::to_string(n));
  for (int k : part)
    if (k < 0 || k >= parts)
      throw Error("sweep order: part " + std::to_string(k) + " of " + std::to_string(parts) + " parts");
  if (parts == 1 || n < kParallelMinRows) return;
  build(rowStart, columns, parts, part);
}

void SweepOrder::build(std::span<const Index> rowStart, std::span<const Index> columns, int parts,
                       std::span<const int> part) {
  const Index n = static_cast<Index>(rowStart.size()) - 1;
  interface_.assign(static_cast<std::size_t>(n), 0);
  std::vector<Index> count(static_cast<std::size_t>(parts) + 1, 0);
  for (Index p = 0; p < n; ++p) {
    for (Index k = rowStart[p]; k < rowStart[p + 1]; ++k)
      if (part[static_cast<std::size_t>(columns[k])] != part[static_cast<std::size_t>(p)]) {
        interface_[p] = 1;
        break;
      }
    ++count[interface_[p] ? parts : part[static_cast<std::size_t>(p)]];
  }
  start_.assign(static_cast<std::size_t>(parts) + 2, 0);
  for (int k = 0; k <= parts; ++k) start_[k + 1] = start_[k] + count[k];
  order_.resize(static_cast<std::size_t>(n));
  std::vector<Index> fill(start_.begin(), start_.end() - 1);
  for (Index p = 0; p < n; ++p)
    order_[fill[interface_[p] ? parts : part[static_cast<std::size_t>(p)]]++] = p;  // ascending per group
  parts_ = parts;
  faceGroups_ = 0;
  splitInterface(rowStart, columns);
}

void SweepOrder::splitInterface(std::span<const Index> rowStart, std::span<const Index> columns) {
  const Index first = start_[parts_], faceSize = start_[parts_ + 1] - first;
  if (faceSize < kInterfaceSplitMinRows) return;
  // the graph of the interface vertices (their couplings among themselves), numbered 0..faceSize-1
  // in ascending order
  std::vector<Index> local(interface_.size(), -1);
  for (Index i = 0; i < faceSize; ++i) local[static_cast<std::size_t>(order_[first + i])] = i;
  std::vector<Index> faceStart(static_cast<std::size_t>(faceSize) + 1, 0), faceColumns;
  for (Index i = 0; i < faceSize; ++i) {
    const Index p = order_[first + i];
    for (Index k = rowStart[p]; k < rowStart[p + 1]; ++k)
      if (const Index q = local[static_cast<std::size_t>(columns[k])]; q >= 0) faceColumns.push_back(q);
    faceStart[static_cast<std::size_t>(i) + 1] = static_cast<Index>(faceColumns.size());
  }
  const std::vector<int> group = partitionPattern(faceStart, faceColumns, parts_);
  if (group.empty()) return;  // the whole interface stays the rest
  // a vertex coupled to an interface vertex of another group belongs to the rest
  std::vector<int> slot(static_cast<std::size_t>(faceSize));
  std::vector<Index> count(static_cast<std::size_t>(parts_) + 1, 0);
  for (Index i = 0; i < faceSize; ++i) {
    int g = group[static_cast<std::size_t>(i)];
    for (Index k = faceStart[i]; k < faceStart[i + 1]; ++k)
      if (group[static_cast<std::size_t>(faceColumns[k])] != g) {
        g = parts_;
        break;
      }
    slot[static_cast<std::size_t>(i)] = g;
    ++count[static_cast<std::size_t>(g)];
  }
  std::vector<Index> start(static_cast<std::size_t>(parts_) + 2, first);
  for (int g = 0; g <= parts_; ++g) start[g + 1] = start[g] + count[g];
  const std::vector<Index> face(order_.begin() + first, order_.begin() + first + faceSize);
  std::vector<Index> fill(start.begin(), start.end() - 1);
  for (Index i = 0; i < faceSize; ++i) order_[fill[slot[static_cast<std::size_t>(i)]]++] = face[i];  // ascending
  start_.resize(static_cast<std::size_t>(parts_));
  start_.insert(start_.end(), start.begin(), start.end());
  faceGroups_ = parts_;
}

SweepOrder SweepOrder::subset(std::span<const char> member) const {
  SweepOrder out;
  out.requested_ = requested_;
  Index members = 0;
  for (char m : member) members += m != 0;
  if (sequential() || members < kParallelMinRows) {
    out.listed_ = true;
    out.order_.reserve(static_cast<std::size_t>(members));
    for (std::size_t p = 0; p < member.size(); ++p)
      if (member[p]) out.order_.push_back(static_cast<Index>(p));
    return out;
  }
  out.parts_ = parts_;
  out.faceGroups_ = faceGroups_;
  out.interface_ = interface_;
  out.start_.assign(start_.size(), 0);
  out.order_.reserve(static_cast<std::size_t>(members));
  for (std::size_t g = 0; g + 1 < start_.size(); ++g) {
    for (Index i = start_[g]; i < start_[g + 1]; ++i)
      if (member[static_cast<std::size_t>(order_[i])]) out.order_.push_back(order_[i]);
    out.start_[g + 1] = static_cast<Index>(out.order_.size());
  }
  return out;
}

}  // namespace obs
