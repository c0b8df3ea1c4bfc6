// sculptctl: the command-line companion of sculptd. This file is its whole
// command line: every command, its options, and what it runs (commands.hpp).
#include <tuple>

#include <CLI/CLI.hpp>

#include "cli/conventions.hpp"
#include "commands.hpp"

namespace sculpt::ctl {
namespace {

// --socket and --json, on every command that talks to a running sculptd.
void add_daemon_options(CLI::App& cmd, DaemonArgs& args) {
  cmd.add_option("--socket", args.socket,
                 "sculptd's socket (default: $SCULPTD_SOCKET, $RUNTIME_DIRECTORY/sculptd.sock, "
                 "$XDG_RUNTIME_DIR/sculptd/sculptd.sock, /run/sculptd/sculptd.sock)")
      ->type_name("PATH");
  cmd.add_flag("--json", args.json, "print JSON instead of text");
}

struct Args {
  InspectArgs inspect;
  RecordArgs record;
  ReplayArgs replay;
  DaemonArgs status, devices, reset, pause, resume;
  SaveArgs save;
  LoadArgs load;
  HistoryMoveArgs undo, redo;
  HistoryArgs history;
  ExportArgs exported;
  HapticsArgs haptics;
};

void add_commands(CLI::App& app, Args& a) {
  CLI::App* cmd = app.add_subcommand(
      "inspect", "load a mesh or scene file as sculptd would and report counts, bounds, material and substeps");
  cmd->add_option("FILE", a.inspect.file,
                  "mesh file (obj, ply, stl, gltf, glb, off, ...), scene .toml, or builtin:default");
  cmd->add_flag("--json", a.inspect.json, "one JSON object per mesh, one per line");
  cmd->add_flag("--formats", a.inspect.formats, "list the mesh file extensions that can be read");
  cmd->add_option("--material", a.inspect.material, "material preset for a lone mesh file (rubber, clay, jelly)");
  cmd->add_option("--weld-tolerance", a.inspect.weld_tolerance,
                  "weld distance as a fraction of the bounding-box diagonal (default 1e-5)");
  cmd->callback([&a] { inspect(a.inspect); });

  cmd = app.add_subcommand("record", "record the joysticks and gamepads into a recording");
  cmd->add_option("FILE", a.record.file, "recording to write (JSON Lines, docs/recording-format.md)")->required();
  cmd->add_option("--duration", a.record.duration, "seconds to record (default: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--wait-devices", a.record.wait_for, "wait until this many devices are present before starting");
  cmd->add_option("--wait-timeout", a.record.wait_timeout, "seconds to wait for them (default 10)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--discovery", a.record.discovery, "auto, udev or inotify (default auto)")
      ->check(CLI::IsMember({"auto", "udev", "inotify"}));
  cmd->add_flag("--all", a.record.all, "record every input device, not only joysticks and gamepads");
  cmd->add_flag("-v,--verbose", a.record.verbose, "log every device considered");
  cmd->callback([&a] { record(a.record); });

  cmd = app.add_subcommand(
      "replay", "play a recording through uinput (virtual devices that answer FF; needs /dev/uinput)");
  cmd->add_option("FILE", a.replay.file, "recording (docs/recording-format.md)")->required();
  cmd->add_option("--speed", a.replay.speed, "playback speed factor (default 1)")->check(CLI::PositiveNumber);
  cmd->add_option("--settle", a.replay.settle,
                  "seconds between creating the devices and the first frame, for clients to open them (default 1)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--hold", a.replay.hold, "seconds the devices stay after the last frame (default 0.5)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("-q,--quiet", a.replay.quiet, "no summary line");
  cmd->callback([&a] { replay(a.replay); });

  cmd = app.add_subcommand("status", "the running daemon's stats (rate, jitter, stages, viewers, devices)");
  add_daemon_options(*cmd, a.status);
  cmd->callback([&a] { status(a.status); });

  cmd = app.add_subcommand("devices", "the joysticks the running daemon knows (slot, node, force feedback, tools)");
  add_daemon_options(*cmd, a.devices);
  cmd->callback([&a] { devices(a.devices); });

  cmd = app.add_subcommand("save", "export the running daemon's current meshes (.obj .ply .stl .glb)");
  cmd->add_option("FILE", a.save.file, "where to write; the extension picks the format")->required();
  cmd->add_option("--mesh", a.save.mesh, "only this mesh (by name)");
  add_daemon_options(*cmd, a.save.daemon);
  cmd->callback([&a] { save(a.save); });

  cmd = app.add_subcommand("load", "load another scene into the running daemon (keeps the sculpt on failure)");
  cmd->add_option("SCENE", a.load.scene, "scene file (TOML) or builtin:default")->required();
  add_daemon_options(*cmd, a.load.daemon);
  cmd->callback([&a] { load(a.load); });

  for (auto [name, help, args, what] :
       {std::tuple{"undo", "undo the last N strokes (the daemon's history)", &a.undo, HistoryMove::undo},
        std::tuple{"redo", "redo the last N undone strokes", &a.redo, HistoryMove::redo}}) {
    cmd = app.add_subcommand(name, help);
    cmd->add_option("N", args->count, "how many strokes (default 1)")->check(CLI::Range(1u, kMaxHistoryMoveCount));
    add_daemon_options(*cmd, args->daemon);
    cmd->callback([args = args, what = what] { move_history(*args, what); });
  }

  cmd = app.add_subcommand("history", "the daemon's strokes (tools, mesh, ticks, vertices, undo data) and budget");
  cmd->add_option("--from", a.history.from, "list from stroke NUMBER on (default: the newest)")
      ->check(CLI::Range(1u, 0xffffffffu));
  cmd->add_option("--limit", a.history.limit, "at most N strokes (default 100, at most 16384)")
      ->check(CLI::Range(1u, kHistoryMaxLimit));
  add_daemon_options(*cmd, a.history.daemon);
  cmd->callback([&a] { history(a.history); });

  cmd = app.add_subcommand("export", "write the whole sculpt (scene, meshes, state, history) as one .sculpt file");
  cmd->add_option("FILE", a.exported.file, "where to write (FILE.sculpt); written atomically")->required();
  cmd->add_flag("--force", a.exported.force, "replace FILE if it exists");
  add_daemon_options(*cmd, a.exported.daemon);
  cmd->callback([&a] { export_sculpt(a.exported); });

  cmd = app.add_subcommand("haptics", "a device's force-feedback gain and hard limit, until the daemon restarts");
  cmd->add_option("SLOT", a.haptics.slot, "the device's slot (sculptctl devices)")->required();
  cmd->add_option("--gain", a.haptics.gain, "0..1: scales every level the device gets");
  cmd->add_option("--limit", a.haptics.limit, "0..1 of full: never exceeded, kicks included");
  add_daemon_options(*cmd, a.haptics.daemon);
  cmd->callback([&a] { haptics(a.haptics); });

  struct Simple {
    const char* name;
    const char* help;
    DaemonArgs& args;
    Control what;
  };
  for (const Simple& s : {Simple{"reset", "every mesh back to its shape as loaded", a.reset, Control::reset},
                          Simple{"pause", "stop simulating (the loop keeps its rate; viewers keep their stream)",
                                 a.pause, Control::pause},
                          Simple{"resume", "simulate again after pause", a.resume, Control::resume}}) {
    cmd = app.add_subcommand(s.name, s.help);
    add_daemon_options(*cmd, s.args);
    cmd->callback([&args = s.args, what = s.what] { control(args, what); });
  }
}

}  // namespace
}  // namespace sculpt::ctl

int main(int argc, char** argv) {
  using namespace sculpt;
  cli::set_program("sculptctl");
  CLI::App app{"sculptctl: inspect scene and mesh files, talk to a running sculptd"};
  cli::apply_conventions(app);
  app.require_subcommand(0, 1);  // no command: cli::parse names the commands
  ctl::Args args;
  ctl::add_commands(app, args);
  try {
    if (const auto status = cli::parse(app, argc, argv)) return *status;
  } catch (const ctl::CommandFailed& failed) {
    return failed.status;
  }
  return 0;
}
