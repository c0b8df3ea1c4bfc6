// What a scene's meshes and [[tool]] tables mean to the tool driver and the
// input router: the mesh box, the driver's specs, the router's routes. One
// reading, used by sculptd and by the tick profiler (tests/bench), so the
// profiler drives its tools exactly as the daemon does.
//
// Header-only glue: whoever includes it also depends on sculpt_scene and
// sculpt_input (the loop library itself needs neither).
#pragma once

#include <vector>

#include "input/mapping.hpp"
#include "simloop/simulation_settings.hpp"
#include "simloop/tool_driver.hpp"
#include "scene/scene.hpp"

namespace sculpt::simloop {

// The box of every mesh's vertices (all zero for a scene without vertices).
inline Box mesh_bounds(const scene::Scene& s) {
  Box b{{0, 0, 0}, {0, 0, 0}};
  bool any = false;
  for (const auto& m : s.meshes)
    for (const auto& p : m.loaded.mesh.positions)
      for (int a = 0; a < 3; ++a) {
        const double v = p[a];
        if (!any || v < b.lo[a]) b.lo[a] = v;
        if (!any || v > b.hi[a]) b.hi[a] = v;
        any = any || a == 2;
      }
  return b;
}

inline std::vector<ToolSpec> tool_specs(const scene::Scene& s) {
  std::vector<ToolSpec> out;
  for (const auto& t : s.tools) {
    ToolSpec spec;
    spec.shape = t.shape == scene::ToolShape::capsule ? sim::ToolShape::capsule : sim::ToolShape::sphere;
    spec.radius = t.radius;
    spec.half_length = t.half_length;
    spec.position = t.position;
    spec.speed = t.speed;
    out.push_back(spec);
  }
  return out;
}

inline std::vector<input::ToolRoute> tool_routes(const scene::Scene& s) {
  std::vector<input::ToolRoute> out;
  for (const auto& t : s.tools) {
    input::ToolRoute r;
    r.device = t.device;
    r.device_name = t.device_name;
    r.stick = t.stick == scene::Stick::right ? input::Stick::right
              : t.stick == scene::Stick::main ? input::Stick::main
                                              : input::Stick::left;
    out.push_back(r);
  }
  return out;
}

// The scene's tools as the driver moves them, within the settings' limits.
inline ToolDriver tool_driver(const scene::Scene& scene, const SimulationSettings& settings, double rate) {
  const auto specs = tool_specs(scene);
  DriverLimits limits;
  limits.bounds = tool_bounds(mesh_bounds(scene), specs, settings.tool_margin);
  limits.size_step = settings.size_step;
  limits.min_scale = settings.min_scale;
  limits.max_scale = settings.max_scale;
  return ToolDriver(specs, limits, rate);
}

}  // namespace sculpt::simloop
