// Why a tick overran. A tick overruns when its work ends after the next
// deadline, i.e. wake-up lateness + work > period; its cause is whichever of
// the two was larger: a late wake or a long step. Each is split once more by
// what the sim thread's own kernel counters say about the tick:
//   late wake: it waited runnable for the CPU (run_delay: another task held
//     the CPU: on this non-preemptible kernel, one inside a system call) or
//     the timer itself fired late (no run_delay: the vCPU was not running,
//     i.e. the host took it, or interrupts were off);
//   long step: the thread was off the CPU during its work (wall − thread CPU
//     time: preempted or stolen by the host, whose steal the guest's
//     thread clock leaves out) or really computed that long.
// The sim thread keeps the last few overruns with their tick, lateness, stage
// times and counters, writing without allocating or locking (a seqlock per
// slot); readers copy them from any thread.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "concurrency/seqlock.hpp"

namespace sculpt::loop {

enum class OverrunCause : int { late_wake = 0, long_step, count };
enum class OverrunDetail : int { wake_waited_for_cpu = 0, wake_timer_late, step_off_cpu, step_on_cpu, count };
const char* overrun_cause_name(OverrunCause c);
const char* overrun_detail_name(OverrunDetail d);

// The stages' order in OverrunRecord::stage_ns (the same as loop::Stage).
inline constexpr int kOverrunStages = 4;

// One tick's timeline on CLOCK_MONOTONIC, ns.
struct TickTiming {
  std::int64_t deadline = 0;     // when the tick was due
  std::int64_t wake = 0;         // t0: the thread ran again
  std::int64_t input_end = 0;    // t1
  std::int64_t step_end = 0;     // t2 (World::step; collision_ns of it is collision)
  std::int64_t publish_end = 0;  // t3: the tick's work is done
  std::uint64_t collision_ns = 0;
};

// The sim thread's kernel counters over one tick (from the end of the
// previous tick's work to the end of this one's), and its CPU time over the
// work alone (wake → t3).
struct TickCounters {
  std::uint64_t work_cpu_ns = 0;   // CLOCK_THREAD_CPUTIME_ID over the work (excludes host steal)
  std::uint64_t run_delay_ns = 0;  // runnable but waiting for a CPU (/proc/thread-self/schedstat)
  std::uint64_t minflt = 0;        // page faults served from memory
  std::uint64_t majflt = 0;        // page faults that waited for I/O
  std::uint64_t nivcsw = 0;        // involuntary context switches (preempted)
};

// Pure functions (the unit tests call them with made-up times).
std::int64_t lateness_ns(const TickTiming& t);  // wake − deadline, never negative
std::int64_t work_ns(const TickTiming& t);      // publish_end − wake, never negative
// The work ended after the next deadline (deadline + period).
bool is_overrun(const TickTiming& t, std::int64_t period_ns);
// Whichever was larger; a tie counts as a late wake (the work did not grow).
OverrunCause classify(std::int64_t lateness_ns, std::int64_t work_ns);
// The cause's split (see the top of this file): a late wake waited for the
// CPU when run_delay covers at least half the lateness; a long step was off
// the CPU when wall − CPU time is at least half the work.
OverrunDetail classify_detail(OverrunCause cause, std::int64_t lateness_ns, std::int64_t work_ns,
                              const TickCounters& c);
// input, collision, integration, publish, ns (collision clamped into the step).
std::array<std::uint64_t, kOverrunStages> stage_times_ns(const TickTiming& t);

struct OverrunRecord {
  std::uint64_t index = 0;  // how many overruns came before this one (readers check it)
  std::uint64_t tick = 0;
  OverrunCause cause = OverrunCause::late_wake;
  OverrunDetail detail = OverrunDetail::wake_timer_late;
  int cpu = -1;             // the CPU the tick woke on
  std::int64_t late_ns = 0;
  std::array<std::uint64_t, kOverrunStages> stage_ns{};
  TickCounters counters{};
};

OverrunRecord make_overrun_record(std::uint64_t tick, int cpu, const TickTiming& t, const TickCounters& c);

// Reads the calling thread's counters; construct and use it on the sim
// thread (it opens /proc/thread-self/schedstat, which names the opener).
// Every call is one non-blocking system call (getrusage, clock_gettime or a
// pread of procfs): no allocation, no lock.
class ThreadProbe {
 public:
  ThreadProbe();
  ~ThreadProbe();
  ThreadProbe(const ThreadProbe&) = delete;
  ThreadProbe& operator=(const ThreadProbe&) = delete;

  static std::uint64_t cpu_ns();  // CLOCK_THREAD_CPUTIME_ID
  // Cumulative since the thread began: run_delay_ns, minflt, majflt, nivcsw
  // (work_cpu_ns is left 0). run_delay stays 0 without procfs.
  TickCounters totals() const;
  bool has_run_delay() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

// Differences of cumulative counters (run_delay, faults, switches).
TickCounters operator-(const TickCounters& a, const TickCounters& b);

// Single writer (the sim thread), any readers.
class OverrunLog {
 public:
  static constexpr std::size_t kKeep = 8;

  // Writer: counts r's cause and detail and keeps r (its index is set here).
  void record(OverrunRecord r);

  // Readers.
  std::uint64_t count(OverrunCause c) const { return causes_[static_cast<int>(c)].load(std::memory_order_relaxed); }
  std::uint64_t count(OverrunDetail d) const { return details_[static_cast<int>(d)].load(std::memory_order_relaxed); }
  std::uint64_t total() const { return written_.load(std::memory_order_acquire); }
  // The last min(total, kKeep) records, oldest first (allocates: not for the sim thread).
  std::vector<OverrunRecord> recent() const;

 private:
  std::array<std::atomic<std::uint64_t>, static_cast<int>(OverrunCause::count)> causes_{};
  std::array<std::atomic<std::uint64_t>, static_cast<int>(OverrunDetail::count)> details_{};
  std::array<concurrency::Seqlock<OverrunRecord>, kKeep> slots_{};
  std::atomic<std::uint64_t> written_{0};
};

}  // namespace sculpt::loop
