// Controls → tool poses: what a stick deflection, a held button and a few
// presses mean for the tool a person drives. Velocity control (full
// deflection = the tool's speed), the tool kept inside the scene's bounds
// grown by a margin, a shape switch, size steps within limits, and grab.
//
// Runs on the sim thread once per tick: no allocation after construction.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/limits.hpp"
#include "sim/tool.hpp"

namespace sculpt::sim {
class StateView;
}

namespace sculpt::simloop {

using Vec3d = std::array<double, 3>;

struct Box {
  Vec3d lo{0, 0, 0};
  Vec3d hi{0, 0, 0};
};

// One tool's starting state (from the scene's [[tool]] table).
struct ToolSpec {
  sim::ToolShape shape = sim::ToolShape::sphere;
  double radius = 0.02;        // m
  double half_length = 0.04;   // m, capsule: centre to cap centre
  Vec3d position{0, 0.2, 0};   // m
  double speed = 0.5;          // m/s at full deflection
};

struct DriverLimits {
  Box bounds;                  // the tools' centres stay inside (scene box + margin)
  double size_step = 1.15;     // each grow/shrink press scales the radius (and capsule length) by this
  double min_scale = 0.25;     // radius stays within [min_scale, max_scale] × its starting value
  double max_scale = 4.0;
};

// What the driver needs from a control (input::ToolControl has these fields).
struct DriveInput {
  std::array<float, 3> stick{};   // -1..1 per tool axis, calibrated
  bool grab = false;
  std::uint32_t shape_toggles = 0;  // monotonic press counters
  std::int32_t size_steps = 0;      // grow presses minus shrink presses, monotonic sum
  bool connected = false;
};

class ToolDriver {
 public:
  // Throws std::invalid_argument naming the bad value (tool index and field).
  ToolDriver(std::vector<ToolSpec> tools, const DriverLimits& limits, double rate_hz);

  std::size_t size() const { return state_.size(); }

  // One tick: inputs[t] drives tool t (missing inputs: disconnected). Writes
  // the poses to out (out.size() >= size()). Allocation-free.
  void update(std::span<const DriveInput> inputs, std::span<sim::Tool> out);

  // Any control type with DriveInput's fields (input::ToolControl), converted
  // in place without allocating (up to sim::kMaxTools per call).
  template <class Control>
  void update_from(std::span<const Control> controls, std::span<sim::Tool> out) {
    std::array<DriveInput, sim::kMaxTools> in{};
    const std::size_t n = controls.size() < sim::kMaxTools ? controls.size() : sim::kMaxTools;
    for (std::size_t i = 0; i < n; ++i) {
      const Control& c = controls[i];
      in[i] = DriveInput{{c.stick[0], c.stick[1], c.stick[2]}, c.grab, c.shape_toggles, c.size_steps, c.connected};
    }
    update({in.data(), n}, out);
  }

  // The current pose of tool t (also what the last update wrote).
  const sim::Tool& tool(std::size_t t) const { return state_[t].tool; }
  const DriverLimits& limits() const { return limits_; }
  double dt() const { return dt_; }  // s per tick

  // The tools' poses and what the driver remembers of their controls, as
  // bytes (allocates): a driver made from the same specs continues from
  // them exactly. restore_state throws std::invalid_argument naming what
  // does not match or cannot be (another tool, a pose outside the bounds, a
  // scale beyond the limits, a flag that is no flag), changing nothing.
  std::vector<std::byte> state() const;
  void restore_state(std::span<const std::byte> bytes);

 private:
  struct State {
    ToolSpec spec;
    sim::Tool tool;
    bool ever_connected = false;
    std::uint32_t toggles_seen = 0;
    std::int32_t steps_seen = 0;
    bool counters_known = false;   // the first control a device sends sets the baseline
    double scale = 1.0;
  };
  void check_state(const sim::StateView& view) const;

  DriverLimits limits_;
  double dt_;
  std::vector<State> state_;
};

// The scene's box (all meshes' vertices) grown by margin on every side, and
// grown further to hold every tool's start position.
Box tool_bounds(const Box& meshes, std::span<const ToolSpec> tools, double margin);

}  // namespace sculpt::simloop
