#include "host/simulation.hpp"

#include "simloop/scene_tools.hpp"
#include "keeper/replica.hpp"
#include "scene/scene_world.hpp"

namespace sculpt::daemon {

Simulation build_simulation(scene::Scene scene, const simloop::SimulationSettings& settings, haptics::FeedbackBoard& board,
                            std::span<const std::byte> state) {
  simloop::check_settings(settings);
  Simulation s;
  s.rate = settings.rate_hz.value_or(scene.settings.rate_hz);
  s.tools = scene.tools.size();
  s.world = scene::build_world(scene, s.rate);
  s.stages = std::make_unique<SculptStages>(simloop::tool_driver(scene, settings, s.rate), board, settings.ring_capacity);
  if (!state.empty()) {
    const ReplicaState parts = split_replica_state(state);
    s.world->restore_state(parts.world);
    s.stages->driver().restore_state(parts.driver);
    s.stages->mapper().restore_state(parts.mapper);
  }
  s.published = std::make_unique<server::PublishedState>(*s.world, s.rate);
  s.stages->set_published(s.published.get());
  s.reader = std::make_unique<server::PublishedReader>(*s.published);
  s.info = scene_info(scene, s.rate);
  s.scene = std::move(scene);
  return s;
}

server::SceneInfo scene_info(const scene::Scene& s, double rate_hz) {
  server::SceneInfo info;
  info.scene = s.file.string();
  info.rate_hz = rate_hz;
  for (const auto& m : s.meshes) {
    server::MeshInfo mi;
    mi.name = m.name;
    const auto& mesh = m.loaded.mesh;
    mi.triangles.reserve(mesh.triangles.size() * 3);
    for (const auto& t : mesh.triangles) mi.triangles.insert(mi.triangles.end(), t.begin(), t.end());
    mi.rest.reserve(mesh.positions.size() * 3);
    for (const auto& p : mesh.positions) mi.rest.insert(mi.rest.end(), p.begin(), p.end());
    const sim::Material& mat = s.material_of(m);
    mi.material = m.material;
    mi.linear_model = mat.model != sim::ForceModel::spring;
    mi.mass = static_cast<float>(mat.mass);
    mi.stiffness = static_cast<float>(mat.stiffness);
    mi.damping = static_cast<float>(mat.damping);
    mi.anchor = static_cast<float>(mat.anchor);
    mi.plastic = mat.plastic;
    mi.yield_strain = static_cast<float>(mat.yield_strain);
    mi.gravity = mat.gravity;
    info.meshes.push_back(std::move(mi));
  }
  for (const auto& t : s.tools) {
    server::ToolInfo ti;
    ti.capsule = t.shape == scene::ToolShape::capsule;
    ti.radius = static_cast<float>(t.radius);
    ti.half_length = static_cast<float>(t.half_length);
    ti.device_slot = -1;
    info.tools.push_back(ti);
  }
  return info;
}

}  // namespace sculpt::daemon
