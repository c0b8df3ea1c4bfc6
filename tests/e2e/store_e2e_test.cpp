// sculptd's store from outside: a sculpt exported with sculptctl opens as the
// same sculpt in another daemon on another store (paused as it was left);
// two daemons never share a store; a state directory that cannot be used
// leaves the sculpt in memory; --fresh keeps the sculpt it replaces.
#include <gtest/gtest.h>

#include <signal.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
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

// The generations kept in `dir` whose names start with `prefix`, sorted.
std::vector<fs::path> generations(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().filename().string().rfind(prefix, 0) == 0) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::string final_hash(Sculptd& d) {
  static const std::regex re("final mesh hash ([0-9a-f]{16})");
  std::smatch m;
  const std::string log = d.log();
  return std::regex_search(log, m, re) ? std::string(m[1]) : std::string();
}

TEST(Store, AnExportedSculptOpensAsTheSameSculptElsewhere) {
  Dir a("store-a"), b("store-b"), files("store-files");
  fs::create_directories(files.path);
  const std::string file = (files.path / "ball.sculpt").string();
  std::string hash;
  {
    Daemon d("export", {"--scene", "builtin:default", "--input", "replay:" + sessions("push.jsonl"), "--state-dir",
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

TEST(Store, TwoDaemonsNeverShareAStore) {
  Dir d("store-shared");
  Daemon first("shared", {"--state-dir", d.path.string()});
  Sculptd second({"--state-dir", d.path.string(), "--socket", temp_path("second.sock")});
  EXPECT_EQ(second.wait_exit(60s), 1);
  EXPECT_NE(second.log().find("in use by another process (PID " + std::to_string(first.process->pid()) + ")"),
            std::string::npos)
      << second.log();
}

TEST(Store, AStateDirectoryThatCannotBeUsedKeepsTheSculptInMemory) {
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

TEST(Store, FreshKeepsTheSculptItReplaces) {
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

}  // namespace
}  // namespace sculpt::e2e
