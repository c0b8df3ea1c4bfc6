// The sim thread's stats at one moment, as the daemon reports them: the
// numbers behind `sculptctl status` and `sculptd --stats-json`
// (simloop/stats_json.hpp turns them into JSON).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "simloop/sim_thread.hpp"

namespace sculpt::simloop {

struct Percentiles {
  double p50 = 0, p99 = 0, max = 0;  // µs
};

struct StatsReading {
  double rate_hz = 0;
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;
  Percentiles jitter_us;
  std::array<Percentiles, static_cast<int>(Stage::count)> stage_us{};
  std::uint64_t vertices_total = 0;
  std::uint64_t vertices_awake = 0;
  std::uint64_t viewers = 0;      // the streaming server's (0 until it exists)
  std::uint64_t devices = 0;      // input devices attached now
  std::uint64_t ff_uploads = 0;   // the haptics thread's
  std::uint64_t bytes_sent = 0;   // the streaming server's
  std::uint64_t blowups = 0;
  std::array<std::uint64_t, static_cast<int>(OverrunCause::count)> overrun_causes{};
  std::uint64_t long_steps_off_cpu = 0;        // of overrun_causes[long_step]
  std::vector<OverrunRecord> recent_overruns;  // oldest first
  TickCounters sim_thread{};                   // faults, preemptions, waits since the loop began
};

Percentiles percentiles_us(const LatencyHistogram& h);

// The sim thread's part (everything but viewers, devices, ff_uploads, bytes_sent).
StatsReading reading(const LoopStats& stats, double rate_hz);

}  // namespace sculpt::simloop
