// One tool's path through a tick as the world sees it (internal to World and
// its stages): the pose at the start and end of the tick, its swept box, and
// what the meshes said back this tick.
#pragma once

#include <array>
#include <cstdint>

#include "sim/geometry.hpp"
#include "sim/tool.hpp"

namespace sculpt::sim {

template <class S>
struct ToolTrack {
  bool active = false;
  bool known = false;  // a pose from the previous tick exists
  bool grab = false, grab_prev = false;
  ToolShape shape = ToolShape::sphere;
  S radius = 0;
  Vec3d c0{}, c1{}, a0{}, a1{};  // centre and half axis at the start and end of the tick
  std::array<S, 3> lo{}, hi{};   // swept box
  std::uint32_t prev_contacts = 0;
  Vec3d force{};  // accumulated this tick
  std::uint32_t contacts = 0;

  // The centre at fraction t of the tick.
  geometry::V3<S> centre(double t) const { return lerp(c0, c1, t); }
  geometry::V3<S> half_axis(double t) const { return lerp(a0, a1, t); }

 private:
  static geometry::V3<S> lerp(const Vec3d& a, const Vec3d& b, double t) {
    return {static_cast<S>(a[0] + (b[0] - a[0]) * t), static_cast<S>(a[1] + (b[1] - a[1]) * t),
            static_cast<S>(a[2] + (b[2] - a[2]) * t)};
  }
};

}  // namespace sculpt::sim
