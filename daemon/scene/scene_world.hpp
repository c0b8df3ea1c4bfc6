// A scene as the simulation runs it. Every check sculptd makes before it
// runs a scene is here, so that starting, `sculptd --check`, `sculptctl
// inspect` and `sculptctl load` accept exactly the same scenes: the file's
// own checks (scene.hpp), then the world built from it (every mesh added as
// a body with its material), at the rate it will run.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "scene/scene.hpp"
#include "sim/world.hpp"

namespace sculpt::scene {

// The world of `scene` at `rate_hz` (the scene's, or a command line's),
// with one tool slot per tool. Throws SceneError naming the scene and what
// is wrong: a rate out of [kMinRateHz, kMaxRateHz], no meshes, more tools
// than can be driven, a mesh or material the world refuses.
std::unique_ptr<sim::World<float>> build_world(const Scene& scene, double rate_hz);

// A short run of `world` with no tool touching it, from a small nudge of one
// vertex per mesh: a mesh that blows up here (the guard restores it) will
// blow up in use. One entry per mesh: "" when it held, else a warning naming
// its material and what to change. Steps the world (build one for this).
std::vector<std::string> probe_stability(sim::World<float>& world, const Scene& scene);

}  // namespace sculpt::scene
