// The tools a person drives, and what the simulation says back about them.
#pragma once

#include <array>
#include <cstdint>

namespace sculpt::sim {

using Vec3d = std::array<double, 3>;

enum class ToolShape { sphere, capsule };

struct Tool {
  bool active = true;
  ToolShape shape = ToolShape::sphere;
  double radius = 0.01;      // m
  Vec3d position{};          // centre (sphere) or middle of the axis (capsule), m
  Vec3d half_axis{};         // capsule: the axis runs position ± half_axis; ignored for spheres
  Vec3d velocity{};          // m/s: only used the first tick a tool appears (sweep start = position − v·dt);
                             // afterwards motion is taken from the poses themselves
  bool grab = false;         // held: pull the vertices within reach at the moment it was pressed
};

// Per tool, per tick: what the haptics need.
struct ToolFeedback {
  Vec3d force{};             // N: net reaction of the meshes on the tool (push and pull), tick average
  std::uint32_t contacts = 0;  // vertices pushed this tick, or held by a grab
  bool onset = false;        // contact began this tick (0 contacts last tick)
  double onset_impulse = 0;  // N·s: |force|·dt on the onset tick, for a rumble kick
  bool ignored = false;      // the input was not finite or not sensible (radius <= 0): tool skipped
};

}  // namespace sculpt::sim
