// sculptd's command line (CLI11, included only by cli.cpp: it costs seconds
// of compile time in every file that includes it). Flags override the config
// file; every flag given is kept so a SIGHUP reload re-applies it on top of
// the new file.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "main/config.hpp"

namespace CLI {
class App;
}  // namespace CLI

namespace sculpt::daemon {

struct CliOptions {
  std::filesystem::path config = kDefaultConfigPath;
  bool config_given = false;   // --config: the file must exist
  bool check = false;          // --check: validate config and scene, then exit
  std::optional<std::string> scene, socket, input, input_clock, stats_json, hash_out, log_level;
  std::optional<double> rate_hz, duration_s, input_delay_ms;
  bool realtime = false, no_realtime = false;
  std::optional<std::string> state_dir, open;
  bool fresh = false, no_store = false;

  // Applies the flags given to `config`; throws ConfigError naming the flag.
  void apply(DaemonConfig& config) const;
};

// Declares every option on `app`, bound to `out`.
void add_options(CLI::App& app, CliOptions& out);

// Parses sculptd's command line into `out` (cli/conventions.hpp): nullopt to
// go on, else the status to exit with (--help, --version, a usage error).
std::optional<int> parse_command_line(int argc, char** argv, CliOptions& out);

}  // namespace sculpt::daemon
