// daemon/store: round trips, tick rules, damaged snapshots, the lock, the
// schema check and bounded disk use.
#include <gtest/gtest.h>
#include <unistd.h>

#include <string>

#include "store/codec.hpp"
#include "test_records.hpp"

namespace sculpt::store::testing {
namespace {

TEST(Store, SnapshotAndJournalComeBackExactlyAfterReopen) {
  TempDir dir;
  const auto state = random_bytes(100'000, 1);
  const auto batch1 = records(11, 20), batch2 = records(21, 30);
  {
    Store s = Store::open(dir.path() / "sculpt");
    ASSERT_TRUE(succeeded(s.write_snapshot(10, state, "{\"vertices\":3}")));
    ASSERT_TRUE(succeeded(s.append(views(batch1))));
    ASSERT_TRUE(succeeded(s.append(views(batch2))));
    const Recovery live = s.recover();
    ASSERT_TRUE(live.snapshot);
    EXPECT_EQ(live.journal.size(), 20u);
  }
  EXPECT_EQ(fs::status(dir.path() / "sculpt").permissions() & fs::perms::all,
            fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec);
  Store s = Store::open(dir.path() / "sculpt");
  const Recovery r = s.recover();
  EXPECT_TRUE(r.exact());
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->tick, 10u);
  EXPECT_EQ(r.snapshot->state, state);
  EXPECT_EQ(r.snapshot->meta, "{\"vertices\":3}");
  std::vector<Record> expected = batch1;
  expected.insert(expected.end(), batch2.begin(), batch2.end());
  EXPECT_EQ(r.journal, expected);
}

TEST(Store, NewStoreRecoversNothingAndJournalAloneIsWhole) {
  TempDir dir;
  Store s = Store::open(dir.path());
  Recovery r = s.recover();
  EXPECT_TRUE(r.exact());
  EXPECT_FALSE(r.snapshot);
  EXPECT_TRUE(r.journal.empty());
  const auto batch = records(0, 5);
  ASSERT_TRUE(succeeded(s.append(views(batch))));
  r = s.recover();
  EXPECT_FALSE(r.snapshot);
  EXPECT_EQ(r.journal, batch);
}

TEST(Store, JournalIsWhatComesAfterTheSnapshotTickInTickOrder) {
  TempDir dir;
  Store s = Store::open(dir.path());
  // A batch committed after the snapshot may still hold ticks it covers.
  ASSERT_TRUE(succeeded(s.append(views(records(1, 8)))));
  ASSERT_TRUE(succeeded(s.write_snapshot(10, random_bytes(1000, 2))));
  const std::vector<Record> late = {record(9), record(10), record(11), record(12)};
  ASSERT_TRUE(succeeded(s.append(views(late))));
  const Record same_tick{12, random_bytes(8, 99)};
  ASSERT_TRUE(succeeded(s.append(views({same_tick}))));
  const Recovery r = s.recover();
  EXPECT_EQ(r.journal, (std::vector<Record>{record(11), record(12), same_tick}));
}

TEST(Store, EmptyStateAndEmptyRecordsRoundTrip) {
  TempDir dir;
  Store s = Store::open(dir.path());
  ASSERT_TRUE(succeeded(s.write_snapshot(3, {})));
  const Record empty{4, {}};
  ASSERT_TRUE(succeeded(s.append(views({empty}))));
  const Recovery r = s.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_TRUE(r.snapshot->state.empty());
  EXPECT_EQ(r.journal, std::vector<Record>{empty});
}

// Flips one bit of the newest snapshot's stored bytes at `offset` (from the
// end when negative), as a bad sector or a stray write would.
void flip_newest_snapshot_bit(const fs::path& file, long offset) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT id, data FROM snapshot ORDER BY id DESC LIMIT 1", -1, &st, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  const sqlite3_int64 id = sqlite3_column_int64(st, 0);
  const auto* p = static_cast<const char*>(sqlite3_column_blob(st, 1));
  std::string data(p, static_cast<std::size_t>(sqlite3_column_bytes(st, 1)));
  sqlite3_finalize(st);
  data[static_cast<std::size_t>(offset >= 0 ? offset : static_cast<long>(data.size()) + offset)] ^= 0x04;
  ASSERT_EQ(sqlite3_prepare_v2(db, "UPDATE snapshot SET data = ? WHERE id = ?", -1, &st, nullptr), SQLITE_OK);
  sqlite3_bind_blob(st, 1, data.data(), static_cast<int>(data.size()), SQLITE_STATIC);
  sqlite3_bind_int64(st, 2, id);
  EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
  sqlite3_finalize(st);
  sqlite3_close(db);
}

TEST(Store, CorruptNewestSnapshotFallsBackToTheOlderOneAndItsJournal) {
  for (const long offset : {-2L, 20'000L, 4L}) {  // checksum, payload, checksum flag
    SCOPED_TRACE(offset);
    TempDir dir;
    const auto old_state = random_bytes(50'000, 3);
    {
      Store s = Store::open(dir.path());
      ASSERT_TRUE(succeeded(s.write_snapshot(10, old_state)));
      ASSERT_TRUE(succeeded(s.append(views(records(11, 20)))));
      ASSERT_TRUE(succeeded(s.write_snapshot(20, random_bytes(50'000, 4))));
      ASSERT_TRUE(succeeded(s.append(views(records(21, 25)))));
    }
    flip_newest_snapshot_bit(dir.path() / "store.db", offset);
    Store s = Store::open(dir.path());
    const Recovery r = s.recover();
    ASSERT_TRUE(r.snapshot);
    EXPECT_EQ(r.snapshot->tick, 10u);
    EXPECT_EQ(r.snapshot->state, old_state);
    EXPECT_EQ(r.journal, records(11, 25));
    ASSERT_EQ(r.lost.size(), 1u);
    EXPECT_NE(r.lost[0].find("skipped the snapshot of tick 20"), std::string::npos) << r.lost[0];
  }
}

TEST(Store, NoSnapshotDecodesIsReportedNotThrown) {
  TempDir dir;
  {
    Store s = Store::open(dir.path());
    ASSERT_TRUE(succeeded(s.write_snapshot(10, random_bytes(5000, 5))));
    ASSERT_TRUE(succeeded(s.append(views(records(11, 12)))));
  }
  raw_sql(dir.path() / "store.db", "UPDATE snapshot SET data = zeroblob(100)");
  Store s = Store::open(dir.path());
  const Recovery r = s.recover();
  EXPECT_FALSE(r.snapshot);
  EXPECT_TRUE(r.journal.empty());
  ASSERT_EQ(r.lost.size(), 2u);
  EXPECT_NE(r.lost[1].find("no snapshot could be decoded"), std::string::npos) << r.lost[1];
}

TEST(Store, SecondOpenIsRefusedNamingTheLockAndItsHolder) {
  TempDir dir;
  Store first = Store::open(dir.path());
  try {
    Store::open(dir.path());
    FAIL() << "a second open succeeded";
  } catch (const StoreError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find((dir.path() / "lock").string()), std::string::npos) << what;
    EXPECT_NE(what.find("PID " + std::to_string(::getpid())), std::string::npos) << what;
  }
}

TEST(Store, NewerSchemaAndForeignDatabasesAreRefused) {
  TempDir dir;
  { Store s = Store::open(dir.path()); }
  raw_sql(dir.path() / "store.db", "PRAGMA user_version = 2");
  try {
    Store::open(dir.path());
    FAIL() << "opened a newer schema";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("schema version 2"), std::string::npos) << e.what();
  }
  TempDir other;
  raw_sql(other.path() / "store.db", "CREATE TABLE t (x)");
  EXPECT_THROW(Store::open(other.path()), StoreError);
}

TEST(Store, OldSnapshotsAndTheirJournalAreDeletedAndFilesStayBounded) {
  TempDir dir;
  Limits limits;
  limits.keep_snapshots = 2;
  Store s = Store::open(dir.path(), limits);
  constexpr std::size_t kState = 300'000;  // random: stored at about this size
  std::uint64_t high_water = 0;
  for (std::uint64_t i = 1; i <= 30; ++i) {
    ASSERT_TRUE(succeeded(s.write_snapshot(i * 100, random_bytes(kState, static_cast<std::uint32_t>(i)))));
    ASSERT_TRUE(succeeded(s.append(views(records(i * 100 + 1, i * 100 + 50)))));
    const Usage u = s.usage();
    high_water = std::max(high_water, u.database_bytes + u.wal_bytes);
  }
  const Usage u = s.usage();
  EXPECT_EQ(u.snapshots, 2);
  EXPECT_EQ(u.journal_records, 100);  // after tick 2900: 2901-2950 and 3001-3050
  // Two snapshots kept plus the one being written, and the journal.
  EXPECT_LT(high_water, 4 * kState);
  ASSERT_TRUE(succeeded(s.write_snapshot(3100, random_bytes(10, 1))));
  EXPECT_EQ(s.usage().wal_bytes, 0u);  // checkpointed and truncated
  const Recovery r = s.recover();
  EXPECT_EQ(r.snapshot->tick, 3100u);
  EXPECT_TRUE(r.journal.empty());
}

TEST(Codec, ShuffleIsItsOwnInverseForEveryTailLength) {
  for (std::size_t n : {0, 1, 3, 4, 5, 7, 8, 1001}) {
    const auto raw = random_bytes(n, static_cast<std::uint32_t>(n));
    EXPECT_EQ(unshuffle4(shuffle4(raw)), raw);
    std::string why;
    const auto back = decode(encode(raw, Codec::shuffle4_zstd, 1), 2, n, why);
    ASSERT_TRUE(back) << why;
    EXPECT_EQ(*back, raw);
  }
}

}  // namespace
}  // namespace sculpt::store::testing
