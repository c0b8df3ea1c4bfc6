#include "simloop/overrun.hpp"

#include <sys/resource.h>
#include <time.h>

#include <algorithm>

namespace sculpt::simloop {

const char* overrun_cause_name(OverrunCause c) {
  switch (c) {
    case OverrunCause::late_wake: return "late_wake";
    case OverrunCause::long_step: return "long_step";
    case OverrunCause::count: break;
  }
  return "?";
}

std::int64_t lateness_ns(const TickTiming& t) { return t.wake > t.deadline ? t.wake - t.deadline : 0; }

std::int64_t work_ns(const TickTiming& t) { return t.publish_end > t.wake ? t.publish_end - t.wake : 0; }

bool is_overrun(const TickTiming& t, std::int64_t period_ns) { return t.publish_end > t.deadline + period_ns; }

OverrunCause classify(std::int64_t lateness, std::int64_t work) {
  return work > lateness ? OverrunCause::long_step : OverrunCause::late_wake;
}

bool off_cpu(std::int64_t work, std::uint64_t work_cpu_ns) {
  if (work <= 0) return false;
  const std::int64_t cpu = static_cast<std::int64_t>(std::min<std::uint64_t>(work_cpu_ns, static_cast<std::uint64_t>(work)));
  return 2 * (work - cpu) >= work;
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
  r.off_cpu = r.cause == OverrunCause::long_step && off_cpu(work, c.work_cpu_ns);
  r.stage_ns = stage_times_ns(t);
  r.counters = c;
  return r;
}

std::uint64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

ThreadTotals thread_totals() {
  ThreadTotals c;
  rusage ru{};
  if (getrusage(RUSAGE_THREAD, &ru) == 0) {
    c.minflt = static_cast<std::uint64_t>(ru.ru_minflt);
    c.majflt = static_cast<std::uint64_t>(ru.ru_majflt);
    c.nvcsw = static_cast<std::uint64_t>(ru.ru_nvcsw);
    c.nivcsw = static_cast<std::uint64_t>(ru.ru_nivcsw);
  }
  return c;
}

ThreadTotals operator-(const ThreadTotals& a, const ThreadTotals& b) {
  const auto d = [](std::uint64_t x, std::uint64_t y) { return x > y ? x - y : 0; };
  return ThreadTotals{d(a.minflt, b.minflt), d(a.majflt, b.majflt), d(a.nvcsw, b.nvcsw), d(a.nivcsw, b.nivcsw)};
}

void OverrunLog::record(OverrunRecord r) {
  const std::uint64_t n = written_.load(std::memory_order_relaxed);
  r.index = n;
  auto& c = causes_[static_cast<int>(r.cause)];
  c.store(c.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  if (r.off_cpu) off_cpu_.store(off_cpu_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  cells_[n % kKeep].store(r);
  written_.store(n + 1, std::memory_order_release);
}

std::vector<OverrunRecord> OverrunLog::recent() const {
  const std::uint64_t n = total();
  std::vector<OverrunRecord> out;
  for (std::uint64_t i = n > kKeep ? n - kKeep : 0; i < n; ++i) {
    const OverrunRecord r = cells_[i % kKeep].load();
    // A cell the writer has reused since holds a newer record: skip it
    // (the next call reads it in its place).
    if (r.index == i) out.push_back(r);
  }
  return out;
}

}  // namespace sculpt::simloop
