// Nothing destroys a sculpt: a store set aside or replaced is kept under a
// generation name, bounded per kind, and a kind never pushes out another; a
// store whose files are taken away while it runs writes them back (or, when
// another store took its directory, goes on in its unnamed files); the
// directory's own lock keeps a second store out when the lock file is gone.
#include <gtest/gtest.h>

#include <fstream>

#include "test_records.hpp"

namespace sculpt::store::testing {
namespace {

std::string meta_of(Store& s) {
  const Recovery r = s.recover();
  return r.snapshot ? r.snapshot->meta : std::string("(none)");
}

// A sculpt in `s`: a snapshot named `meta` at tick 10 and records of ticks 11-20.
void sculpt(Store& s, const std::string& meta) {
  ASSERT_TRUE(succeeded(s.write_snapshot(10, random_bytes(5000, 3), meta)));
  ASSERT_TRUE(succeeded(s.append(views(records(11, 20)))));
}

TEST(Kept, SetAsideKeepsTheStoreAndStartsAnEmptyOne) {
  TempDir dir;
  Store s = Store::open(dir.path());
  EXPECT_TRUE(s.set_aside(Kept::previous).empty()) << "an empty store keeps nothing";
  sculpt(s, "first");
  const fs::path kept = s.set_aside(Kept::previous);
  ASSERT_FALSE(kept.empty());
  EXPECT_TRUE(fs::exists(kept));
  EXPECT_EQ(meta_of(s), "(none)");
  EXPECT_TRUE(s.recover().journal.empty());
  ASSERT_TRUE(succeeded(s.append(views(records(1, 3)))));  // the new store works
  Store back = s.open_candidate(kept);
  const Recovery r = back.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->meta, "first");
  EXPECT_EQ(r.journal.size(), 10u);
}

TEST(Kept, GenerationsAreBoundedPerKindAndOneKindNeverPushesOutTheOther) {
  TempDir dir;
  Store s = Store::open(dir.path());
  std::vector<fs::path> previous;
  for (int i = 0; i < 4; ++i) {
    sculpt(s, "good " + std::to_string(i));
    previous.push_back(s.set_aside(Kept::previous));
  }
  const std::vector<fs::path> newest(previous.begin() + 1, previous.end());
  EXPECT_EQ(Store::generations(dir.path(), Kept::previous), newest) << "the oldest of four went";
  for (int i = 0; i < 5; ++i) {
    sculpt(s, "bad " + std::to_string(i));
    ASSERT_FALSE(s.set_aside(Kept::unrecovered).empty());
  }
  EXPECT_EQ(Store::generations(dir.path(), Kept::unrecovered).size(), Store::kKeptGenerations);
  EXPECT_EQ(Store::generations(dir.path(), Kept::previous), newest)
      << "stores that did not recover never push out one that did";
  Store last = s.open_candidate(newest.back());
  EXPECT_EQ(meta_of(last), "good 3");
}

TEST(Taken, ADatabaseRemovedWithItsLogIsWrittenBackAtTheNextWrite) {
  TempDir dir;
  Store s = Store::open(dir.path());
  sculpt(s, "kept");
  const fs::path db = dir.path() / "store.db";
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(db.string() + suffix);
  ASSERT_TRUE(succeeded(s.append(views(records(21, 25)))));
  const Health h = s.health();
  EXPECT_EQ(h.relocations, 1u);
  EXPECT_NE(h.relocation.find("was removed"), std::string::npos) << h.relocation;
  EXPECT_NE(h.relocation.find(db.string()), std::string::npos) << h.relocation;
  EXPECT_FALSE(h.unnamed);
  EXPECT_TRUE(fs::exists(db));
  ASSERT_TRUE(succeeded(s.append(views(records(26, 27)))));
  EXPECT_EQ(s.health().relocations, 1u) << "once: the files are the store's again";
  {
    Store moved = std::move(s);  // closes with the scope
  }
  Store again = Store::open(dir.path());
  const Recovery r = again.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.snapshot->meta, "kept");
  EXPECT_EQ(r.journal.size(), 17u) << "ticks 11-27: nothing written before or after is lost";
  EXPECT_TRUE(r.exact());
}

TEST(Taken, AStoreWithNothingToWriteFindsItsFilesGoneWhenItLooks) {
  TempDir base;
  const fs::path dir = base.path() / "state";
  Store s = Store::open(dir);
  sculpt(s, "kept");
  fs::remove_all(dir);
  EXPECT_TRUE(s.check_files().ok);
  EXPECT_EQ(s.health().relocations, 1u);
  EXPECT_THROW(Store::open(dir), StoreInUse) << "made again and locked before anyone else came";
  EXPECT_TRUE(s.check_files().ok);
  EXPECT_EQ(s.health().relocations, 1u) << "nothing more to do";
  EXPECT_EQ(meta_of(s), "kept");
}

TEST(Taken, AWriteAheadLogRemovedAloneIsWrittenBackToo) {
  TempDir dir;
  Store s = Store::open(dir.path());
  sculpt(s, "kept");
  fs::remove(dir.path() / "store.db-wal");
  ASSERT_TRUE(succeeded(s.append(views(records(21, 22)))));
  EXPECT_NE(s.health().relocation.find("store.db-wal was removed"), std::string::npos) << s.health().relocation;
  {
    Store moved = std::move(s);
  }
  Store again = Store::open(dir.path());
  const Recovery r = again.recover();
  ASSERT_TRUE(r.snapshot);
  EXPECT_EQ(r.journal.size(), 12u);
}

TEST(Taken, AFileThatReplacedTheDatabaseIsKeptAsideNotOverwritten) {
  TempDir dir;
  Store s = Store::open(dir.path());
  sculpt(s, "kept");
  const fs::path db = dir.path() / "store.db";
  std::ofstream(dir.path() / "other") << "someone's file";
  fs::rename(dir.path() / "other", db);
  ASSERT_TRUE(succeeded(s.append(views(records(21, 22)))));
  EXPECT_NE(s.health().relocation.find("was replaced by another file"), std::string::npos) << s.health().relocation;
  EXPECT_EQ(read_file(db.string() + ".foreign"), "someone's file");
  EXPECT_EQ(meta_of(s), "kept");
}

TEST(Taken, TheDirectoryRemovedIsMadeAgainAndLockedAgain) {
  TempDir base;
  const fs::path dir = base.path() / "state";
  Store s = Store::open(dir);
  sculpt(s, "kept");
  fs::remove_all(dir);
  ASSERT_TRUE(succeeded(s.append(views(records(21, 22)))));
  EXPECT_NE(s.health().relocation.find("directory"), std::string::npos) << s.health().relocation;
  EXPECT_TRUE(fs::exists(dir / "store.db"));
  EXPECT_THROW(Store::open(dir), StoreInUse) << "the new directory is this store's";
  EXPECT_EQ(meta_of(s), "kept");
  EXPECT_EQ(s.recover().journal.size(), 12u);
}

TEST(Taken, ADirectoryAnotherStoreTookIsLeftToItAndThisOneGoesOnUnnamed) {
  TempDir base, files;
  const fs::path dir = base.path() / "state";
  Store s = Store::open(dir);
  sculpt(s, "mine");
  fs::remove_all(dir);
  Store other = Store::open(dir);  // another daemon, first to the new directory
  ASSERT_TRUE(succeeded(other.write_snapshot(1, random_bytes(10, 1), "theirs")));
  const Status st = s.append(views(records(21, 22)));
  EXPECT_TRUE(st.ok) << st.error;
  const Health h = s.health();
  EXPECT_TRUE(h.unnamed);
  EXPECT_NE(h.relocation.find("in use by another process"), std::string::npos) << h.relocation;
  EXPECT_EQ(meta_of(other), "theirs") << "the other store is untouched";
  // What this one holds can still be saved: its connection reads it all.
  s.export_copy(files.path() / "mine.sculpt");
  Store reader = other.open_candidate(files.path() / "mine.sculpt");
  EXPECT_EQ(meta_of(reader), "mine");
  EXPECT_EQ(reader.recover().journal.size(), 12u);
}

TEST(Lock, ARemovedLockFileDoesNotLetASecondStoreIn) {
  TempDir dir;
  Store s = Store::open(dir.path());
  fs::remove(dir.path() / "lock");
  EXPECT_THROW(Store::open(dir.path()), StoreInUse);
  ASSERT_TRUE(succeeded(s.append(views(records(1, 2)))));
  EXPECT_EQ(read_file(dir.path() / "lock"), std::to_string(::getpid()) + "\n") << "made again, naming the holder";
  try {
    Store::open(dir.path());
    ADD_FAILURE() << "a second store opened";
  } catch (const StoreInUse& e) {
    EXPECT_NE(std::string(e.what()).find("(PID " + std::to_string(::getpid()) + ")"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sculpt::store::testing
