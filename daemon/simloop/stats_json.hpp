// The daemon's stats as one JSON object: written by `sculptd --stats-json` at
// exit and (later) printed by `sculptctl status --json`. Built in one place so
// both always carry exactly the same keys:
//   rate_hz, ticks, overruns, jitter_us {p50, p99, max},
//   stage_us {input, collision, integration, publish: {p50, p99, max}},
//   vertices_total, vertices_awake, viewers, devices, ff_uploads, bytes_sent, blowups,
// and why ticks overran (simloop/overrun.hpp):
//   overrun_causes {late_wake, long_step, long_step_off_cpu},
//   recent_overruns [{tick, cause, cpu, late_us, stage_us {input, collision,
//     integration, publish}, work_cpu_us, minflt, majflt, nivcsw, work_nvcsw,
//     work_nvcsw_no_fault}] (the last 8),
//   sim_thread {minflt, majflt, nivcsw, work_nvcsw, work_nvcsw_no_fault} (since the loop began)
#pragma once

#include <nlohmann/json_fwd.hpp>

#include "simloop/stats.hpp"

namespace sculpt::simloop {

nlohmann::json stats_json(const StatsReading& s);

}  // namespace sculpt::simloop
