// The status-latency benchmark: how long another client's status call waits
// while sculptd serves what a client can throw at it. sculptd runs the 50k
// scene with the benchmark recording sculpting it; a probe (status_probe.hpp)
// asks for the status every 10 ms from its own connection, and each phase
// does one thing meanwhile:
//   idle        nothing more
//   flood       one raw client sends 2000 keyframe() calls it never reads,
//               then closes (as fault_soak does), again and again
//   flood-held  the same, but the client holds the connection until the
//               daemon drops it (over max_queued_bytes)
//   load        sculptctl load of a big scene (8 spheres of 164k vertices,
//               as fault_e2e's), seconds of building off the io loop
//   bursts      garbage, 200 connect/close at once, 20 silent connections
//   viewers     six viewers at 60 fps, three of them not reading
// Each phase runs on a fresh daemon (the recording at the same point), and per
// phase it prints the calls, p50/p99/max of the wait, and whose it was: the
// probe thread's and the daemon's io thread's run-queue time during the call
// (/proc/.../schedstat field 2), all the daemon's threads' summed, and the
// daemon's part = wait − probe's queueing − io thread's queueing. The part
// less every daemon thread's queueing is a lower bound (the sim thread waits
// for a CPU while the io thread works, too) and is printed apart.
// Numbers only: it fails only if the daemon fails or a call is not answered.
//
//   status_bench SCENE RECORDING [--seconds S] [--rounds N] [--phases a,b,..]
//                [--sculptd PATH]... [--realtime 0|1]
// Several --sculptd alternate phase by phase (a before/after comparison in
// one run, on the same machine at the same time). STATUS_BENCH_DEBUG=1 prints
// each daemon's log.
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "daemon_fixture.hpp"
#include "raw_rpc.hpp"
#include "status_probe.hpp"
#include "stream_viewer.hpp"

using namespace sculpt;
using namespace sculpt::e2e;
using namespace std::chrono_literals;

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string scene, recording;
  double seconds = 6;
  int rounds = 2;
  std::vector<std::string> phases = {"idle", "flood", "flood-held", "load", "bursts", "viewers"};
  std::vector<std::string> binaries;
  bool realtime = false;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, ',');)
    if (!part.empty()) out.push_back(part);
  return out;
}

// A scene that takes seconds to build: fault_e2e_test.cpp's big scene.
std::string big_scene(const fs::path& dir) {
  std::string text = "[simulation]\nrate_hz = 200\n";
  for (int i = 0; i < 8; ++i)
    text += "[[mesh]]\nfile = \"builtin:icosphere\"\nparams = { subdivisions = 7, radius = 0.1 }\nposition = [" +
            std::to_string(0.3 * i) + ", 0, 0]\n";
  text += "[[tool]]\nname = \"finger\"\n";
  const fs::path p = dir / "big.toml";
  std::ofstream(p) << text;
  return p.string();
}

struct Failed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One phase's load on the daemon, for `seconds` (the load phase: one load).
void run_phase(const std::string& phase, const std::string& socket, const Options& o, const fs::path& dir,
               std::mt19937& rng) {
  const auto end = Clock::now() + std::chrono::duration<double>(o.seconds);
  if (phase == "idle") {
    std::this_thread::sleep_until(end);
  } else if (phase == "flood") {
    while (Clock::now() < end) {
      {
        RawRpc raw(socket);
        raw.hello();
        for (std::uint32_t q = 2; q < 2002 && raw.keyframe(q); ++q) {
        }
      }
      std::this_thread::sleep_for(100ms);
    }
  } else if (phase == "flood-held") {
    while (Clock::now() < end) {
      RawRpc raw(socket);
      raw.hello();
      for (std::uint32_t q = 2; q < 2002 && raw.keyframe(q); ++q) {
      }
      if (!raw.closed_within(60s)) throw Failed("the daemon never dropped a client flooding unread calls");
    }
  } else if (phase == "load") {
    const CtlRun r = sculptctl({"load", big_scene(dir), "--socket", socket});
    if (r.status != 0) throw Failed("sculptctl load: " + r.err);
  } else if (phase == "bursts") {
    while (Clock::now() < end) {
      for (int i = 0; i < 20; ++i) {
        const int fd = connect_raw(socket);
        std::vector<std::uint8_t> junk(1 + rng() % 8192);
        for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
        write_all(fd, junk.data(), junk.size());
        ::close(fd);
      }
      for (int i = 0; i < 200; ++i) ::close(connect_raw(socket));
      std::vector<int> silent;
      for (int i = 0; i < 20; ++i) silent.push_back(connect_raw(socket));
      std::this_thread::sleep_for(300ms);
      for (int fd : silent) ::close(fd);
    }
  } else if (phase == "viewers") {
    std::vector<std::unique_ptr<StreamViewer>> viewers;
    for (int i = 0; i < 6; ++i) viewers.push_back(std::make_unique<StreamViewer>(socket, 0.0f, 60.0f));
    for (int i = 0; i < 3; ++i) viewers[static_cast<std::size_t>(i)]->stop_reading();
    std::this_thread::sleep_until(end);
    for (auto& v : viewers) v->resume_reading();
  } else {
    throw Failed("unknown phase " + phase + " (idle, flood, flood-held, load, bursts, viewers)");
  }
}

using Samples = std::vector<StatusProbe::Sample>;

// CPU time (ns) the daemon's io thread (its main thread) has run.
std::uint64_t io_cpu_ns(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/schedstat");
  std::uint64_t on_cpu = 0;
  in >> on_cpu;
  return on_cpu;
}

// One message's worth of the io loop's work: a keyframe() answer to a client
// that reads it (what a flood asks for 2000 times), its size and the io
// thread's CPU time during the call, per call.
struct KeyframeCost {
  std::vector<double> cpu_ms;
  double bytes = 0;
};
void measure_keyframe(const std::string& socket, pid_t pid, KeyframeCost& out) {
  auto io = kj::setupAsyncIo();
  client::Connection c(io, socket, "status-bench");
  for (int i = 0; i < 10; ++i) {
    const std::uint64_t cpu0 = io_cpu_ns(pid);
    auto r = c.session().keyframeRequest().send().wait(io.waitScope);
    out.cpu_ms.push_back(static_cast<double>(io_cpu_ns(pid) - cpu0) * 1e-6);
    out.bytes = static_cast<double>(r.totalSize().wordCount * 8);
  }
}

void print_row(const std::string& label, const Samples& samples) {
  const WaitSpread w = wait_spread(samples);
  auto col = [](const Spread& s) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%6.2f %6.2f %7.2f", s.p50, s.p99, s.max);
    return std::string(buf);
  };
  std::printf("  %-26s %6zu %4zu  %s  %s  %s  %s  %s  %7.2f\n", label.c_str(), w.calls, w.failures,
              col(w.wait).c_str(), col(w.probe_queued).c_str(), col(w.io_queued).c_str(),
              col(w.daemon_queued).c_str(), col(w.daemons_part).c_str(), w.daemons_part_all.max);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: %s SCENE RECORDING [--seconds S] [--rounds N] [--phases a,b,..] [--sculptd PATH]... "
                 "[--realtime 0|1]\n",
                 argv[0]);
    return 2;
  }
  Options o;
  o.scene = argv[1], o.recording = argv[2];
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--seconds") o.seconds = std::stod(v);
    else if (k == "--rounds") o.rounds = std::stoi(v);
    else if (k == "--phases") o.phases = split(v);
    else if (k == "--sculptd") o.binaries.push_back(v);
    else if (k == "--realtime") o.realtime = v == "1";
    else {
      std::fprintf(stderr, "status_bench: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if (o.binaries.empty()) o.binaries.push_back(SCULPTD_BIN);
  const fs::path dir = temp_path("status-bench");
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::mt19937 rng(19);
  // By binary, then phase: every call of every round.
  std::map<std::string, std::map<std::string, Samples>> all;
  std::map<std::string, KeyframeCost> keyframe_cost;
  try {
    for (int round = 0; round < o.rounds; ++round)
      for (const std::string& phase : o.phases)
        for (const std::string& binary : o.binaries) {
          const std::string socket = (dir / "sculptd.sock").string();
          ::unlink(socket.c_str());
          std::vector<std::string> args = {"--scene", o.scene, "--input", "replay:" + o.recording, "--socket", socket,
                                           "--log-level", "notice"};
          if (o.realtime) args.push_back("--realtime");
          Sculptd d(args, binary);
          if (!d.wait_for_log("sculptd ready", 120s)) throw Failed("sculptd did not start:\n" + d.log());
          measure_keyframe(socket, d.pid(), keyframe_cost[binary]);
          StatusProbe probe(socket, d.pid());
          // The first calls connect; the recording gets going.
          std::this_thread::sleep_for(1s);
          probe.take_samples();
          run_phase(phase, socket, o, dir, rng);
          Samples s = probe.take_samples();
          const StatusProbe::Result r = probe.stop();
          if (d.wait_exit(0ms)) throw Failed("sculptd died during " + phase + ":\n" + d.log());
          if (r.failures != 0) throw Failed(phase + ": a status call failed: " + r.first_failure);
          auto& acc = all[binary][phase];
          acc.insert(acc.end(), s.begin(), s.end());
          std::fprintf(stderr, "status_bench: round %d, %s, %s: %zu calls\n", round + 1, phase.c_str(),
                       binary.c_str(), s.size());
          d.signal(SIGTERM);
          if (d.wait_exit(60s) != 0) throw Failed("sculptd did not exit cleanly:\n" + d.log());
          if (std::getenv("STATUS_BENCH_DEBUG")) std::fprintf(stderr, "%s", d.log().c_str());
        }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "status_bench: %s\n", e.what());
    fs::remove_all(dir);
    return 1;
  }
  fs::remove_all(dir);
  std::printf("status_bench: %s + %s, a status call every 10 ms, %d rounds of %.0f s per phase%s\n", o.scene.c_str(),
              o.recording.c_str(), o.rounds, o.seconds, o.realtime ? ", sculptd --realtime" : "");
  std::printf("  ms, p50 p99 max of: the wait; the probe thread's run-queue time during it; the daemon io thread's;\n"
              "  all daemon threads' (summed); the daemon's part = wait - probe's - io thread's queueing; and the\n"
              "  largest wait - probe's - all daemon threads' queueing (a lower bound of the daemon's part)\n");
  for (const std::string& binary : o.binaries) {
    if (o.binaries.size() > 1) std::printf(" sculptd %s\n", binary.c_str());
    const KeyframeCost& sc = keyframe_cost[binary];
    const Spread cpu = spread(sc.cpu_ms);
    std::printf("  one keyframe() answer (%.1f MB): the io thread's CPU per call p50 %.2f ms, max %.2f ms\n",
                sc.bytes / 1e6, cpu.p50, cpu.max);
    std::printf("  %-26s %6s %4s  %-21s  %-21s  %-21s  %-21s  %-21s  %7s\n", "phase", "calls", "fail", "wait",
                "probe queued", "io thread queued", "daemon queued (all)", "daemon's part", "lower");
    for (const std::string& phase : o.phases) print_row(phase, all[binary][phase]);
  }
  return 0;
}
