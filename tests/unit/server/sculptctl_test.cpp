// sculptctl undo, redo, history and export, run as a child process against
// the server on a fake daemon (fake_daemon.hpp): what they ask, what they
// print (text and --json), their exit statuses, and the exported file
// (complete, atomic, never replacing a file without --force).
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fake_daemon.hpp"
#include "files/temp_dir.hpp"
#include "support/child_process.hpp"
#include "support/read_file.hpp"

namespace sculpt::test {
namespace {

namespace fs = std::filesystem;

// A fresh directory for one test (removed after).
struct TempDir : files::TempDir {
  TempDir() : files::TempDir("sculptctl-test") {}
};

support::CommandRun ctl(const FakeDaemon& d, std::vector<std::string> args) {
  args.push_back("--socket");
  args.push_back(d.socket());
  return support::run_command(SCULPTCTL_BIN, args);
}

using support::read_file;

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(Sculptctl, UndoAndRedoPassNAndPrintWhatWasDone) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(), [](FakeControl& c) { c.history_move_outcome = {"", 0, 12345}; });
  auto r = ctl(d, {"undo"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "undid 1 stroke at tick 12345\n");
  r = ctl(d, {"undo", "3"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "undid 3 strokes at tick 12345\n");
  r = ctl(d, {"redo", "2"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "redid 2 strokes at tick 12345\n");
  r = ctl(d, {"redo", "10000", "--json"});
  EXPECT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["command"], "redo");
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["error"], "");
  EXPECT_EQ(j["asked"], 10000);
  EXPECT_EQ(j["done"], 10000);
  EXPECT_EQ(j["tick"], 12345);
  d.with_control([](FakeControl& c) {
    EXPECT_EQ(c.undo_counts, (std::vector<std::uint32_t>{1, 3}));
    EXPECT_EQ(c.redo_counts, (std::vector<std::uint32_t>{2, 10000}));
    c.history_move_outcome = {"", 2, 13000};
  });
  r = ctl(d, {"undo", "5"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "undid 2 of 5 strokes at tick 13000 (no more to undo)\n");
}

TEST(Sculptctl, ARefusedUndoIsTheDaemonsErrorOnStderrAndExit1) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(), [](FakeControl& c) { c.history_move_outcome = {"nothing to undo", 0, 0}; });
  auto r = ctl(d, {"undo"});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "sculptctl: error: undo: nothing to undo\n");
  r = ctl(d, {"redo", "--json"});
  EXPECT_EQ(r.status, 1);
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ok"], false);
  EXPECT_EQ(j["error"], "nothing to undo");
}

TEST(Sculptctl, BadCountsAreUsageErrors) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"undo", "0"}, {"redo", "10001"}, {"undo", "x"}, {"undo", "-2"}, {"undo", "1", "2"}, {"export"}}) {
    const auto r = support::run_command(SCULPTCTL_BIN, args);
    EXPECT_EQ(r.status, 2) << args[0] << ": " << r.err;
    EXPECT_EQ(r.err.rfind("sculptctl: error: ", 0), 0u) << r.err;
  }
}

TEST(Sculptctl, HapticsSetsOnlyWhatIsGivenAndPrintsBoth) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string());
  auto r = ctl(d, {"haptics", "0", "--gain", "0.5"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "slot 0: gain 0.5, limit 1\n");
  r = ctl(d, {"haptics", "0", "--limit", "0.25", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["gain"], 0.5);
  EXPECT_EQ(j["limit"], 0.25);
  r = ctl(d, {"haptics", "0"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "slot 0: gain 0.5, limit 0.25\n");
}

TEST(Sculptctl, HapticsRefusalsAreNamed) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string());
  auto r = ctl(d, {"haptics", "7", "--gain", "0.5"});
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, "sculptctl: error: haptics: no device on slot 7")) << r.err;
  r = ctl(d, {"haptics", "0", "--gain", "1.5"});
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, "gain")) << r.err;
  r = ctl(d, {"haptics", "0", "--limit", "nan"});
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(has(r.err, "limit")) << r.err;
  r = ctl(d, {"haptics"});
  EXPECT_EQ(r.status, 2) << r.err;
}

TEST(Sculptctl, HistoryIsATableOfStrokesAndTheBudget) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(), [](FakeControl& c) { c.history_now = sample_history(); });
  auto r = ctl(d, {"history"});
  ASSERT_EQ(r.status, 0) << r.err;
  std::vector<std::string> lines;
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 5u) << r.out;
  for (const char* column : {"stroke", "tools", "mesh", "start tick", "end tick", "vertices", "size"})
    EXPECT_TRUE(has(lines[0], column)) << lines[0];
  EXPECT_TRUE(has(lines[1], "ball (0)") && has(lines[1], "1000") && has(lines[1], "1420") && has(lines[1], "1500") &&
              has(lines[1], "18.0 KiB"))
      << lines[1];
  EXPECT_FALSE(has(lines[1], "undone")) << lines[1];
  EXPECT_TRUE(has(lines[2], "0,1")) << lines[2];
  EXPECT_TRUE(has(lines[3], "clay (1)") && has(lines[3], "undone")) << lines[3];
  EXPECT_EQ(lines[1].substr(0, 6), "     7") << "stroke numbers right-aligned under their heading";
  EXPECT_TRUE(has(lines[4], "3 strokes (1 undone")) << lines[4];
  EXPECT_TRUE(has(lines[4], "54.0 KiB of a 256 MiB budget")) << lines[4];
  EXPECT_TRUE(has(lines[4], "6 strokes fell off the budget")) << lines[4];

  d.with_control([](FakeControl& c) { c.history_now = {}; });
  r = ctl(d, {"history"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "no strokes; undo data 0 B of a 0 B budget\n");
}

TEST(Sculptctl, HistoryJsonHasStableSnakeCaseNames) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(), [](FakeControl& c) { c.history_now = sample_history(); });
  const auto r = ctl(d, {"history", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["budget_bytes"], 256u << 20);
  EXPECT_EQ(j["used_bytes"], 3 * 18432);
  EXPECT_EQ(j["dropped"], 6);
  EXPECT_EQ(j["omitted"], 0);
  ASSERT_EQ(j["strokes"].size(), 3u);
  const auto& s = j["strokes"][1];
  std::vector<std::string> keys;
  for (const auto& [k, v] : s.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"bytes", "end_tick", "first_tick", "mesh", "mesh_name", "number", "tools",
                                            "undone", "vertices"}));
  EXPECT_EQ(s["number"], 8);
  EXPECT_EQ(s["mesh"], 0);
  EXPECT_EQ(s["mesh_name"], "ball");
  EXPECT_EQ(s["tools"], nlohmann::json::array({0, 1}));
  EXPECT_EQ(s["first_tick"], 2000);
  EXPECT_EQ(s["end_tick"], 2420);
  EXPECT_EQ(s["vertices"], 1501);
  EXPECT_EQ(s["bytes"], 18432);
  EXPECT_EQ(s["undone"], false);
  EXPECT_EQ(j["strokes"][2]["undone"], true);
}

TEST(Sculptctl, ExportWritesTheWholeFileAndNeverReplacesOneWithoutForce) {
  TempDir dir;
  const std::string first = export_pattern((std::size_t{9} << 20) + 7);
  FakeDaemon d((dir.path() / "s.sock").string(), [&](FakeControl& c) { c.export_bytes = first; });
  const fs::path file = dir.path() / "my.sculpt";
  auto r = ctl(d, {"export", file.string()});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "exported " + std::to_string(first.size()) + " bytes to " + file.string() + "\n");
  EXPECT_TRUE(read_file(file) == first) << "the file differs from the export";
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));

  d.with_control([](FakeControl& c) { c.export_bytes = "second export"; });
  r = ctl(d, {"export", file.string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, file.string()) && has(r.err, "--force")) << r.err;
  EXPECT_TRUE(read_file(file) == first) << "replaced without --force";

  r = ctl(d, {"export", file.string(), "--force", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["file"], file.string());
  EXPECT_EQ(j["bytes"], 13);
  EXPECT_EQ(read_file(file), "second export");
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"my.sculpt", "s.sock"})) << "a temporary file was left behind";
  d.with_control([](FakeControl& c) { EXPECT_EQ(c.exports_asked, 2) << "asked the daemon for a file it may not write"; });
}

TEST(Sculptctl, HistoryPagesFromAStrokeOrTheNewestAndCountsTheRest) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(), [](FakeControl& c) { c.history_now = sample_history(); });  // 7, 8, 9
  auto r = ctl(d, {"history", "--limit", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.out, "clay (1)") && !has(r.out, "ball (0)")) << "the newest one: " << r.out;
  EXPECT_TRUE(has(r.out, "3 strokes (1 undone: redo brings it back), the 2 oldest not listed;")) << r.out;
  r = ctl(d, {"history", "--from", "8", "--limit", "1", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["strokes"].size(), 1u);
  EXPECT_EQ(j["strokes"][0]["number"], 8);
  EXPECT_EQ(j["omitted"], 1);
  EXPECT_EQ(j["newer"], 1);
  EXPECT_EQ(j["total"], 3);
  r = ctl(d, {"history", "--from", "8"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(has(r.out, "3 strokes (1 undone: redo brings it back), the 1 oldest not listed;")) << r.out;
  // What was asked of the daemon: the page only, the newest 100 by default.
  d.with_control([](FakeControl& c) {
    const std::vector<std::pair<std::uint32_t, std::uint32_t>> asked{{0, 1}, {8, 1}, {8, 100}};
    EXPECT_EQ(c.history_asks, asked);
  });
  for (const std::vector<std::string>& bad : std::vector<std::vector<std::string>>{
           {"history", "--limit", "0"}, {"history", "--limit", "16385"}, {"history", "--from", "0"}}) {
    r = ctl(d, bad);
    EXPECT_EQ(r.status, 2) << bad[1] << " " << bad[2] << ": " << r.err;
    EXPECT_TRUE(has(r.err, bad[1])) << r.err;
  }
}

TEST(Sculptctl, ExportForcedReplacesOnlyARegularFileNeverADeviceFifoOrLink) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(), [](FakeControl& c) { c.export_bytes = "a sculpt"; });
  const fs::path device = dir.path() / "null", fifo = dir.path() / "fifo", target = dir.path() / "target",
                 link = dir.path() / "link";
  ASSERT_EQ(::mknod(device.c_str(), S_IFCHR | 0666, makedev(1, 3)), 0) << "the tests run as root";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0666), 0);
  std::ofstream(target) << "kept";
  fs::create_symlink(target, link);
  for (const auto& [path, kind] : std::vector<std::pair<fs::path, std::string>>{
           {device, "character device"}, {fifo, "FIFO"}, {link, "symbolic link"}}) {
    for (const bool force : {true, false}) {
      std::vector<std::string> args{"export", path.string()};
      if (force) args.push_back("--force");
      const auto r = ctl(d, args);
      EXPECT_EQ(r.status, 1) << path << ": " << r.out;
      EXPECT_TRUE(has(r.err, path.string() + ": is a " + kind + ", not a regular file")) << r.err;
    }
  }
  struct stat st {};
  ASSERT_EQ(::lstat(device.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode)) << "the device node is still one";
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(read_file(target), "kept");
  d.with_control([](FakeControl& c) { EXPECT_EQ(c.exports_asked, 0) << "refused before asking the daemon"; });
}

TEST(Sculptctl, ExportErrorsNameTheFileAndLeaveNothing) {
  TempDir dir;
  FakeDaemon d((dir.path() / "s.sock").string(),
               [](FakeControl& c) { c.export_error = "the sculpt cannot be exported now"; });
  const fs::path file = dir.path() / "x.sculpt";
  auto r = ctl(d, {"export", file.string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err, "sculptctl: error: export: the sculpt cannot be exported now\n");
  EXPECT_FALSE(fs::exists(file));
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));

  const fs::path nowhere = dir.path() / "no" / "such" / "dir" / "x.sculpt";
  r = ctl(d, {"export", nowhere.string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err.rfind("sculptctl: error: export: " + nowhere.string() + ": ", 0), 0u) << r.err;

  r = ctl(d, {"export", dir.path().string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_TRUE(has(r.err, dir.path().string() + ": is a directory")) << r.err;
}

TEST(Sculptctl, NoDaemonIsExit3ForEveryNewCommand) {
  TempDir dir;
  const std::string nobody = (dir.path() / "nobody.sock").string();
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"undo"}, {"redo", "2"}, {"history"}, {"history", "--json"}, {"export", (dir.path() / "x.sculpt").string()}}) {
    std::vector<std::string> a = args;
    a.push_back("--socket");
    a.push_back(nobody);
    const auto r = support::run_command(SCULPTCTL_BIN, a);
    EXPECT_EQ(r.status, 3) << args[0] << ": " << r.err;
    EXPECT_TRUE(has(r.err, "no daemon is listening on " + nobody)) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path() / "x.sculpt"));
}

}  // namespace
}  // namespace sculpt::test
