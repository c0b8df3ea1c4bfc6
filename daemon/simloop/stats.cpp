#include "simloop/stats.hpp"

namespace sculpt::simloop {

Percentiles percentiles_us(const LatencyHistogram& h) {
  return Percentiles{h.quantile_ns(0.50) / 1e3, h.quantile_ns(0.99) / 1e3, static_cast<double>(h.max_ns()) / 1e3};
}

StatsReading reading(const LoopStats& stats, double rate_hz) {
  StatsReading s;
  s.rate_hz = rate_hz;
  s.ticks = stats.ticks.load(std::memory_order_acquire);
  s.overruns = stats.overrun_log.total();
  s.jitter_us = percentiles_us(stats.jitter);
  for (int i = 0; i < static_cast<int>(Stage::count); ++i) s.stage_us[i] = percentiles_us(stats.stage[i]);
  s.vertices_total = stats.vertices_total.load(std::memory_order_relaxed);
  s.vertices_awake = stats.vertices_awake.load(std::memory_order_relaxed);
  s.blowups = stats.blowups.load(std::memory_order_relaxed);
  for (int i = 0; i < static_cast<int>(OverrunCause::count); ++i)
    s.overrun_causes[static_cast<std::size_t>(i)] = stats.overrun_log.count(static_cast<OverrunCause>(i));
  s.long_steps_off_cpu = stats.overrun_log.long_steps_off_cpu();
  s.recent_overruns = stats.overrun_log.recent();
  s.sim_thread.minflt = stats.thread_minflt.load(std::memory_order_relaxed);
  s.sim_thread.majflt = stats.thread_majflt.load(std::memory_order_relaxed);
  s.sim_thread.nivcsw = stats.thread_nivcsw.load(std::memory_order_relaxed);
  s.sim_thread.work_nvcsw = stats.thread_work_nvcsw.load(std::memory_order_relaxed);
  s.sim_thread.work_nvcsw_no_fault = stats.thread_work_nvcsw_no_fault.load(std::memory_order_relaxed);
  return s;
}

}  // namespace sculpt::simloop
