// What of the daemon's configuration building a scene's simulation needs
// (host/simulation.hpp), and the ranges it is held to. A config file, the
// command line and a stored scene bundle (keeper/scene_bundle.hpp) are all
// held to the same ranges: a .sculpt file is no more trusted than a config.
#pragma once

#include <cstddef>
#include <optional>

namespace sculpt::simloop {

struct SettingRange {
  const char* name;
  double lo, hi;
};
inline constexpr SettingRange kRateRange{"rate_hz", 1.0, 100000.0};
inline constexpr SettingRange kToolMarginRange{"tools.margin", 0.0, 100.0};
inline constexpr SettingRange kSizeStepRange{"tools.size_step", 1.0001, 10.0};
inline constexpr SettingRange kMinScaleRange{"tools.min_scale", 1e-3, 1.0};
inline constexpr SettingRange kMaxScaleRange{"tools.max_scale", 1.0, 1000.0};
// The input ring: the daemon uses kLiveRingCapacity, or kReplayRingCapacity for a replay.
inline constexpr SettingRange kRingCapacityRange{"input ring capacity", 16.0, 16384.0};

inline constexpr std::size_t kLiveRingCapacity = 4096;  // io → sim messages in flight
// A replay is queued as far ahead as this ring holds, less a slot per device
// for a swap's re-attaches (~1 KiB a message; a
// minute and more of a typical recording), so an io thread starved for
// seconds on a loaded machine still delivers every frame before its tick:
// a late one would make the run differ from the recording.
inline constexpr std::size_t kReplayRingCapacity = 16384;

// Copied when a build starts.
struct SimulationSettings {
  std::optional<double> rate_hz;   // --rate / the config; unset: the scene's
  double tool_margin = 0.1;        // simloop::DriverLimits
  double size_step = 1.15;
  double min_scale = 0.25;
  double max_scale = 4.0;
  std::size_t ring_capacity = kLiveRingCapacity;  // io → sim input messages in flight
};

// The settings within the ranges above. Throws std::invalid_argument
// naming the setting, its value and its range.
void check_settings(const SimulationSettings& settings);

}  // namespace sculpt::simloop
