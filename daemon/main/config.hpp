// sculptd's configuration: /etc/sculptd/sculptd.conf (TOML, every key in
// docs/config.md), then the command line on top. Parsing checks every key
// and names file:line and the key on anything wrong; unknown keys are errors
// (a typo must not be silently ignored).
#pragma once

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <toml++/toml.h>

#include "haptics/haptics_engine.hpp"
#include "simloop/simulation_settings.hpp"
#include "devices/input_spec.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {

inline constexpr const char* kDefaultConfigPath = "/etc/sculptd/sculptd.conf";
// No socket given (flag or config file): the path follows the clients' rule
// (client/socket_path.hpp: $SCULPTD_SOCKET, $RUNTIME_DIRECTORY,
// $XDG_RUNTIME_DIR/sculptd, /run/sculptd/sculptd.sock).
inline constexpr const char* kDefaultSocketPath = "";

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "auto", "evdev" or "replay:FILE"; throws ConfigError naming `what`.
InputSpec parse_input_spec(std::string_view text, std::string_view what);
std::string to_string(const InputSpec& spec);

// [keeper]: the keeper (keeper/keeper.hpp, docs/store.md): the store, the
// history and recovery. Its old name [store] is still read, with a warning.
struct KeeperConfig {
  bool enabled = true;
  // "": $STATE_DIRECTORY (systemd's StateDirectory=), else
  // $XDG_STATE_HOME/sculptd, else ~/.local/state/sculptd.
  std::string dir;
  double snapshot_interval_s = 30.0;
  double max_mb = 1024.0;      // the store's database, at most
  double history_mb = 256.0;   // undo history in memory, at most
  // The command line's, for this start only.
  bool fresh = false;          // --fresh: do not resume the saved sculpt
  std::string open;            // --open FILE.sculpt: start from it
};

struct DaemonConfig {
  std::filesystem::path file;           // what was read ("" when only defaults)
  // [daemon]
  std::string scene = "builtin:default";
  std::string socket = kDefaultSocketPath;
  std::optional<double> rate_hz;        // unset: the scene's rate (1000 Hz unless it says otherwise)
  InputSpec input;
  InputClock input_clock = InputClock::arrival;
  double input_delay_ms = 50.0;         // --input-clock device: device time + this = when it applies
  double duration_s = 0.0;              // 0: run until stopped
  bool realtime = false;
  int realtime_priority = 50;
  // Sleep until this long before each deadline and spin the rest; unset:
  // 100 with realtime (measured: docs/benchmarks.md), else 0.
  std::optional<double> wake_early_us;
  log::Level log_level = log::Level::info;
  std::string stats_json;               // "" : none
  std::string hash_out;                 // "" : none
  double watchdog_fraction = 0.5;       // WATCHDOG=1 every fraction × WatchdogSec
  // [tools]
  double tool_margin = 0.1;             // m around the scene's box the tools may roam
  double size_step = 1.15;
  double min_scale = 0.25;
  double max_scale = 4.0;
  // [haptics]
  haptics::HapticsSettings haptics;
  // [keeper]
  KeeperConfig keeper;
  // The whole file: the input module reads [input] and [[device]] from it (input::parse_mapping).
  toml::table mapping_table;
};

// Parses config text; `file` names it in errors. Throws ConfigError.
DaemonConfig parse_config(std::string_view text, const std::filesystem::path& file);
// What a scene's build reads of `config` (host/simulation.hpp), copied for the worker thread.
simloop::SimulationSettings simulation_settings(const DaemonConfig& config);

// Reads and parses a file. A missing file is an error unless `optional`
// (the default path may legitimately not exist): then the defaults.
DaemonConfig load_config(const std::filesystem::path& file, bool optional);

}  // namespace sculpt::daemon
