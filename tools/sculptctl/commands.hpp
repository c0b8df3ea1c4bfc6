// sculptctl subcommands: one file each, each adding itself to the app. A new
// command is a new file plus one line in main.cpp's list.
#pragma once

#include <CLI/CLI.hpp>

namespace sculpt::ctl {

// `inspect FILE [--json]`: offline report of a mesh or scene file (inspect.cpp).
void add_inspect_command(CLI::App& app);
// `record FILE` / `replay FILE`: sessions of joystick input (record.cpp, replay.cpp).
void add_record_command(CLI::App& app);
void add_replay_command(CLI::App& app);
// Against a running sculptd (daemon_link.hpp: --socket, --json, exit statuses):
// `status`, `devices` (status.cpp), `save FILE` (save.cpp), `load SCENE`,
// `reset`, `pause`, `resume` (control.cpp).
void add_status_command(CLI::App& app);
void add_devices_command(CLI::App& app);
void add_save_command(CLI::App& app);
void add_control_commands(CLI::App& app);

// Commands report failure by printing one line to stderr and throwing this;
// main turns it into the exit status.
struct CommandFailed {
  int status = 1;
};

}  // namespace sculpt::ctl
