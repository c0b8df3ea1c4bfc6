// The run's last word, at shutdown: one log line with the loop's totals,
// and the files --stats-json and --hash-out ask for, each written whole or
// not at all (like a save: a reader never sees half a file).
#pragma once

#include <cstdint>

#include "simloop/stats.hpp"
#include "main/config.hpp"

namespace sculpt::daemon {

struct RunTotals {
  simloop::StatsReading stats;
  std::uint64_t ff_errors = 0;
  std::uint64_t mesh_hash = 0;
  std::uint64_t late_inputs = 0;  // scheduled inputs applied after their tick
  bool replay = false;
};

// Logs the totals and writes the files `config` names; false when one of
// them could not be written (logged).
bool report_run(const RunTotals& totals, const DaemonConfig& config);

}  // namespace sculpt::daemon
