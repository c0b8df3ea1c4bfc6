// The built-in default scene: a TOML text like any scene file, so the same
// parser (and the same documentation) covers it. docs/scene-format.md shows it.
#include "scene/scene.hpp"

namespace sculpt::scene {

std::string_view default_scene_text() {
  return R"toml(# sculptd's built-in default scene: a rubber ball, a jelly torus and a slab of
# clay in a row, and two tools for a gamepad's two sticks.
version = 1

[simulation]
rate_hz = 1000
substeps = "auto"

[[mesh]]
name = "ball"
file = "builtin:icosphere"
params = { radius = 0.07, subdivisions = 3 }
material = "rubber"
position = [-0.2, 0.0, 0.0]

[[mesh]]
name = "torus"
file = "builtin:torus"
params = { major_radius = 0.07, minor_radius = 0.028, rings = 40, sides = 20 }
material = "jelly"
rotation = [60.0, 0.0, 0.0]

[[mesh]]
name = "clay"
file = "builtin:box"
params = { size = [0.14, 0.06, 0.14], cells = 12 }
material = "clay"
position = [0.2, 0.0, 0.0]

[[tool]]
name = "left"
shape = "sphere"
radius = 0.02
device = 0
stick = "left"
position = [-0.15, 0.15, 0.05]

[[tool]]
name = "right"
shape = "capsule"
radius = 0.012
half_length = 0.03
device = 0
stick = "right"
position = [0.15, 0.15, 0.05]
)toml";
}

}  // namespace sculpt::scene
