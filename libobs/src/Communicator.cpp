#include "obs/obs/Communicator.hpp"

#include <algorithm>
#include <climits>
#include <exception>
#include <limits>
#include <type_traits>
#include <vector>

#include "obs/mesh/Error.hpp"

#ifdef OBS_HAVE_MPI
#include <mpi.h>
#endif

namespace obs {

namespace {

#ifdef OBS_HAVE_MPI
bool mpiRunning() {
  int initialised = 0, finalised = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalised);
  return initialised && !finalised;
}
#endif

}  // namespace

bool Communicator::built() {
#ifdef OBS_HAVE_MPI
  return true;
#else
  return false;
#endif
}

namespace {
CommunicationCounts& counters() {
  static CommunicationCounts c;
  return c;
}
[[maybe_unused]] void countReduction(std::size_t values) {
  ++counters().reductions;
  counters().reducedValues += static_cast<long long>(values);
}
}  // namespace

const CommunicationCounts& Communicator::counts() { return counters(); }
void Communicator::resetCounts() { counters() = CommunicationCounts{}; }

Communicator Communicator::world() {
#ifdef OBS_HAVE_MPI
  if (mpiRunning()) {
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    return Communicator(rank, size);
  }
#endif
  return Communicator(0, 1);
}

#ifdef OBS_HAVE_MPI
namespace {
/// MPI_Allreduce of one value over MPI_COMM_WORLD.
template <class T>
T allReduce(T x, MPI_Datatype type, MPI_Op op) {
  countReduction(1);
  T y{};
  MPI_Allreduce(&x, &y, 1, type, op, MPI_COMM_WORLD);
  return y;
}
}  // namespace
#endif

double Communicator::sum(double x) const {
#ifdef OBS_HAVE_MPI
  if (size_ > 1) return allReduce(x, MPI_DOUBLE, MPI_SUM);
#endif
  return x;
}

long long Communicator::sum(long long x) const {
#ifdef OBS_HAVE_MPI
  if (size_ > 1) return allReduce(x, MPI_LONG_LONG, MPI_SUM);
#endif
  return x;
}

double Communicator::max(double x) const {
#ifdef OBS_HAVE_MPI
  if (size_ > 1) return allReduce(x, MPI_DOUBLE, MPI_MAX);
#endif
  return x;
}

void Communicator::sum(std::vector<double>& x) const {
#ifdef OBS_HAVE_MPI
  if (size_ > 1) {
    if (x.size() > static_cast<std::size_t>(INT_MAX)) throw Error("communicator: a sum of too many values");
    countReduction(x.size());
    MPI_Allreduce(MPI_IN_PLACE, x.data(), static_cast<int>(x.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  }
#else
  (void)x;
#endif
}

void Communicator::max(std::vector<double>& x) const {
#ifdef OBS_HAVE_MPI
  if (size_ > 1) {
    if (x.size() > static_cast<std::size_t>(INT_MAX)) throw Error("communicator: a maximum of too many values");
    countReduction(x.size());
    MPI_Allreduce(MPI_IN_PLACE, x.data(), static_cast<int>(x.size()), MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  }
#else
  (void)x;
#endif
}

std::string Communicator::broadcast(const std::string& text, int root) const {
  if (root < 0 || root >= size_)
    throw Error("communicator: broadcast from rank " + std::to_string(root) + " of " + std::to_string(size_));
#ifdef OBS_HAVE_MPI
  if (size_ > 1) {
    ++counters().otherCollectives;
    long long n = rank_ == root ? static_cast<long long>(text.size()) : 0;
    MPI_Bcast(&n, 1, MPI_LONG_LONG, root, MPI_COMM_WORLD);
    if (n > INT_MAX) throw Error("communicator: a broadcast of " + std::to_string(n) + " characters");
    std::string out = rank_ == root ? text : std::string(static_cast<std::size_t>(n), '\0');
    if (n > 0) MPI_Bcast(out.data(), static_cast<int>(n), MPI_CHAR, root, MPI_COMM_WORLD);
    return out;
  }
#endif
  return text;
}

void Communicator::barrier() const {
#ifdef OBS_HAVE_MPI
  if (size_ > 1) {
    ++counters().otherCollectives;
    MPI_Barrier(MPI_COMM_WORLD);
  }
#endif
}

namespace {

#ifdef OBS_HAVE_MPI
template <class T>
MPI_Datatype mpiType();
template <>
MPI_Datatype mpiType<double>() {
  return MPI_DOUBLE;
}
template <>
MPI_Datatype mpiType<std::uint64_t>() {
  return MPI_UINT64_T;
}
#endif

/// Communicator::exchange for one value type: MPI_Alltoall of the counts, MPI_Alltoallv of the values.
template <class T>
std::vector<std::vector<T>> allToAll(const std::vector<std::vector<T>>& send, int size) {
  if (send.size() != static_cast<std::size_t>(size))
    throw Error("communicator: exchange with " + std::to_string(send.size()) + " buffers for " + std::to_string(size) +
                " ranks");
#ifdef OBS_HAVE_MPI
  if (size > 1) {
    ++counters().otherCollectives;
    std::vector<int> sendCounts(static_cast<std::size_t>(size)), recvCounts(sendCounts.size());
    std::vector<int> sendOffsets(sendCounts.size() + 1, 0), recvOffsets(sendCounts.size() + 1, 0);
    for (int r = 0; r < size; ++r) {
      if (send[r].size() > static_cast<std::size_t>(INT_MAX)) throw Error("communicator: an exchange buffer too large");
      sendCounts[r] = static_cast<int>(send[r].size());
    }
    MPI_Alltoall(sendCounts.data(), 1, MPI_INT, recvCounts.data(), 1, MPI_INT, MPI_COMM_WORLD);
    for (int r = 0; r < size; ++r) {
      const long long s = static_cast<long long>(sendOffsets[r]) + sendCounts[r];
      const long long t = static_cast<long long>(recvOffsets[r]) + recvCounts[r];
      if (s > INT_MAX || t > INT_MAX) throw Error("communicator: an exchange too large");
      sendOffsets[r + 1] = static_cast<int>(s);
      recvOffsets[r + 1] = static_cast<int>(t);
    }
    std::vector<T> out(static_cast<std::size_t>(sendOffsets.back())), in(static_cast<std::size_t>(recvOffsets.back()));
    for (int r = 0; r < size; ++r) std::copy(send[r].begin(), send[r].end(), out.begin() + sendOffsets[r]);
    MPI_Alltoallv(out.data(), sendCounts.data(), sendOffsets.data(), mpiType<T>(), in.data(), recvCounts.data(),
                  recvOffsets.data(), mpiType<T>(), MPI_COMM_WORLD);
    std::vector<std::vector<T>> received(static_cast<std::size_t>(size));
    for (int r = 0; r < size; ++r) received[r].assign(in.begin() + recvOffsets[r], in.begin() + recvOffsets[r + 1]);
    return received;
  }
#endif
  return send;
}

}  // namespace

std::vector<std::vector<double>> Communicator::exchange(const std::vector<std::vector<double>>& send) const {
  return allToAll(send, size_);
}

std::vector<std::vector<std::uint64_t>> Communicator::exchange(const std::vector<std::vector<std::uint64_t>>& send) const {
  return allToAll(send, size_);
}

std::vector<long long> Communicator::allGather(long long x) const {
  std::vector<long long> all(static_cast<std::size_t>(size_), x);
#ifdef OBS_HAVE_MPI
  if (size_ > 1) ++counters().otherCollectives;
  if (size_ > 1) MPI_Allgather(&x, 1, MPI_LONG_LONG, all.data(), 1, MPI_LONG_LONG, MPI_COMM_WORLD);
#endif
  return all;
}

namespace {

/// MPI_Allgatherv of vectors of any length (the counts gathered first).
template <typename T>
std::vector<std::vector<T>> gatherAll(const Communicator& comm, const std::vector<T>& x) {
  std::vector<std::vector<T>> all(static_cast<std::size_t>(comm.size()));
  if (comm.size() == 1) {
    all[0] = x;
    return all;
  }
#ifdef OBS_HAVE_MPI
  const std::vector<long long> counts = comm.allGather(static_cast<long long>(x.size()));
  ++counters().otherCollectives;
  std::vector<int> count(counts.size()), displacement(counts.size() + 1, 0);
  for (std::size_t r = 0; r < counts.size(); ++r) {
    if (displacement[r] + counts[r] > std::numeric_limits<int>::max())
      throw Error("communicator: an all-gather of more than 2^31 values");
    count[r] = static_cast<int>(counts[r]);
    displacement[r + 1] = displacement[r] + count[r];
  }
  std::vector<T> flat(static_cast<std::size_t>(displacement.back()));
  const MPI_Datatype type = std::is_same_v<T, double> ? MPI_DOUBLE : MPI_UINT64_T;
  MPI_Allgatherv(x.data(), static_cast<int>(x.size()), type, flat.data(), count.data(), displacement.data(), type,
                 MPI_COMM_WORLD);
  for (std::size_t r = 0; r < all.size(); ++r)
    all[r].assign(flat.begin() + displacement[r], flat.begin() + displacement[r + 1]);
#endif
  return all;
}

}  // namespace

std::vector<std::vector<double>> Communicator::allGather(const std::vector<double>& x) const { return gatherAll(*this, x); }

std::vector<std::vector<std::uint64_t>> Communicator::allGather(const std::vector<std::uint64_t>& x) const {
  return gatherAll(*this, x);
}

void Communicator::exchange(const std::vector<int>& to, const std::vector<std::vector<double>>& send,
                            const std::vector<int>& from, std::vector<std::vector<double>>& recv) const {
  if (to.size() != send.size() || from.size() != recv.size())
    throw Error("communicator: a neighbour exchange with lists of different lengths");
  for (const std::vector<int>* ranks : {&to, &from})
    for (int r : *ranks)
      if (r < 0 || r >= size_ || r == rank_)
        throw Error("communicator: a neighbour exchange with rank " + std::to_string(r) + " (this is rank " +
                    std::to_string(rank_) + " of " + std::to_string(size_) + ")");
#ifdef OBS_HAVE_MPI
  if (size_ > 1) {
    CommunicationCounts& c = counters();
    if (!to.empty() || !from.empty()) ++c.neighbourExchanges;
    c.messagesSent += static_cast<long long>(to.size());
    for (const std::vector<double>& m : send) c.bytesSent += static_cast<long long>(m.size() * sizeof(double));
    std::vector<MPI_Request> requests;
    requests.reserve(to.size() + from.size());
    for (std::size_t k = 0; k < from.size(); ++k) {
      if (recv[k].size() > static_cast<std::size_t>(INT_MAX)) throw Error("communicator: a message too large");
      requests.emplace_back();
      MPI_Irecv(recv[k].data(), static_cast<int>(recv[k].size()), MPI_DOUBLE, from[k], 0, MPI_COMM_WORLD, &requests.back());
    }
    for (std::size_t k = 0; k < to.size(); ++k) {
      if (send[k].size() > static_cast<std::size_t>(INT_MAX)) throw Error("communicator: a message too large");
      requests.emplace_back();
      MPI_Isend(send[k].data(), static_cast<int>(send[k].size()), MPI_DOUBLE, to[k], 0, MPI_COMM_WORLD, &requests.back());
    }
    MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  }
#endif
}

void Communicator::collective(const std::function<void()>& work) const {
  std::string message;
  bool failed = false;
  try {
    work();
  } catch (const std::exception& e) {  // obs::Error, and anything else that would leave the others waiting
    failed = true;
    message = e.what();
  }
  if (size_ == 1) {
    if (failed) throw Error(message);
    return;
  }
  // the lowest failing rank (size_ if none) and its message, on every rank
  const double lowest = -max(-static_cast<double>(failed ? rank_ : size_));
  if (lowest >= size_) return;
  const int root = static_cast<int>(lowest);
  throw Error("rank " + std::to_string(root) + ": " + broadcast(message, root));
}

MpiSession::MpiSession(int& argc, char**& argv) {
#ifdef OBS_HAVE_MPI
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) {
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    owner_ = true;
  }
#else
  (void)argc;
  (void)argv;
#endif
}

MpiSession::~MpiSession() {
#ifdef OBS_HAVE_MPI
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (owner_ && !finalised) MPI_Finalize();
#endif
}

}  // namespace obs
