// sculptd's store from outside: a sculpt exported with sculptctl opens as the
// same sculpt in another daemon on another store (paused as it was left);
// two daemons never share a store, also when its lock file or its whole
// directory is removed; a state directory that cannot be used leaves the
// sculpt in memory; --fresh keeps the sculpt it replaces; a file that does
// not recover replaces nothing, one that does keeps the one it replaces; a
// store that does not recover is kept; store files removed under a running
// daemon are written back, and a crash after it loses nothing.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <thread>

#include <nlohmann/json.hpp>
#include <sqlite3.h>

#include "daemon_fixture.hpp"
#include "sculptd_process.hpp"
#include "support/timing.hpp"

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

// The generations kept in `dir` whose names start with `prefix`, sorted.
std::vector<fs::path> generations(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().filename().string().rfind(prefix, 0) == 0) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::string final_hash(Sculptd& d);

// Runs SQL on a store file no daemon has open.
void raw_sql(const fs::path& db_file, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_file.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
}

// A sculpt pushed for `ms` in `dir`, stopped with SIGTERM: its final hash.
std::string sculpt_in(const fs::path& dir, const std::string& name, int ms, const std::string& recording = "push.jsonl") {
  Sculptd d({"--scene", "builtin:default", "--input", "replay:" + recordings(recording), "--state-dir", dir.string(),
             "--socket", temp_path(name + ".sock")});
  if (!d.wait_for_log("sculptd ready", 60s)) return "(did not start: " + d.log() + ")";
  std::this_thread::sleep_for(std::chrono::milliseconds(ms));
  d.signal(SIGTERM);
  if (d.wait_exit(30s) != 0) return "(did not stop: " + d.log() + ")";
  return final_hash(d);
}

std::string final_hash(Sculptd& d) {
  static const std::regex re("final mesh hash ([0-9a-f]{16})");
  std::smatch m;
  const std::string log = d.log();
  return std::regex_search(log, m, re) ? std::string(m[1]) : std::string();
}

TEST(SculptdStore, AnExportedSculptOpensAsTheSameSculptElsewhere) {
  Dir a("store-a"), b("store-b"), files("store-files");
  fs::create_directories(files.path);
  const std::string file = (files.path / "ball.sculpt").string();
  std::string hash;
  {
    Daemon d("export", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl"), "--state-dir",
                        a.path.string()});
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));
    ASSERT_EQ(sculptctl({"pause", "--socket", d.socket}).status, 0);
    const CtlRun ex = sculptctl({"export", file, "--socket", d.socket});
    ASSERT_EQ(ex.status, 0) << ex.err;
    EXPECT_NE(ex.out.find("bytes"), std::string::npos) << ex.out;
    d.process->signal(SIGTERM);
    ASSERT_EQ(d.process->wait_exit(30s), 0) << d.process->log();
    hash = final_hash(*d.process);
    ASSERT_FALSE(hash.empty()) << d.process->log();
  }
  Sculptd opened({"--open", file, "--state-dir", b.path.string(), "--socket", temp_path("opened.sock")});
  ASSERT_TRUE(opened.wait_for_log("sculptd ready", 60s)) << opened.log();
  const std::string log = opened.log();
  EXPECT_NE(log.find("recovered the sculpt of builtin:default"), std::string::npos) << log;
  EXPECT_NE(log.find("(mesh hash " + hash + "), paused"), std::string::npos) << log;
  opened.signal(SIGTERM);
  EXPECT_EQ(opened.wait_exit(30s), 0);
  EXPECT_EQ(final_hash(opened), hash) << "paused as it was left: not a tick ran";

  // Not a sculpt: refused by name, nothing started.
  const std::string junk = (files.path / "junk.sculpt").string();
  std::ofstream(junk) << "not a sculpt";
  Sculptd bad({"--open", junk, "--state-dir", b.path.string(), "--socket", temp_path("bad.sock")});
  EXPECT_EQ(bad.wait_exit(60s), 1);
  EXPECT_NE(bad.log().find(junk), std::string::npos) << bad.log();
}

TEST(SculptdStore, TwoDaemonsNeverShareAStore) {
  Dir d("store-shared");
  Daemon first("shared", {"--state-dir", d.path.string()});
  Sculptd second({"--state-dir", d.path.string(), "--socket", temp_path("second.sock")});
  EXPECT_EQ(second.wait_exit(60s), 1);
  EXPECT_NE(second.log().find("in use by another process (PID " + std::to_string(first.process->pid()) + ")"),
            std::string::npos)
      << second.log();
}

TEST(SculptdStore, AStateDirectoryThatCannotBeUsedKeepsTheSculptInMemory) {
  Dir d("store-blocked");
  fs::create_directories(d.path);
  std::ofstream(d.path / "file") << "a file where the store's directory would be";
  Daemon daemon("blocked", {"--state-dir", (d.path / "file" / "state").string()});
  EXPECT_NE(daemon.process->log().find("kept in memory only"), std::string::npos) << daemon.process->log();
  const CtlRun undo = sculptctl({"undo", "--socket", daemon.socket});
  EXPECT_EQ(undo.status, 1);
  EXPECT_NE(undo.err.find("nothing to undo"), std::string::npos) << undo.err;
  EXPECT_EQ(sculptctl({"history", "--socket", daemon.socket}).status, 0);
}

TEST(SculptdStore, FreshKeepsTheSculptItReplaces) {
  Dir d("store-fresh");
  {
    Daemon first("fresh-1", {"--state-dir", d.path.string()});
  }
  Daemon again("fresh-2", {"--state-dir", d.path.string(), "--fresh"});
  const std::vector<fs::path> kept = generations(d.path, "previous-");
  ASSERT_EQ(kept.size(), 1u) << again.process->log();
  EXPECT_NE(again.process->log().find("kept as " + kept[0].string()), std::string::npos) << again.process->log();
  EXPECT_EQ(again.process->log().find("recovered the sculpt"), std::string::npos);
}

TEST(Open, AFileThatDoesNotRecoverReplacesNothingHoweverOftenItIsTried) {
  Dir d("open-bad"), files("open-bad-files");
  fs::create_directories(files.path);
  const std::string hash = sculpt_in(d.path, "open-bad-1", 1500);
  ASSERT_EQ(hash.size(), 16u) << hash;
  // A real export whose snapshots are gone: a store, checksummed, and no sculpt in it.
  const fs::path bad = files.path / "bad.sculpt";
  fs::copy_file(d.path / "store.db", bad);
  raw_sql(bad, "DELETE FROM snapshot");
  const std::string junk = (files.path / "junk.sculpt").string();
  std::ofstream(junk) << "not a sculpt";
  const auto entries_before = std::distance(fs::directory_iterator(d.path), fs::directory_iterator());
  for (const std::string& file : {bad.string(), bad.string(), junk, junk}) {
    Sculptd open({"--open", file, "--state-dir", d.path.string(), "--socket", temp_path("open-bad.sock")});
    EXPECT_EQ(open.wait_exit(60s), 1) << open.log();
    EXPECT_TRUE(open.wait_for_log("nothing was changed", 10s)) << open.log();  // the log read to its end
    EXPECT_NE(open.log().find("--open " + file), std::string::npos) << open.log();
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(d.path), fs::directory_iterator()), entries_before)
      << "no generation kept, no copy left";
  Sculptd again({"--state-dir", d.path.string(), "--socket", temp_path("open-bad-2.sock")});
  ASSERT_TRUE(again.wait_for_log("sculptd ready", 60s)) << again.log();
  const auto rec = parse_recovery(again.log());
  ASSERT_TRUE(rec) << again.log();
  EXPECT_EQ(rec->hash, hash) << "the sculpt as it was left";
  EXPECT_NE(again.log().find("nothing saved was lost"), std::string::npos) << again.log();
  again.signal(SIGTERM);
  EXPECT_EQ(again.wait_exit(30s), 0);
}

TEST(Open, AFileThatRecoversReplacesTheSculptWhichItsGenerationBringsBack) {
  Dir d("open-good"), other("open-good-other"), files("open-good-files");
  fs::create_directories(files.path);
  const std::string mine = sculpt_in(d.path, "open-good-1", 1500);
  const std::string theirs = sculpt_in(other.path, "open-good-2", 2500, "pull.jsonl");
  ASSERT_NE(mine, theirs);
  const fs::path file = files.path / "theirs.sculpt";
  fs::copy_file(other.path / "store.db", file);  // a stopped daemon's store is a .sculpt
  fs::path kept;
  {
    Sculptd open({"--open", file.string(), "--state-dir", d.path.string(), "--socket", temp_path("open-good.sock")});
    ASSERT_TRUE(open.wait_for_log("sculptd ready", 60s)) << open.log();
    const auto rec = parse_recovery(open.log());
    ASSERT_TRUE(rec) << open.log();
    EXPECT_EQ(rec->hash, theirs);
    const std::vector<fs::path> gens = generations(d.path, "previous-");
    ASSERT_EQ(gens.size(), 1u) << open.log();
    kept = gens[0];
    EXPECT_NE(open.log().find("the one it replaces is kept as " + kept.string()), std::string::npos) << open.log();
    open.signal(SIGTERM);
    EXPECT_EQ(open.wait_exit(30s), 0);
  }
  Sculptd back({"--open", kept.string(), "--state-dir", d.path.string(), "--socket", temp_path("open-good-3.sock")});
  ASSERT_TRUE(back.wait_for_log("sculptd ready", 60s)) << back.log();
  const auto rec = parse_recovery(back.log());
  ASSERT_TRUE(rec) << back.log();
  EXPECT_EQ(rec->hash, mine) << "the generation is the sculpt it replaced";
  back.signal(SIGTERM);
  EXPECT_EQ(back.wait_exit(30s), 0);
}

TEST(Open, AStoreThatDoesNotRecoverIsKeptAsItWasAndTheSculptStartsAnew) {
  Dir d("unrecovered");
  ASSERT_EQ(sculpt_in(d.path, "unrecovered-1", 1000).size(), 16u);
  // Every snapshot and the scene's bundle they share: none can be used.
  raw_sql(d.path / "store.db",
          "UPDATE snapshot SET data = zeroblob(length(data)); UPDATE blob SET data = zeroblob(length(data))");
  const auto before = std::filesystem::file_size(d.path / "store.db");
  Daemon again("unrecovered-2", {"--state-dir", d.path.string()});
  const std::string log = again.process->log();
  EXPECT_NE(log.find("cannot be recovered; starting anew"), std::string::npos) << log;
  const std::vector<fs::path> kept = generations(d.path, "unrecovered-");
  ASSERT_EQ(kept.size(), 1u) << log;
  EXPECT_NE(log.find("kept as " + kept[0].string()), std::string::npos) << log;
  EXPECT_EQ(fs::file_size(kept[0]), before) << "kept as it was";
  EXPECT_TRUE(generations(d.path, "previous-").empty());
}

TEST(SculptdLock, NeitherALockFileNorADirectoryRemovedLetsASecondDaemonIn) {
  Dir base("lock-gone");
  const fs::path dir = base.path / "state";
  Daemon first("lock-gone-1", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl"),
                               "--state-dir", dir.string()});
  const std::string pid = std::to_string(first.process->pid());
  fs::remove(dir / "lock");
  {
    Sculptd second({"--state-dir", dir.string(), "--socket", temp_path("lock-gone-2.sock")});
    EXPECT_EQ(second.wait_exit(60s), 1);
    EXPECT_NE(second.log().find("in use by another process"), std::string::npos) << second.log();
  }
  // The holder writes the lock file again (its PID for the next refusal).
  EXPECT_TRUE(support::wait_until([&] { return read_file((dir / "lock").string()) == pid + "\n"; }, 20s, 20ms));
  fs::remove_all(dir);
  ASSERT_TRUE(first.process->wait_for_log("the store's directory " + dir.string() + " was removed", 20s))
      << first.process->log();
  Sculptd second({"--state-dir", dir.string(), "--socket", temp_path("lock-gone-3.sock")});
  EXPECT_EQ(second.wait_exit(60s), 1);
  EXPECT_NE(second.log().find("in use by another process (PID " + pid + ")"), std::string::npos) << second.log();
}

TEST(SculptdTaken, StoreFilesRemovedUnderTheDaemonAreWrittenBackAndACrashAfterLosesNothing) {
  Dir d("taken");
  const std::string recording = recordings("bench_sculpt.jsonl");
  std::uint64_t removed_at = 0;
  {
    Daemon run("taken-1", {"--scene", "builtin:default", "--input", "replay:" + recording, "--state-dir",
                           d.path.string()});
    std::this_thread::sleep_for(1500ms);
    const CtlRun status = sculptctl({"status", "--json", "--socket", run.socket});
    ASSERT_EQ(status.status, 0) << status.err;
    removed_at = nlohmann::json::parse(status.out)["ticks"].get<std::uint64_t>();
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(d.path.string() + "/store.db" + suffix);
    ASSERT_TRUE(run.process->wait_for_log("store.db was removed: its content was written back", 20s))
        << run.process->log();
    std::this_thread::sleep_for(500ms);
    run.process->signal(SIGKILL);
    ASSERT_EQ(run.process->wait_exit(30s), 128 + SIGKILL);
  }
  Sculptd again({"--state-dir", d.path.string(), "--socket", temp_path("taken-2.sock")});
  ASSERT_TRUE(again.wait_for_log("sculptd ready", 60s)) << again.log();
  const auto rec = parse_recovery(again.log());
  ASSERT_TRUE(rec) << again.log();
  EXPECT_GT(rec->tick, removed_at) << "what was committed after the removal is there";
  EXPECT_NE(again.log().find("nothing saved was lost"), std::string::npos) << again.log();
  again.signal(SIGTERM);
  EXPECT_EQ(again.wait_exit(30s), 0);
  EXPECT_EQ(rec->hash, reference_hash(recording, rec->tick, "taken-ref")) << "tick " << rec->tick;
}

}  // namespace
}  // namespace sculpt::e2e
