#include "main/control_desk.hpp"

#include <cmath>
#include <filesystem>

#include "simloop/stats.hpp"
#include "keeper/scene_bundle.hpp"

namespace sculpt::daemon {

server::DaemonStatus ControlDesk::status() {
  server::DaemonStatus d;
  const simloop::LoopStats& stats = sims_.stats();
  d.stats = simloop::reading(stats, sims_.rate());
  const simloop::LatencyHistogram& j = stats.jitter;
  for (std::size_t i = 0; i < simloop::LatencyHistogram::kBuckets; ++i)
    if (const std::uint64_t n = j.bucket(i))
      d.jitter.push_back({simloop::LatencyHistogram::lower_bound(i), simloop::LatencyHistogram::upper_bound(i), n});
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
  return load_(
      [path] {
        auto bundle = std::make_shared<SceneBundle>(read_bundle(path, {}));
        return SceneSource{load_bundle(*bundle), std::move(bundle)};
      },
      "load scene");
}

kj::Promise<std::string> ControlDesk::reset() {
  // The scene as loaded, again (meshes keep their loaded shapes in it),
  // copied on the worker: only a swap changes the installed scene, and none
  // runs while a load does.
  return load_([this] { return SceneSource{sims_.scene(), std::make_shared<SceneBundle>(*sims_.bundle())}; }, "reset");
}

namespace {
constexpr const char* kNoStore = "the daemon keeps no store (--no-store, or a replay without --state-dir): no history";
}  // namespace

kj::Promise<server::HistoryMoveOutcome> ControlDesk::move_history(bool undo, std::uint32_t count) {
  if (!keeper_) return server::HistoryMoveOutcome{kNoStore};
  // A paused loop runs no tick, and stroke images go into the world between ticks.
  if (sims_.paused()) return server::HistoryMoveOutcome{std::string("the sculpt is paused: resume it to ") + (undo ? "undo" : "redo")};
  return (undo ? keeper_->undo(count) : keeper_->redo(count)).then([](HistoryMoveResult r) {
    return server::HistoryMoveOutcome{std::move(r.error), r.done, r.tick};
  });
}

kj::Promise<server::HistoryMoveOutcome> ControlDesk::undo(std::uint32_t count) { return move_history(true, count); }
kj::Promise<server::HistoryMoveOutcome> ControlDesk::redo(std::uint32_t count) { return move_history(false, count); }

server::History ControlDesk::history(std::uint32_t from, std::uint32_t limit) {
  server::History h;
  if (!keeper_) return h;
  const HistoryInfo info = keeper_->history(from, limit);
  h.budget_bytes = info.budget;
  h.used_bytes = info.used;
  h.dropped = info.dropped;
  h.total = info.total;
  h.older = info.older;
  h.newer = info.newer;
  h.entries.reserve(info.strokes.size());
  for (const StrokeInfo& s : info.strokes) {
    server::HistoryEntry e;
    e.number = s.number;
    e.mesh = s.body;
    e.mesh_name = s.mesh_name;
    for (std::uint32_t t = 0; t < 64; ++t)
      if ((s.tools >> t) & 1u) e.tools.push_back(t);
    e.first_tick = s.first_tick;
    e.end_tick = s.end_tick;
    e.vertices = s.vertices;
    e.bytes = s.bytes;
    e.undone = s.undone;
    h.entries.push_back(std::move(e));
  }
  return h;
}

kj::Promise<server::ExportOutcome> ControlDesk::export_sculpt() {
  if (!keeper_) return server::ExportOutcome{kNoStore};
  return keeper_->export_sculpt().then([](ExportResult r) {
    return server::ExportOutcome{std::move(r.error), r.fd, r.bytes};
  });
}

}  // namespace sculpt::daemon
