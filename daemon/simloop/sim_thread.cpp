#include "simloop/sim_thread.hpp"

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


namespace sculpt::simloop {

std::int64_t monotonic_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

namespace {

timespec to_timespec(std::int64_t ns) {
  return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

// The deadline after `deadline`, or, when `now` is past it (an overrun, or a
// paused period that woke late), the first one still ahead: the missed
// periods are dropped. A tick started at once would begin up to a period
// late and overrun in turn (one stall counted twice), and a burst of
// catch-up ticks would shorten the periods the devices feel.
std::int64_t next_deadline(std::int64_t deadline, std::int64_t now, std::int64_t period) {
  deadline += period;
  if (now > deadline) deadline += ((now - deadline) / period + 1) * period;
  return deadline;
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
  SimProbe probe(stats_);
  std::int64_t deadline = monotonic_ns() + period_ns_;
  std::uint64_t tick = options_.first_tick;
  while (!stop_.load(std::memory_order_acquire)) {
    const std::int64_t woke = wait_for(deadline);
    probe.woke(deadline, woke);
    take_commands(tick);
    if (stats_.paused.load(std::memory_order_relaxed)) {
      probe.idled();
      deadline = next_deadline(deadline, monotonic_ns(), period_ns_);
      continue;
    }
    const TickTiming timing = run_tick(tick, deadline, woke);
    probe.ticked(tick, timing, world_.stats(), period_ns_);
    ++tick;
    const std::int64_t next = next_deadline(deadline, timing.publish_end, period_ns_);
    if (const std::int64_t missed = (next - deadline) / period_ns_ - 1; missed > 0) probe.skipped(missed);
    deadline = next;
    if (options_.max_ticks != 0 && stats_.ticks.load(std::memory_order_relaxed) >= options_.max_ticks) break;
  }
  take_commands(tick);  // a pause asked just before the stop is the state a swap carries over
  finished_.store(true, std::memory_order_release);
}

std::int64_t SimThread::wait_for(std::int64_t deadline) {
  // Paused, nothing needs the deadline kept to the microsecond: no spin.
  const bool spin = !stats_.paused.load(std::memory_order_relaxed) && spin_.load(std::memory_order_relaxed);
  const timespec ts = to_timespec(deadline - (spin ? options_.wake_early_ns : 0));
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
  std::int64_t now = monotonic_ns();
  while (now < deadline) now = monotonic_ns();  // woken early on purpose: hold the CPU to the deadline
  return now;
}

void SimThread::take_commands(std::uint64_t tick) {
  while (const std::uint8_t* c = commands_.peek()) {
    const bool paused = *c != 0;
    if (paused != stats_.paused.load(std::memory_order_relaxed)) stages_.paused_changed(tick, paused);
    stats_.paused.store(paused, std::memory_order_release);
    commands_.pop();
  }
}

TickTiming SimThread::run_tick(std::uint64_t tick, std::int64_t deadline, std::int64_t woke) {
  stages_.input(tick, tools_);
  const std::int64_t input_end = monotonic_ns();
  world_.step(tools_);
  const std::int64_t step_end = monotonic_ns();
  stages_.publish(tick, world_);  // positions to viewers, contact forces to the haptics
  const std::int64_t publish_end = monotonic_ns();
  return TickTiming{deadline, woke, input_end, step_end, publish_end, world_.collision_ns()};
}

}  // namespace sculpt::simloop
