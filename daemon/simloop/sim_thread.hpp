// The fixed-rate simulation thread. Every period, at an absolute deadline on
// CLOCK_MONOTONIC: input stage (inputs due → tool poses), World::step, publish
// stage (feedback, change log), then the stats (simloop/sim_probe.hpp). Nothing in the loop allocates,
// locks or makes a blocking call other than clock_nanosleep: the stages are
// the caller's, and must keep to the same rule.
#pragma once

#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "concurrency/spsc_ring.hpp"
#include "simloop/sim_probe.hpp"
#include "sim/tool.hpp"
#include "sim/world.hpp"

namespace sculpt::simloop {

// What the sim thread calls around World::step, on the sim thread.
class TickStages {
 public:
  virtual ~TickStages() = default;
  // Apply the inputs due at `tick` and write the tools' poses into `tools`.
  virtual void input(std::uint64_t tick, std::span<sim::Tool> tools) = 0;
  // Hand the tick's results on (feedback to the haptics, changes to viewers).
  virtual void publish(std::uint64_t tick, const sim::World<float>& world) = 0;
  // The loop paused (or resumed) before running `tick`.
  virtual void paused_changed(std::uint64_t /*tick*/, bool /*paused*/) {}
};

struct SimThreadOptions {
  double rate_hz = 1000.0;
  std::uint64_t max_ticks = 0;   // stop by itself after this many ticks (0: run until stop())
  bool realtime = false;         // SCHED_FIFO + mlockall, when permitted
  int realtime_priority = 50;    // SCHED_FIFO priority, 1..99
  // Sleep until this long before each deadline, then spin to it: the thread
  // then holds its CPU when the deadline comes, so a wake-up delayed by the
  // host or by another task's system call costs this much less (at this much
  // CPU per period). 0..max_wake_early_ns(rate_hz).
  std::int64_t wake_early_ns = 0;
  // Spin only once SCHED_FIFO is granted: at normal priority the thread can
  // lose its CPU mid-spin anyway, so the spin would cost CPU for little.
  bool wake_early_needs_fifo = false;
  // The tick number of the thread's first tick (a scene swapped in mid-run
  // continues the old timeline: queued inputs and viewers' sequences go on;
  // a recovered world continues its own). The stats' tick count starts
  // there too.
  std::uint64_t first_tick = 0;
};

// The longest wake_early_ns a rate allows: half its period.
std::int64_t max_wake_early_ns(double rate_hz);

// Outcome of asking for real-time scheduling: what worked and, if not, why.
struct RealtimeResult {
  bool fifo = false;
  bool locked = false;
  std::vector<std::string> warnings;
};

std::int64_t monotonic_ns();

class SimThread {
 public:
  // The world and stages must outlive the thread. tool_count tools are
  // passed to World::step each tick. Throws std::invalid_argument on a bad rate.
  SimThread(sim::World<float>& world, TickStages& stages, std::size_t tool_count, const SimThreadOptions& options);
  ~SimThread();
  SimThread(const SimThread&) = delete;
  SimThread& operator=(const SimThread&) = delete;

  // Starts the thread (and applies --realtime). Throws std::system_error if
  // the thread cannot be created.
  RealtimeResult start();
  // Asks the thread to stop after its current tick and joins it. Idempotent.
  void stop();
  // Asks the same without waiting: finished() tells when it has.
  void request_stop() { stop_.store(true, std::memory_order_release); }
  // Control from one other thread (the io thread), applied at the next tick
  // boundary through a lock-free ring: a paused loop keeps its period (and
  // heartbeats) but runs no stage and no step. False when the ring is full.
  bool request_pause(bool paused);
  bool paused() const { return stats_.paused.load(std::memory_order_acquire); }

  // The thread has left its loop (stop(), max_ticks reached).
  bool finished() const { return finished_.load(std::memory_order_acquire); }

  const LoopStats& stats() const { return stats_; }
  const SimThreadOptions& options() const { return options_; }
  std::uint64_t ticks() const { return stats_.ticks.load(std::memory_order_acquire); }

 private:
  void run();
  // Sleeps (and spins, when asked) until `deadline`; the time it woke.
  std::int64_t wait_for(std::int64_t deadline);
  // Pause and resume requests, applied at the tick boundary before `tick`.
  void take_commands(std::uint64_t tick);
  // One tick's work: inputs due → tool poses, World::step, publish.
  TickTiming run_tick(std::uint64_t tick, std::int64_t deadline, std::int64_t woke);

  sim::World<float>& world_;
  TickStages& stages_;
  std::vector<sim::Tool> tools_;
  SimThreadOptions options_;
  std::int64_t period_ns_;
  std::atomic<bool> spin_{false};  // wake early and spin (see SimThreadOptions::wake_early_needs_fifo)
  LoopStats stats_;
  concurrency::SpscRing<std::uint8_t> commands_{64};  // 1: pause, 0: resume
  std::atomic<bool> stop_{false};
  std::atomic<bool> finished_{false};
  std::thread thread_;
};

}  // namespace sculpt::simloop
