#include "scene/scene_world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace sculpt::scene {

std::unique_ptr<sim::World<float>> build_world(const Scene& scene, double rate_hz) {
  const std::string name = scene.file.string();
  if (!(rate_hz >= kMinRateHz && rate_hz <= kMaxRateHz))
    throw SceneError(scene.file, 0, fmt::format("rate {} Hz is outside [{}, {}] Hz", rate_hz, kMinRateHz, kMaxRateHz));
  if (scene.meshes.empty()) throw SceneError(scene.file, 0, "the scene has no meshes: nothing to sculpt");
  if (scene.tools.size() > sim::kMaxTools)
    throw SceneError(scene.file, 0, fmt::format("{} tools, at most {} can be driven", scene.tools.size(), sim::kMaxTools));
  sim::SimSettings settings = scene.settings;
  settings.rate_hz = rate_hz;
  std::unique_ptr<sim::World<float>> world;
  try {
    world = std::make_unique<sim::World<float>>(settings, static_cast<int>(std::max<std::size_t>(scene.tools.size(), 1)));
  } catch (const std::invalid_argument& e) {
    throw SceneError(scene.file, 0, fmt::format("[simulation]: {}", e.what()));
  }
  for (const SceneMesh& m : scene.meshes) {
    try {
      world->add_body(m.loaded.mesh, scene.material_of(m));
    } catch (const std::invalid_argument& e) {
      throw SceneError(scene.file, m.line, fmt::format("mesh '{}': {}", m.name, e.what()));
    }
  }
  return world;
}

std::vector<std::string> probe_stability(sim::World<float>& world, const Scene& scene) {
  // A tenth of a second, at most 200 ticks: an unstable step grows a
  // rounding error by orders of magnitude every few ticks.
  const int ticks = static_cast<int>(std::clamp(world.settings().rate_hz / 10.0, 10.0, 200.0));
  std::vector<std::uint64_t> before(world.body_count());
  std::vector<int> substeps(world.body_count());  // the guard raises them as it restores
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    before[b] = world.body(b).blowups;
    substeps[b] = world.substeps(b);
    world.wake_all(b);
    // A nudge of a thousandth of the mesh's size: an exact rest shape has no
    // forces to grow.
    const auto& positions = scene.meshes[b].loaded.mesh.positions;
    if (positions.empty()) continue;
    float lo = positions[0][1], hi = positions[0][1];
    for (const auto& p : positions) lo = std::min(lo, p[1]), hi = std::max(hi, p[1]);
    const sim::Vec3d at = world.position(b, 0);
    world.set_state(b, 0, {at[0], at[1] + 1e-3 * std::max(1e-3, static_cast<double>(hi - lo)), at[2]}, {0, 0, 0});
  }
  for (int t = 0; t < ticks; ++t) world.step({});
  std::vector<std::string> warnings(world.body_count());
  for (std::size_t b = 0; b < world.body_count() && b < scene.meshes.size(); ++b) {
    const std::uint64_t n = world.body(b).blowups - before[b];
    if (n == 0) continue;
    const SceneMesh& m = scene.meshes[b];
    const sim::Material& mat = scene.material_of(m);
    const auto& g = scene.settings.gravity;
    const double gravity = mat.gravity ? std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) : 0;
    warnings[b] = fmt::format(
        "mesh '{}' blew up {} time(s) in {} ticks with no tool touching it (material '{}': stiffness {:g}, mass "
        "{:g}, gravity {:g} m/s^2, {} substeps{}): the simulation will restore it again and again; lower the "
        "stiffness or the gravity, raise the mass, or let substeps be \"auto\"",
        m.name, n, ticks, m.material, mat.stiffness, mat.mass, gravity, substeps[b],
        scene.settings.substeps > 0 ? " fixed" : "");
  }
  return warnings;
}

}  // namespace sculpt::scene
