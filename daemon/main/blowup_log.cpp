#include "main/blowup_log.hpp"

#include <fmt/format.h>

#include "sim/world.hpp"

namespace sculpt::daemon {

void BlowupLog::reset(std::vector<std::string> mesh_names) {
  names_ = std::move(mesh_names);
  seen_ = 0;
  next_ = {};
}

std::string BlowupLog::describe(const simloop::LoopStats& stats) const {
  const std::uint32_t body = stats.last_blowup_body.load(std::memory_order_relaxed);
  const auto cause = static_cast<sim::BlowupCause>(stats.last_blowup_cause.load(std::memory_order_relaxed));
  const std::string mesh = body < names_.size() ? "mesh '" + names_[body] + "'" : fmt::format("body {}", body);
  return fmt::format("{}: {}", mesh,
                     cause == sim::BlowupCause::non_finite
                         ? "a position became non-finite (NaN or infinity)"
                         : "its energy grew fourfold with no tool or grab adding any");
}

std::string BlowupLog::check(const simloop::LoopStats& stats, std::uint64_t tick, Clock::time_point now) {
  const std::uint64_t total = stats.blowups.load(std::memory_order_acquire);  // then body and cause
  if (total <= seen_) return {};
  std::string line;
  if (seen_ == 0) {
    line = fmt::format("blow-up at tick {}, {}; the guard restored its last good state and doubled its substeps "
                       "(sculptd --check probes a scene for this)",
                       tick, describe(stats));
  } else if (now >= next_) {
    line = fmt::format("{} more blow-up(s) in the last {} s (the latest: {}); {} in this scene so far", total - seen_,
                       kEvery.count(), describe(stats), total);
  } else {
    return {};
  }
  seen_ = total;
  next_ = now + kEvery;
  return line;
}

}  // namespace sculpt::daemon
