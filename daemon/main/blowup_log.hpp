// Blow-ups are loud. When a mesh's step diverges (a position goes non-finite,
// or its energy grows with nothing adding any) the simulation's guard
// restores its last good state and raises its substeps, on the sim thread,
// which cannot log. The io thread reads the counters the sim thread keeps
// and says so: the first blow-up of a scene at once, with the mesh and the
// cause, then at most one line per interval with the count since.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "simloop/sim_thread.hpp"

namespace sculpt::daemon {

class BlowupLog {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::seconds kEvery{10};

  // A new scene (its world counts from zero): the names of its meshes, body order.
  void reset(std::vector<std::string> mesh_names);
  // Reads the counters; returns the line to log, or "" when nothing is due.
  std::string check(const simloop::LoopStats& stats, std::uint64_t tick, Clock::time_point now);

 private:
  std::string describe(const simloop::LoopStats& stats) const;

  std::vector<std::string> names_;
  std::uint64_t seen_ = 0;        // blow-ups already reported
  Clock::time_point next_{};      // when the next count may be logged
};

}  // namespace sculpt::daemon
