#include "loop/stats_json.hpp"

namespace sculpt::loop {

Percentiles percentiles_us(const LatencyHistogram& h) {
  return Percentiles{h.quantile_ns(0.50) / 1e3, h.quantile_ns(0.99) / 1e3, static_cast<double>(h.max_ns()) / 1e3};
}

StatsSnapshot snapshot(const LoopStats& stats, double rate_hz) {
  StatsSnapshot s;
  s.rate_hz = rate_hz;
  s.ticks = stats.ticks.load(std::memory_order_acquire);
  s.overruns = stats.overruns.load(std::memory_order_relaxed);
  s.jitter_us = percentiles_us(stats.jitter);
  for (int i = 0; i < static_cast<int>(Stage::count); ++i) s.stage_us[i] = percentiles_us(stats.stage[i]);
  s.vertices_total = stats.vertices_total.load(std::memory_order_relaxed);
  s.vertices_awake = stats.vertices_awake.load(std::memory_order_relaxed);
  s.blowups = stats.blowups.load(std::memory_order_relaxed);
  return s;
}

namespace {
nlohmann::json to_json(const Percentiles& p) { return {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}}; }
}  // namespace

nlohmann::json stats_json(const StatsSnapshot& s) {
  nlohmann::json stages = nlohmann::json::object();
  for (int i = 0; i < static_cast<int>(Stage::count); ++i) stages[stage_name(static_cast<Stage>(i))] = to_json(s.stage_us[i]);
  return {
      {"rate_hz", s.rate_hz},
      {"ticks", s.ticks},
      {"overruns", s.overruns},
      {"jitter_us", to_json(s.jitter_us)},
      {"stage_us", stages},
      {"vertices_total", s.vertices_total},
      {"vertices_awake", s.vertices_awake},
      {"viewers", s.viewers},
      {"devices", s.devices},
      {"ff_uploads", s.ff_uploads},
      {"bytes_sent", s.bytes_sent},
      {"blowups", s.blowups},
  };
}

}  // namespace sculpt::loop
