// sculptd's store on file systems that misbehave, made here (root, on
// loop-mounted ext4 images): one forced read-only under a running daemon
// (ext4's own error path, errors=remount-ro, triggered through sysfs: a
// remount with files open for writing is refused), which is then killed —
// the restart says how much sculpt was never saved and why, never "nothing
// saved was lost", while an export made before the kill holds that sculpt —
// and one frozen (fsfreeze) while undo, redo and history are asked: each
// answers while the disk is frozen, and the daemon stops cleanly once it
// thaws.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/mount.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <regex>
#include <thread>

#include <nlohmann/json.hpp>

#include "daemon_fixture.hpp"
#include "sculptd_process.hpp"

namespace sculpt::e2e {
namespace {

namespace fs = std::filesystem;

// A program by name, from the usual places (run_command takes a path).
std::string tool(const std::string& name) {
  for (const char* dir : {"/usr/sbin", "/sbin", "/usr/bin", "/bin"})
    if (::access((std::string(dir) + "/" + name).c_str(), X_OK) == 0) return std::string(dir) + "/" + name;
  return name;
}

support::CommandRun run(const std::string& name, const std::vector<std::string>& args) {
  return support::run_command(tool(name), args);
}

// An ext4 image of its own, loop-mounted (errors=remount-ro), unmounted (and
// thawed) at the end.
class Mounted {
 public:
  explicit Mounted(const std::string& name) : dir_(temp_path(name)), image_(temp_path(name + ".img")) {
    fs::create_directories(dir_);
    std::ofstream(image_).close();
    fs::resize_file(image_, 64u << 20);
    support::CommandRun r = run("mkfs.ext4", {"-q", "-F", image_});
    if (r.status == 0) r = mount();
    error_ = r.err;
  }
  ~Mounted() {
    if (frozen_) run("fsfreeze", {"-u", dir_});
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
    std::error_code ec;
    fs::remove_all(dir_, ec);
    fs::remove(image_, ec);
  }
  Mounted(const Mounted&) = delete;
  Mounted& operator=(const Mounted&) = delete;

  bool ok() const { return mounted_; }
  const std::string& error() const { return error_; }
  const std::string& dir() const { return dir_; }
  // What a failing disk does to ext4: an error, and the file system turns
  // read-only under every open file (EROFS).
  bool force_read_only() {
    const std::string device = run("findmnt", {"-n", "-o", "SOURCE", dir_}).out;
    const std::string name = fs::path(device.substr(0, device.find('\n'))).filename().string();
    std::ofstream("/sys/fs/ext4/" + name + "/trigger_fs_error") << "sculptd test: forced read-only\n";
    return run("findmnt", {"-n", "-o", "OPTIONS", dir_}).out.find("emergency_ro") != std::string::npos;
  }
  // Unmounted and mounted again: writable (once nothing holds it open).
  bool remount() {
    if (mounted_ && ::umount(dir_.c_str()) != 0) return false;
    mounted_ = false;
    return mount().status == 0;
  }
  bool freeze(bool on) {
    frozen_ = run("fsfreeze", {on ? "-f" : "-u", dir_}).status == 0 ? on : frozen_;
    return frozen_ == on;
  }

 private:
  support::CommandRun mount() {
    support::CommandRun r = run("mount", {"-o", "loop,errors=remount-ro", image_, dir_});
    mounted_ = r.status == 0;
    return r;
  }

  std::string dir_, image_, error_;
  bool mounted_ = false, frozen_ = false;
};

std::uint64_t ticks_of(const std::string& socket) {
  const CtlRun r = sculptctl({"status", "--json", "--socket", socket});
  return r.status == 0 ? nlohmann::json::parse(r.out)["ticks"].get<std::uint64_t>() : 0;
}

TEST(ReadOnly, SculptHeldInMemoryWhenTheDaemonDiesIsNamedAsLostAtTheRestart) {
  Mounted m("store-ro");
  ASSERT_TRUE(m.ok()) << "cannot loop-mount an ext4 image (the test runs as root): " << m.error();
  const std::string dir = m.dir() + "/state";
  std::uint64_t failing_at = 0, exported_at = 0, killed_at = 0;  // ticks the daemon had run
  const std::string rescue = temp_path("store-ro-rescue.sculpt");
  ::unlink(rescue.c_str());
  {
    Daemon d("store-ro-1", {"--scene", "builtin:default", "--input", "replay:" + recordings("bench_sculpt.jsonl"),
                            "--state-dir", dir});
    std::this_thread::sleep_for(1s);
    ASSERT_TRUE(m.force_read_only());
    ASSERT_TRUE(d.process->wait_for_log("the sculpt goes on in memory and the store is retried", 20s))
        << d.process->log();
    failing_at = ticks_of(d.socket);
    std::this_thread::sleep_for(2s);  // sculpt the store never gets
    // What the disk refuses can still be saved elsewhere: an export holds it.
    exported_at = ticks_of(d.socket);
    const CtlRun ex = sculptctl({"export", rescue, "--socket", d.socket});
    EXPECT_EQ(ex.status, 0) << ex.err;
    killed_at = ticks_of(d.socket);
    d.process->signal(SIGKILL);
    ASSERT_EQ(d.process->wait_exit(30s), 128 + SIGKILL);
  }
  ASSERT_TRUE(m.remount());
  Sculptd again({"--state-dir", dir, "--socket", temp_path("store-ro-2.sock")});
  ASSERT_TRUE(again.wait_for_log("sculptd ready", 60s)) << again.log();
  const std::string log = again.log();
  EXPECT_EQ(log.find("nothing saved was lost"), std::string::npos) << log;
  EXPECT_NE(log.find("s of sculpt lost, see below"), std::string::npos) << log;
  EXPECT_NE(log.find("the store could not be written since"), std::string::npos) << log;
  // The ticks named cover what the daemon ran while its disk refused writes:
  // from before the warning to its last commit attempt before the kill (at
  // most 300 ticks before it, as recovery_e2e allows a busy machine).
  std::smatch never;
  ASSERT_TRUE(std::regex_search(log, never, std::regex(R"(ticks (\d+)-(\d+) \(([0-9.]+) s of sculpt, held in its memory\) were never saved)")))
      << log;
  const std::uint64_t first = std::stoull(never[1]), last = std::stoull(never[2]);
  EXPECT_LE(first, failing_at) << log;
  EXPECT_GE(last + 300, killed_at) << log;
  EXPECT_NEAR(std::stod(never[3]), static_cast<double>(last - first + 1) / 1000.0, 0.051) << log;
  again.signal(SIGTERM);
  EXPECT_EQ(again.wait_exit(30s), 0);
  // The export made while the disk refused writes opens as the sculpt up to it.
  const std::string other = temp_path("store-ro-other");
  fs::remove_all(other);
  Sculptd opened({"--open", rescue, "--state-dir", other, "--socket", temp_path("store-ro-3.sock")});
  ASSERT_TRUE(opened.wait_for_log("sculptd ready", 60s)) << opened.log();
  const auto rec = parse_recovery(opened.log());
  ASSERT_TRUE(rec) << opened.log();
  EXPECT_GE(rec->tick + 1, exported_at) << opened.log();
  opened.signal(SIGTERM);
  EXPECT_EQ(opened.wait_exit(30s), 0);
  fs::remove_all(other);
  ::unlink(rescue.c_str());
}

TEST(Frozen, UndoRedoAndHistoryAnswerWhileTheDiskIsFrozen) {
  Mounted m("store-frozen");
  ASSERT_TRUE(m.ok()) << "cannot loop-mount an ext4 image (the test runs as root): " << m.error();
  Daemon d("store-frozen", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl"),
                            "--state-dir", m.dir() + "/state"});
  std::this_thread::sleep_for(3s);  // the pushes are made
  ASSERT_TRUE(m.freeze(true));
  std::this_thread::sleep_for(200ms);  // the store thread is held now, in its next commit
  // Each runs while the disk stays frozen; the bound is only there to end a hang.
  for (const std::string cmd : {"undo", "redo", "history", "status"}) {
    const std::vector<std::string> args{cmd, "--socket", d.socket};
    auto answer = std::async(std::launch::async, [args] { return sculptctl(args); });
    ASSERT_EQ(answer.wait_for(60s), std::future_status::ready) << cmd << " waited on the frozen disk";
    const CtlRun r = answer.get();
    EXPECT_EQ(r.status, 0) << cmd << ": " << r.err;
  }
  ASSERT_TRUE(m.freeze(false));
  d.process->signal(SIGTERM);
  EXPECT_EQ(d.process->wait_exit(60s), 0) << d.process->log();
}

}  // namespace
}  // namespace sculpt::e2e
