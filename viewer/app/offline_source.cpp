// Offline input: a scene file through daemon/scene, shown as loaded. Handy
// without a daemon, and deterministic (the golden images use it).
#include <fmt/format.h>

#include <chrono>
#include <stdexcept>
#include <thread>

#include "app/source.hpp"
#include "scene/scene.hpp"

namespace sculpt::view {

void fill_from_scene_file(ViewModel& model, const std::string& scene_file) {
  scene::Scene s;
  try {
    s = scene::load_scene(scene_file);
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what());  // SceneError/LoadError already name file:line and key
  }
  model = ViewModel{};
  model.scene = scene_file;
  std::uint32_t id = 0;
  for (const auto& m : s.meshes) {
    std::vector<float> xyz;
    xyz.reserve(m.loaded.mesh.positions.size() * 3);
    for (const auto& p : m.loaded.mesh.positions) xyz.insert(xyz.end(), p.begin(), p.end());
    std::vector<std::uint32_t> tris;
    tris.reserve(m.loaded.mesh.triangles.size() * 3);
    for (const auto& t : m.loaded.mesh.triangles) tris.insert(tris.end(), t.begin(), t.end());
    model.meshes.emplace_back(id++, m.name, m.material, std::move(tris), xyz, xyz);
  }
  std::uint32_t tool_id = 0;
  for (const auto& t : s.tools) {
    ViewTool v;
    v.id = tool_id++;
    v.shape = t.shape == scene::ToolShape::capsule ? ToolShape::capsule : ToolShape::sphere;
    v.radius = static_cast<float>(t.radius);
    v.half_length = static_cast<float>(t.half_length);
    v.position = {static_cast<float>(t.position[0]), static_cast<float>(t.position[1]), static_cast<float>(t.position[2])};
    // Capsules start upright (sculptd's ToolDriver): +x turned onto +y.
    if (v.shape == ToolShape::capsule) v.orientation = {0.70710678f, 0.0f, 0.0f, 0.70710678f};
    model.tools.push_back(v);
  }
  model.scene_bounds = model.bounds_now();
  model.generation = 1;
}

namespace {

class OfflineSource final : public Source {
 public:
  explicit OfflineSource(const std::string& file) { fill_from_scene_file(model_, file); }

  void pump(double timeout_s) override {
    // Nothing ever arrives: just let the caller's frame pacing pass.
    if (timeout_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(timeout_s));
  }
  bool has_state() const override { return true; }
  std::vector<std::string> describe() const override {
    std::size_t vertices = 0, triangles = 0;
    for (const auto& m : model_.meshes) {
      vertices += m.vertex_count();
      triangles += m.triangle_count();
    }
    return {fmt::format("OFFLINE  {}", model_.scene),
            fmt::format("{} MESHES  {} VERTICES  {} TRIANGLES  {} TOOLS", model_.meshes.size(), vertices, triangles,
                        model_.tools.size())};
  }
};

}  // namespace

std::unique_ptr<Source> make_offline_source(const std::string& scene_file) {
  return std::make_unique<OfflineSource>(scene_file);
}

}  // namespace sculpt::view
