// sculptctl: the command-line companion of sculptd.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"sculptctl: inspect scene and mesh files, talk to a running sculptd"};
  app.require_subcommand(1);
  sculpt::ctl::add_inspect_command(app);
  sculpt::ctl::add_record_command(app);
  sculpt::ctl::add_replay_command(app);
  sculpt::ctl::add_status_command(app);
  sculpt::ctl::add_devices_command(app);
  sculpt::ctl::add_save_command(app);
  sculpt::ctl::add_control_commands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const sculpt::ctl::CommandFailed& failed) {
    return failed.status;
  }
  return 0;
}
