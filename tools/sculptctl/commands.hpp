// sculptctl's commands: what each one takes and runs, one file each. The
// command line that fills these in is main.cpp, the only file that includes
// CLI11 (it costs seconds of compile time in every file that does). A new
// command is a new file, its Args here, and its options in main.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace sculpt::ctl {

// Exit statuses every command shares (daemon_link.hpp adds those of the
// commands that talk to a running sculptd).
inline constexpr int kExitCommandFailed = 1;
inline constexpr int kExitUsage = 2;

// Commands report failure by printing one line to stderr and throwing this;
// main turns it into the exit status.
struct CommandFailed {
  int status = kExitCommandFailed;
};

// `inspect FILE [--json]`: offline report of a mesh or scene file (inspect.cpp).
struct InspectArgs {
  std::string file;
  bool json = false;
  bool formats = false;
  std::string material = "rubber";
  std::optional<double> weld_tolerance;
};
void inspect(const InspectArgs& args);

// `record FILE`: the joysticks into a recording (record.cpp).
struct RecordArgs {
  std::string file;
  double duration = 0;        // 0: until a signal
  std::size_t wait_for = 0;   // start the clock once this many devices are there
  double wait_timeout = 10;
  bool all = false;
  bool verbose = false;
  std::string discovery = "auto";
};
void record(const RecordArgs& args);

// `replay FILE`: a recording through uinput (replay.cpp).
struct ReplayArgs {
  std::string file;
  double speed = 1.0;
  double settle = 1.0;   // seconds between creating the devices and the first frame
  double hold = 0.5;     // seconds the devices stay after the last frame
  bool quiet = false;
};
void replay(const ReplayArgs& args);

// Against a running sculptd: --socket and --json (daemon_link.hpp).
struct DaemonArgs {
  std::string socket;  // "" : the usual rule (client/socket_path.hpp)
  bool json = false;
};
void status(const DaemonArgs& args);   // status.cpp
void devices(const DaemonArgs& args);  // status.cpp

// `save FILE [--mesh NAME]` (save.cpp).
struct SaveArgs {
  DaemonArgs daemon;
  std::string file;
  std::string mesh;  // "": every mesh
};
void save(const SaveArgs& args);

// `load SCENE`, `reset`, `pause`, `resume` (control.cpp).
struct LoadArgs {
  DaemonArgs daemon;
  std::string scene;
};
void load(const LoadArgs& args);
enum class Control { reset, pause, resume };
void control(const DaemonArgs& args, Control what);

// `undo [N]`, `redo [N]` and `history` (history.cpp): the daemon's strokes.
inline constexpr std::uint32_t kMaxHistoryMoveCount = 10000;  // the daemon's max_history_move_count
struct HistoryMoveArgs {
  DaemonArgs daemon;
  std::uint32_t count = 1;
};
enum class HistoryMove { undo, redo };
void move_history(const HistoryMoveArgs& args, HistoryMove what);
inline constexpr std::uint32_t kHistoryDefaultLimit = 100;
inline constexpr std::uint32_t kHistoryMaxLimit = 16384;  // the daemon's page, at most
struct HistoryArgs {
  DaemonArgs daemon;
  std::uint32_t from = 0;                       // 0: the newest
  std::uint32_t limit = kHistoryDefaultLimit;
};
void history(const HistoryArgs& args);

// `export FILE [--force]` (export.cpp): the whole sculpt as one .sculpt file.
struct ExportArgs {
  DaemonArgs daemon;
  std::string file;
  bool force = false;
};
void export_sculpt(const ExportArgs& args);

// `haptics SLOT [--gain G] [--limit L]` (haptics.cpp): a device's
// force-feedback tuning, each 0..1 of full.
struct HapticsArgs {
  DaemonArgs daemon;
  std::uint32_t slot = 0;
  std::optional<double> gain, limit;
};
void haptics(const HapticsArgs& args);

}  // namespace sculpt::ctl
