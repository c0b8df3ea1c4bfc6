// Why a tick overran. A tick overruns when its work ends after the next
// deadline, i.e. wake-up lateness + work > period; its cause is whichever of
// the two was larger: a late wake or a long step. A long step is split once
// more by the thread's CPU time over the work: off the CPU for at least half
// of it (preempted, or the vCPU stolen by the host: the guest's thread clock
// leaves steal out) or really computing. A late wake cannot be split from
// user space: the kernel's run_delay misses the wait behind another task's
// non-preemptible system call, which a scheduler trace shows is the usual
// one here (docs/daemon.md, "Why ticks overrun").
// The sim thread keeps the last few overruns with their tick, lateness, stage
// times and counters, writing without allocating or locking (a seqlock per
// cell); readers copy them from any thread.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "concurrency/seqlock.hpp"

namespace sculpt::simloop {

enum class OverrunCause : int { late_wake = 0, long_step, count };
const char* overrun_cause_name(OverrunCause c);

// The stages' order in OverrunRecord::stage_ns (the same as simloop::Stage).
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
// previous tick's work to the end of this one's), and its CPU time and
// voluntary switches over the work alone (wake → t3).
struct TickCounters {
  std::uint64_t work_cpu_ns = 0;  // CLOCK_THREAD_CPUTIME_ID over the work (excludes host steal)
  // Voluntary context switches over the work: the thread waited on something
  // (a lock, a full socket, a page read from disk, a page the kernel was
  // moving). Host steal and preemption leave it 0.
  std::uint64_t work_nvcsw = 0;
  std::uint64_t minflt = 0;       // page faults served from memory
  std::uint64_t majflt = 0;       // page faults that waited for I/O
  std::uint64_t nivcsw = 0;       // involuntary context switches (preempted)
  // work_nvcsw of a tick whose work took no page fault: a wait on something
  // other than memory (a lock, a socket, a blocking call). The sim thread makes
  // no blocking call, so this stays 0. A wait inside a page fault is the
  // kernel's memory management (compaction migrating a page, a busy mmap lock)
  // and is counted in work_nvcsw only.
  std::uint64_t work_nvcsw_no_fault = 0;
};

// Pure functions (the unit tests call them with made-up times).
std::int64_t lateness_ns(const TickTiming& t);  // wake − deadline, never negative
std::int64_t work_ns(const TickTiming& t);      // publish_end − wake, never negative
// The work ended after the next deadline (deadline + period).
bool is_overrun(const TickTiming& t, std::int64_t period_ns);
// Whichever was larger; a tie counts as a late wake (the work did not grow).
OverrunCause classify(std::int64_t lateness_ns, std::int64_t work_ns);
// A long step was off the CPU when wall − CPU time is at least half the work.
bool off_cpu(std::int64_t work_ns, std::uint64_t work_cpu_ns);
// input, collision, integration, publish, ns (collision clamped into the step).
std::array<std::uint64_t, kOverrunStages> stage_times_ns(const TickTiming& t);

struct OverrunRecord {
  std::uint64_t index = 0;  // how many overruns came before this one (readers check it)
  std::uint64_t tick = 0;
  OverrunCause cause = OverrunCause::late_wake;
  bool off_cpu = false;     // a long step mostly off the CPU (see off_cpu())
  int cpu = -1;             // the CPU the tick woke on
  std::int64_t late_ns = 0;
  std::array<std::uint64_t, kOverrunStages> stage_ns{};
  TickCounters counters{};
};

OverrunRecord make_overrun_record(std::uint64_t tick, int cpu, const TickTiming& t, const TickCounters& c);

// The calling thread's counters: each call is one non-blocking system call
// (clock_gettime, getrusage), no allocation, no lock.
std::uint64_t thread_cpu_ns();  // CLOCK_THREAD_CPUTIME_ID
// The calling thread's getrusage counters, cumulative since it began: the
// loop subtracts two readings to get a tick's (TickCounters).
struct ThreadTotals {
  std::uint64_t minflt = 0, majflt = 0;  // page faults
  std::uint64_t nvcsw = 0, nivcsw = 0;   // voluntary (waits, sleeps) and involuntary context switches
};
ThreadTotals thread_totals();

// Differences of cumulative counters, never negative.
ThreadTotals operator-(const ThreadTotals& a, const ThreadTotals& b);

// Single writer (the sim thread), any readers.
class OverrunLog {
 public:
  static constexpr std::size_t kKeep = 8;

  // Writer: counts r's cause and keeps r (its index is set here).
  void record(OverrunRecord r);

  // Readers.
  std::uint64_t count(OverrunCause c) const { return causes_[static_cast<int>(c)].load(std::memory_order_relaxed); }
  std::uint64_t long_steps_off_cpu() const { return off_cpu_.load(std::memory_order_relaxed); }
  std::uint64_t total() const { return written_.load(std::memory_order_acquire); }
  // The last min(total, kKeep) records, oldest first (allocates: not for the sim thread).
  std::vector<OverrunRecord> recent() const;

 private:
  std::array<std::atomic<std::uint64_t>, static_cast<int>(OverrunCause::count)> causes_{};
  std::atomic<std::uint64_t> off_cpu_{0};
  std::array<concurrency::Seqlock<OverrunRecord>, kKeep> cells_{};
  std::atomic<std::uint64_t> written_{0};
};

}  // namespace sculpt::simloop
