// daemon/store's blobs (kept while a kept snapshot refers to them, and a
// snapshot missing one is not used), clearing a store, and a store copied
// out (export_copy), opened beside another directory's store and adopted
// by it (open_candidate, adopt).
#include <gtest/gtest.h>

#include <fstream>

#include "test_records.hpp"

namespace sculpt::store::testing {
namespace {

std::int64_t blob_count(const fs::path& dir) {
  sqlite::Connection db(dir / "store.db", false);
  return db.query_int("SELECT count(*) FROM blob", "count");
}

TEST(Blobs, KeptWhileAKeptSnapshotRefersToThem) {
  TempDir dir;
  Limits limits;
  limits.keep_snapshots = 2;
  Store s = Store::open(dir.path(), limits);
  const auto a = random_bytes(5000, 1), b = random_bytes(7000, 2);
  const std::vector<BlobWrite> both{{"a", a}, {"b", b}};
  const std::vector<std::string> ab{"a", "b"}, only_b{"b"};
  ASSERT_TRUE(s.write_snapshot(1, random_bytes(100, 3), "one", both, ab).ok);
  ASSERT_TRUE(s.write_snapshot(2, random_bytes(100, 4), "two", {}, only_b).ok);
  EXPECT_EQ(blob_count(dir.path()), 2) << "snapshot one still refers to a";
  ASSERT_TRUE(s.write_snapshot(3, random_bytes(100, 5), "three", {}, only_b).ok);
  EXPECT_EQ(blob_count(dir.path()), 1) << "no kept snapshot refers to a";
  const Recovery r = s.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->meta, "three");
  ASSERT_EQ(r.snapshot->blobs.size(), 1u);
  EXPECT_EQ(r.snapshot->blobs.at("b"), b);
}

TEST(Blobs, ASnapshotMissingOneIsNotUsed) {
  TempDir dir;
  Store s = Store::open(dir.path());
  const auto a = random_bytes(5000, 1);
  const std::vector<BlobWrite> blobs{{"a", a}};
  const std::vector<std::string> refs{"a"}, missing{"a", "gone"};
  ASSERT_TRUE(s.write_snapshot(1, random_bytes(100, 3), "good", blobs, refs).ok);
  ASSERT_TRUE(s.write_snapshot(2, random_bytes(100, 4), "bad", {}, missing).ok);
  const Recovery r = s.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->meta, "good");
  ASSERT_EQ(r.lost.size(), 1u);
  EXPECT_NE(r.lost[0].find("blob gone is missing"), std::string::npos) << r.lost[0];
}

TEST(Store, ClearEmptiesEverything) {
  TempDir dir;
  Store s = Store::open(dir.path());
  const auto a = random_bytes(100, 1);
  const std::vector<BlobWrite> blobs{{"a", a}};
  const std::vector<std::string> refs{"a"};
  ASSERT_TRUE(s.write_snapshot(5, random_bytes(100, 2), "m", blobs, refs).ok);
  ASSERT_TRUE(s.append(views(records(6, 9))).ok);
  s.clear();
  const Recovery r = s.recover();
  EXPECT_FALSE(r.snapshot);
  EXPECT_TRUE(r.journal.empty());
  EXPECT_EQ(blob_count(dir.path()), 0);
}

TEST(Store, ACopyIsOpenedBesideTheStoreAndOnlyAdoptedReplacesItWhichIsKept) {
  TempDir from, to, files;
  const auto state = random_bytes(20000, 7);
  {
    Store s = Store::open(from.path());
    ASSERT_TRUE(s.write_snapshot(3, state, "exported").ok);
    ASSERT_TRUE(s.append(views(records(4, 8))).ok);
    s.export_copy(files.path() / "x.sculpt");
  }
  {
    Store old = Store::open(to.path());
    ASSERT_TRUE(old.write_snapshot(1, random_bytes(10, 1), "replaced").ok);
  }
  fs::path kept;
  {
    Store s = Store::open(to.path());
    Store candidate = s.open_candidate(files.path() / "x.sculpt");
    const Recovery c = candidate.recover();
    ASSERT_TRUE(c.snapshot);
    EXPECT_EQ(c.snapshot->meta, "exported");
    const Recovery before = s.recover();
    ASSERT_TRUE(before.snapshot);
    EXPECT_EQ(before.snapshot->meta, "replaced") << "a candidate changes nothing of the store";
    kept = s.adopt(std::move(candidate));
    ASSERT_FALSE(kept.empty());
    EXPECT_EQ(kept.parent_path(), to.path());
    EXPECT_EQ(kept.filename().string().rfind("previous-", 0), 0u) << kept;
    EXPECT_EQ(Store::generations(to.path(), Kept::previous), std::vector<fs::path>{kept});
    const Recovery r = s.recover();
    ASSERT_TRUE(r.snapshot);
    EXPECT_EQ(r.snapshot->meta, "exported");
    EXPECT_EQ(r.snapshot->state, state);
    EXPECT_EQ(r.journal.size(), 5u);
    EXPECT_FALSE(fs::exists(to.path() / "opening.db"));
  }
  {
    // The kept one is a sculpt to open again; a candidate dropped leaves no copy.
    Store s = Store::open(to.path());
    {
      Store back = s.open_candidate(kept);
      const Recovery r = back.recover();
      ASSERT_TRUE(r.snapshot);
      EXPECT_EQ(r.snapshot->meta, "replaced");
    }
    EXPECT_FALSE(fs::exists(to.path() / "opening.db"));
    // Not a store, or not there: refused by name, the store as it was, no copy left.
    std::ofstream(files.path() / "junk.sculpt") << "junk";
    try {
      (void)s.open_candidate(files.path() / "junk.sculpt");
      ADD_FAILURE() << "junk opened";
    } catch (const StoreError& e) {
      EXPECT_NE(std::string(e.what()).find("junk.sculpt"), std::string::npos) << e.what();
    }
    EXPECT_THROW((void)s.open_candidate(files.path() / "none.sculpt"), StoreError);
    EXPECT_FALSE(fs::exists(to.path() / "opening.db"));
    const Recovery r = s.recover();
    ASSERT_TRUE(r.snapshot);
    EXPECT_EQ(r.snapshot->meta, "exported");
  }
}

}  // namespace
}  // namespace sculpt::store::testing
