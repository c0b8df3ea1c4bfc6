#include "main/run_report.hpp"

#include <string>

#include <nlohmann/json.hpp>

#include "simloop/stats_json.hpp"
#include "log/log.hpp"
#include "files/atomic_file.hpp"

namespace sculpt::daemon {
namespace {

bool write_output(const char* flag, const std::string& path, const std::string& text) {
  if (path.empty()) return true;
  try {
    files::write_file_atomically(path, text);
    return true;
  } catch (const std::exception& e) {
    log::err("{}: {}", flag, e.what());
    return false;
  }
}

}  // namespace

bool report_run(const RunTotals& totals, const DaemonConfig& config) {
  const simloop::StatsReading& s = totals.stats;
  if (totals.late_inputs != 0)
    log::warning("{} input messages arrived after their tick (the io thread fell behind){}", totals.late_inputs,
                 totals.replay ? ": this replay is not reproducible" : "");
  log::info("stopped after {} ticks: {} overruns, jitter p50 {:.1f} us p99 {:.1f} us max {:.1f} us, "
            "{} FF uploads ({} errors), final mesh hash {:016x}",
            s.ticks, s.overruns, s.jitter_us.p50, s.jitter_us.p99, s.jitter_us.max, s.ff_uploads, totals.ff_errors,
            totals.mesh_hash);
  const bool stats_written = write_output("--stats-json", config.stats_json, simloop::stats_json(s).dump(2) + "\n");
  const bool hash_written = write_output("--hash-out", config.hash_out, fmt::format("{:016x}\n", totals.mesh_hash));
  return stats_written && hash_written;
}

}  // namespace sculpt::daemon
