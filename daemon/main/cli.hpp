// sculptd's command line (CLI11). Flags override the config file; every flag
// given is kept so a SIGHUP reload re-applies it on top of the new file.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "main/config.hpp"

namespace sculpt::daemon {

struct CliOptions {
  std::filesystem::path config = kDefaultConfigPath;
  bool config_given = false;   // --config: the file must exist
  bool check = false;          // --check: validate config and scene, then exit
  std::optional<std::string> scene, socket, input, input_clock, stats_json, hash_out, log_level;
  std::optional<double> rate_hz, duration_s, input_delay_ms;
  bool realtime = false;

  // Applies the flags given to `config`; throws ConfigError naming the flag.
  void apply(DaemonConfig& config) const;
};

// Declares every option on `app`, bound to `out`.
void add_options(CLI::App& app, CliOptions& out);

}  // namespace sculpt::daemon
