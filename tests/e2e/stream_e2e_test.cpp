// Streaming end to end on the host (no devices: a recording replays
// into sculptd): many viewers reconstruct the sculpt within their tolerance,
// a stalled viewer slows nobody, bad clients are dropped while the others are
// served, an old protocol is refused with a reason, an idle scene sends only
// keep-alives, and every sculptctl command against a running daemon.
// (fault_e2e_test.cpp: what a client, a file or a recording must not be able to
// do to the daemon.)
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <optional>
#include <set>

#include <gtest/gtest.h>
#include <kj/async-io.h>

#include "client/connection.hpp"
#include "client/mesh_mirror.hpp"
#include "daemon_fixture.hpp"
#include "stream_viewer.hpp"

namespace sculpt::e2e {
namespace {

// One control connection on the calling thread.
struct Control {
  kj::AsyncIoContext io = kj::setupAsyncIo();
  client::Connection c;
  explicit Control(const std::string& socket) : c(io, socket, "stream-e2e-test") {}

  proto::Stats::Reader status_into(capnp::Response<proto::Session::StatusResults>& r) { return r.getStats(); }
  bool pause(bool p) {
    if (p) return c.session().pauseRequest().send().wait(io.waitScope).getResult().getOk();
    return c.session().resumeRequest().send().wait(io.waitScope).getResult().getOk();
  }
  // The sim loop's counters that say whether it was held up.
  struct Loop {
    std::uint64_t ticks, overruns, waits_mid_tick;  // waits in ticks without a page fault
    std::uint64_t waits_in_all;                     // with those inside page faults (the kernel's)
  };
  std::uint64_t overruns_printed = 0;
  Loop loop() {
    auto r = c.session().statusRequest().send().wait(io.waitScope);
    const auto s = r.getStats();
    const auto recent = s.getRecentOverruns();
    const std::uint64_t first = s.getOverruns() - recent.size();  // the records are the last few, oldest first
    for (unsigned i = 0; i < recent.size(); ++i) {
      if (first + i < overruns_printed) continue;
      const auto o = recent[i];
      std::printf("  overrun at tick %llu: %s, %s CPU, late %.1f ms, waits mid-tick %llu\n",
                  static_cast<unsigned long long>(o.getTick()),
                  o.getCause() == proto::OverrunCause::LONG_STEP ? "long step" : "late wake",
                  o.getOffCpu() ? "off the" : "on the", static_cast<double>(o.getLateNs()) / 1e6,
                  static_cast<unsigned long long>(o.getWorkNvcsw()));
    }
    overruns_printed = s.getOverruns();
    return {s.getTicks(), s.getOverruns(), s.getSimThread().getWorkNvcswNoFault(), s.getSimThread().getWorkNvcsw()};
  }
  std::uint64_t viewers() { return c.session().statusRequest().send().wait(io.waitScope).getStats().getViewers(); }
  // The daemon's whole state now, as a mirror.
  client::MeshMirror keyframe() {
    auto r = c.session().keyframeRequest().send().wait(io.waitScope);
    client::MeshMirror m;
    m.apply(r.getKeyframe());
    return m;
  }
};

// Largest distance between a viewer's copy and the truth, over every vertex.
double max_error(const std::vector<client::MirrorMesh>& have, const std::vector<client::MirrorMesh>& truth) {
  if (have.size() != truth.size()) return INFINITY;
  double worst = 0;
  for (std::size_t m = 0; m < have.size(); ++m) {
    if (have[m].positions.size() != truth[m].positions.size()) return INFINITY;
    for (std::size_t i = 0; i < have[m].positions.size(); i += 3) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = have[m].positions[i + a] - truth[m].positions[i + a];
        d2 += d * d;
      }
      worst = std::max(worst, std::sqrt(d2));
    }
  }
  return worst;
}

// Pauses the daemon, then checks every viewer reaches the final state within
// its tolerance (the last frames arrive within about a keep-alive period).
void expect_viewers_match(Control& control, std::vector<std::unique_ptr<StreamViewer>>& viewers) {
  ASSERT_TRUE(control.pause(true));
  // A keyframe after the pause is the final state; every viewer gets a frame
  // at or after its sequence (changes, or the next keep-alive).
  const client::MeshMirror truth = control.keyframe();
  for (auto& v : viewers) {
    ASSERT_TRUE(v->wait_for_sequence(truth.sequence(), 20s)) << v->seen().error_text;
    // The frame carrying the last changes may be the one after the first at
    // this sequence (it was computed from a sync that began before it).
    double err = max_error(v->meshes(), truth.meshes());
    const auto deadline = std::chrono::steady_clock::now() + 5s;
    while (err > v->tolerance() * (1 + 1e-5) + 1e-7 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(20ms);
      err = max_error(v->meshes(), truth.meshes());
    }
    EXPECT_LE(err, v->tolerance() * (1 + 1e-5) + 1e-7) << "viewer with tolerance " << v->tolerance();
    EXPECT_FALSE(v->seen().error) << v->seen().error_text;
    EXPECT_EQ(v->seen().not_increasing, 0u) << "sequence numbers must strictly increase per viewer";
  }
}

TEST(Stream, SixteenViewersComingAndGoingEachReconstructTheSculptWithinTheirTolerance) {
  Daemon d("sixteen", {"--scene", "builtin:default", "--input", "replay:" + recordings("bench_sculpt.jsonl")});
  Control control(d.socket);
  const float tolerances[] = {0.0f, 1e-4f, 1e-3f, 5e-3f};
  const float rates[] = {30.0f, 60.0f, 120.0f, 500.0f};
  std::vector<std::unique_ptr<StreamViewer>> viewers;
  auto add = [&](int i) {
    viewers.push_back(std::make_unique<StreamViewer>(d.socket, tolerances[i % 4], rates[(i / 4) % 4]));
    ASSERT_FALSE(viewers.back()->seen().error) << viewers.back()->seen().error_text;
  };
  // Each wave streams before the next comes (frames, not a time).
  const auto streaming = [&](std::size_t from) {
    for (std::size_t i = from; i < viewers.size(); ++i)
      ASSERT_TRUE(viewers[i]->wait_for_frames(2, 30s)) << "viewer " << i << ": " << viewers[i]->seen().error_text;
  };
  for (int i = 0; i < 8; ++i) add(i);
  streaming(0);
  for (int i = 8; i < 16; ++i) add(i);
  streaming(8);
  // Four leave mid-run, four new ones come.
  viewers.erase(viewers.begin(), viewers.begin() + 4);
  for (int i = 16; i < 20; ++i) add(i);
  streaming(12);
  // The daemon counts the four gone once it has seen them close.
  std::uint64_t counted = control.viewers();
  for (const auto end = std::chrono::steady_clock::now() + 30s; counted != 16 && std::chrono::steady_clock::now() < end;) {
    std::this_thread::sleep_for(20ms);
    counted = control.viewers();
  }
  EXPECT_EQ(counted, 16u);
  // The recorded gamepad (slot 0) drives both tools.
  const client::MeshMirror now = control.keyframe();
  ASSERT_EQ(now.tools().size(), 2u);
  for (const auto& t : now.tools()) EXPECT_EQ(t.device_slot, 0) << "tool " << t.id;

  // The recording sculpts (from a second or so in): the viewers see it
  // before the pause.
  const auto with_meshes = [&] {
    std::uint64_t n = 0;
    for (auto& v : viewers) n += v->seen().frames_with_meshes;
    return n;
  };
  for (const auto end = std::chrono::steady_clock::now() + 60s; with_meshes() == 0 && std::chrono::steady_clock::now() < end;)
    std::this_thread::sleep_for(20ms);
  EXPECT_GT(with_meshes(), 0u) << "the recording sculpted nothing the viewers saw";
  expect_viewers_match(control, viewers);
}

TEST(Stream, AViewerThatStopsReadingSlowsNobodyAndCatchesUpWhenItResumes) {
  // A sanitized daemon keeps freed memory in quarantine: keep that small so
  // RSS shows what is held.
  if (const char* asan = std::getenv("ASAN_OPTIONS"))
    ::setenv("ASAN_OPTIONS", (std::string(asan) + ":quarantine_size_mb=1").c_str(), 1);
  constexpr double kRateHz = 20;
  Daemon d("stall", {"--scene", "builtin:default", "--rate", "20", "--input",
                     "replay:" + recordings("bench_sculpt.jsonl")});
  Control control(d.socket);
  std::vector<std::unique_ptr<StreamViewer>> viewers;
  viewers.push_back(std::make_unique<StreamViewer>(d.socket, 0.0f, 1000.0f));  // the one that stalls
  viewers.push_back(std::make_unique<StreamViewer>(d.socket, 0.0f, 60.0f));
  ASSERT_TRUE(viewers[0]->wait_for_frames(3, 20s)) << viewers[0]->seen().error_text;
  const std::uint64_t rss_before = rss_kb(d.process->pid());
  // Held up by a viewer, the sim thread would wait mid-tick (a voluntary
  // context switch: it makes no blocking call) and stop ticking. That is what
  // is asserted, not "no overrun": a shared host can steal a vCPU for longer
  // than a period whatever the viewers do. Overruns are printed with their
  // cause (none was a wait). A wait inside a page fault (compaction moving a
  // page) is the kernel's, not a viewer's: printed, not asserted.
  const Control::Loop before = control.loop();
  const auto stall_began = std::chrono::steady_clock::now();
  viewers[0]->stop_reading();
  const std::uint64_t other_before = viewers[1]->seen().frames;
  // The stalled viewer blocks inside its next frame; its socket fills.
  for (const auto end = stall_began + 30s; !viewers[0]->blocked_now() && std::chrono::steady_clock::now() < end;)
    std::this_thread::sleep_for(10ms);
  EXPECT_TRUE(viewers[0]->blocked_now()) << "the stalled viewer got no frame";
  // Seconds of stall (long enough for a queue of its frames to show in
  // RSS), through which the other viewer keeps getting frames.
  std::this_thread::sleep_for(4s);
  EXPECT_TRUE(viewers[1]->wait_for_frames(other_before + 10, 60s)) << "the other viewer was held up";
  EXPECT_TRUE(viewers[0]->blocked_now());
  const std::uint64_t rss_during = rss_kb(d.process->pid());
  const Control::Loop during = control.loop();
  const double stalled_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - stall_began).count();
  EXPECT_EQ(during.waits_mid_tick, before.waits_mid_tick) << "the sim thread waited on something mid-tick";
  // Held up, it would make none (the rate is printed, not asserted: a busy
  // host may steal periods).
  EXPECT_GT(during.ticks, before.ticks) << "no tick over " << stalled_s << " s of stall";
  std::printf("over %.1f s of stall: %llu ticks (%.0f%% of the rate), %llu overruns, %llu waits inside page faults\n",
              stalled_s, static_cast<unsigned long long>(during.ticks - before.ticks),
              100.0 * static_cast<double>(during.ticks - before.ticks) / (kRateHz * stalled_s),
              static_cast<unsigned long long>(during.overruns - before.overruns),
              static_cast<unsigned long long>((during.waits_in_all - during.waits_mid_tick) -
                                              (before.waits_in_all - before.waits_mid_tick)));
  // A queue of 4 s of 1000-fps frames would be tens of MB; one call in flight is not.
  EXPECT_LT(rss_during, rss_before + 16 * 1024) << "RSS " << rss_before << " kB -> " << rss_during << " kB";
  viewers[0]->resume_reading();
  expect_viewers_match(control, viewers);
  EXPECT_EQ(control.loop().waits_mid_tick, before.waits_mid_tick) << "the sim thread waited on something mid-tick";
}

TEST(Stream, GarbageTruncatedSilentAndRapidClientsLeaveTheOthersServed) {
  Daemon d("garbage", {"--scene", "builtin:default", "--input", "replay:" + recordings("bench_sculpt.jsonl")});
  StreamViewer good(d.socket, 0.0f, 60.0f);
  ASSERT_TRUE(good.wait_for_frames(2, 20s)) << good.seen().error_text;

  // A client that connects and never speaks, kept open throughout.
  const int silent = connect_raw(d.socket);
  ASSERT_GE(silent, 0);

  // Random bytes.
  std::mt19937 rng(7);
  for (int i = 0; i < 20; ++i) {
    const int fd = connect_raw(d.socket);
    ASSERT_GE(fd, 0);
    std::vector<std::uint8_t> junk(static_cast<std::size_t>(1 + rng() % 4096));
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    write_all(fd, junk.data(), junk.size());
    ::close(fd);
  }
  // A message header announcing far more than the limit, then nothing.
  {
    const int fd = connect_raw(d.socket);
    const std::uint32_t header[2] = {0, 1u << 28};  // one segment of 2^28 words
    write_all(fd, header, sizeof header);
    ::close(fd);
  }
  // A valid-looking header whose body never completes (truncated).
  {
    const int fd = connect_raw(d.socket);
    const std::uint32_t header[2] = {0, 64};
    write_all(fd, header, sizeof header);
    const std::uint64_t some[8] = {};
    write_all(fd, some, sizeof some);
    ::close(fd);
  }
  // Deep garbage that parses: a flood of segment-count-heavy headers.
  {
    const int fd = connect_raw(d.socket);
    const std::uint32_t header[2] = {1000, 0};  // 1001 segments: over capnp's limit
    write_all(fd, header, sizeof header);
    ::close(fd);
  }
  // 1000 rapid connects, half of them saying hello.
  for (int i = 0; i < 1000; ++i) {
    if (i % 2 == 0) {
      const int fd = connect_raw(d.socket);
      ASSERT_GE(fd, 0) << "connect " << i;
      ::close(fd);
    } else {
      auto io = kj::setupAsyncIo();
      client::Connection c(io, d.socket, "rapid");
    }
  }
  const std::uint64_t frames = good.seen().frames;
  ASSERT_TRUE(good.wait_for_frames(frames + 5, 20s)) << good.seen().error_text;
  EXPECT_FALSE(good.seen().error) << good.seen().error_text;

  Control control(d.socket);
  EXPECT_EQ(control.viewers(), 1u);
  // The silent client held a place for no longer than the hello timeout.
  EXPECT_TRUE(d.process->wait_for_log("said no hello within 5 s (hello_timeout)", 20s)) << d.process->log();
  char byte;
  EXPECT_EQ(::recv(silent, &byte, 1, 0), 0) << "the daemon did not close the silent connection";
  ::close(silent);
  std::vector<std::unique_ptr<StreamViewer>> viewers;
  viewers.push_back(std::make_unique<StreamViewer>(d.socket, 1e-4f, 60.0f));
  expect_viewers_match(control, viewers);
}

TEST(Stream, AClientOfAnotherMajorVersionIsRefusedWithAReason) {
  Daemon d("major", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  auto io = kj::setupAsyncIo();
  try {
    client::Connection c(io, d.socket, "future-client", proto::PROTOCOL_MAJOR + 1, 0);
    FAIL() << "a client speaking major " << proto::PROTOCOL_MAJOR + 1 << " was accepted";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.kind(), client::ClientError::Kind::incompatible);
    EXPECT_NE(std::string(e.what()).find("daemon speaks protocol 1, this client 2"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(d.process->wait_for_log("refused", 10s));
  client::Connection ok(io, d.socket, "current-client");  // and the daemon still serves the right one
  EXPECT_FALSE(ok.server().empty());
}

TEST(Stream, TheSocketIsForTheOwnerAndGroupOnly) {
  Daemon d("mode", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl")});
  struct stat st {};
  ASSERT_EQ(::stat(d.socket.c_str(), &st), 0) << d.socket;
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0660u);
}

TEST(Stream, NoDaemonIsNamedClearly) {
  auto io = kj::setupAsyncIo();
  const std::string path = temp_path("nobody.sock");
  try {
    client::Connection c(io, path, "lonely");
    FAIL() << "connected to nothing";
  } catch (const client::ClientError& e) {
    EXPECT_EQ(e.kind(), client::ClientError::Kind::no_daemon);
    EXPECT_EQ(std::string(e.what()), "no daemon is listening on " + path);
  }
}

TEST(Stream, AnIdleSceneStreamsOnlyKeepAlives) {
  // A recording with its gamepad and no input at all: nothing ever moves.
  const std::string idle = temp_path("idle.jsonl");
  {
    std::ifstream in(recordings("push.jsonl"));
    std::string header;
    std::getline(in, header);
    std::ofstream(idle) << header << "\n";
  }
  Daemon d("idle", {"--scene", "builtin:default", "--input", "replay:" + idle});
  const auto subscribed = std::chrono::steady_clock::now();
  StreamViewer v(d.socket, 0.0f, 120.0f);
  // About one a second: three, then a little longer for any extra to show.
  EXPECT_TRUE(v.wait_for_frames(3, 60s)) << v.seen().error_text;
  std::this_thread::sleep_for(1500ms);
  const auto seen = v.seen();
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - subscribed).count();
  EXPECT_FALSE(seen.error) << seen.error_text;
  EXPECT_EQ(seen.keyframes, 1u);
  EXPECT_EQ(seen.frames_with_meshes, 0u);
  EXPECT_EQ(seen.frames, seen.keepalives);
  EXPECT_GE(seen.keepalives, 3u);
  // At most one a second (keepalive_ns), however long it took: not one per
  // tick, nor per maxFps period.
  EXPECT_LE(static_cast<double>(seen.keepalives), elapsed_s + 1) << "in " << elapsed_s << " s";
  std::printf("%llu keep-alives in %.1f s\n", static_cast<unsigned long long>(seen.keepalives), elapsed_s);
  EXPECT_EQ(seen.not_increasing, 0u) << "keep-alives at the same tick repeated a sequence number";
  ::unlink(idle.c_str());
}

TEST(Stream, SocketActivationServesThePassedSocket) {
  // systemd-socket-activate listens, then execs sculptd with LISTEN_FDS=1 on
  // the first connection, as sculptd.socket does.
  const char* activate = "/usr/bin/systemd-socket-activate";
  ASSERT_EQ(::access(activate, X_OK), 0) << "systemd (systemd-socket-activate) is a build dependency";
  const std::string socket = temp_path("activated.sock"), other = temp_path("not-used.sock");
  ::unlink(socket.c_str());
  ::unlink(other.c_str());
  support::ChildProcess activated({activate, "-l", socket, SCULPTD_BIN, "--scene", "builtin:default", "--input",
                                   "replay:" + recordings("push.jsonl"), "--socket", other},
                                  {.err = support::ChildProcess::Output::capture});
  {
    auto io = kj::setupAsyncIo();
    // The socket's file exists once systemd-socket-activate has bound it,
    // a moment before it listens: a connection refused then is retried.
    std::optional<client::Connection> c;
    for (const auto end = std::chrono::steady_clock::now() + 30s; !c;) {
      try {
        c.emplace(io, socket, "activated-client");  // this connection starts sculptd
      } catch (const client::ClientError& e) {
        if (e.kind() != client::ClientError::Kind::no_daemon || std::chrono::steady_clock::now() > end) throw;
        std::this_thread::sleep_for(10ms);
      }
    }
    auto st = c->session().statusRequest().send().wait(io.waitScope);
    EXPECT_EQ(st.getStats().getScene(), "builtin:default");
  }
  EXPECT_NE(::access(other.c_str(), F_OK), 0) << "sculptd bound --socket although systemd passed one";
  // "sculptd ready" comes after the first tick, which may follow the answer.
  EXPECT_TRUE(activated.err().wait_for("(socket activation)", 5s)) << activated.err().text();
  activated.signal(SIGTERM);
  activated.wait(30s);
  ::unlink(socket.c_str());
}

// --- sculptctl ------------------------------------------------------------------

std::set<std::string> keys_of(const nlohmann::json& j) {
  std::set<std::string> k;
  for (const auto& [key, value] : j.items()) k.insert(key);
  return k;
}

TEST(Sculptctl, EveryDaemonCommandAgainstARunningSculptd) {
  const std::string stats = temp_path("ctl-stats.json");
  Daemon d("ctl", {"--scene", "builtin:default", "--input", "replay:" + recordings("push.jsonl"), "--stats-json", stats});
  const std::vector<std::string> sock = {"--socket", d.socket};
  auto with = [&](std::vector<std::string> a) {
    a.insert(a.end(), sock.begin(), sock.end());
    return sculptctl(a);
  };

  CtlRun r = with({"status"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("running"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("jitter"), std::string::npos) << r.out;

  r = with({"status", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto status = nlohmann::json::parse(r.out);
  for (const char* k : {"rate_hz", "ticks", "overruns", "jitter_us", "stage_us", "vertices_total", "vertices_awake",
                        "viewers", "devices", "ff_uploads", "bytes_sent", "blowups"})
    EXPECT_TRUE(status.contains(k)) << k;
  EXPECT_TRUE(status["jitter_us"].contains("p99"));
  EXPECT_EQ(status["devices"], 1);

  r = with({"devices"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("slot 0"), std::string::npos) << r.out;
  r = with({"devices", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out).size(), 1u);
  EXPECT_TRUE(nlohmann::json::parse(r.out)[0].contains("ff_uploads")) << r.out;

  // A slot's force-feedback tuning, through the daemon's own checks.
  r = with({"haptics", "0", "--gain", "0.5"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "slot 0: gain 0.5, limit 1\n");
  r = with({"haptics", "0", "--limit", "0.25"});
  EXPECT_EQ(r.out, "slot 0: gain 0.5, limit 0.25\n") << r.err;
  r = with({"devices", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_DOUBLE_EQ(nlohmann::json::parse(r.out)[0]["gain"].get<double>(), 0.5) << r.out;
  EXPECT_DOUBLE_EQ(nlohmann::json::parse(r.out)[0]["limit"].get<double>(), 0.25) << r.out;
  r = with({"haptics", "0", "--gain", "nan"});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("gain"), std::string::npos) << r.err;
  r = with({"haptics", "9", "--gain", "0.5"});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("no device on slot 9"), std::string::npos) << r.err;

  r = with({"pause"});
  EXPECT_EQ(r.status, 0) << r.err;
  // Paused (the answer came once the sim thread obeyed): no tick from here.
  r = with({"status"});
  for (const auto end = std::chrono::steady_clock::now() + 30s;
       r.out.find("paused") == std::string::npos && std::chrono::steady_clock::now() < end;) {
    std::this_thread::sleep_for(20ms);
    r = with({"status"});
  }
  EXPECT_NE(r.out.find("paused"), std::string::npos) << r.out;
  r = with({"status", "--json"});
  const auto t0 = nlohmann::json::parse(r.out)["ticks"].get<std::uint64_t>();
  std::this_thread::sleep_for(300ms);
  r = with({"status"});
  EXPECT_NE(r.out.find("paused"), std::string::npos) << r.out;
  r = with({"status", "--json"});
  EXPECT_EQ(nlohmann::json::parse(r.out)["ticks"].get<std::uint64_t>(), t0) << "a paused daemon ticked";
  r = with({"resume", "--json"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["ok"], true);

  for (const char* ext : {"obj", "ply", "stl", "glb"}) {
    const std::string out = temp_path(std::string("saved.") + ext);
    r = with({"save", out});
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_GT(read_file(out).size(), 100u) << ext;
    ::unlink(out.c_str());
  }
  r = with({"save", temp_path("saved.xyz")});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("saved.xyz"), std::string::npos) << r.err;

  // A bad scene names the file and keeps the sculpt; a good one loads.
  const std::string bad = temp_path("bad.toml");
  std::ofstream(bad) << "[settings]\nrate_hz = \"fast\"\n";
  r = with({"load", bad});
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
  ::unlink(bad.c_str());
  r = with({"load", std::string(SCULPT_TEST_DATA) + "/scenes/sculpt_50k.toml"});
  EXPECT_EQ(r.status, 0) << r.err;
  r = with({"status", "--json"});
  EXPECT_GT(nlohmann::json::parse(r.out)["vertices_total"].get<std::uint64_t>(), 40000u);
  r = with({"reset"});
  EXPECT_EQ(r.status, 0) << r.err;
  r = with({"load", "builtin:default", "--json"});
  EXPECT_EQ(r.status, 0) << r.err;

  // The stroke history (protocol 1.5): the daemon answers each command
  // (done, or its refusal with exit 1; never a broken connection), history
  // --json has its keys, and a refused export leaves no file.
  r = with({"history", "--json"});
  ASSERT_EQ(r.status, 0) << r.err;
  const auto history = nlohmann::json::parse(r.out);
  for (const char* k : {"strokes", "budget_bytes", "used_bytes", "dropped", "omitted"})
    EXPECT_TRUE(history.contains(k)) << k << ": " << r.out;
  for (const char* cmd : {"undo", "redo"}) {
    r = with({cmd, "--json"});
    EXPECT_TRUE(r.status == 0 || r.status == 1) << cmd << ": " << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["command"], cmd);
  }
  const std::string sculpt_file = temp_path("e2e.sculpt");
  r = with({"export", sculpt_file});
  EXPECT_TRUE(r.status == 0 || r.status == 1) << r.err;
  if (r.status == 0) EXPECT_GT(read_file(sculpt_file).size(), 0u);
  else EXPECT_FALSE(std::ifstream(sculpt_file).good()) << "a failed export left " << sculpt_file;
  ::unlink(sculpt_file.c_str());

  // --stats-json at exit has exactly the keys status --json prints.
  d.process->signal(SIGTERM);
  ASSERT_EQ(d.process->wait_exit(30s), 0);
  EXPECT_EQ(keys_of(read_json(stats)), keys_of(status));
  ::unlink(stats.c_str());
}

TEST(Sculptctl, NoDaemonIsADistinctExitStatus) {
  const std::string path = temp_path("nobody.sock");
  for (const char* cmd : {"status", "devices", "pause", "resume", "reset"}) {
    CtlRun r = sculptctl({cmd, "--socket", path});
    EXPECT_EQ(r.status, 3) << cmd;
    EXPECT_NE(r.err.find("no daemon is listening on " + path), std::string::npos) << r.err;
  }
  CtlRun r = sculptctl({"save", temp_path("x.obj"), "--socket", path});
  EXPECT_EQ(r.status, 3);
  for (const char* cmd : {"undo", "redo", "history"}) {
    r = sculptctl({cmd, "--socket", path});
    EXPECT_EQ(r.status, 3) << cmd;
  }
  r = sculptctl({"export", temp_path("x.sculpt"), "--socket", path});
  EXPECT_EQ(r.status, 3);
  r = sculptctl({"load", "builtin:default", "--socket", path});
  EXPECT_EQ(r.status, 3);
}

}  // namespace
}  // namespace sculpt::e2e
