#include "simloop/stats_json.hpp"

#include <nlohmann/json.hpp>

namespace sculpt::simloop {

namespace {
nlohmann::json to_json(const Percentiles& p) { return {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}}; }

double us(std::uint64_t ns) { return static_cast<double>(ns) / 1e3; }

nlohmann::json to_json(const OverrunRecord& r) {
  nlohmann::json stages = nlohmann::json::object();
  for (int i = 0; i < kOverrunStages; ++i)
    stages[stage_name(static_cast<Stage>(i))] = us(r.stage_ns[static_cast<std::size_t>(i)]);
  return {
      {"tick", r.tick},
      {"cause", overrun_cause_name(r.cause)},
      {"off_cpu", r.off_cpu},
      {"cpu", r.cpu},
      {"late_us", us(static_cast<std::uint64_t>(r.late_ns))},
      {"stage_us", stages},
      {"work_cpu_us", us(r.counters.work_cpu_ns)},
      {"minflt", r.counters.minflt},
      {"majflt", r.counters.majflt},
      {"nivcsw", r.counters.nivcsw},
      {"work_nvcsw", r.counters.work_nvcsw},
      {"work_nvcsw_no_fault", r.counters.work_nvcsw_no_fault},
  };
}
}  // namespace

nlohmann::json stats_json(const StatsReading& s) {
  nlohmann::json stages = nlohmann::json::object();
  for (int i = 0; i < static_cast<int>(Stage::count); ++i) stages[stage_name(static_cast<Stage>(i))] = to_json(s.stage_us[i]);
  nlohmann::json causes = nlohmann::json::object();
  for (int i = 0; i < static_cast<int>(OverrunCause::count); ++i)
    causes[overrun_cause_name(static_cast<OverrunCause>(i))] = s.overrun_causes[static_cast<std::size_t>(i)];
  causes["long_step_off_cpu"] = s.long_steps_off_cpu;
  nlohmann::json recent = nlohmann::json::array();
  for (const OverrunRecord& r : s.recent_overruns) recent.push_back(to_json(r));
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
      {"overrun_causes", causes},
      {"recent_overruns", recent},
      {"sim_thread",
       {{"minflt", s.sim_thread.minflt},
        {"majflt", s.sim_thread.majflt},
        {"nivcsw", s.sim_thread.nivcsw},
        {"work_nvcsw", s.sim_thread.work_nvcsw},
        {"work_nvcsw_no_fault", s.sim_thread.work_nvcsw_no_fault}}},
  };
}

}  // namespace sculpt::simloop
