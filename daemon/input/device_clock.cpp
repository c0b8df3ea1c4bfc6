#include "input/device_clock.hpp"

#include <algorithm>
#include <cmath>

#include "input/replay_source.hpp"

namespace sculpt::input {

DeviceClock::Placement DeviceClock::place(const InputFrame& frame, std::uint64_t now_tick) {
  // Frames without a device clock (a resync, a device without
  // MSC_TIMESTAMP) apply in order, right after what is already queued.
  if (!frame.device_clock) return {};
  Anchor& a = anchors_[frame.slot % anchors_.size()];
  const auto ticks_of = [this](std::int64_t t_us) {
    return static_cast<std::int64_t>(replay_tick(0, t_us, rate_hz_));
  };
  Placement p;
  if (!a.valid) {
    const auto delay = static_cast<std::int64_t>(std::llround(delay_ms_ * 1e-3 * rate_hz_));
    a.base = static_cast<std::int64_t>(now_tick) + delay - ticks_of(frame.device_time_us);
    a.last = 1;
    a.valid = true;
    p.anchored = true;
  }
  const std::int64_t t = std::max({a.base + ticks_of(frame.device_time_us), a.last, std::int64_t{1}});
  a.last = t;
  p.tick = static_cast<std::uint64_t>(t);
  return p;
}

}  // namespace sculpt::input
