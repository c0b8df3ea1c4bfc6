// The streaming benchmark (issue 6): sculptd on the 50k-vertex scene, the
// benchmark recording sculpting it, viewers at 60 fps with tolerance 0.1 mm.
// One daemon run alternates windows of 0, 1, 8 and 16 viewers while the
// recording plays; per viewer count it prints bytes/s per viewer and the
// tick → receipt latency (publishedNs is CLOCK_MONOTONIC on the same host),
// p50/p99 over every frame with changes; and the sim loop's jitter p99 in
// the 16-viewer windows divided by the jitter p99 in the 0-viewer windows,
// both from the loop's own histogram diffed over each window
// (Stats.jitterHistogram). Numbers only: it fails only if something breaks.
//
//   stream_bench SCENE RECORDING [--window S] [--rounds N] [--fps F] [--tolerance M] [--realtime 0|1]
// --realtime 1 runs sculptd --realtime (SCHED_FIFO when permitted), as a
// deployment would: the viewers here share the machine's cores with it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <kj/async-io.h>

#include "client/connection.hpp"
#include "jitter_histogram.hpp"
#include "sculptd_process.hpp"
#include "stream_viewer.hpp"

using namespace sculpt;
using namespace std::chrono_literals;

namespace {

using Histogram = bench::JitterHistogram;
using bench::add_diff;
using bench::quantile_us;

Histogram jitter_now(client::Connection& c, kj::WaitScope& ws) {
  auto r = c.session().statusRequest().send().wait(ws);
  return bench::jitter_of(r.getStats());
}



double percentile(std::vector<std::int64_t>& v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::min<double>(static_cast<double>(v.size() - 1), q * static_cast<double>(v.size())));
  return static_cast<double>(v[i]);
}

}  // namespace

int main(int argc, char** argv) {
  // sculptd is the one this build made (SCULPTD_BIN).
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s SCENE RECORDING [--window S] [--rounds N] [--fps F] [--tolerance M]\n", argv[0]);
    return 2;
  }
  double window_s = 1.5, fps = 60, tolerance = 1e-4, settle_s = 0.3;
  int rounds = 3;
  bool realtime = false;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--window") window_s = std::stod(argv[i + 1]);
    else if (k == "--rounds") rounds = std::stoi(argv[i + 1]);
    else if (k == "--fps") fps = std::stod(argv[i + 1]);
    else if (k == "--tolerance") tolerance = std::stod(argv[i + 1]);
    else if (k == "--realtime") realtime = std::string(argv[i + 1]) == "1";
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  const std::string socket = "/tmp/sculpt-stream-bench-" + std::to_string(::getpid()) + ".sock";
  std::vector<std::string> args = {"--scene", argv[1], "--input", std::string("replay:") + argv[2], "--socket", socket,
                                   "--log-level", std::getenv("STREAM_BENCH_DEBUG") ? "debug" : "notice"};
  if (realtime) args.push_back("--realtime");
  e2e::Sculptd d(args);
  if (!d.wait_for_log("sculptd ready", 120s)) {
    std::fprintf(stderr, "sculptd did not start:\n%s", d.log().c_str());
    return 1;
  }
  auto io = kj::setupAsyncIo();
  client::Connection control(io, socket, "stream-bench");

  struct Acc {
    double seconds = 0;
    std::uint64_t bytes = 0, viewer_windows = 0;
    std::vector<std::int64_t> latency;
    Histogram jitter;
  };
  std::map<int, Acc> acc;
  const int counts[] = {0, 1, 8, 16};
  const auto window = std::chrono::duration<double>(window_s);
  const auto settle = std::chrono::duration<double>(settle_s);
  for (int round = 0; round < rounds; ++round) {
    for (int n : counts) {
      std::vector<std::unique_ptr<e2e::StreamViewer>> viewers;
      for (int i = 0; i < n; ++i)
        viewers.push_back(std::make_unique<e2e::StreamViewer>(socket, static_cast<float>(tolerance), static_cast<float>(fps)));
      for (auto& v : viewers)
        if (v->seen().error) {
          std::fprintf(stderr, "viewer failed: %s\n", v->seen().error_text.c_str());
          return 1;
        }
      // Keyframes and connection set-up are not what is measured.
      std::this_thread::sleep_for(settle);
      std::vector<std::uint64_t> bytes0;
      for (auto& v : viewers) {
        bytes0.push_back(v->seen().frame_bytes);
        v->take_latencies();
      }
      const Histogram h0 = jitter_now(control, io.waitScope);
      const auto t0 = std::chrono::steady_clock::now();
      std::this_thread::sleep_for(window);
      const Histogram h1 = jitter_now(control, io.waitScope);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      Acc& a = acc[n];
      a.seconds += secs;
      add_diff(a.jitter, h0, h1);
      if (std::getenv("STREAM_BENCH_DEBUG"))
        for (auto& v : viewers) {
          const auto s = v->seen();
          std::fprintf(stderr, "n=%d keyframes %llu frames %llu keepalives %llu seq %llu err %s\n", n,
                       (unsigned long long)s.keyframes, (unsigned long long)s.frames, (unsigned long long)s.keepalives,
                       (unsigned long long)s.sequence, s.error_text.c_str());
        }
      for (std::size_t i = 0; i < viewers.size(); ++i) {
        a.bytes += viewers[i]->seen().frame_bytes - bytes0[i];
        ++a.viewer_windows;
        auto l = viewers[i]->take_latencies();
        a.latency.insert(a.latency.end(), l.begin(), l.end());
      }
    }
  }
  auto status = control.session().statusRequest().send().wait(io.waitScope);
  const auto st = status.getStats();
  std::printf("stream_bench: %s + %s, %g fps, tolerance %g m, %d rounds of %.1f s windows (after %.1f s settling)%s\n",
              argv[1], argv[2], fps, tolerance, rounds, window_s, settle_s, realtime ? ", sculptd --realtime" : "");
  std::printf("  sim: %llu vertices, %llu ticks, %llu overruns so far\n",
              static_cast<unsigned long long>(st.getVerticesTotal()), static_cast<unsigned long long>(st.getTicks()),
              static_cast<unsigned long long>(st.getOverruns()));
  std::printf("  viewers  bytes/s/viewer  latency p50 us  p99 us  frames   jitter p50 us  p99 us\n");
  for (int n : counts) {
    Acc& a = acc[n];
    const double per_viewer = a.viewer_windows ? static_cast<double>(a.bytes) / (a.seconds / rounds * static_cast<double>(a.viewer_windows)) : 0;
    const std::size_t frames = a.latency.size();
    const double p50 = percentile(a.latency, 0.5) * 1e-3, p99 = percentile(a.latency, 0.99) * 1e-3;
    std::printf("  %7d  %14.0f  %14.1f  %6.1f  %6zu   %13.1f  %6.1f\n", n, per_viewer, p50, p99, frames,
                quantile_us(a.jitter, 0.5), quantile_us(a.jitter, 0.99));
  }
  const double j0 = quantile_us(acc[0].jitter, 0.99), j16 = quantile_us(acc[16].jitter, 0.99);
  std::printf("  jitter p99 with 16 viewers / with none: %.2f (goal <= 1.1)\n", j0 > 0 ? j16 / j0 : NAN);
  d.signal(SIGTERM);
  d.wait_exit(30s);
  if (std::getenv("STREAM_BENCH_DEBUG")) std::fprintf(stderr, "%s", d.log().c_str());
  return 0;
}
