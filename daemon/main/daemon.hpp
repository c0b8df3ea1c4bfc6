// sculptd's io thread: a kj event loop that owns the devices (evdev reads,
// hot-plug), the config, the scene, the signals (SIGTERM/SIGINT stop,
// SIGHUP reloads) and sd_notify (READY, WATCHDOG while the sim thread
// ticks, STATUS, STOPPING); it starts the sim and haptics threads.
#pragma once

#include <filesystem>
#include <functional>

#include "main/config.hpp"

namespace sculpt::daemon {

struct RunOptions {
  DaemonConfig config;
  std::filesystem::path config_path;      // re-read on SIGHUP ("" : nothing to re-read)
  bool config_optional = true;            // a missing default config file is fine
  // Re-applies the command line on top of a re-read config (flags win).
  std::function<void(DaemonConfig&)> overrides;
};

// Runs until SIGTERM/SIGINT or --duration; returns the process exit status.
// Errors while setting up (bad scene, no devices subsystem) are logged and
// give 1. Must be called from the main thread before any other thread exists
// (it blocks the handled signals for every thread it starts).
int run(RunOptions options);

}  // namespace sculpt::daemon
