#include "simloop/sim_probe.hpp"

#include <sched.h>

namespace sculpt::simloop {
namespace {

template <class T, class V>
void store(std::atomic<T>& a, V v) {
  a.store(static_cast<T>(v), std::memory_order_relaxed);
}

template <class T, class V>
void add(std::atomic<T>& a, V v) {
  store(a, a.load(std::memory_order_relaxed) + static_cast<T>(v));
}

}  // namespace

const char* stage_name(Stage s) {
  switch (s) {
    case Stage::input: return "input";
    case Stage::collision: return "collision";
    case Stage::integration: return "integration";
    case Stage::publish: return "publish";
    case Stage::count: break;
  }
  return "?";
}

SimProbe::SimProbe(LoopStats& stats) : stats_(stats), at_start_(thread_totals()), prev_(at_start_) {}

void SimProbe::woke(std::int64_t deadline, std::int64_t now) {
  cpu_ns_at_wake_ = thread_cpu_ns();
  at_wake_ = thread_totals();
  cpu_ = sched_getcpu();
  stats_.jitter.record(static_cast<std::uint64_t>(now > deadline ? now - deadline : 0));
  stats_.heartbeats.store(stats_.heartbeats.load(std::memory_order_relaxed) + 1, std::memory_order_release);
}

TickCounters SimProbe::take_counters() {
  const ThreadTotals now = thread_totals();
  const ThreadTotals since_start = now - at_start_;
  store(stats_.thread_minflt, since_start.minflt);
  store(stats_.thread_majflt, since_start.majflt);
  store(stats_.thread_nivcsw, since_start.nivcsw);
  const ThreadTotals tick = now - prev_;
  prev_ = now;
  TickCounters c;
  c.minflt = tick.minflt, c.majflt = tick.majflt, c.nivcsw = tick.nivcsw;
  return c;
}

void SimProbe::idled() { take_counters(); }

void SimProbe::ticked(std::uint64_t tick, const TickTiming& timing, const sim::TickStats& world,
                      std::int64_t period) {
  const std::uint64_t cpu_ns = thread_cpu_ns();
  // World::step collides and integrates substep by substep; its stage
  // clock adds up the collision part, the rest is integration.
  const auto stage_ns = stage_times_ns(timing);
  for (int i = 0; i < static_cast<int>(Stage::count); ++i)
    stats_.stage[i].record(stage_ns[static_cast<std::size_t>(i)]);

  store(stats_.vertices_awake, world.awake_vertices);
  store(stats_.last_blowup_body, world.last_blowup_body);
  store(stats_.last_blowup_cause, static_cast<std::uint8_t>(world.last_blowup_cause));
  // Release: a reader that sees the new count sees the body and cause above.
  stats_.blowups.store(world.blowups_total, std::memory_order_release);
  store(stats_.contacts, world.contacts);
  stats_.last_tick_ns.store(timing.publish_end, std::memory_order_relaxed);

  TickCounters counters = take_counters();
  counters.work_cpu_ns = cpu_ns > cpu_ns_at_wake_ ? cpu_ns - cpu_ns_at_wake_ : 0;
  // The tick's voluntary switches include the sleep's: count them from the
  // wake instead. A wait in a tick whose work faulted may be the kernel
  // moving a page (compaction): only the others are the thread's own blocking.
  const ThreadTotals work = prev_ - at_wake_;
  counters.work_nvcsw = work.nvcsw;
  counters.work_nvcsw_no_fault = work.minflt + work.majflt == 0 ? work.nvcsw : 0;
  add(stats_.thread_work_nvcsw, counters.work_nvcsw);
  add(stats_.thread_work_nvcsw_no_fault, counters.work_nvcsw_no_fault);
  // Counted by the log: overrun_log.total().
  if (is_overrun(timing, period)) stats_.overrun_log.record(make_overrun_record(tick, cpu_, timing, counters));
  stats_.ticks.store(stats_.ticks.load(std::memory_order_relaxed) + 1, std::memory_order_release);
}

void SimProbe::skipped(std::int64_t periods) { add(stats_.skipped_periods, periods); }

}  // namespace sculpt::simloop
