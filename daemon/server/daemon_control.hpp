// What the server asks of the daemon (implemented by daemon/main on the io
// thread), and the static description of the loaded scene it streams.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <kj/async.h>

#include "loop/stats_json.hpp"

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
  loop::StatsSnapshot stats;              // viewers and bytes_sent are filled in by the server
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
  // What the sim thread runs now (pause answers once this agrees: a snapshot
  // taken after pause() returns is the final state).
  virtual bool paused_now() = 0;
};

}  // namespace sculpt::server
