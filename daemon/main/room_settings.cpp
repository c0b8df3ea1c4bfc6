#include "main/room_settings.hpp"

#include <cmath>
#include <cstdlib>
#include <string>

namespace sculpt::daemon {

bool store_wanted(const DaemonConfig& c) {
  if (!c.keeper.enabled) return false;
  return c.input.kind != InputSpec::Kind::replay || !c.keeper.dir.empty();
}

std::filesystem::path state_dir(const KeeperConfig& store) {
  if (!store.dir.empty()) return store.dir;
  const auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);
    return v ? v : "";
  };
  if (const std::string s = env("STATE_DIRECTORY"); !s.empty()) return s.substr(0, s.find(':'));
  if (const std::string s = env("XDG_STATE_HOME"); !s.empty()) return std::filesystem::path(s) / "sculptd";
  if (const std::string s = env("HOME"); !s.empty()) return std::filesystem::path(s) / ".local/state/sculptd";
  throw ConfigError("[keeper]: no state directory: set dir, $STATE_DIRECTORY, $XDG_STATE_HOME or $HOME");
}

KeeperSettings keeper_settings(const DaemonConfig& c) {
  KeeperSettings k;
  k.dir = state_dir(c.keeper);
  k.limits.max_bytes = static_cast<std::uint64_t>(std::llround(c.keeper.max_mb * 1048576.0));
  k.snapshot_every = std::chrono::milliseconds(std::llround(c.keeper.snapshot_interval_s * 1000.0));
  k.history_budget = static_cast<std::uint64_t>(std::llround(c.keeper.history_mb * 1048576.0));
  return k;
}

SimHostSettings sim_host_settings(const DaemonConfig& c) {
  return SimHostSettings{.realtime = c.realtime,
                         .realtime_priority = c.realtime_priority,
                         .wake_early_us = c.wake_early_us,
                         .duration_s = c.duration_s};
}

}  // namespace sculpt::daemon
