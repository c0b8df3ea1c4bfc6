// The sim thread's instruments, kept beside its loop: at each wake the
// lateness against the deadline (jitter) and the heartbeat; after each tick
// the stage times, the world's counters (awake vertices, blow-ups,
// contacts), the thread's kernel counters (page faults, context switches)
// and, for a tick that overran, its record. All of it lands in LoopStats,
// which any thread reads. Sim thread only: no allocation, no lock, four
// cheap non-blocking system calls a period (two at the wake, which count in
// the input stage's time).
#pragma once

#include <atomic>
#include <cstdint>

#include "simloop/histogram.hpp"
#include "simloop/overrun.hpp"
#include "sim/world.hpp"

namespace sculpt::simloop {

enum class Stage : int { input = 0, collision, integration, publish, count };
const char* stage_name(Stage s);

// Written by the sim thread only; read from anywhere.
struct LoopStats {
  std::atomic<std::uint64_t> ticks{0};             // simulated ticks (a paused loop adds none)
  std::atomic<std::uint64_t> heartbeats{0};        // loop periods run, paused or not (the watchdog's)
  std::atomic<bool> paused{false};
  std::atomic<std::uint64_t> skipped_periods{0};  // whole periods dropped to get back on schedule
  std::atomic<std::uint64_t> vertices_total{0};
  std::atomic<std::uint64_t> vertices_awake{0};
  std::atomic<std::uint64_t> blowups{0};
  std::atomic<std::uint32_t> last_blowup_body{0};  // with the cause, of the latest blow-up
  std::atomic<std::uint8_t> last_blowup_cause{0};  // sim::BlowupCause
  std::atomic<std::uint64_t> contacts{0};         // this tick, all tools
  std::atomic<std::int64_t> last_tick_ns{0};      // CLOCK_MONOTONIC of the last completed tick
  LatencyHistogram jitter;                        // wake-up lateness against the deadline, ns
  LatencyHistogram stage[static_cast<int>(Stage::count)];  // per-stage duration, ns
  OverrunLog overrun_log;                         // why each overrun happened (simloop/overrun.hpp)
  // The sim thread's own kernel counters since its loop began: page faults,
  // preemptions, and waits in the middle of a tick's work: all of them, and
  // those in ticks without a page fault (0 unless something it calls blocks:
  // a stalled viewer or device must never make one).
  std::atomic<std::uint64_t> thread_minflt{0};
  std::atomic<std::uint64_t> thread_majflt{0};
  std::atomic<std::uint64_t> thread_nivcsw{0};
  std::atomic<std::uint64_t> thread_work_nvcsw{0};
  std::atomic<std::uint64_t> thread_work_nvcsw_no_fault{0};
};

class SimProbe {
 public:
  // Takes the thread's counters as they stand: construct on the sim thread,
  // as its loop begins.
  explicit SimProbe(LoopStats& stats);

  // The thread woke at `now` for the tick due at `deadline`.
  void woke(std::int64_t deadline, std::int64_t now);
  // A paused period: the thread's counters only.
  void idled();
  // The tick's work is done (timing.publish_end was just read); `world` is
  // its step's stats. Counts the tick, with its record when it overran.
  void ticked(std::uint64_t tick, const TickTiming& timing, const sim::TickStats& world, std::int64_t period);
  // Whole periods dropped to get back on schedule.
  void skipped(std::int64_t periods);

 private:
  TickCounters take_counters();

  LoopStats& stats_;
  ThreadTotals at_start_;
  ThreadTotals prev_;       // the last reading take_counters() took
  ThreadTotals at_wake_;
  std::uint64_t cpu_ns_at_wake_ = 0;
  int cpu_ = -1;            // the CPU the tick woke on
};

}  // namespace sculpt::simloop
