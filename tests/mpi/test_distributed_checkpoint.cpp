// Checkpoints with rows under mpirun (tests/CMakeLists.txt: 1, 2 and 3 ranks; docs/checkpoint.md#rows):
// a record whose row entries each rank fills with its rows is written to one file (parallel HDF5,
// collective writes) and read back by every rank for another distribution of the keys, as a run on
// another number of ranks would; the file is the one a single process would write (the serial
// reader accepts it, content hash included), a file written by one process is read on the ranks,
// and a key the file does not hold stops every rank with the same error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/obs/Checkpoint.hpp"
#include "obs/obs/Communicator.hpp"

namespace {

namespace fs = std::filesystem;

constexpr long long kRows = 1000;
constexpr int kComponents = 3;

/// A key per global row (distinct 64-bit values, not ordered like the rows).
std::uint64_t keyOf(long long row) {
  std::uint64_t x = static_cast<std::uint64_t>(row) * 0x9E3779B97F4A7C15ull + 12345;
  x ^= x >> 29;
  return x * 0xBF58476D1CE4E5B9ull;
}

double valueOf(long long row, int c) { return std::sin(0.37 * static_cast<double>(row) + c) * 1e3 + c; }

/// The rows [first, last) as a record with row entries (displacement: 3 per row; a scalar per row;
/// an empty row entry) and entries the same on every rank.
obs::CheckpointRecord recordOf(long long first, long long last) {
  obs::CheckpointRecord r;
  r.kind = "test";
  r.set("scene/text", std::string("a scene\nwith two lines"), "text");
  r.set("scheme/time", 0.125, "real");
  r.set("scheme/step", 42LL, "integer");
  r.set("run/figures", Eigen::VectorXd::LinSpaced(5, 0, 1), "vector");
  std::vector<std::uint64_t> keys;
  Eigen::VectorXd u((last - first) * kComponents), s(last - first);
  for (long long i = first; i < last; ++i) {
    keys.push_back(keyOf(i));
    for (int c = 0; c < kComponents; ++c) u[(i - first) * kComponents + c] = valueOf(i, c);
    s[i - first] = -static_cast<double>(i);
  }
  r.setRowKeys(keys);
  r.setRows("scheme/displacement", u, kComponents, "rows of three");
  r.setRows("scheme/mass", s, 1, "one per row");
  r.setRows("scheme/acceleration", Eigen::VectorXd(), kComponents, "empty");
  return r;
}

fs::path fileFor(const obs::Communicator& comm, const std::string& name) {
  return fs::temp_directory_path() / ("obs_mpi_checkpoint_" + name + "_" + std::to_string(comm.size()) + ".h5");
}

/// Every rank asks for the rows i = rank (mod ranks), and rank 0 also for row 7 (asked twice).
std::vector<long long> askedRows(const obs::Communicator& comm) {
  std::vector<long long> rows;
  for (long long i = comm.rank(); i < kRows; i += comm.size()) rows.push_back(i);
  if (comm.rank() == 0 && comm.size() > 1) rows.push_back(7);
  return rows;
}

void expectRows(const obs::CheckpointRecord& r, const std::vector<long long>& rows) {
  EXPECT_EQ(r.kind, "test");
  EXPECT_EQ(r.text("scene/text"), "a scene\nwith two lines");
  EXPECT_EQ(r.real("scheme/time"), 0.125);
  EXPECT_EQ(r.integer("scheme/step"), 42);
  EXPECT_EQ(r.vector("run/figures"), Eigen::VectorXd::LinSpaced(5, 0, 1));
  EXPECT_EQ(r.rowComponents("scheme/displacement"), kComponents);
  EXPECT_EQ(r.vector("scheme/acceleration").size(), 0);
  const Eigen::VectorXd& u = r.vector("scheme/displacement");
  const Eigen::VectorXd& s = r.vector("scheme/mass");
  ASSERT_EQ(u.size(), static_cast<Eigen::Index>(rows.size()) * kComponents);
  ASSERT_EQ(r.rowKeys().size(), rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    EXPECT_EQ(r.rowKeys()[k], keyOf(rows[k]));
    EXPECT_EQ(s[static_cast<Eigen::Index>(k)], -static_cast<double>(rows[k]));
    for (int c = 0; c < kComponents; ++c)  // bit for bit
      ASSERT_EQ(u[static_cast<Eigen::Index>(k) * kComponents + c], valueOf(rows[k], c)) << "row " << rows[k];
  }
}

std::vector<std::uint64_t> keysOf(const std::vector<long long>& rows) {
  std::vector<std::uint64_t> keys;
  for (long long i : rows) keys.push_back(keyOf(i));
  return keys;
}

TEST(DistributedCheckpoint, RowsWrittenOnTheRanksAreReadForAnyDistribution) {
  const obs::Communicator comm = obs::Communicator::world();
  const fs::path file = fileFor(comm, "rows");
  // uneven blocks, the last rank's the largest
  const long long first = kRows * comm.rank() * comm.rank() / (comm.size() * comm.size());
  const long long last = kRows * (comm.rank() + 1) * (comm.rank() + 1) / (comm.size() * comm.size());
  obs::writeCheckpoint(file, recordOf(first, last), comm);
  EXPECT_FALSE(fs::exists(fs::path(file.string() + ".tmp")));
  const std::vector<long long> rows = askedRows(comm);
  expectRows(obs::readCheckpoint(file, keysOf(rows), comm), rows);
  // the file of one process: the serial reader takes it, the rows in rank order
  if (comm.rank() == 0) {
    const obs::CheckpointRecord whole = obs::readCheckpoint(file);
    std::vector<long long> all(kRows);
    for (long long i = 0; i < kRows; ++i) all[static_cast<std::size_t>(i)] = i;
    expectRows(whole, all);
  }
  comm.barrier();
  if (comm.rank() == 0) fs::remove(file);
}

TEST(DistributedCheckpoint, AFileOfOneProcessIsReadOnTheRanks) {
  const obs::Communicator comm = obs::Communicator::world();
  const fs::path file = fileFor(comm, "serial");
  if (comm.rank() == 0) obs::writeCheckpoint(file, recordOf(0, kRows));  // one process: all rows
  comm.barrier();
  const std::vector<long long> rows = askedRows(comm);
  expectRows(obs::readCheckpoint(file, keysOf(rows), comm), rows);
  comm.barrier();
  if (comm.rank() == 0) fs::remove(file);
}

TEST(DistributedCheckpoint, AMissingKeyOrADamagedFileStopsEveryRank) {
  const obs::Communicator comm = obs::Communicator::world();
  const fs::path file = fileFor(comm, "missing");
  const long long first = kRows * comm.rank() / comm.size(), last = kRows * (comm.rank() + 1) / comm.size();
  obs::writeCheckpoint(file, recordOf(first, last), comm);
  std::vector<std::uint64_t> keys = keysOf(askedRows(comm));
  if (comm.rank() == comm.size() - 1) keys.push_back(keyOf(kRows + 5));  // not in the file
  try {
    (void)obs::readCheckpoint(file, keys, comm);
    ADD_FAILURE() << "no error for a key the file does not hold";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find("1 vertices of this run are not in the checkpoint"), std::string::npos) << e.what();
  }
  // one flipped byte in the rows: the content hash differs on every rank
  comm.barrier();
  if (comm.rank() == 0) {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(0, std::ios::end);
    const auto size = static_cast<long long>(f.tellg());
    // the largest dataset (the displacement rows) fills most of the file's second half
    f.seekp(size * 3 / 4);
    char c = 0;
    f.read(&c, 1);
    f.seekp(size * 3 / 4);
    c = static_cast<char>(c ^ 0x10);
    f.write(&c, 1);
  }
  comm.barrier();
  try {
    (void)obs::readCheckpoint(file, keysOf(askedRows(comm)), comm);
    ADD_FAILURE() << "no error for a damaged file";
  } catch (const obs::Error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
  comm.barrier();
  if (comm.rank() == 0) fs::remove(file);
}

}  // namespace

int main(int argc, char** argv) {
  obs::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
