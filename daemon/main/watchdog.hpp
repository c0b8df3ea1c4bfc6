// systemd's watchdog, fed only while the sim thread's loop moves: a ping is
// due every `fraction` × WatchdogSec, and goes out only if the loop's
// heartbeat counter (which a paused loop keeps counting) moved since the
// last one. A stuck sim thread thus gets the service restarted
// (Restart=on-failure) after WatchdogSec, with one log line saying why.
#pragma once

#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>

namespace sculpt::daemon {

class Watchdog {
 public:
  using Clock = std::chrono::steady_clock;
  enum class Due {
    nothing,        // not time yet, or no watchdog
    ping,           // send WATCHDOG=1
    stalled,        // the loop has not moved since the last ping: withhold it (log this once)
    still_stalled,  // likewise, already logged
  };

  // `interval`: WatchdogSec, when systemd set one (notify::watchdog_interval()).
  explicit Watchdog(std::optional<std::chrono::microseconds> interval) : interval_(interval) {}

  Due check(Clock::time_point now, std::uint64_t heartbeats, double fraction);

 private:
  std::optional<std::chrono::microseconds> interval_;
  Clock::time_point next_{};
  std::uint64_t last_heartbeats_ = std::numeric_limits<std::uint64_t>::max();
  bool stall_reported_ = false;
};

}  // namespace sculpt::daemon
