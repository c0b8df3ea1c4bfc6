#include "simloop/tool_driver.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <type_traits>
#include <stdexcept>
#include <string>

#include "sim/state_bytes.hpp"

namespace sculpt::simloop {
namespace {

bool finite3(const Vec3d& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

void set_half_axis(sim::Tool& tool, double half_length) {
  // Capsules stand upright (the scene's y axis), like a finger pressing down.
  tool.half_axis = tool.shape == sim::ToolShape::capsule ? Vec3d{0.0, half_length, 0.0} : Vec3d{0.0, 0.0, 0.0};
}

}  // namespace

ToolDriver::ToolDriver(std::vector<ToolSpec> tools, const DriverLimits& limits, double rate_hz)
    : limits_(limits), dt_(1.0 / rate_hz) {
  if (!(rate_hz > 0) || !std::isfinite(rate_hz)) throw std::invalid_argument("tool driver: rate_hz must be > 0");
  if (!(limits.size_step > 1.0) || !std::isfinite(limits.size_step))
    throw std::invalid_argument("tool driver: size_step must be > 1");
  if (!(limits.min_scale > 0) || !(limits.max_scale >= 1.0) || !(limits.min_scale <= 1.0))
    throw std::invalid_argument("tool driver: need 0 < min_scale <= 1 <= max_scale");
  if (!finite3(limits.bounds.lo) || !finite3(limits.bounds.hi))
    throw std::invalid_argument("tool driver: bounds must be finite");
  for (int a = 0; a < 3; ++a)
    if (limits.bounds.lo[a] > limits.bounds.hi[a]) throw std::invalid_argument("tool driver: bounds lo > hi");
  if (tools.size() > sim::kMaxTools)
    throw std::invalid_argument("tool driver: at most " + std::to_string(sim::kMaxTools) + " tools");
  state_.reserve(tools.size());
  for (std::size_t i = 0; i < tools.size(); ++i) {
    const ToolSpec& s = tools[i];
    const std::string where = "tool " + std::to_string(i) + ": ";
    if (!(s.radius > 0) || !std::isfinite(s.radius)) throw std::invalid_argument(where + "radius must be > 0");
    if (!(s.half_length >= 0) || !std::isfinite(s.half_length))
      throw std::invalid_argument(where + "half_length must be >= 0");
    if (!(s.speed >= 0) || !std::isfinite(s.speed)) throw std::invalid_argument(where + "speed must be >= 0");
    if (!finite3(s.position)) throw std::invalid_argument(where + "position must be finite");
    State st;
    st.spec = s;
    st.tool.active = false;  // until its device shows up
    st.tool.shape = s.shape;
    st.tool.radius = s.radius;
    st.tool.position = s.position;
    for (int a = 0; a < 3; ++a)
      st.tool.position[a] = std::clamp(st.tool.position[a], limits.bounds.lo[a], limits.bounds.hi[a]);
    set_half_axis(st.tool, s.half_length);
    state_.push_back(st);
  }
}

void ToolDriver::update(std::span<const DriveInput> inputs, std::span<sim::Tool> out) {
  for (std::size_t t = 0; t < state_.size(); ++t) {
    State& st = state_[t];
    const DriveInput in = t < inputs.size() ? inputs[t] : DriveInput{};
    sim::Tool& tool = st.tool;
    if (in.connected) {
      if (!st.counters_known) {
        // A control's counters start wherever the mapper's are: presses made
        // before this tool was driven do not count.
        st.toggles_seen = in.shape_toggles;
        st.steps_seen = in.size_steps;
        st.counters_known = true;
      }
      st.ever_connected = true;
      // Shape: every press switches sphere <-> capsule (unsigned difference is wrap-safe).
      const std::uint32_t presses = in.shape_toggles - st.toggles_seen;
      st.toggles_seen = in.shape_toggles;
      if (presses & 1u)
        tool.shape = tool.shape == sim::ToolShape::sphere ? sim::ToolShape::capsule : sim::ToolShape::sphere;
      // Size: grow/shrink presses since the last tick, within the limits.
      const std::int32_t steps = static_cast<std::int32_t>(static_cast<std::uint32_t>(in.size_steps) -
                                                           static_cast<std::uint32_t>(st.steps_seen));
      st.steps_seen = in.size_steps;
      if (steps != 0) {
        st.scale = std::clamp(st.scale * std::pow(limits_.size_step, static_cast<double>(steps)),
                              limits_.min_scale, limits_.max_scale);
      }
    }
    tool.active = st.ever_connected;
    tool.radius = st.spec.radius * st.scale;
    set_half_axis(tool, st.spec.half_length * st.scale);
    // Velocity control: a released (or unplugged) stick leaves the tool where it is.
    Vec3d v{0, 0, 0};
    if (in.connected) {
      for (int a = 0; a < 3; ++a) {
        const double s = std::isfinite(in.stick[a]) ? std::clamp(static_cast<double>(in.stick[a]), -1.0, 1.0) : 0.0;
        v[a] = s * st.spec.speed;
      }
    }
    for (int a = 0; a < 3; ++a) {
      const double p = std::clamp(tool.position[a] + v[a] * dt_, limits_.bounds.lo[a], limits_.bounds.hi[a]);
      tool.velocity[a] = (p - tool.position[a]) / dt_;
      tool.position[a] = p;
    }
    tool.grab = in.connected && in.grab;
    if (t < out.size()) out[t] = tool;
  }
}

Box tool_bounds(const Box& meshes, std::span<const ToolSpec> tools, double margin) {
  Box b = meshes;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] -= margin;
    b.hi[a] += margin;
    for (const ToolSpec& t : tools) {
      b.lo[a] = std::min(b.lo[a], t.position[a]);
      b.hi[a] = std::max(b.hi[a], t.position[a]);
    }
  }
  return b;
}

std::vector<std::byte> ToolDriver::state() const {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  w.array(state_);
  return out;
}

void ToolDriver::restore_state(std::span<const std::byte> bytes) {
  for (const bool dry : {true, false}) {
    sim::StateReader r(bytes, dry);
    sim::StateView view;
    if (dry) r.note_to(&view);
    r.array(state_, "tool driver: tools");
    if (!r.done()) throw std::invalid_argument("tool driver state: bytes left over");
    if (dry) check_state(view);
  }
}

// What a driver of these specs can hold: each tool's spec the scene's, its
// flags flags, its shape a shape, its scale within the limits and its pose
// within the bounds. Flags and the shape are looked at as bytes.
void ToolDriver::check_state(const sim::StateView& view) const {
  const auto tools = view.array(state_);
  for (std::size_t t = 0; t < tools.size(); ++t) {
    const std::string at = "tool driver state: tool " + std::to_string(t) + ": ";
    const std::span<const std::byte> raw = tools.element(t);
    for (std::size_t off : {offsetof(State, tool) + offsetof(sim::Tool, active),
                            offsetof(State, tool) + offsetof(sim::Tool, grab), offsetof(State, ever_connected),
                            offsetof(State, counters_known)})
      if (std::to_integer<unsigned>(raw[off]) > 1) throw std::invalid_argument(at + "a flag is not a flag");
    for (std::size_t off : {offsetof(State, spec) + offsetof(ToolSpec, shape), offsetof(State, tool) + offsetof(sim::Tool, shape)}) {
      std::underlying_type_t<sim::ToolShape> shape;
      std::memcpy(&shape, raw.data() + off, sizeof shape);
      if (shape != static_cast<int>(sim::ToolShape::sphere) && shape != static_cast<int>(sim::ToolShape::capsule))
        throw std::invalid_argument(at + "shape " + std::to_string(shape));
    }
    const State s = tools[t];
    const ToolSpec& want = state_[t].spec;
    if (s.spec.shape != want.shape || std::memcmp(&s.spec.radius, &want.radius, sizeof want.radius) != 0 ||
        std::memcmp(&s.spec.half_length, &want.half_length, sizeof want.half_length) != 0 ||
        std::memcmp(&s.spec.speed, &want.speed, sizeof want.speed) != 0 ||
        std::memcmp(s.spec.position.data(), want.position.data(), sizeof want.position) != 0)
      throw std::invalid_argument(at + "not the scene's tool");
    if (!(s.scale >= limits_.min_scale && s.scale <= limits_.max_scale))
      throw std::invalid_argument(at + "scale " + std::to_string(s.scale) + ", the limits " +
                                  std::to_string(limits_.min_scale) + " to " + std::to_string(limits_.max_scale));
    if (!(s.tool.radius > 0) || !std::isfinite(s.tool.radius) || !finite3(s.tool.half_axis) || !finite3(s.tool.velocity))
      throw std::invalid_argument(at + "its size or motion is not finite");
    for (int a = 0; a < 3; ++a)
      if (!(s.tool.position[a] >= limits_.bounds.lo[a] && s.tool.position[a] <= limits_.bounds.hi[a]))
        throw std::invalid_argument(at + "its position is outside the scene's bounds");
  }
}

}  // namespace sculpt::simloop
