// A seeded, reproducible soak against one running sculptd: for
// SCULPT_SOAK_SECONDS (120 by default) a random mix, from SCULPT_SOAK_SEED, of
// good and bad scene loads, saves, pauses, resets, viewers that connect,
// stall, flood and vanish, garbage, silent connections and bursts, while a
// probe asks for the status every 10 ms. At the end the daemon must have
// run throughout, answered every status call, kept simulating (its sim time
// advanced over every stretch of seconds it was not paused), and kept its
// memory bounded. The figures are printed: what was tried, the simulated
// rate, the status waits and whose they were (status_probe.hpp; the
// benchmark of them is status_bench.cpp), the peak RSS, and what the soak was
// doing during the slowest calls.
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <thread>
#include <tuple>

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

double env_number(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}

struct Status {
  std::string scene;
  bool paused = false;
  double sim_s = 0;
};

Status status_of(const std::string& socket) {
  auto io = kj::setupAsyncIo();
  client::Connection c(io, socket, "soak-check");
  auto r = c.session().statusRequest().send().wait(io.waitScope);
  const auto s = r.getStats();
  return {s.getScene(), s.getPaused(), static_cast<double>(s.getSimTimeNs()) * 1e-9};
}

TEST(Soak, OneDaemonTakesEveryKindOfFaultAndStaysAliveAtRateAndBounded) {
  // A sanitized daemon keeps freed memory in quarantine: keep that small so
  // RSS shows what is held.
  if (const char* asan = std::getenv("ASAN_OPTIONS"))
    ::setenv("ASAN_OPTIONS", (std::string(asan) + ":quarantine_size_mb=1").c_str(), 1);
  const double seconds = env_number("SCULPT_SOAK_SECONDS", 120);
  const auto seed = static_cast<std::uint32_t>(env_number("SCULPT_SOAK_SEED", 19));
  std::printf("soak: %.0f s, seed %u (SCULPT_SOAK_SECONDS, SCULPT_SOAK_SEED)\n", seconds, seed);
  std::mt19937 rng(seed);
  auto chance = [&](int n) { return static_cast<int>(rng() % static_cast<unsigned>(n)); };

  const fs::path dir = temp_path("soak-dir");
  fs::remove_all(dir);
  fs::create_directories(dir / "saves");
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  const std::string ball = "[[mesh]]\nfile = \"builtin:icosphere\"\nparams = { subdivisions = 4, radius = 0.1 }\n";
  std::vector<std::string> good = {"builtin:default", write("ball.toml", "[simulation]\nrate_hz = 500\n" + ball + "[[tool]]\nname = \"f\"\n")};
#ifndef SCULPT_SANITIZED_BUILD
  good.push_back(std::string(SCULPT_TEST_DATA) + "/scenes/sculpt_50k.toml");  // at rate only unsanitized
#endif
  const std::string fifo = (dir / "fifo.toml").string();
  ::mkfifo(fifo.c_str(), 0600);
  std::string tools;
  for (int i = 0; i < 9; ++i) tools += "[[tool]]\nname = \"t" + std::to_string(i) + "\"\n";
  const std::vector<std::string> bad = {
      write("fast.toml", "[simulation]\nrate_hz = 100001\n" + ball), write("tools.toml", ball + tools),
      write("empty.toml", ""), write("garbage.toml", "[[mesh\n"), fifo, "/dev/zero", "/dev/urandom", "/dev/null",
      dir.string(), (dir / "none.toml").string()};

  Daemon d("soak", {"--scene", "builtin:default", "--input", "replay:" + recordings("bench_sculpt.jsonl")});
  const pid_t pid = d.process->pid();
  const std::uint64_t rss_start = rss_kb(pid);
  StatusProbe probe(d.socket, pid);
  std::vector<std::unique_ptr<StreamViewer>> viewers;
  std::vector<int> silent;
  std::map<std::string, int> tried;
  std::string scene = "builtin:default";
  bool paused = false;
  double paused_s = 0;
  std::uint64_t rss_peak = rss_start;
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  const Status first = status_of(d.socket);
  double pause_began = 0;
  // The sim kept ticking: over every kStretchS of unpaused time its sim time
  // advanced (by anything: a slow machine ticks slower, a hung sim thread
  // not at all).
  constexpr double kStretchS = 5;
  auto unpaused_s = [&] { return elapsed() - paused_s - (paused ? elapsed() - pause_began : 0); };
  Status checked = first;
  double checked_at = 0, checked_unpaused = 0;
  int stretches = 0;

  // What ran when, to say which input a slow status answer came with.
  std::vector<std::tuple<std::chrono::steady_clock::time_point, std::chrono::steady_clock::time_point, std::string>>
      timeline;
  while (elapsed() < seconds) {
    ASSERT_EQ(d.process->wait_exit(0ms), std::nullopt) << "sculptd died:\n" << d.process->log();
    const int what = chance(12);
    const auto began = std::chrono::steady_clock::now();
    const std::map<std::string, int> before = tried;
    if (what == 0) {  // a good load
      const std::string s = good[static_cast<std::size_t>(chance(static_cast<int>(good.size())))];
      const CtlRun r = sculptctl({"load", s, "--socket", d.socket});
      EXPECT_EQ(r.status, 0) << s << ": " << r.err;
      if (r.status == 0) scene = s;
      ++tried["good load"];
    } else if (what == 1) {  // a bad load: refused, the sculpt kept
      const std::string s = bad[static_cast<std::size_t>(chance(static_cast<int>(bad.size())))];
      const CtlRun r = sculptctl({"load", s, "--socket", d.socket});
      EXPECT_EQ(r.status, 1) << s << ": " << r.err;
      EXPECT_EQ(status_of(d.socket).scene, scene) << "after the bad load of " << s;
      ++tried["bad load"];
    } else if (what == 2) {
      const CtlRun r = sculptctl({"save", (dir / "saves" / ("s" + std::to_string(chance(4)) + ".glb")).string(),
                                  "--socket", d.socket});
      EXPECT_EQ(r.status, 0) << r.err;
      ++tried["save"];
    } else if (what == 3) {
      const CtlRun r = sculptctl({paused ? "resume" : "pause", "--socket", d.socket});
      EXPECT_EQ(r.status, 0) << r.err;
      if (paused) paused_s += elapsed() - pause_began;
      else pause_began = elapsed();
      paused = !paused;
      ++tried["pause/resume"];
    } else if (what == 4) {
      EXPECT_EQ(sculptctl({"reset", "--socket", d.socket}).status, 0);
      ++tried["reset"];
    } else if (what == 5 && viewers.size() < 6) {
      const float tolerances[] = {0.0f, 1e-4f, 1e-3f};
      viewers.push_back(std::make_unique<StreamViewer>(d.socket, tolerances[chance(3)], 10.0f + chance(110)));
      ++tried["viewer connects"];
    } else if (what == 6 && !viewers.empty()) {
      auto& v = viewers[static_cast<std::size_t>(chance(static_cast<int>(viewers.size())))];
      v->stop_reading();
      std::this_thread::sleep_for(std::chrono::milliseconds(200 + chance(2000)));
      v->resume_reading();
      ++tried["viewer stalls"];
    } else if (what == 7 && !viewers.empty()) {
      viewers.erase(viewers.begin() + chance(static_cast<int>(viewers.size())));
      ++tried["viewer vanishes"];
    } else if (what == 8) {  // calls whose answers are never read
      RawRpc raw(d.socket);
      raw.hello();
      for (std::uint32_t q = 2; q < 2002 && raw.keyframe(q); ++q) {
      }
      ++tried["flood of unread calls"];
    } else if (what == 9) {
      RawRpc raw(d.socket);
      raw.hello(static_cast<std::uint32_t>(9 + chance(5000)));
      EXPECT_TRUE(raw.closed_within(10s));
      ++tried["capabilities flood"];
    } else if (what == 10) {
      const int fd = connect_raw(d.socket);
      std::vector<std::uint8_t> junk(static_cast<std::size_t>(1 + chance(8192)));
      for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
      write_all(fd, junk.data(), junk.size());
      ::close(fd);
      ++tried["garbage"];
    } else if (what == 11) {
      if (chance(2) == 0) {
        for (int i = 0; i < 20; ++i) silent.push_back(connect_raw(d.socket));
        ++tried["silent connections (20)"];
      } else {
        for (int i = 0; i < 200; ++i) ::close(connect_raw(d.socket));
        ++tried["connect/close burst (200)"];
      }
    }
    for (const auto& [kind, n] : tried)
      if (before.count(kind) == 0 || before.at(kind) != n) timeline.emplace_back(began, std::chrono::steady_clock::now(), kind);
    rss_peak = std::max(rss_peak, rss_kb(pid));
    if (unpaused_s() - checked_unpaused >= kStretchS) {
      const Status now = status_of(d.socket);
      EXPECT_GT(now.sim_s, checked.sim_s) << "the sim time stood still from " << checked_at << " s to " << elapsed()
                                          << " s of the soak, " << unpaused_s() - checked_unpaused << " s of it unpaused";
      ++stretches;
      checked = now, checked_at = elapsed(), checked_unpaused = unpaused_s();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20 + chance(180)));
  }
  if (paused) {
    EXPECT_EQ(sculptctl({"resume", "--socket", d.socket}).status, 0);
    paused_s += elapsed() - pause_began;
  }
  const double wall = elapsed();
  const Status last = status_of(d.socket);
  const StatusProbe::Result p = probe.stop();
  viewers.clear();
  for (int fd : silent) ::close(fd);
  rss_peak = std::max(rss_peak, rss_kb(pid));

  int total = 0;
  for (const auto& [kind, n] : tried) total += n;
  std::printf("soak: %d inputs tried in %.0f s:", total, wall);
  for (const auto& [kind, n] : tried) std::printf(" %s %d,", kind.c_str(), n);
  std::printf("\nsoak: crashes 0; simulated %.1f s of %.1f s unpaused (%.0f%%; advancing in each of %d stretches "
              "of %.0f s unpaused checked); RSS %llu kB at the start, peak %llu kB\n",
              last.sim_s - first.sim_s, wall - paused_s, 100 * (last.sim_s - first.sim_s) / (wall - paused_s),
              stretches, kStretchS, static_cast<unsigned long long>(rss_start),
              static_cast<unsigned long long>(rss_peak));
  print_waits("soak", p.samples);
  // The slowest calls by the daemon's part, and what the soak was doing then.
  std::vector<StatusProbe::Sample> slowest = p.samples;
  std::sort(slowest.begin(), slowest.end(),
            [](const auto& a, const auto& b) { return a.daemons_part_ms() > b.daemons_part_ms(); });
  slowest.resize(std::min<std::size_t>(slowest.size(), 5));
  for (const auto& s : slowest) {
    std::string during = "nothing the soak did";
    for (const auto& [b, e, kind] : timeline)
      if (s.at + std::chrono::microseconds(static_cast<std::int64_t>(s.wait_ms * 1000)) >= b && s.at <= e + 100ms)
        during = kind;
    std::printf("soak: a status call at %.2f s waited %.1f ms (probe queued %.1f, io thread %.1f, all daemon threads "
                "%.1f), during: %s\n",
                std::chrono::duration<double>(s.at - t0).count(), s.wait_ms, s.probe_queued_ms, s.io_queued_ms,
                s.daemon_queued_ms, during.c_str());
  }
  EXPECT_EQ(p.failures, 0u) << p.first_failure;
  EXPECT_GT(last.sim_s, first.sim_s) << "the sim time never advanced";
  // Bounded: what a scene needs (the 50k scene with its viewers) plus one
  // client's queue limit, never what the floods asked for.
  EXPECT_LT(rss_peak, rss_start + 512 * 1024) << "RSS grew from " << rss_start << " kB to " << rss_peak << " kB";
  d.process->signal(SIGTERM);
  EXPECT_EQ(d.process->wait_exit(60s), 0) << d.process->log();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sculpt::e2e
