// sculptctl: the command-line companion of sculptd.
#include <CLI/CLI.hpp>

#include "cli/conventions.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  sculpt::cli::set_program("sculptctl");
  CLI::App app{"sculptctl: inspect scene and mesh files, talk to a running sculptd"};
  sculpt::cli::apply_conventions(app);
  app.require_subcommand(0, 1);  // no command: cli::parse names the commands
  sculpt::ctl::add_inspect_command(app);
  sculpt::ctl::add_record_command(app);
  sculpt::ctl::add_replay_command(app);
  sculpt::ctl::add_status_command(app);
  sculpt::ctl::add_devices_command(app);
  sculpt::ctl::add_save_command(app);
  sculpt::ctl::add_control_commands(app);
  try {
    if (const auto status = sculpt::cli::parse(app, argc, argv)) return *status;
  } catch (const sculpt::ctl::CommandFailed& failed) {
    return failed.status;
  }
  return 0;
}
