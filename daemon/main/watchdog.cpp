#include "main/watchdog.hpp"

namespace sculpt::daemon {

Watchdog::Due Watchdog::check(Clock::time_point now, std::uint64_t heartbeats, double fraction) {
  if (!interval_ || now < next_) return Due::nothing;
  next_ = now + std::chrono::duration_cast<Clock::duration>(*interval_ * fraction);
  if (heartbeats != last_heartbeats_) {
    last_heartbeats_ = heartbeats;
    stall_reported_ = false;
    return Due::ping;
  }
  if (stall_reported_) return Due::still_stalled;
  stall_reported_ = true;
  return Due::stalled;
}

}  // namespace sculpt::daemon
