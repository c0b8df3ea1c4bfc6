// The sim loop while a sculpt is exported (issue 29): sculptd on a big clay
// scene, a recording sculpting it, its store on, and `sculptctl
// export` (a child process writing the file, as a person would) started at
// the beginning of some windows and not others. Per kind of window it prints
// the loop's wake-up jitter p50/p99/max, from the loop's own histogram
// diffed over each window (Stats.jitterHistogram), the overruns in them by
// cause, and the sim thread's page faults and involuntary switches: side by
// side, one daemon run. Numbers only: it fails only if something breaks.
//
// The recording's phases differ (grabs, rests), so which windows export is
// balanced: the recording is played `--loops` + 1 times back to back, cut into
// windows aligned to the loop by the daemon's own tick count. The first
// loop is not measured: on the pristine ball its first grabs are the
// simulation's own long steps (docs/daemon.md, "Why ticks overrun"), which
// the later loops, on the sculpted ball, do not have. Then a window exports
// in loops 1 and 4 when its index is even, in loops 2 and 3 when odd
// (ABBA): every phase is measured as often with an export as without.
// `--no-export` runs the same schedule exporting nothing: the two columns
// then show what the schedule alone does. EXPORT_JITTER_DEBUG=1 prints each
// window's overruns (stderr).
//
//   export_jitter_bench SCENE RECORDING [--window S] [--loops N] [--realtime 0|1] [--subdivisions K] [--no-export]
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
#include <string>
#include <vector>

#include <kj/async-io.h>
#include <nlohmann/json.hpp>

#include "client/connection.hpp"
#include "jitter_histogram.hpp"
#include "sculptd_process.hpp"
#include "support/child_process.hpp"
#include "support/read_file.hpp"

using namespace sculpt;
using namespace std::chrono_literals;

namespace {

namespace fs = std::filesystem;
using Histogram = bench::JitterHistogram;
using bench::quantile_us;

struct Reading {
  Histogram jitter;
  std::uint64_t overruns = 0, ticks = 0;
  std::uint64_t late_wake = 0, long_step = 0, off_cpu = 0;  // overruns by cause
  std::uint64_t minflt = 0, nivcsw = 0;                     // the sim thread's
};

Reading read_now(client::Connection& c, kj::WaitScope& ws) {
  auto r = c.session().statusRequest().send().wait(ws);
  const auto st = r.getStats();
  Reading out;
  out.jitter = bench::jitter_of(st);
  out.overruns = st.getOverruns();
  out.ticks = st.getTicks();
  out.late_wake = st.getOverrunCauses().getLateWake();
  out.long_step = st.getOverrunCauses().getLongStep();
  out.off_cpu = st.getOverrunCauses().getLongStepOffCpu();
  out.minflt = st.getSimThread().getMinflt();
  out.nivcsw = st.getSimThread().getNivcsw();
  return out;
}

struct Acc {
  Histogram jitter;
  std::uint64_t overruns = 0, ticks = 0, windows = 0;
  std::uint64_t late_wake = 0, long_step = 0, off_cpu = 0, minflt = 0, nivcsw = 0;
};

void add(Acc& acc, const Reading& before, const Reading& after) {
  bench::add_diff(acc.jitter, before.jitter, after.jitter);
  acc.overruns += after.overruns - before.overruns;
  acc.ticks += after.ticks - before.ticks;
  acc.late_wake += after.late_wake - before.late_wake;
  acc.long_step += after.long_step - before.long_step;
  acc.off_cpu += after.off_cpu - before.off_cpu;
  acc.minflt += after.minflt - before.minflt;
  acc.nivcsw += after.nivcsw - before.nivcsw;
  ++acc.windows;
}


// The upper bound of the highest non-empty bucket.
double max_us(const Histogram& h) {
  for (auto it = h.rbegin(); it != h.rend(); ++it)
    if (it->second.second > 0) return static_cast<double>(it->second.first) * 1e-3;
  return 0;
}

// `recording` played `loops` times, each copy `period_us` after the last;
// returns the period (the recording's length and a second of rest).
std::uint64_t loop_recording(const std::string& recording, int loops, const fs::path& out) {
  std::ifstream in(recording);
  std::string header, line;
  std::getline(in, header);
  std::vector<nlohmann::json> frames;
  while (std::getline(in, line))
    if (!line.empty()) frames.push_back(nlohmann::json::parse(line));
  const std::uint64_t period = (frames.empty() ? 0 : frames.back()[0].get<std::uint64_t>()) + 1000000;
  std::ofstream o(out);
  o << header << "\n";
  for (int l = 0; l < loops; ++l)
    for (nlohmann::json f : frames) {
      f[0] = f[0].get<std::uint64_t>() + static_cast<std::uint64_t>(l) * period;
      o << f.dump() << "\n";
    }
  return period;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: %s SCENE RECORDING [--window S] [--loops N] [--realtime 0|1] [--subdivisions K] [--no-export]\n",
                 argv[0]);
    return 2;
  }
  double window_s = 2.0;
  int loops = 4, subdivisions = 0;
  bool realtime = false, exporting = true;
  for (int i = 3; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--no-export") {
      exporting = false;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s needs a value\n", k.c_str());
      return 2;
    }
    if (k == "--window") window_s = std::stod(argv[++i]);
    else if (k == "--loops") loops = std::max(1, std::stoi(argv[++i]));
    else if (k == "--realtime") realtime = std::string(argv[++i]) == "1";
    else if (k == "--subdivisions") subdivisions = std::stoi(argv[++i]);
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
    // The same layout, its spheres finer.
    std::string text = support::read_file(scene);
    text = std::regex_replace(text, std::regex(R"(subdivisions\s*=\s*\d+)"), "subdivisions = " + std::to_string(subdivisions));
    scene = (tmp / "scene.toml").string();
    std::ofstream(scene) << text;
  }
  const std::uint64_t period_us = loop_recording(argv[2], loops + 1, tmp / "recording.jsonl");
  const std::uint64_t period_ticks = period_us / 1000, window_ticks = static_cast<std::uint64_t>(window_s * 1000);
  const std::uint64_t windows_per_loop = period_ticks > 1000 ? (period_ticks - 1000) / window_ticks : 0;
  const std::string socket = (tmp / "sculptd.sock").string();
  std::vector<std::string> args = {"--scene", scene, "--input", "replay:" + (tmp / "recording.jsonl").string(),
                                   "--socket", socket, "--state-dir", (tmp / "state").string(), "--log-level", "notice"};
  if (realtime) args.push_back("--realtime");
  int status = 0;
  {
    e2e::Sculptd d(args);
    if (!d.wait_for_log("sculptd ready", 180s)) {
      std::fprintf(stderr, "sculptd did not start:\n%s", d.log().c_str());
      fs::remove_all(tmp);
      return 1;
    }
    auto io = kj::setupAsyncIo();
    client::Connection control(io, socket, "export-jitter-bench");
    const auto wait_for_tick = [&](std::uint64_t tick) {
      for (;;) {
        const std::uint64_t now = control.session().statusRequest().send().wait(io.waitScope).getStats().getTicks();
        if (now >= tick) return now;
        std::this_thread::sleep_for(std::chrono::milliseconds(std::min<std::uint64_t>(20, tick - now)));
      }
    };
    std::map<bool, Acc> acc;  // false: no export, true: an export
    std::vector<double> export_s;
    std::uint64_t export_bytes = 0;
    for (int loop = 1; loop <= loops && status == 0; ++loop) {
      const bool even_exports = loop % 4 == 1 || loop % 4 == 0;  // ABBA
      for (std::uint64_t w = 0; w < windows_per_loop && status == 0; ++w) {
        // Nor is the first second of a loop (the rest between two).
        const std::uint64_t start = static_cast<std::uint64_t>(loop) * period_ticks + 1000 + w * window_ticks;
        wait_for_tick(start);
        const bool exports = ((w % 2 == 0) == even_exports);
        const Reading before = read_now(control, io.waitScope);
        if (exports && exporting) {
          const auto t0 = std::chrono::steady_clock::now();
          const std::string file = (tmp / "out.sculpt").string();
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
        wait_for_tick(start + window_ticks);
        const Reading after = read_now(control, io.waitScope);
        if (std::getenv("EXPORT_JITTER_DEBUG"))
          std::fprintf(stderr, "loop %d window %llu %s: %llu overruns\n", loop, static_cast<unsigned long long>(w),
                       exports ? "export" : "quiet", static_cast<unsigned long long>(after.overruns - before.overruns));
        add(acc[exports], before, after);
      }
    }
    auto st = control.session().statusRequest().send().wait(io.waitScope).getStats();
    std::printf("export_jitter_bench: %s (%llu vertices) + %s x%d after one not measured, %llu windows of %.1f s "
                "per loop%s%s\n",
                argv[1],
                static_cast<unsigned long long>(st.getVerticesTotal()), argv[2], loops,
                static_cast<unsigned long long>(windows_per_loop), window_s, realtime ? ", sculptd --realtime" : "",
                exporting ? "" : ", --no-export: no window exports");
    if (!export_s.empty()) {
      std::sort(export_s.begin(), export_s.end());
      std::printf("  export: %llu bytes, %.2f s median (%.2f-%.2f; sculptctl export, start to file written)\n",
                  static_cast<unsigned long long>(export_bytes), export_s[export_s.size() / 2], export_s.front(),
                  export_s.back());
    }
    std::printf("  windows           ticks   jitter p50 us  p99 us   max us   overruns (late wake, long step, "
                "off CPU)   sim thread minflt, nivcsw\n");
    for (const bool e : {false, true}) {
      const Acc& a = acc[e];
      std::printf("  %-15s %7llu   %13.1f  %6.1f  %7.1f   %8llu (%llu, %llu, %llu)   %llu, %llu\n",
                  e ? (exporting ? "with export" : "(export slots)") : "no export",
                  static_cast<unsigned long long>(a.ticks), quantile_us(a.jitter, 0.5), quantile_us(a.jitter, 0.99),
                  max_us(a.jitter), static_cast<unsigned long long>(a.overruns),
                  static_cast<unsigned long long>(a.late_wake), static_cast<unsigned long long>(a.long_step),
                  static_cast<unsigned long long>(a.off_cpu), static_cast<unsigned long long>(a.minflt),
                  static_cast<unsigned long long>(a.nivcsw));
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
