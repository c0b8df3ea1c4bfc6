#include "main/control_desk.hpp"

#include <cmath>
#include <filesystem>

#include "loop/stats_json.hpp"

namespace sculpt::daemon {

server::DaemonStatus ControlDesk::status() {
  server::DaemonStatus d;
  const loop::LoopStats& stats = sims_.stats();
  d.stats = loop::snapshot(stats, sims_.rate());
  const loop::LatencyHistogram& j = stats.jitter;
  for (std::size_t i = 0; i < loop::LatencyHistogram::kBuckets; ++i)
    if (const std::uint64_t n = j.bucket(i))
      d.jitter.push_back({loop::LatencyHistogram::lower_bound(i), loop::LatencyHistogram::upper_bound(i), n});
  d.stats.devices = device_count();
  d.stats.ff_uploads = ff_uploads();
  d.paused = sims_.paused();
  d.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  d.scene = sims_.scene().file.string();
  d.sim_time_ns = static_cast<std::uint64_t>(std::llround(sims_.simulated_s() * 1e9));
  return d;
}

kj::Promise<std::string> ControlDesk::load_scene(const std::string& path) {
  if (path.empty()) return std::string("the scene path is empty");
  if (path != "builtin:default" && !std::filesystem::path(path).is_absolute())
    return "scene path must be absolute (the daemon's working directory is not yours): " + path;
  return load_([path] { return scene::load_scene(path); }, "load scene");
}

kj::Promise<std::string> ControlDesk::reset() {
  // The scene as loaded, again (meshes keep their loaded shapes in it),
  // copied on the worker: only a swap changes the installed scene, and none
  // runs while a load does.
  return load_([this] { return sims_.scene(); }, "reset");
}

kj::Promise<server::EditOutcome> ControlDesk::undo(std::uint32_t) {
  return server::EditOutcome{"undo is not available yet"};
}

kj::Promise<server::EditOutcome> ControlDesk::redo(std::uint32_t) {
  return server::EditOutcome{"redo is not available yet"};
}

server::History ControlDesk::history() { return {}; }

kj::Promise<server::ExportOutcome> ControlDesk::export_sculpt() {
  return server::ExportOutcome{"export is not available yet"};
}

}  // namespace sculpt::daemon
