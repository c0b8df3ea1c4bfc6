// One scene's simulation: the world, the sim thread's stages and what the
// streaming server shows of it, built completely before anything running is
// touched. Starting, loading and resetting all build one; a swap replaces the
// running one only once the new one exists (docs/daemon.md: a load is a
// transaction). Building may take seconds (a 2M-triangle mesh) and runs off
// the io thread (host/worker.hpp), so it reads nothing of the daemon's but
// its arguments.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>

#include "haptics/feedback_board.hpp"
#include "simloop/simulation_settings.hpp"
#include "host/sculpt_stages.hpp"
#include "scene/scene.hpp"
#include "server/daemon_control.hpp"
#include "server/published_state.hpp"
#include "sim/world.hpp"

namespace sculpt::daemon {

struct SceneBundle;

// A scene to build, and the bytes it was read from (keeper/scene_bundle.hpp).
struct SceneSource {
  scene::Scene scene;
  std::shared_ptr<SceneBundle> bundle;
};

struct Simulation {
  scene::Scene scene;
  std::shared_ptr<const SceneBundle> bundle;            // what it was built from
  std::shared_ptr<const scene::Scene> replica_scene;    // a copy for the keeper's replica (none: no keeper)
  double rate = 0;
  std::size_t tools = 0;
  std::unique_ptr<sim::World<float>> world;
  std::unique_ptr<SculptStages> stages;
  std::unique_ptr<server::PublishedState> published;  // ticks renumbered by start_at() at the swap
  std::unique_ptr<server::PublishedReader> reader;    // the server's view of it, filled
  server::SceneInfo info;          // what viewers get told about the scene
};

// Throws (scene::SceneError, std::invalid_argument) naming what is wrong;
// scene::build_world makes the checks every reader of a scene shares.
// `state` (Replica::state(), keeper/replica.hpp): where the world, the tools
// and the controls continue from (a recovered sculpt); empty: the scene as loaded.
Simulation build_simulation(scene::Scene scene, const simloop::SimulationSettings& settings, haptics::FeedbackBoard& board,
                            std::span<const std::byte> state = {});

// What streaming clients need to know about a scene that never changes while it is loaded.
server::SceneInfo scene_info(const scene::Scene& s, double rate_hz);

}  // namespace sculpt::daemon
