#include "main/cli.hpp"

#include <CLI/CLI.hpp>

#include "cli/conventions.hpp"

namespace sculpt::daemon {
namespace {

// CLI11 2.1 binds plain values; these keep "was it given" next to the value.
template <class T>
void optional_option(CLI::App& app, const std::string& name, std::optional<T>& out, const std::string& help,
                     const std::string& value_name = {}) {
  auto* opt = app.add_option_function<T>(name, [&out](const T& value) { out = value; }, help);
  if (!value_name.empty()) opt->type_name(value_name);
}

}  // namespace

void add_options(CLI::App& app, CliOptions& o) {
  app.add_option_function<std::string>(
         "-c,--config", [&o](const std::string& p) { o.config = p; o.config_given = true; },
         "config file (TOML; default /etc/sculptd/sculptd.conf, which may be absent)")
      ->type_name("PATH");
  optional_option(app, "--scene", o.scene, "scene file (TOML), or builtin:default (the default)", "SCENE");
  optional_option(app, "--socket", o.socket, "control/streaming socket path (default: $SCULPTD_SOCKET, $RUNTIME_DIRECTORY/sculptd.sock, "
                  "$XDG_RUNTIME_DIR/sculptd/sculptd.sock, /run/sculptd/sculptd.sock)", "PATH");
  optional_option(app, "--rate", o.rate_hz, "simulation rate in Hz (default: the scene's, 1000)", "HZ");
  optional_option(app, "--input", o.input, "auto | evdev | replay:FILE (default auto)", "INPUT");
  optional_option(app, "--input-clock", o.input_clock,
                  "arrival | device: schedule live input by arrival or by the device's MSC_TIMESTAMP", "CLOCK");
  optional_option(app, "--input-delay", o.input_delay_ms, "ms added to device time with --input-clock device (50)", "MS");
  optional_option(app, "--duration", o.duration_s, "exit cleanly after this many seconds of simulation", "SECONDS");
  auto* realtime = app.add_flag("--realtime", o.realtime, "SCHED_FIFO + mlockall for the sim thread, when permitted");
  app.add_flag("--no-realtime", o.no_realtime, "not, whatever the config file says")->excludes(realtime);
  optional_option(app, "--stats-json", o.stats_json, "write the stats as JSON to FILE at exit", "FILE");
  optional_option(app, "--hash-out", o.hash_out, "write the final mesh hash (16 hex digits) to FILE at exit", "FILE");
  optional_option(app, "--log-level", o.log_level, "error | warning | notice | info | debug (default info)", "LEVEL");
  optional_option(app, "--state-dir", o.state_dir,
                  "where the sculpt is saved (default: $STATE_DIRECTORY, $XDG_STATE_HOME/sculptd, "
                  "~/.local/state/sculptd); also saves a replay", "DIR");
  app.add_flag("--fresh", o.fresh, "start the scene anew instead of resuming the saved sculpt (which is replaced)");
  optional_option(app, "--open", o.open, "start from a sculpt exported with `sculptctl export` (replaces the saved one)",
                  "FILE.sculpt");
  app.add_flag("--no-store", o.no_store, "no keeper: no history on disk, no recovery");
  app.add_flag("--check", o.check, "check the config and the scene (and probe its stability), then exit");
}

std::optional<int> parse_command_line(int argc, char** argv, CliOptions& out) {
  CLI::App app{"sculptd " SCULPTD_VERSION ": joysticks push and pull elastic meshes, with force feedback"};
  cli::apply_conventions(app);
  app.set_version_flag("--version", SCULPTD_VERSION);
  add_options(app, out);
  return cli::parse(app, argc, argv);
}

void CliOptions::apply(DaemonConfig& c) const {
  if (scene) c.scene = *scene;
  if (socket) c.socket = *socket;
  if (rate_hz) {
    if (!(*rate_hz >= simloop::kRateRange.lo && *rate_hz <= simloop::kRateRange.hi))
      throw ConfigError("--rate: must be within [1, 100000] Hz");
    c.rate_hz = *rate_hz;
  }
  if (input) c.input = parse_input_spec(*input, "--input");
  if (input_clock) {
    if (*input_clock == "arrival") c.input_clock = InputClock::arrival;
    else if (*input_clock == "device") c.input_clock = InputClock::device;
    else throw ConfigError("--input-clock: must be arrival or device, not \"" + *input_clock + "\"");
  }
  if (input_delay_ms) {
    if (!(*input_delay_ms >= 0 && *input_delay_ms <= 10000)) throw ConfigError("--input-delay: must be within [0, 10000] ms");
    c.input_delay_ms = *input_delay_ms;
  }
  if (duration_s) {
    if (!(*duration_s >= 0 && *duration_s <= 1e9)) throw ConfigError("--duration: must be >= 0 seconds");
    c.duration_s = *duration_s;
  }
  if (realtime) c.realtime = true;
  if (no_realtime) c.realtime = false;
  if (state_dir) {
    if (state_dir->empty()) throw ConfigError("--state-dir: must name a directory");
    c.keeper.dir = *state_dir;
    c.keeper.enabled = true;
  }
  if (no_store && (state_dir || fresh || open)) throw ConfigError("--no-store: cannot go with --state-dir, --fresh or --open");
  if (fresh && open) throw ConfigError("--fresh and --open: choose one");
  if (no_store) c.keeper.enabled = false;
  if (fresh) c.keeper.fresh = true;
  if (open) {
    if (open->empty()) throw ConfigError("--open: must name a .sculpt file");
    c.keeper.open = *open;
    c.keeper.enabled = true;
  }
  if (stats_json) c.stats_json = *stats_json;
  if (hash_out) c.hash_out = *hash_out;
  if (log_level && !log::parse_level(*log_level, c.log_level))
    throw ConfigError("--log-level: must be error, warning, notice, info or debug, not \"" + *log_level + "\"");
}

}  // namespace sculpt::daemon
