#include "loop/overrun.hpp"

#include <fcntl.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>

namespace sculpt::loop {

const char* overrun_cause_name(OverrunCause c) {
  switch (c) {
    case OverrunCause::late_wake: return "late_wake";
    case OverrunCause::long_step: return "long_step";
    case OverrunCause::count: break;
  }
  return "?";
}

const char* overrun_detail_name(OverrunDetail d) {
  switch (d) {
    case OverrunDetail::wake_waited_for_cpu: return "wake_waited_for_cpu";
    case OverrunDetail::wake_timer_late: return "wake_timer_late";
    case OverrunDetail::step_off_cpu: return "step_off_cpu";
    case OverrunDetail::step_on_cpu: return "step_on_cpu";
    case OverrunDetail::count: break;
  }
  return "?";
}

std::int64_t lateness_ns(const TickTiming& t) { return t.wake > t.deadline ? t.wake - t.deadline : 0; }

std::int64_t work_ns(const TickTiming& t) { return t.publish_end > t.wake ? t.publish_end - t.wake : 0; }

bool is_overrun(const TickTiming& t, std::int64_t period_ns) { return t.publish_end > t.deadline + period_ns; }

OverrunCause classify(std::int64_t lateness, std::int64_t work) {
  return work > lateness ? OverrunCause::long_step : OverrunCause::late_wake;
}

OverrunDetail classify_detail(OverrunCause cause, std::int64_t lateness, std::int64_t work, const TickCounters& c) {
  if (cause == OverrunCause::late_wake)
    return 2 * static_cast<std::int64_t>(c.run_delay_ns) >= lateness ? OverrunDetail::wake_waited_for_cpu
                                                                      : OverrunDetail::wake_timer_late;
  const std::int64_t off = work - static_cast<std::int64_t>(std::min<std::uint64_t>(c.work_cpu_ns, work));
  return 2 * off >= work ? OverrunDetail::step_off_cpu : OverrunDetail::step_on_cpu;
}

std::array<std::uint64_t, kOverrunStages> stage_times_ns(const TickTiming& t) {
  const auto span = [](std::int64_t a, std::int64_t b) { return static_cast<std::uint64_t>(b > a ? b - a : 0); };
  const std::uint64_t step = span(t.input_end, t.step_end);
  const std::uint64_t collision = std::min(t.collision_ns, step);
  return {span(t.wake, t.input_end), collision, step - collision, span(t.step_end, t.publish_end)};
}

OverrunRecord make_overrun_record(std::uint64_t tick, int cpu, const TickTiming& t, const TickCounters& c) {
  OverrunRecord r;
  r.tick = tick;
  r.cpu = cpu;
  r.late_ns = lateness_ns(t);
  const std::int64_t work = work_ns(t);
  r.cause = classify(r.late_ns, work);
  r.detail = classify_detail(r.cause, r.late_ns, work, c);
  r.stage_ns = stage_times_ns(t);
  r.counters = c;
  return r;
}

ThreadProbe::ThreadProbe() : fd_(::open("/proc/thread-self/schedstat", O_RDONLY | O_CLOEXEC)) {}

ThreadProbe::~ThreadProbe() {
  if (fd_ >= 0) ::close(fd_);
}

std::uint64_t ThreadProbe::cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

TickCounters ThreadProbe::totals() const {
  TickCounters c;
  rusage ru{};
  if (getrusage(RUSAGE_THREAD, &ru) == 0) {
    c.minflt = static_cast<std::uint64_t>(ru.ru_minflt);
    c.majflt = static_cast<std::uint64_t>(ru.ru_majflt);
    c.nivcsw = static_cast<std::uint64_t>(ru.ru_nivcsw);
  }
  if (fd_ >= 0) {
    // "<on-cpu ns> <run_delay ns> <timeslices>\n": the second number.
    char buf[96];
    const ssize_t n = ::pread(fd_, buf, sizeof buf, 0);
    std::uint64_t v = 0;
    int field = 0;
    for (ssize_t i = 0; i < n && field < 2; ++i) {
      if (buf[i] >= '0' && buf[i] <= '9') {
        if (field == 1) v = v * 10 + static_cast<std::uint64_t>(buf[i] - '0');
      } else if (buf[i] == ' ') {
        ++field;
      } else {
        break;
      }
    }
    c.run_delay_ns = v;
  }
  return c;
}

TickCounters operator-(const TickCounters& a, const TickCounters& b) {
  const auto d = [](std::uint64_t x, std::uint64_t y) { return x > y ? x - y : 0; };
  return TickCounters{d(a.work_cpu_ns, b.work_cpu_ns), d(a.run_delay_ns, b.run_delay_ns), d(a.minflt, b.minflt),
                      d(a.majflt, b.majflt), d(a.nivcsw, b.nivcsw)};
}

void OverrunLog::record(OverrunRecord r) {
  const std::uint64_t n = written_.load(std::memory_order_relaxed);
  r.index = n;
  auto& c = causes_[static_cast<int>(r.cause)];
  c.store(c.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  auto& d = details_[static_cast<int>(r.detail)];
  d.store(d.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  slots_[n % kKeep].store(r);
  written_.store(n + 1, std::memory_order_release);
}

std::vector<OverrunRecord> OverrunLog::recent() const {
  const std::uint64_t n = total();
  std::vector<OverrunRecord> out;
  for (std::uint64_t i = n > kKeep ? n - kKeep : 0; i < n; ++i) {
    const OverrunRecord r = slots_[i % kKeep].load();
    // A slot the writer has reused since holds a newer record: skip it
    // (the next call reads it in its place).
    if (r.index == i) out.push_back(r);
  }
  return out;
}

}  // namespace sculpt::loop
