// What the server asks of the daemon (implemented by daemon/main on the io
// thread), and the static description of the loaded scene it streams.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <kj/async.h>

#include "simloop/stats.hpp"

namespace sculpt::server {

struct MeshInfo {
  std::string name;
  std::vector<std::uint32_t> triangles;   // 3 per triangle, file order
  std::vector<float> rest;                // x,y,z per vertex, as loaded
  // Material (proto::Material).
  std::string material;
  bool linear_model = false;
  float mass = 0, stiffness = 0, damping = 0, anchor = 0, yield_strain = 0;
  bool plastic = false, gravity = false;
};

struct ToolInfo {
  bool capsule = false;
  float radius = 0, half_length = 0;
  std::int32_t device_slot = -1;
};

struct SceneInfo {
  std::string scene;                      // path or "builtin:default"
  double rate_hz = 0;
  std::vector<MeshInfo> meshes;           // body i of the world is meshes[i]
  std::vector<ToolInfo> tools;
};

struct HistogramBucket {
  std::uint64_t lower_ns = 0, upper_ns = 0, count = 0;
};

struct DaemonStatus {
  simloop::StatsReading stats;              // viewers and bytes_sent are filled in by the server
  std::vector<HistogramBucket> jitter;    // non-empty buckets of the loop's jitter histogram
  bool paused = false;
  double uptime_s = 0;
  std::string scene;
  std::uint64_t sim_time_ns = 0;
};

struct DeviceEntry {
  std::uint32_t slot = 0;
  std::string name, node, kind;
  std::uint16_t vendor = 0, product = 0;
  bool connected = false;
  int ff = 0;                             // 0 none, 1 rumble, 2 constant
  std::vector<std::uint32_t> tools;
  std::uint64_t ff_uploads = 0;
  std::string bus;                        // "usb", "bluetooth", "virtual", ... ("" unknown)
  double gain = 1.0, limit = 1.0;         // force-feedback tuning, 0..1 of full
};

// What tune_haptics asks: each value set is 0..1 (the daemon checks).
struct HapticsTune {
  std::optional<double> gain, limit;
};

struct HapticsTuneOutcome {
  std::string error;                      // "" on success, else why not
  double gain = 1.0, limit = 1.0;         // the slot's tuning now
};

// One stroke of the history (proto::HistoryEntry): one tool's contact with a
// mesh from onset to release.
struct HistoryEntry {
  std::uint32_t number = 0;        // stroke number, counting from 1 since the daemon's store was made
  std::uint32_t mesh = 0;          // body index; mesh_name its name
  std::string mesh_name;
  std::vector<std::uint32_t> tools;  // tool slots that took part
  std::uint64_t first_tick = 0, end_tick = 0;  // onset, release
  std::uint64_t vertices = 0;      // vertices the stroke changed
  std::uint64_t bytes = 0;         // memory its undo data takes
  bool undone = false;             // on the redo side
};

// One page of the history.
struct History {
  std::vector<HistoryEntry> entries;   // oldest first
  std::uint64_t budget_bytes = 0, used_bytes = 0;
  std::uint64_t dropped = 0;           // strokes that fell off the budget so far
  std::uint64_t total = 0;             // strokes held
  std::uint64_t older = 0, newer = 0;  // held strokes before and after this page
};

struct HistoryMoveOutcome {
  std::string error;                   // "" on success, else why (nothing to undo, the stroke was made before a scene reload at tick N, ...)
  std::uint32_t done = 0;              // strokes undone/redone
  std::uint64_t tick = 0;              // tick at which it applied
};

struct ExportOutcome {
  std::string error;
  // A readable regular file (the daemon keeps no path to it: an unlinked or
  // O_TMPFILE file, or a memfd) whose size is `bytes`; on success the server
  // owns it and closes it (also when the client has gone meanwhile). On
  // error, -1 (the server closes one given anyway).
  int fd = -1;
  std::uint64_t bytes = 0;
};

class DaemonControl {
 public:
  virtual ~DaemonControl() = default;
  virtual DaemonStatus status() = 0;
  virtual std::vector<DeviceEntry> devices() = 0;
  // Each resolves to "" on success, else what went wrong (naming the
  // file/field); the running sculpt is untouched on failure. The work runs
  // off the io loop, which serves everyone meanwhile.
  virtual kj::Promise<std::string> load_scene(const std::string& path) = 0;
  virtual kj::Promise<std::string> reset() = 0;
  // Asks; the sim thread applies it at its next tick boundary.
  virtual std::string set_paused(bool paused) = 0;
  // What the sim thread runs now (pause answers once this agrees: a keyframe
  // taken after pause() returns is the final state).
  virtual bool paused_now() = 0;

  // Undo / redo the last `count` strokes (the server passes 1 ≤ count ≤
  // ServerOptions::max_history_move_count only, at most a few calls per client at a
  // time). HistoryMoveOutcome.error says why not ("" when done).
  virtual kj::Promise<HistoryMoveOutcome> undo(std::uint32_t count) = 0;
  virtual kj::Promise<HistoryMoveOutcome> redo(std::uint32_t count) = 0;
  // One page of the stroke history now: the strokes numbered `from` and up
  // (0: the newest), at most `limit` (the server passes 1 ≤ limit ≤
  // ServerOptions::max_history_entries). Runs on the io loop: it must cost
  // the page, not the whole history.
  virtual History history(std::uint32_t from, std::uint32_t limit) = 0;
  // The whole sculpt as one .sculpt file (written off the io loop). The
  // server asks at most ServerOptions::max_exports at a time (open readers
  // included).
  virtual kj::Promise<ExportOutcome> export_sculpt() = 0;
  // A device slot's force-feedback gain and limit (run-time, not saved).
  virtual HapticsTuneOutcome tune_haptics(std::uint32_t slot, const HapticsTune& tune) = 0;
};

}  // namespace sculpt::server
