// Disk faults: full (max_page_count), read-only (query_only: the tests run as
// root, for whom a chmod changes nothing), an uncreatable directory. Writes
// fail softly with a message, back off, keep the journal in memory and catch
// up when the disk comes back.
#include <gtest/gtest.h>

#include "test_records.hpp"

namespace sculpt::store::testing {
namespace {

Limits retry_every_call() {
  Limits l;
  l.retry_interval = std::chrono::milliseconds(0);
  return l;
}

void expect_mentions(const Status& s, std::string_view what, const Store& store) {
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.error.find(what), std::string::npos) << s.error;
  EXPECT_NE(s.error.find(store.database().string()), std::string::npos) << s.error;
}

TEST(Faults, DiskFullFailsSoftlyAndTheJournalCatchesUpWhenSpaceReturns) {
  TempDir dir;
  Store s = Store::open(dir.path(), retry_every_call());
  ASSERT_TRUE(succeeded(s.write_snapshot(0, random_bytes(10'000, 1))));
  s.execute_for_testing("PRAGMA max_page_count = 1");  // clamps to the current size
  const auto lost_while_full = records(1, 200);
  const Status full = s.append(views(lost_while_full));
  expect_mentions(full, "full", s);
  EXPECT_FALSE(full.deferred);
  expect_mentions(s.write_snapshot(150, random_bytes(10'000, 2)), "full", s);
  EXPECT_TRUE(s.health().degraded);
  EXPECT_EQ(s.health().pending_records, 200u);

  s.execute_for_testing("PRAGMA max_page_count = 1000000");
  const auto after = records(201, 210);
  ASSERT_TRUE(succeeded(s.append(views(after))));
  EXPECT_FALSE(s.health().degraded);
  EXPECT_EQ(s.health().pending_records, 0u);
  const Recovery r = s.recover();
  EXPECT_TRUE(r.exact());
  EXPECT_EQ(r.journal, records(1, 210));
}

TEST(Faults, ReadOnlyDatabaseFailsSoftlyAndRecovers) {
  TempDir dir;
  Store s = Store::open(dir.path(), retry_every_call());
  s.execute_for_testing("PRAGMA query_only = 1");
  const Status ro = s.write_snapshot(5, random_bytes(100, 1));
  expect_mentions(ro, "readonly", s);
  expect_mentions(s.append(views(records(6, 7))), "readonly", s);
  s.execute_for_testing("PRAGMA query_only = 0");
  ASSERT_TRUE(succeeded(s.append(views(records(8, 9)))));
  ASSERT_TRUE(succeeded(s.write_snapshot(9, random_bytes(100, 2))));
  const Recovery r = s.recover();
  EXPECT_EQ(r.snapshot->tick, 9u);
  EXPECT_TRUE(r.journal.empty());
}

TEST(Faults, ACopyMadeWhileTheDiskRefusesWritesHoldsWhatIsHeldInMemory) {
  TempDir dir, files;
  Store s = Store::open(dir.path(), retry_every_call());
  ASSERT_TRUE(succeeded(s.write_snapshot(5, random_bytes(100, 1), "snap")));
  ASSERT_TRUE(succeeded(s.append(views(records(6, 7)))));
  s.execute_for_testing("PRAGMA max_page_count = 1");  // full: the disk refuses the journal
  EXPECT_FALSE(s.append(views(records(8, 300))).ok);
  ASSERT_EQ(s.health().pending_records, 293u);
  s.export_copy(files.path() / "rescue.sculpt");
  Store reader = Store::open(files.path());  // a store of its own, to open the copy beside
  Store copy = reader.open_candidate(files.path() / "rescue.sculpt");
  const Recovery r = copy.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->meta, "snap");
  EXPECT_EQ(r.journal, records(6, 300)) << "the records the disk refused are in the copy";
}

TEST(Faults, AfterAFailureWritesAreDeferredUntilTheRetryIsDue) {
  TempDir dir;
  Limits limits;
  limits.retry_interval = std::chrono::hours(1);
  Store s = Store::open(dir.path(), limits);
  s.execute_for_testing("PRAGMA query_only = 1");
  EXPECT_FALSE(s.append(views(records(1, 1))).deferred);
  s.execute_for_testing("PRAGMA query_only = 0");  // fixed, but the retry is an hour away
  for (int i = 0; i < 3; ++i) {
    const Status st = s.append(views(records(2 + i, 2 + i)));
    EXPECT_TRUE(st.deferred);
    EXPECT_NE(st.error.find("degraded"), std::string::npos) << st.error;
  }
  EXPECT_TRUE(s.write_snapshot(10, random_bytes(10, 1)).deferred);
  EXPECT_EQ(s.health().failures, 1u);  // the deferred calls never touched the disk
  EXPECT_EQ(s.health().pending_records, 4u);
  EXPECT_TRUE(s.recover().journal.empty());
}

TEST(Faults, RecordsBeyondThePendingBudgetBecomeAReportedGapThatASnapshotHeals) {
  TempDir dir;
  Limits limits = retry_every_call();
  limits.max_pending_bytes = 10 * 64;
  Store s = Store::open(dir.path(), limits);
  ASSERT_TRUE(succeeded(s.write_snapshot(0, random_bytes(100, 1))));
  s.execute_for_testing("PRAGMA query_only = 1");
  for (std::uint64_t t = 1; t <= 30; t += 5) EXPECT_FALSE(s.append(views(records(t, t + 4))));
  EXPECT_EQ(s.health().dropped_records, 20u);
  s.execute_for_testing("PRAGMA query_only = 0");
  ASSERT_TRUE(succeeded(s.append(views(records(31, 32)))));
  Recovery r = s.recover();
  EXPECT_EQ(r.journal, records(21, 32));  // the newest ten kept, then the new two
  ASSERT_EQ(r.lost.size(), 1u);
  EXPECT_NE(r.lost[0].find("20 journal records of ticks 1-20"), std::string::npos) << r.lost[0];

  ASSERT_TRUE(succeeded(s.write_snapshot(32, random_bytes(100, 2))));
  r = s.recover();
  EXPECT_TRUE(r.exact());
}

TEST(Faults, DirectoryThatCannotBeMadeIsAClearOpenError) {
  TempDir dir;
  write_file(dir.path() / "plain", "x", 1);
  try {
    Store::open(dir.path() / "plain" / "sculpt");
    FAIL() << "opened a store below a regular file";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find((dir.path() / "plain").string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sculpt::store::testing
