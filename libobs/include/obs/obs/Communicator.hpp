#pragma once
/// \file Communicator.hpp
/// The processes of a distributed run (docs/architecture.md#communicator): a thin wrapper over MPI's
/// world communicator, and the one-process communicator when obs is built without MPI
/// (`OBS_WITH_MPI=OFF`) or MPI is not initialised. It is the layer the
/// distributed grid, halo exchange and multigrid call, so that none of them calls MPI itself.
///
/// Errors never hang a run: collective() runs a piece of work on every rank, and if it throws
/// obs::Error on any rank, every rank throws the same obs::Error (the message of the lowest failing
/// rank, naming it), instead of the other ranks waiting for it in their next collective call.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace obs {

/// What this process has communicated through Communicator since it started (or resetCounts()):
/// the counters of the scaling tables and the cluster model (docs/performance.md#distributed-model).
/// Only calls on more than one rank count (a one-process run communicates nothing).
struct CommunicationCounts {
  long long neighbourExchanges = 0;  ///< point-to-point rounds with a message, exchange(to, send, from, recv)
  long long messagesSent = 0;        ///< the messages this rank sent in them
  long long bytesSent = 0;           ///< and their bytes
  long long reductions = 0;          ///< all-reduce calls: sum, max (collective() makes one)
  long long reducedValues = 0;       ///< the values reduced in them
  long long otherCollectives = 0;    ///< all-to-all exchanges, all-gathers, broadcasts, barriers
};

class Communicator {
public:
  /// The world communicator: all processes of an MPI launch, if obs is built with MPI and MPI is
  /// initialised (MpiSession), else this process alone.
  static Communicator world();
  /// This process alone (rank 0 of 1, under mpirun too): for work that is this process's own, e.g.
  /// a one-process solve inside an MPI launch. Its calls communicate nothing.
  static Communicator self() { return Communicator(0, 1); }
  /// True if obs was built with MPI (OBS_WITH_MPI and MPI found).
  static bool built();
  /// This process's counters (MPI calls are made from one thread: MPI_THREAD_FUNNELED).
  static const CommunicationCounts& counts();
  static void resetCounts();

  int rank() const { return rank_; }
  int size() const { return size_; }
  double sum(double x) const;
  long long sum(long long x) const;
  double max(double x) const;
  /// Element-wise sums of x over the ranks, in place (every rank must pass the same length).
  void sum(std::vector<double>& x) const;
  /// Element-wise maxima of x over the ranks, in place (every rank must pass the same length).
  void max(std::vector<double>& x) const;
  /// The string of rank `root` on every rank.
  std::string broadcast(const std::string& text, int root = 0) const;
  void barrier() const;
  /// All-to-all: send[r] goes to rank r (send has size() entries); returns what each rank sent to
  /// this one (received[r] from rank r). A collective call.
  std::vector<std::vector<double>> exchange(const std::vector<std::vector<double>>& send) const;
  /// The same for 64-bit keys (e.g. DistributedGrid's vertex keys).
  std::vector<std::vector<std::uint64_t>> exchange(const std::vector<std::vector<std::uint64_t>>& send) const;
  /// Every rank's x, in rank order (a collective call).
  std::vector<long long> allGather(long long x) const;
  /// Every rank's vector (of any length), in rank order (received[r] from rank r; a collective call):
  /// what every rank needs of every other, e.g. a surface or a few rows that each rank holds a part of.
  std::vector<std::vector<double>> allGather(const std::vector<double>& x) const;
  std::vector<std::vector<std::uint64_t>> allGather(const std::vector<std::uint64_t>& x) const;
  /// Point to point between neighbours: send[k] goes to rank to[k], and recv[k] (sized by the
  /// caller) is filled from rank from[k]. Every message must be matched by a receive of the same
  /// size on the other rank (as HaloExchange arranges). Self-messages are not allowed.
  void exchange(const std::vector<int>& to, const std::vector<std::vector<double>>& send, const std::vector<int>& from,
                std::vector<std::vector<double>>& recv) const;
  /// Runs `work` on this rank; a collective call (every rank must make it). If `work` throws an
  /// exception (std::exception) on any rank, every rank throws obs::Error("rank r: message") with the
  /// lowest failing rank r and its message (one rank: the message alone).
  void collective(const std::function<void()>& work) const;

private:
  Communicator(int rank, int size) : rank_(rank), size_(size) {}
  int rank_ = 0, size_ = 1;
};

/// Initialises MPI for the lifetime of the object if obs is built with MPI and it is not initialised
/// yet (MPI_Init_thread, MPI_THREAD_FUNNELED: OpenMP threads inside a rank, MPI calls from the main
/// thread), and finalises it on destruction. Without MPI it does nothing.
class MpiSession {
public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

private:
  bool owner_ = false;
};

}  // namespace obs
