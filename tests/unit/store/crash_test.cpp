// Crash safety the way SQLite tests itself: a crash can stop the writes to
// the WAL at any byte. The store's files are copied while it is open (as a
// crash would leave them), the -wal copy is cut at every byte offset of its
// last two commits, and a store opened on each cut copy must recover the
// snapshot and exactly the journal transactions that were complete.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstring>

#include "test_records.hpp"

namespace sculpt::store::testing {
namespace {

std::uint32_t big_endian32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return (std::uint32_t{u[0]} << 24) | (std::uint32_t{u[1]} << 16) | (std::uint32_t{u[2]} << 8) | u[3];
}

// The byte offsets at which each commit's frames end, from the WAL format
// (sqlite.org/fileformat.html#the_write_ahead_log): a 32-byte header, then
// frames of a 24-byte header and one page; a commit frame's header holds
// the database size after the commit (nonzero) at bytes 4-7.
std::vector<std::size_t> commit_ends(const std::string& wal) {
  std::vector<std::size_t> ends;
  if (wal.size() < 32) return ends;
  const std::size_t frame = 24 + big_endian32(wal.data() + 8);
  for (std::size_t at = 32; at + frame <= wal.size(); at += frame)
    if (big_endian32(wal.data() + at + 4) != 0) ends.push_back(at + frame);
  return ends;
}

// Thousands of opens, each fsyncing its checkpoint on close: in memory when
// the machine has a tmpfs, so the test takes seconds, not minutes.
fs::path scratch_base() {
  std::error_code ec;
  if (fs::is_directory("/dev/shm", ec) && ::access("/dev/shm", W_OK) == 0) return "/dev/shm";
  return fs::temp_directory_path();
}

// The sanitized build (ASan + UBSan) checks the store's own code; SQLite is
// the system's, uninstrumented, and takes a frame whole or not at all, so
// every cut inside one page takes the same path through the store. There the
// cuts are every byte of each frame's header and of the 32 bytes either side
// of each frame boundary, and every 61st byte of the pages between; the
// optimised build cuts at every byte.
bool cut_here(std::size_t cut, std::size_t frame) {
  if (!kSanitized || cut < 32) return true;
  const std::size_t in_frame = (cut - 32) % frame;
  return in_frame < 24 + 32 || in_frame >= frame - 32 || in_frame % 61 == 0;
}

TEST(Crash, WalCutAtEveryByteOfTheLastTwoCommitsLosesOnlyTheCutCommit) {
  TempDir dir, copy(scratch_base());
  const auto state = random_bytes(20'000, 7);
  std::vector<std::vector<Record>> batches;
  for (std::uint64_t b = 0; b < 6; ++b) batches.push_back(records(101 + b * 20, 120 + b * 20));

  Store s = Store::open(dir.path() / "live");
  ASSERT_TRUE(s.write_snapshot(100, state));  // checkpointed: the WAL starts empty
  for (const auto& batch : batches) ASSERT_TRUE(succeeded(s.append(views(batch))));
  const std::string db = read_file(s.database());
  const std::string wal = read_file(s.database().string() + "-wal");
  const std::vector<std::size_t> ends = commit_ends(wal);
  ASSERT_EQ(ends.size(), batches.size());
  ASSERT_EQ(ends.back(), wal.size());

  const std::size_t from = ends[ends.size() - 3], frame = 24 + big_endian32(wal.data() + 8);
  std::size_t checked = 0, wanted = 0;
  for (std::size_t cut = from; cut <= wal.size(); ++cut) {
    if (!cut_here(cut, frame)) continue;
    ++wanted;
    const fs::path store_dir = copy.path() / "cut";
    fs::remove_all(store_dir);
    fs::create_directories(store_dir);
    write_file(store_dir / "store.db", db.data(), db.size());
    write_file(store_dir / "store.db-wal", wal.data(), cut);

    std::size_t whole = 0;  // commits entirely before the cut
    while (whole < ends.size() && ends[whole] <= cut) ++whole;
    std::vector<Record> expected;
    for (std::size_t b = 0; b < whole; ++b) expected.insert(expected.end(), batches[b].begin(), batches[b].end());

    Store cut_store = Store::open(store_dir);
    const Recovery r = cut_store.recover();
    const bool ok = r.exact() && r.snapshot && r.snapshot->tick == 100 && r.snapshot->state == state &&
                    r.journal == expected;
    ASSERT_TRUE(ok) << "cut at byte " << cut << " of " << wal.size() << ": expected " << whole << " batches, got "
                    << r.journal.size() << " records; lost: " << (r.lost.empty() ? "" : r.lost.front());
    ++checked;
  }
  EXPECT_EQ(checked, wanted);
  RecordProperty("cuts", static_cast<int>(checked));
}

}  // namespace
}  // namespace sculpt::store::testing
