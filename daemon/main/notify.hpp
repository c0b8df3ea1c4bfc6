// The service manager's side channel (sd_notify): READY=1, STATUS=, WATCHDOG=1,
// STOPPING=1. All no-ops outside systemd (no $NOTIFY_SOCKET).
#pragma once

#include <chrono>
#include <optional>
#include <string_view>

namespace sculpt::daemon::notify {

void ready(std::string_view status);
void status(std::string_view status);
void watchdog();
void stopping(std::string_view status);
// WatchdogSec of the unit, when the manager expects pings from this process.
std::optional<std::chrono::microseconds> watchdog_interval();

}  // namespace sculpt::daemon::notify
