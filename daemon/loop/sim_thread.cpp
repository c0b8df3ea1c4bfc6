#include "loop/sim_thread.hpp"

#include <pthread.h>
#include <sys/prctl.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <system_error>


namespace sculpt::loop {

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

std::int64_t monotonic_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

namespace {

timespec to_timespec(std::int64_t ns) {
  return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

template <class T, class V>
void store(std::atomic<T>& a, V v) {
  a.store(static_cast<T>(v), std::memory_order_relaxed);
}

}  // namespace

std::int64_t max_wake_early_ns(double rate_hz) { return std::llround(1e9 / rate_hz) / 2; }

SimThread::SimThread(sim::World<float>& world, TickStages& stages, std::size_t tool_count,
                     const SimThreadOptions& options)
    : world_(world), stages_(stages), tools_(tool_count), options_(options) {
  if (!(options.rate_hz >= 1.0 && options.rate_hz <= 100'000.0))
    throw std::invalid_argument("rate must be between 1 and 100000 Hz, got " + std::to_string(options.rate_hz));
  if (options.realtime_priority < 1 || options.realtime_priority > 99)
    throw std::invalid_argument("realtime priority must be 1..99");
  period_ns_ = std::llround(1e9 / options.rate_hz);
  if (options.wake_early_ns < 0 || options.wake_early_ns > max_wake_early_ns(options.rate_hz))
    throw std::invalid_argument("wake early must be between 0 and half the period (" +
                                std::to_string(max_wake_early_ns(options.rate_hz)) + " ns), got " +
                                std::to_string(options.wake_early_ns) + " ns");
  spin_.store(!options.wake_early_needs_fifo, std::memory_order_relaxed);
  for (auto& t : tools_) t.active = false;
  world_.set_stage_clock([] { return static_cast<std::uint64_t>(monotonic_ns()); });
  std::uint64_t total = 0;
  for (std::size_t b = 0; b < world.body_count(); ++b) total += world.body(b).n;
  store(stats_.vertices_total, total);
  store(stats_.ticks, options.first_tick);
}

SimThread::~SimThread() { stop(); }

RealtimeResult SimThread::start() {
  RealtimeResult rt;
  if (thread_.joinable()) return rt;
  if (options_.realtime) {
    // Lock what is mapped now and what comes later: a page fault in the loop
    // is a disk read away from an overrun.
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) rt.locked = true;
    else rt.warnings.push_back(std::string("--realtime: mlockall failed (") + std::strerror(errno) +
                               "): memory may be paged out; raise LimitMEMLOCK or grant CAP_IPC_LOCK");
  }
  thread_ = std::thread([this] { run(); });
  pthread_setname_np(thread_.native_handle(), "sculptd-sim");
  if (options_.realtime) {
    sched_param sp{};
    sp.sched_priority = options_.realtime_priority;
    const int err = pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &sp);
    if (err == 0) {
      rt.fifo = true;
      spin_.store(true, std::memory_order_relaxed);
    } else rt.warnings.push_back(std::string("--realtime: SCHED_FIFO refused (") + std::strerror(err) +
                               "): running at normal priority; grant CAP_SYS_NICE or an RLIMIT_RTPRIO");
  }
  return rt;
}

bool SimThread::request_pause(bool paused) { return commands_.try_push(paused ? 1 : 0); }

void SimThread::stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void SimThread::run() {
  // A normal thread's timer slack (50 µs) would be added to every wake-up:
  // ask for deadlines kept to the nanosecond.
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  const std::int64_t period = period_ns_;
  // The thread's own counters, read every period (four cheap system calls,
  // ~1.7 µs measured here; the two at the wake, ~0.85 µs, count in the input
  // stage's time): they say why a tick overran, and whether the thread ever
  // waited on something mid-tick.
  const ThreadTotals at_start = thread_totals();
  ThreadTotals prev = at_start;
  const auto take_counters = [&] {
    const ThreadTotals now = thread_totals();
    const ThreadTotals since_start = now - at_start;
    store(stats_.thread_minflt, since_start.minflt);
    store(stats_.thread_majflt, since_start.majflt);
    store(stats_.thread_nivcsw, since_start.nivcsw);
    const ThreadTotals tick = now - prev;
    prev = now;
    TickCounters c;
    c.minflt = tick.minflt, c.majflt = tick.majflt, c.nivcsw = tick.nivcsw;
    return c;
  };
  std::int64_t deadline = monotonic_ns() + period;
  std::uint64_t tick = world_.tick() + options_.first_tick;
  auto& stage = stats_.stage;
  while (!stop_.load(std::memory_order_acquire)) {
    // Paused, nothing needs the deadline kept to the microsecond: no spin.
    const bool was_paused = stats_.paused.load(std::memory_order_relaxed);
    const bool spin = !was_paused && spin_.load(std::memory_order_relaxed);
    const timespec ts = to_timespec(deadline - (spin ? options_.wake_early_ns : 0));
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    std::int64_t t0 = monotonic_ns();
    while (t0 < deadline) t0 = monotonic_ns();  // woken early on purpose: hold the CPU to the deadline
    const std::uint64_t cpu0 = thread_cpu_ns();
    const ThreadTotals at_wake = thread_totals();
    const int cpu = sched_getcpu();
    stats_.jitter.record(static_cast<std::uint64_t>(t0 > deadline ? t0 - deadline : 0));
    stats_.heartbeats.store(stats_.heartbeats.load(std::memory_order_relaxed) + 1, std::memory_order_release);
    while (const std::uint8_t* c = commands_.peek()) {
      stats_.paused.store(*c != 0, std::memory_order_release);
      commands_.pop();
    }
    if (stats_.paused.load(std::memory_order_relaxed)) {
      take_counters();
      deadline += period;
      const std::int64_t now = monotonic_ns();
      if (now > deadline) deadline += ((now - deadline) / period + 1) * period;
      continue;
    }

    stages_.input(tick, tools_);
    const std::int64_t t1 = monotonic_ns();
    world_.step(tools_);
    const std::int64_t t2 = monotonic_ns();
    stages_.publish(tick, world_);
    const std::int64_t t3 = monotonic_ns();
    const std::uint64_t cpu3 = thread_cpu_ns();

    // World::step collides and integrates substep by substep; its stage
    // clock adds up the collision part, the rest is integration.
    const TickTiming timing{deadline, t0, t1, t2, t3, world_.collision_ns()};
    const auto stage_ns = stage_times_ns(timing);
    for (int i = 0; i < static_cast<int>(Stage::count); ++i) stage[i].record(stage_ns[static_cast<std::size_t>(i)]);

    const sim::TickStats& ws = world_.stats();
    store(stats_.vertices_awake, ws.awake_vertices);
    store(stats_.last_blowup_body, ws.last_blowup_body);
    store(stats_.last_blowup_cause, static_cast<std::uint8_t>(ws.last_blowup_cause));
    // Release: a reader that sees the new count sees the body and cause above.
    stats_.blowups.store(ws.blowups_total, std::memory_order_release);
    store(stats_.contacts, ws.contacts);
    stats_.last_tick_ns.store(t3, std::memory_order_relaxed);

    TickCounters counters = take_counters();
    counters.work_cpu_ns = cpu3 > cpu0 ? cpu3 - cpu0 : 0;
    // The tick's voluntary switches include the sleep's: count them from the
    // wake instead. prev is the reading take_counters just took. A wait in a
    // tick whose work faulted may be the kernel moving a page (compaction):
    // only the others are the thread's own blocking.
    const ThreadTotals work = prev - at_wake;
    counters.work_nvcsw = work.nvcsw;
    counters.work_nvcsw_no_fault = work.minflt + work.majflt == 0 ? work.nvcsw : 0;
    store(stats_.thread_work_nvcsw, stats_.thread_work_nvcsw.load(std::memory_order_relaxed) + counters.work_nvcsw);
    store(stats_.thread_work_nvcsw_no_fault,
          stats_.thread_work_nvcsw_no_fault.load(std::memory_order_relaxed) + counters.work_nvcsw_no_fault);
    const bool overran = is_overrun(timing, period);  // counted by the log: overrun_log.total()
    if (overran) stats_.overrun_log.record(make_overrun_record(tick, cpu, timing, counters));
    ++tick;
    stats_.ticks.store(stats_.ticks.load(std::memory_order_relaxed) + 1, std::memory_order_release);

    deadline += period;
    // Past the next deadline (an overrun): resume at the first deadline still
    // ahead, dropping the missed periods. A tick started at once would begin
    // up to a period late and overrun in turn (one stall counted twice), and a
    // burst of catch-up ticks would shorten the periods the devices feel.
    if (overran) {
      const std::int64_t missed = (t3 - deadline) / period + 1;
      deadline += missed * period;
      stats_.skipped_periods.store(stats_.skipped_periods.load(std::memory_order_relaxed) +
                                       static_cast<std::uint64_t>(missed),
                                   std::memory_order_relaxed);
    }
    if (options_.max_ticks != 0 && stats_.ticks.load(std::memory_order_relaxed) >= options_.max_ticks) break;
  }
  finished_.store(true, std::memory_order_release);
}

}  // namespace sculpt::loop
