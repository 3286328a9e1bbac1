// obs::Communicator under mpirun (tests/CMakeLists.txt runs this with 1, 2 and 3 ranks): reductions
// and broadcasts agree on every rank, and an error on one rank reaches every rank as the same
// obs::Error instead of leaving the others waiting (docs/architecture.md#communicator).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Communicator.hpp"

namespace {

TEST(Communicator, WorldIsTheLaunch) {
  const obs::Communicator c = obs::Communicator::world();
  EXPECT_TRUE(obs::Communicator::built());
  EXPECT_GE(c.size(), 1);
  EXPECT_GE(c.rank(), 0);
  EXPECT_LT(c.rank(), c.size());
}

TEST(Communicator, ReductionsAndBroadcast) {
  const obs::Communicator c = obs::Communicator::world();
  const int n = c.size(), r = c.rank();
  EXPECT_EQ(c.sum(static_cast<long long>(r + 1)), static_cast<long long>(n) * (n + 1) / 2);
  EXPECT_EQ(c.sum(0.5 * (r + 1)), 0.25 * n * (n + 1));  // exact in binary
  EXPECT_EQ(c.max(static_cast<double>(r)), static_cast<double>(n - 1));
  const std::string from = c.broadcast("rank " + std::to_string(r), n - 1);
  EXPECT_EQ(from, "rank " + std::to_string(n - 1));
  EXPECT_EQ(c.broadcast(r == 0 ? std::string() : std::string("x")), "");
  EXPECT_THROW(c.broadcast("x", n), obs::Error);
  c.barrier();
}

/// Communicator::self() is this process alone on any launch: its reductions return the rank's own
/// value, its all-gather holds one entry, and an error in its collective is this rank's only.
TEST(Communicator, SelfIsThisProcessAlone) {
  const obs::Communicator self = obs::Communicator::self();
  const int r = obs::Communicator::world().rank();
  EXPECT_EQ(self.size(), 1);
  EXPECT_EQ(self.rank(), 0);
  EXPECT_EQ(self.sum(static_cast<long long>(r + 1)), r + 1);
  EXPECT_EQ(self.max(0.5 * r), 0.5 * r);
  std::vector<double> v{1.0 * r, 2.0};
  self.sum(v);
  EXPECT_EQ(v, (std::vector<double>{1.0 * r, 2.0}));
  EXPECT_EQ(self.allGather(static_cast<long long>(r)), std::vector<long long>{r});
  if (r == 0) {
    EXPECT_THROW(self.collective([] { throw obs::Error("only here"); }), obs::Error);
  }
  obs::Communicator::world().barrier();
}

TEST(Communicator, AnErrorOnOneRankReachesEveryRank) {
  const obs::Communicator c = obs::Communicator::world();
  const int failing = c.size() - 1;  // the last rank (the only one on one rank)
  try {
    c.collective([&] {
      if (c.rank() == failing) throw obs::Error("the mesh file is missing");
    });
    FAIL() << "no error on rank " << c.rank();
  } catch (const obs::Error& e) {
    const std::string expected = c.size() == 1 ? "the mesh file is missing"
                                               : "rank " + std::to_string(failing) + ": the mesh file is missing";
    EXPECT_EQ(std::string(e.what()), expected);
  }
  // several failing ranks: the lowest is reported
  try {
    c.collective([&] {
      if (c.rank() >= c.size() / 2) throw obs::Error("failed on rank " + std::to_string(c.rank()));
    });
    FAIL() << "no error";
  } catch (const obs::Error& e) {
    const int lowest = c.size() / 2;
    const std::string message = "failed on rank " + std::to_string(lowest);
    EXPECT_EQ(std::string(e.what()), c.size() == 1 ? message : "rank " + std::to_string(lowest) + ": " + message);
  }
  // no error: nothing thrown, and the ranks go on together
  EXPECT_NO_THROW(c.collective([] {}));
  EXPECT_EQ(c.sum(1LL), c.size());
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
