// sculptd against a store that asks too much of it (docs/store.md, "What
// recovery checks"): a journal record far ahead is refused by name and the
// daemon starts; one that would take the replay minutes is stopped by SIGTERM
// at once, leaving the store as it was. The store is made by sculptd itself
// and then altered with SQLite (the journal's records carry no checksum of
// their own; SQLite keeps its file's).
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>

#include <filesystem>
#include <thread>

#include "daemon_fixture.hpp"
#include "sculptd_process.hpp"

namespace sculpt::e2e {
namespace {

namespace fs = std::filesystem;

struct Dir {
  fs::path path;
  explicit Dir(const std::string& name) : path(temp_path(name)) { fs::remove_all(path); }
  ~Dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

// A sculpt saved by sculptd: the push recording for a couple of seconds, stopped.
void sculpt_into(const fs::path& dir) {
  Daemon d("untrusted-make", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl"),
                              "--state-dir", dir.string()});
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
}

// A journal mark ("the sim thread finished this tick") at store tick `tick`,
// or `ahead` ticks after the newest record when tick is 0.
void add_mark(const fs::path& dir, std::int64_t tick, std::int64_t ahead = 0) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "store.db").c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "INSERT INTO journal (tick, data) VALUES "
                               "(CASE WHEN ?1 > 0 THEN ?1 ELSE (SELECT max(tick) FROM journal) + ?2 END, ?3)",
                               -1, &st, nullptr),
            SQLITE_OK);
  const unsigned char mark[9] = {5, 0, 0, 0, 0, 0, 0, 0, 0};  // JournalEntry::Kind::reached, wall time 0
  sqlite3_bind_int64(st, 1, tick);
  sqlite3_bind_int64(st, 2, ahead);
  sqlite3_bind_blob(st, 3, mark, sizeof mark, SQLITE_STATIC);
  EXPECT_EQ(sqlite3_step(st), SQLITE_DONE) << sqlite3_errmsg(db);
  sqlite3_finalize(st);
  sqlite3_close(db);
}

std::int64_t journal_rows(const fs::path& dir) {
  sqlite3* db = nullptr;
  sqlite3_open((dir / "store.db").c_str(), &db);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT count(*) FROM journal", -1, &st, nullptr);
  const std::int64_t n = sqlite3_step(st) == SQLITE_ROW ? sqlite3_column_int64(st, 0) : -1;
  sqlite3_finalize(st);
  sqlite3_close(db);
  return n;
}

TEST(SculptdUntrusted, AJournalRecordFarAheadIsRefusedByNameAndTheDaemonStarts) {
  Dir d("untrusted-far");
  sculpt_into(d.path);
  add_mark(d.path, std::int64_t{1} << 62);
  Daemon again("untrusted-far-2", {"--state-dir", d.path.string()});
  const std::string log = again.process->log();
  EXPECT_NE(log.find("recovered the sculpt of builtin:default"), std::string::npos) << log;
  EXPECT_NE(log.find("not exact, see below"), std::string::npos) << log;
  EXPECT_NE(log.find("a journal record of tick 4611686018427387903 is "), std::string::npos) << log;
  EXPECT_NE(log.find("the journal after it is not replayed"), std::string::npos) << log;
  EXPECT_NE(log.find("is kept as"), std::string::npos) << log;
}

TEST(SculptdUntrusted, SIGTERMStopsALongReplayAndLeavesTheStoreAsItWas) {
  Dir d("untrusted-long");
  sculpt_into(d.path);
  add_mark(d.path, 0, 30'000'000);  // 8 h 20 min of ticks at 1 kHz after the last: within the span, not the time
  const std::int64_t rows = journal_rows(d.path);
  Sculptd slow({"--state-dir", d.path.string(), "--socket", temp_path("untrusted-long.sock")});
  std::this_thread::sleep_for(std::chrono::seconds(2));
  ASSERT_EQ(slow.log().find("sculptd ready"), std::string::npos) << "still replaying:\n" << slow.log();
  const auto asked = std::chrono::steady_clock::now();
  slow.signal(SIGTERM);
  EXPECT_EQ(slow.wait_exit(30s), 0) << slow.log();
  EXPECT_LT(std::chrono::steady_clock::now() - asked, 20s) << "a hang, not a stop";
  EXPECT_NE(slow.log().find("recovery stopped at tick"), std::string::npos) << slow.log();
  EXPECT_EQ(journal_rows(d.path), rows) << "a stopped recovery changes nothing";
}

}  // namespace
}  // namespace sculpt::e2e
