// The sim loop while a sculpt is exported (issue 29): sculptd on a big clay
// scene, a recorded session sculpting it, its store on; windows of equal
// length alternate between no export and one `sculptctl export` (a child
// process writing the file, as a person would) started at the window's
// start. Per kind of window it prints the loop's wake-up jitter p50/p99/max,
// from the loop's own histogram diffed over each window
// (Stats.jitterHistogram), and the overruns in them; side by side, one
// daemon run. Numbers only: it fails only if something breaks.
//
//   export_jitter_bench SCENE SESSION [--window S] [--rounds N] [--realtime 0|1] [--subdivisions K]
// SCENE is a scene file; with --subdivisions K its icospheres are rebuilt
// with K subdivisions in a temporary copy (its meshes must be builtin: 7 makes
// the acceptance layout ~173k vertices, the size the issue measured).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <kj/async-io.h>

#include "client/connection.hpp"
#include "sculptd_process.hpp"
#include "support/command.hpp"

using namespace sculpt;
using namespace std::chrono_literals;

namespace {

namespace fs = std::filesystem;
using Histogram = std::map<std::uint64_t, std::pair<std::uint64_t, std::uint64_t>>;  // lower → (upper, count)

struct Reading {
  Histogram jitter;
  std::uint64_t overruns = 0, ticks = 0;
  std::uint64_t late_wake = 0, long_step = 0, off_cpu = 0;  // overruns by cause
  std::uint64_t minflt = 0, nivcsw = 0;                     // the sim thread's
};

Reading read_now(client::Connection& c, kj::WaitScope& ws) {
  auto r = c.session().statusRequest().send().wait(ws);
  Reading out;
  for (const auto b : r.getStats().getJitterHistogram()) out.jitter[b.getLowerNs()] = {b.getUpperNs(), b.getCount()};
  out.overruns = r.getStats().getOverruns();
  out.ticks = r.getStats().getTicks();
  out.late_wake = r.getStats().getOverrunCauses().getLateWake();
  out.long_step = r.getStats().getOverrunCauses().getLongStep();
  out.off_cpu = r.getStats().getOverrunCauses().getLongStepOffCpu();
  out.minflt = r.getStats().getSimThread().getMinflt();
  out.nivcsw = r.getStats().getSimThread().getNivcsw();
  return out;
}

struct Acc {
  Histogram jitter;
  std::uint64_t overruns = 0, ticks = 0, windows = 0;
  std::uint64_t late_wake = 0, long_step = 0, off_cpu = 0, minflt = 0, nivcsw = 0;
  double seconds = 0;
};

void add(Acc& acc, const Reading& before, const Reading& after, double seconds) {
  for (const auto& [lo, uc] : after.jitter) {
    std::uint64_t prev = 0;
    if (auto it = before.jitter.find(lo); it != before.jitter.end()) prev = it->second.second;
    auto& slot = acc.jitter[lo];
    slot.first = uc.first;
    slot.second += uc.second - prev;
  }
  acc.overruns += after.overruns - before.overruns;
  acc.ticks += after.ticks - before.ticks;
  acc.late_wake += after.late_wake - before.late_wake;
  acc.long_step += after.long_step - before.long_step;
  acc.off_cpu += after.off_cpu - before.off_cpu;
  acc.minflt += after.minflt - before.minflt;
  acc.nivcsw += after.nivcsw - before.nivcsw;
  acc.seconds += seconds;
  ++acc.windows;
}

// As LatencyHistogram::quantile_ns: the middle of the bucket holding the quantile.
double quantile_us(const Histogram& h, double q) {
  std::uint64_t total = 0;
  for (const auto& [lo, uc] : h) total += uc.second;
  if (total == 0) return 0;
  std::uint64_t seen = 0;
  for (const auto& [lo, uc] : h) {
    seen += uc.second;
    if (static_cast<double>(seen) >= q * static_cast<double>(total) && seen > 0)
      return 0.5 * static_cast<double>(lo + uc.first) * 1e-3;
  }
  return 0;
}

// The upper bound of the highest non-empty bucket.
double max_us(const Histogram& h) {
  for (auto it = h.rbegin(); it != h.rend(); ++it)
    if (it->second.second > 0) return static_cast<double>(it->second.first) * 1e-3;
  return 0;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s SCENE SESSION [--window S] [--rounds N] [--realtime 0|1] [--subdivisions K]\n",
                 argv[0]);
    return 2;
  }
  double window_s = 2.0;
  int rounds = 5, subdivisions = 0;
  bool realtime = false;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--window") window_s = std::stod(argv[i + 1]);
    else if (k == "--rounds") rounds = std::stoi(argv[i + 1]);
    else if (k == "--realtime") realtime = std::string(argv[i + 1]) == "1";
    else if (k == "--subdivisions") subdivisions = std::stoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  const fs::path tmp = fs::path("/tmp") / ("sculpt-export-jitter-" + std::to_string(::getpid()));
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  std::string scene = argv[1];
  if (subdivisions > 0) {
    // The same layout, its spheres finer; mesh files it names stay where they are.
    std::string text = read_file(scene);
    text = std::regex_replace(text, std::regex(R"(subdivisions\s*=\s*\d+)"), "subdivisions = " + std::to_string(subdivisions));
    const fs::path copy = tmp / "scene.toml";
    std::ofstream(copy) << text;
    scene = copy.string();
  }
  const std::string socket = (tmp / "sculptd.sock").string();
  std::vector<std::string> args = {"--scene", scene, "--input", std::string("replay:") + argv[2], "--socket", socket,
                                   "--state-dir", (tmp / "state").string(), "--log-level", "notice"};
  if (realtime) args.push_back("--realtime");
  int status = 0;
  {
    e2e::Sculptd d(args);
    const bool ready = d.wait_for_log("sculptd ready", 180s).has_value();
    if (!ready) {
      std::fprintf(stderr, "sculptd did not start:\n%s", d.log().c_str());
      fs::remove_all(tmp);
      return 1;
    }
    auto io = kj::setupAsyncIo();
    client::Connection control(io, socket, "export-jitter-bench");
    std::map<bool, Acc> acc;  // false: no export, true: an export
    std::vector<double> export_s;
    std::uint64_t export_bytes = 0;
    const auto window = std::chrono::duration<double>(window_s);
    std::this_thread::sleep_for(1s);  // the first snapshot and the replica's start are not measured
    for (int round = 0; round < rounds && status == 0; ++round) {
      // Alternating which comes first: neither kind always gets the session's same phase.
      for (int k = 0; k < 2; ++k) {
        const bool exporting = (k == 0) == (round % 2 == 0);
        const Reading before = read_now(control, io.waitScope);
        const auto t0 = std::chrono::steady_clock::now();
        if (exporting) {
          const std::string file = (tmp / ("round-" + std::to_string(round) + ".sculpt")).string();
          const support::CommandRun ex = support::run_command(SCULPTCTL_BIN, {"export", file, "--socket", socket});
          export_s.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
          if (ex.status != 0) {
            std::fprintf(stderr, "export failed (%d): %s\n", ex.status, ex.err.c_str());
            status = 1;
            break;
          }
          export_bytes = fs::file_size(file);
          fs::remove(file);
        }
        std::this_thread::sleep_until(t0 + window);
        const Reading after = read_now(control, io.waitScope);
        add(acc[exporting], before, after,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
    }
    auto st = control.session().statusRequest().send().wait(io.waitScope).getStats();
    std::printf("export_jitter_bench: %s (%llu vertices) + %s, %d rounds of one %.1f s window each way%s\n", argv[1],
                static_cast<unsigned long long>(st.getVerticesTotal()), argv[2], rounds, window_s,
                realtime ? ", sculptd --realtime" : "");
    if (!export_s.empty()) {
      std::sort(export_s.begin(), export_s.end());
      std::printf("  export: %llu bytes, %.2f-%.2f s (sculptctl export, start to file written)\n",
                  static_cast<unsigned long long>(export_bytes), export_s.front(), export_s.back());
    }
    std::printf("  windows          ticks   jitter p50 us  p99 us   max us   overruns (late wake, long step, "
                "off CPU)   sim thread minflt, nivcsw\n");
    for (const bool e : {false, true}) {
      const Acc& a = acc[e];
      std::printf("  %-14s %7llu   %13.1f  %6.1f  %7.1f   %8llu (%llu, %llu, %llu)   %llu, %llu\n",
                  e ? "with export" : "no export", static_cast<unsigned long long>(a.ticks),
                  quantile_us(a.jitter, 0.5), quantile_us(a.jitter, 0.99), max_us(a.jitter),
                  static_cast<unsigned long long>(a.overruns), static_cast<unsigned long long>(a.late_wake),
                  static_cast<unsigned long long>(a.long_step), static_cast<unsigned long long>(a.off_cpu),
                  static_cast<unsigned long long>(a.minflt), static_cast<unsigned long long>(a.nivcsw));
    }
    d.signal(SIGTERM);
    if (d.wait_exit(60s) != 0) {
      std::fprintf(stderr, "sculptd did not exit cleanly:\n%s", d.log().c_str());
      status = 1;
    }
  }
  fs::remove_all(tmp);
  return status;
}
