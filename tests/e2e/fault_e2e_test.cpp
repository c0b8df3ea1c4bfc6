// Nothing a client, a file or a recording can send may crash, freeze or starve
// a running sculptd. One test per kind of fault found from outside: scenes
// the simulation cannot run, files that are not files, a big load, a bad
// recording line, clients that hold memory or places, unstable scenes, and the
// smaller ones. Each checks the daemon named the problem, kept running, kept
// its sculpt, and kept answering (fault_soak_test.cpp mixes them all).
#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <kj/async-io.h>

#include "client/connection.hpp"
#include "daemon_fixture.hpp"
#include "raw_rpc.hpp"
#include "status_probe.hpp"
#include "stream_viewer.hpp"

namespace sculpt::e2e {
namespace {

namespace fs = std::filesystem;

// A scratch directory for one test's files, removed at the end.
struct Scratch {
  fs::path dir;
  explicit Scratch(const std::string& name) : dir(temp_path(name + "-dir")) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = dir / name;
    std::ofstream(p) << text;
    return p.string();
  }
  std::string fifo(const std::string& name) const {
    const fs::path p = dir / name;
    ::mkfifo(p.c_str(), 0600);
    return p.string();
  }
};

// What the daemon's status says about the scene it runs.
struct Running {
  std::string scene;
  std::uint64_t vertices = 0;
};
Running running(const std::string& socket) {
  auto io = kj::setupAsyncIo();
  client::Connection c(io, socket, "fault-test");
  auto r = c.session().statusRequest().send().wait(io.waitScope);
  return {r.getStats().getScene(), r.getStats().getVerticesTotal()};
}

// A small valid scene, at `rate` Hz.
std::string scene_at(const std::string& rate) {
  return "[simulation]\nrate_hz = " + rate + R"(

[[mesh]]
name = "ball"
file = "builtin:icosphere"
params = { subdivisions = 3, radius = 0.1 }

[[tool]]
name = "finger"
)";
}


// --- a load is a transaction; one validator ---------------------------------------

TEST(Load, ScenesTheSimulationCannotRunAreRefusedAndTheSculptKept) {
  Scratch s("refused");
  Daemon d("refused", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  StreamViewer viewer(d.socket, 0.0f, 30.0f);
  ASSERT_TRUE(viewer.wait_for_frames(2, 20s)) << viewer.seen().error_text;
  const Running before = running(d.socket);
  std::string tools;
  for (int i = 0; i < 9; ++i) tools += "[[tool]]\nname = \"t" + std::to_string(i) + "\"\n";
  const std::string mesh = "[[mesh]]\nfile = \"builtin:icosphere\"\n";
  struct Bad {
    std::string path, says;
  } bad[] = {
      {s.write("fast.toml", scene_at("100001")), "rate_hz: must be in [1, 100000]"},
      {s.write("tools.toml", mesh + tools), "more than 8 tools"},
      {s.write("empty.toml", ""), "has no meshes"},
      {s.write("garbage.toml", "[[mesh\nfile = "), "not valid TOML"},
      {s.fifo("fifo.toml"), "is a FIFO, not a regular file"},
      {s.write("fifo_mesh.toml", "[[mesh]]\nfile = \"" + s.fifo("mesh.obj") + "\"\n"), "is a FIFO, not a regular file"},
      {"/dev/zero", "is a character device, not a regular file"},
      {"/dev/urandom", "is a character device, not a regular file"},
      {"/dev/null", "is a character device, not a regular file"},
      {s.dir.string(), "is a directory"},
      {(s.dir / "none.toml").string(), "no such file"},
  };
  for (const Bad& b : bad) {
    const auto t0 = std::chrono::steady_clock::now();
    const CtlRun r = sculptctl({"load", b.path, "--socket", d.socket});
    const double s_taken = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(r.status, 1) << b.path << ": " << r.err;
    EXPECT_NE(r.err.find(b.says), std::string::npos) << b.path << ": " << r.err;
    EXPECT_LT(s_taken, 10.0) << b.path << " took " << s_taken << " s to refuse";
    const Running now = running(d.socket);
    EXPECT_EQ(now.scene, before.scene) << "after " << b.path;
    EXPECT_EQ(now.vertices, before.vertices) << "after " << b.path;
  }
  // The viewer saw no new keyframe: its sculpt was never touched.
  EXPECT_EQ(viewer.seen().keyframes, 1u);
  EXPECT_FALSE(viewer.seen().error) << viewer.seen().error_text;
  // An empty path is the caller's mistake, told by sculptctl itself.
  const CtlRun empty = sculptctl({"load", "", "--socket", d.socket});
  EXPECT_EQ(empty.status, 2) << empty.err;
  EXPECT_NE(empty.err.find("sculptctl: error: load: the scene path is empty"), std::string::npos) << empty.err;
  EXPECT_EQ(d.process->wait_exit(0ms), std::nullopt) << "sculptd died:\n" << d.process->log();
}

TEST(Load, StartCheckInspectAndLoadAcceptTheSameScenes) {
  Scratch s("validator");
  const std::string fast = s.write("fast.toml", scene_at("100001"));
  const std::string good = s.write("good.toml", scene_at("500"));
  for (const std::string& scene : {fast, good}) {
    const bool ok = scene == good;
    Sculptd check({"--config", "/dev/null", "--check", "--scene", scene});
    EXPECT_EQ(check.wait_exit(60s), ok ? 0 : 1) << check.log();
    const CtlRun inspect = sculptctl({"inspect", scene});
    EXPECT_EQ(inspect.status, ok ? 0 : 1) << inspect.err;
    Sculptd start({"--config", "/dev/null", "--scene", scene, "--duration", "0.2", "--socket", temp_path("v.sock")});
    EXPECT_EQ(start.wait_exit(60s), ok ? 0 : 1) << start.log();
    if (!ok) {
      EXPECT_NE(check.log().find("rate_hz"), std::string::npos) << check.log();
      EXPECT_NE(inspect.err.find("rate_hz"), std::string::npos) << inspect.err;
      EXPECT_NE(start.log().find("rate_hz"), std::string::npos) << start.log();
    }
  }
}

// --- the io loop never waits on a file --------------------------------------------

#ifdef SCULPT_SANITIZED_BUILD
constexpr int kBigMeshes = 2;  // sanitized code builds them several times slower
#else
constexpr int kBigMeshes = 8;
#endif

// A scene that takes seconds to build (164k-vertex spheres), longer than
// the watchdog's period.
std::string big_scene(const Scratch& s) {
  std::string text = "[simulation]\nrate_hz = 200\n";
  for (int i = 0; i < kBigMeshes; ++i)
    text += "[[mesh]]\nfile = \"builtin:icosphere\"\nparams = { subdivisions = 7, radius = 0.1 }\nposition = [" +
            std::to_string(0.3 * i) + ", 0, 0]\n";
  text += "[[tool]]\nname = \"finger\"\n";
  return s.write("big.toml", text);
}

// systemd's side of sd_notify: a datagram socket the daemon's WATCHDOG=1 pings arrive on.
struct NotifySocket {
  std::string path = temp_path("notify.sock");
  int fd = -1;
  NotifySocket() {
    ::unlink(path.c_str());
    fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  }
  ~NotifySocket() {
    ::close(fd);
    ::unlink(path.c_str());
  }
  // Times of the WATCHDOG=1 pings received so far.
  std::vector<std::chrono::steady_clock::time_point> pings;
  void drain() {
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) return;
      if (std::string(buf, static_cast<std::size_t>(n)).find("WATCHDOG=1") != std::string::npos)
        pings.push_back(std::chrono::steady_clock::now());
    }
  }
};

TEST(Load, TheIoLoopServesAndTheWatchdogIsFedWhileABigSceneLoads) {
  Scratch s("big");
  const std::string scene = big_scene(s);
  NotifySocket notify;
  // WatchdogSec=10s: the daemon pings every 5 s. A load on the io loop would
  // hold the pings back for as long as it takes (seconds: kBigMeshes spheres);
  // a busy machine delays them by far less than the 5 s of slack.
  constexpr double kWatchdogS = 10;
  ::setenv("NOTIFY_SOCKET", notify.path.c_str(), 1);
  ::setenv("WATCHDOG_USEC", "10000000", 1);
  Daemon d("big", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  // Pings on either side of the load: the first before it begins, every one
  // as it comes until one after it ended.
  const auto first_ping_by = std::chrono::steady_clock::now() + 60s;
  while (notify.pings.empty() && std::chrono::steady_clock::now() < first_ping_by) {
    notify.drain();
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_FALSE(notify.pings.empty()) << "no watchdog ping";
  StatusProbe probe(d.socket, d.process->pid());
  ASSERT_TRUE(probe.wait_for_calls(1, 30s)) << "the probe made no call";
  const std::uint64_t calls_before = probe.calls();
  std::atomic<bool> load_done{false};
  std::chrono::steady_clock::time_point loaded;
  std::thread drainer([&] {
    const auto end = std::chrono::steady_clock::now() + 120s;
    while (std::chrono::steady_clock::now() < end) {
      notify.drain();
      if (load_done.load() && notify.pings.back() > loaded) break;
      std::this_thread::sleep_for(20ms);
    }
  });
  const auto t0 = std::chrono::steady_clock::now();
  const CtlRun r = sculptctl({"load", scene, "--socket", d.socket});
  loaded = std::chrono::steady_clock::now();
  load_done.store(true);
  const double load_s = std::chrono::duration<double>(loaded - t0).count();
  // The io loop kept answering while the scene was built (seconds): calls
  // answered during the load, none failed. (A load on the io loop would
  // hold the one call in flight until it ended.)
  const std::uint64_t calls_during = probe.calls() - calls_before;
  const StatusProbe::Result p = probe.stop();
  drainer.join();
  EXPECT_GT(notify.pings.back(), loaded) << "no watchdog ping after the load";
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(running(d.socket).vertices, kBigMeshes * 163842u);
  // Between the pings before and after the load, none was missing for
  // WatchdogSec: the service would not have been killed.
  double worst_gap = 0;
  for (std::size_t i = 1; i < notify.pings.size(); ++i)
    worst_gap = std::max(worst_gap, std::chrono::duration<double>(notify.pings[i] - notify.pings[i - 1]).count());
  std::printf("load of %d meshes took %.1f s; %zu watchdog pings, worst gap %.2f s (WatchdogSec %.0f s)\n", kBigMeshes,
              load_s, notify.pings.size(), worst_gap, kWatchdogS);
  print_waits("during the load", p.samples);
  EXPECT_GE(notify.pings.size(), 2u);
  EXPECT_LT(worst_gap, kWatchdogS) << "a watchdog ping was late past WatchdogSec during the load";
  EXPECT_GE(calls_during, 2u) << "the status calls waited for the load";
  EXPECT_EQ(p.failures, 0u) << p.first_failure;
}

TEST(Files, InspectAndCheckRefuseWhatIsNotARegularFileAtOnce) {
  Scratch s("inspect");
  for (const std::string& path : {s.fifo("x.toml"), s.fifo("y.obj"), std::string("/dev/zero")}) {
    const auto t0 = std::chrono::steady_clock::now();
    const CtlRun r = sculptctl({"inspect", path});
    EXPECT_EQ(r.status, 1) << path;
    EXPECT_NE(r.err.find("not a regular file"), std::string::npos) << r.err;
    Sculptd check({"--config", "/dev/null", "--check", "--scene", path});
    EXPECT_EQ(check.wait_exit(30s), 1) << check.log();
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0) << path;
  }
  Sculptd config({"--config", s.fifo("sculptd.conf"), "--check"});
  EXPECT_EQ(config.wait_exit(30s), 1);
  EXPECT_NE(config.log().find("is a FIFO, not a regular file"), std::string::npos) << config.log();
}

// --- a replay's bad line ends the replay, never the daemon --------------------------

// push.jsonl's frames, four a millisecond, repeated until `frames` lines:
// long enough that the replay cannot read it all ahead (16k frames), short
// enough to play through in seconds.
std::string long_recording(const Scratch& s, std::size_t frames, const std::string& name) {
  std::ifstream in(recordings("push.jsonl"));
  std::string header, line;
  std::getline(in, header);
  std::vector<std::string> lines;
  while (std::getline(in, line))
    if (!line.empty()) lines.push_back(line);
  std::ostringstream out;
  out << header << "\n";
  for (std::size_t i = 0; i < frames; ++i) {
    const std::string& l = lines[i % lines.size()];
    out << "[" << i * 250 << l.substr(l.find(',')) << "\n";
  }
  return s.write(name, out.str());
}

TEST(Replay, ABadLineDeepInTheRecordingIsNamedBeforeTheFirstTick) {
  Scratch s("badline");
  std::string recording = long_recording(s, 20000, "late.jsonl");
  std::ofstream(recording, std::ios::app) << "[1, 0, [[3, 0, 18446744073709551615]]]\n";
  Sculptd d({"--config", "/dev/null", "--input", "replay:" + recording, "--duration", "60", "--socket",
             temp_path("late.sock")});
  EXPECT_EQ(d.wait_exit(60s), 1) << d.log();
  EXPECT_NE(d.log().find(recording + ":20002:"), std::string::npos) << d.log();
  EXPECT_EQ(d.log().find("sculptd ready"), std::string::npos) << "it started ticking on a recording it could not play";
}

TEST(Replay, ARecordingThatChangesUnderTheDaemonEndsTheReplayNotTheDaemon) {
  Scratch s("changed");
  const std::string recording = long_recording(s, 30000, "changing.jsonl");
  Daemon d("changed", {"--scene", "builtin:default", "--input", "replay:" + recording});
  // Past what the replay has read ahead (16k frames), a line goes bad.
  {
    std::fstream f(recording, std::ios::in | std::ios::out);
    f.seekp(static_cast<std::streamoff>(fs::file_size(recording) * 9 / 10));
    f << "\n{not json}\n";
  }
  EXPECT_TRUE(d.process->wait_for_log("replay ended early", 60s)) << d.process->log();
  EXPECT_EQ(running(d.socket).scene, "builtin:default");
  d.process->signal(SIGTERM);
  EXPECT_EQ(d.process->wait_exit(30s), 0) << d.process->log();
}

// --- per-client limits ---------------------------------------------------------------

TEST(Clients, CallsWhoseAnswersAreNeverReadEndThatClientOnly) {
  // A sanitized daemon keeps freed memory in quarantine: keep that small.
  if (const char* asan = std::getenv("ASAN_OPTIONS"))
    ::setenv("ASAN_OPTIONS", (std::string(asan) + ":quarantine_size_mb=1").c_str(), 1);
  Daemon d("flood", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  StreamViewer viewer(d.socket, 0.0f, 30.0f);
  ASSERT_TRUE(viewer.wait_for_frames(2, 20s));
  const std::uint64_t rss_before = rss_kb(d.process->pid());
  RawRpc raw(d.socket);
  ASSERT_TRUE(raw.hello());
  std::uint32_t sent = 0;
  for (std::uint32_t q = 2; q < 20002 && raw.keyframe(q); ++q) ++sent;
  EXPECT_TRUE(raw.closed_within(60s)) << "the flooding client was never disconnected";
  EXPECT_TRUE(d.process->wait_for_log("max_queued_bytes", 20s)) << d.process->log();
  std::uint64_t rss_peak = 0;
  for (int i = 0; i < 10; ++i) rss_peak = std::max(rss_peak, rss_kb(d.process->pid())), std::this_thread::sleep_for(50ms);
  std::printf("%u pipelined keyframe() calls sent before the daemon closed the connection; RSS %llu kB before, "
              "%llu kB after\n",
              sent, static_cast<unsigned long long>(rss_before), static_cast<unsigned long long>(rss_peak));
  EXPECT_LT(rss_peak, rss_before + 256 * 1024) << "the queue's memory was not given back";
  const std::uint64_t frames = viewer.seen().frames;
  EXPECT_TRUE(viewer.wait_for_frames(frames + 3, 20s)) << "the other viewer was held up";
}

TEST(Clients, MessagesFullOfCapabilitiesEndThatClientOnly) {
  if (const char* asan = std::getenv("ASAN_OPTIONS"))
    ::setenv("ASAN_OPTIONS", (std::string(asan) + ":quarantine_size_mb=1").c_str(), 1);
  Daemon d("caps", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  const std::uint64_t rss_before = rss_kb(d.process->pid());
  {
    RawRpc raw(d.socket);  // a 16 MB hello with a million capabilities: over the size limit
    raw.hello(1'000'000);
    EXPECT_TRUE(raw.closed_within(30s));
  }
  EXPECT_TRUE(d.process->wait_for_log("malformed or oversized message", 20s)) << d.process->log();
  {
    RawRpc raw(d.socket);  // small, but a thousand capabilities
    raw.hello(1000);
    EXPECT_TRUE(raw.closed_within(30s));
  }
  EXPECT_TRUE(d.process->wait_for_log("carried 1000 capabilities (limit: 8 per message)", 20s)) << d.process->log();
  const std::uint64_t rss_after = rss_kb(d.process->pid());
  std::printf("RSS %llu kB before, %llu kB after\n", static_cast<unsigned long long>(rss_before),
              static_cast<unsigned long long>(rss_after));
  EXPECT_LT(rss_after, rss_before + 64 * 1024);
  EXPECT_EQ(running(d.socket).scene, "builtin:default");
}

TEST(Clients, SilentConnectionsAndBurstsNeverLockTheOthersOut) {
  Daemon d("lockout", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  std::vector<int> silent;
  for (int i = 0; i < 80; ++i) silent.push_back(connect_raw(d.socket));
  // Every place is held by a connection that has said nothing; once they
  // have been silent for longer than a hello takes (a second), a newcomer
  // takes the place of one. Until then it is refused (max_clients), or
  // closed unanswered while 8 refusals are pending (max_refusing).
  CtlRun r = sculptctl({"status", "--socket", d.socket});
  for (const auto end = std::chrono::steady_clock::now() + 30s; r.status != 0 && std::chrono::steady_clock::now() < end;) {
    std::this_thread::sleep_for(100ms);
    r = sculptctl({"status", "--socket", d.socket});
  }
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(d.process->wait_for_log("closed to make room for a new connection", 10s)) << d.process->log();
  // A burst of connects that close at once, while another client asks for
  // the status: answered during it and after.
  StatusProbe probe(d.socket, d.process->pid());
  ASSERT_TRUE(probe.wait_for_calls(1, 30s)) << "the probe made no call";
  for (int i = 0; i < 2000; ++i) ::close(connect_raw(d.socket));
  EXPECT_TRUE(probe.wait_for_calls(1, 30s)) << "no status answer after the burst";
  const StatusProbe::Result p = probe.stop();
  EXPECT_EQ(p.failures, 0u) << p.first_failure;
  // The silent ones are closed by the hello timeout.
  for (int fd : silent) {
    char b;
    pollfd pf{fd, POLLIN, 0};
    ::poll(&pf, 1, 10000);
    EXPECT_EQ(::recv(fd, &b, 1, MSG_DONTWAIT), 0) << "a silent connection was kept past the hello timeout";
    ::close(fd);
  }
  EXPECT_EQ(sculptctl({"status", "--socket", d.socket}).status, 0);
}

TEST(Clients, AFullTableRefusesWithTheReason) {
  Daemon d("full", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  auto io = kj::setupAsyncIo();
  std::vector<std::unique_ptr<client::Connection>> held;
  for (int i = 0; i < 64; ++i) held.push_back(std::make_unique<client::Connection>(io, d.socket, "holder"));
  try {
    client::Connection extra(io, d.socket, "one-too-many");
    FAIL() << "a 65th client was accepted";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.kind(), client::ClientError::Kind::refused) << e.what();
    EXPECT_NE(std::string(e.what()).find("64 clients are connected, the limit (max_clients)"), std::string::npos)
        << e.what();
  }
  CtlRun r = sculptctl({"status", "--socket", d.socket});
  EXPECT_EQ(r.status, 1) << "the daemon refused (4 is for another protocol major): " << r.err;
  EXPECT_NE(r.err.find("max_clients"), std::string::npos) << r.err;
  held.pop_back();
  // The place is freed when the daemon sees the close: refused until then.
  r = sculptctl({"status", "--socket", d.socket});
  for (const auto end = std::chrono::steady_clock::now() + 30s; r.status != 0 && std::chrono::steady_clock::now() < end;) {
    EXPECT_EQ(r.status, 1) << r.err;
    std::this_thread::sleep_for(50ms);
    r = sculptctl({"status", "--socket", d.socket});
  }
  EXPECT_EQ(r.status, 0) << r.err;
}

TEST(Clients, BadToleranceIsAnErrorNamingIt) {
  Daemon d("tolerance", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  auto io = kj::setupAsyncIo();
  client::Connection c(io, d.socket, "tolerance-test");
  class Nothing final : public proto::Viewer::Server {};
  for (float bad : {std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN(), -1.0f}) {
    auto req = c.session().subscribeRequest();
    req.setViewer(kj::heap<Nothing>());
    req.setToleranceM(bad);
    req.setMaxFps(30);
    try {
      req.send().wait(io.waitScope);
      ADD_FAILURE() << "tolerance " << bad << " accepted";
    } catch (const kj::Exception& e) {
      EXPECT_NE(std::string(e.getDescription().cStr()).find("toleranceM"), std::string::npos)
          << e.getDescription().cStr();
    }
  }
  auto req = c.session().subscribeRequest();
  req.setViewer(kj::heap<Nothing>());
  req.setToleranceM(1e-4f);
  req.setMaxFps(30);
  auto sub = req.send().wait(io.waitScope).getSubscription();
  auto set = sub.setToleranceRequest();
  set.setToleranceM(std::numeric_limits<float>::infinity());
  EXPECT_THROW(set.send().wait(io.waitScope), kj::Exception);
}

// --- blow-ups are loud ----------------------------------------------------------------

TEST(Blowups, AnUnstableSceneIsNamedByCheckInspectAndTheLog) {
  Scratch s("blowup");
  const std::string scene = s.write("stiff.toml", R"([simulation]
substeps = 1

[materials.steel]
stiffness = 1e12
gravity = true

[[mesh]]
name = "anvil"
file = "builtin:icosphere"
material = "steel"

[[tool]]
name = "finger"
)");
  Sculptd check({"--config", "/dev/null", "--check", "--scene", scene});
  EXPECT_EQ(check.wait_exit(60s), 0) << check.log();
  EXPECT_NE(check.log().find("mesh 'anvil' blew up"), std::string::npos) << check.log();
  const CtlRun inspect = sculptctl({"inspect", scene});
  EXPECT_EQ(inspect.status, 0) << inspect.err;
  EXPECT_NE(inspect.out.find("mesh 'anvil' blew up"), std::string::npos) << inspect.out;
  Daemon d("blowup", {"--scene", scene, "--input", "replay:" + recordings("push.jsonl")});
  EXPECT_TRUE(d.process->wait_for_log("blow-up at tick", 20s)) << d.process->log();
  EXPECT_NE(d.process->log().find("mesh 'anvil'"), std::string::npos) << d.process->log();
}

// --- the smaller ones -----------------------------------------------------------------

TEST(Small, DirectoriesSculptdCreatesIgnoreTheUmask) {
  const std::string dir = temp_path("umask-dir");
  fs::remove_all(dir);
  const mode_t old = ::umask(0);
  std::optional<Sculptd> d;
  d.emplace(std::vector<std::string>{"--config", "/dev/null", "--scene", "builtin:default", "--socket",
                                     dir + "/nested/sculptd.sock", "--duration", "30"});
  ::umask(old);
  ASSERT_TRUE(d->wait_for_log("sculptd ready", 60s)) << d->log();
  for (const std::string& p : {dir, dir + "/nested"}) {
    struct stat st {};
    ASSERT_EQ(::stat(p.c_str(), &st), 0) << p;
    EXPECT_EQ(st.st_mode & 07777, 0750u) << p;
  }
  d.reset();
  fs::remove_all(dir);
}

TEST(Small, UsageErrorsOfSculptctlExit2NamingWhatIsWrong) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"--frobnicate"}, {"frob"}, {}, {"status", "--bogus"}, {"save"}, {"inspect", "--material", "tin", "x.obj"},
           {"undo", "0"}, {"redo", "10001"}, {"export"}}) {
    const CtlRun r = sculptctl(args);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_EQ(r.err.rfind("sculptctl: error: ", 0), 0u) << r.err;
  }
}

}  // namespace
}  // namespace sculpt::e2e
