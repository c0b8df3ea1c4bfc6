#include "input/control_mapper.hpp"

#include <linux/input.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "sim/state_bytes.hpp"

namespace sculpt::input {

ControlMapper::ControlMapper(std::size_t tools) : tools_(std::min(tools, sim::kMaxTools)) {}

void ControlMapper::apply(const InputMessage& m) {
  if (m.slot >= kMaxDevices) return;
  DeviceState& d = devices_[m.slot];
  switch (m.kind) {
    case MessageKind::attach:
      d = DeviceState{};
      d.attached = true;
      d.binding = m.binding;
      break;
    case MessageKind::detach:
      // Sticks of a device that is gone read as centred, buttons as released
      // (a grab does not stay stuck on through an unplug).
      d = DeviceState{};
      break;
    case MessageKind::frame:
      if (!d.attached) return;
      for (std::size_t i = 0; i < m.frame.count && i < kMaxFrameEvents; ++i) apply_event(d, m.frame.events[i]);
      break;
  }
  recompute();
}

std::size_t ControlMapper::drain(concurrency::SpscRing<InputMessage>& ring, std::uint64_t tick) {
  std::size_t n = 0;
  while (const InputMessage* m = ring.peek()) {
    if (m->at_tick != 0 && m->at_tick > tick) break;
    take(*m, tick);
    ring.pop();
    ++n;
  }
  return n;
}

void ControlMapper::take(const InputMessage& m, std::uint64_t tick) {
  if (m.at_tick != 0 && m.at_tick < tick) ++late_;
  apply(m);
}

std::vector<std::byte> ControlMapper::state() const {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  w.value(static_cast<std::uint64_t>(tools_));
  w.value(devices_), w.value(controls_), w.value(late_), w.value(undo_presses_), w.value(redo_presses_);
  return out;
}

void ControlMapper::restore_state(std::span<const std::byte> bytes) {
  for (const bool dry : {true, false}) {
    sim::StateReader r(bytes, dry);
    sim::StateView view;
    if (dry) r.note_to(&view);
    std::uint64_t tools = 0;
    r.value(tools, "mapper: tool count");
    if (tools != tools_)
      throw std::invalid_argument("mapper state: " + std::to_string(tools) + " tools, this scene has " +
                                  std::to_string(tools_));
    r.field(devices_, "mapper: devices"), r.field(controls_, "mapper: controls"), r.field(late_, "mapper: late");
    r.field(undo_presses_, "mapper: undo presses"), r.field(redo_presses_, "mapper: redo presses");
    if (!r.done()) throw std::invalid_argument("mapper state: bytes left over");
    if (dry) check_state(view);
  }
}

// What a mapper can hold: flags that are flags, bindings the io thread could
// have made, finite values within their ranges. Flags are looked at as bytes.
void ControlMapper::check_state(const sim::StateView& view) const {
  auto flag = [](std::span<const std::byte> bytes, std::size_t offset, const std::string& what) {
    if (std::to_integer<unsigned>(bytes[offset]) > 1) throw std::invalid_argument("mapper state: " + what + " is not a flag");
  };
  const auto devices = view.bytes_of(&devices_);
  for (std::size_t d = 0; d < kMaxDevices; ++d) {
    const std::span<const std::byte> raw = devices.subspan(d * sizeof(DeviceState), sizeof(DeviceState));
    const std::string at = "device " + std::to_string(d);
    flag(raw, offsetof(DeviceState, attached), at + " attached");
    for (std::size_t i = 0; i < kMaxBoundButtons; ++i) flag(raw, offsetof(DeviceState, held) + i, at + " button");
    DeviceState s;
    std::memcpy(static_cast<void*>(&s), raw.data(), sizeof s);
    if (const std::string error = binding_error(s.binding); !error.empty())
      throw std::invalid_argument("mapper state: " + at + ": " + error);
    for (float v : s.value)
      if (!std::isfinite(v) || std::abs(v) > 1e3f)
        throw std::invalid_argument("mapper state: " + at + ": axis value " + std::to_string(v));
  }
  const auto controls = view.bytes_of(&controls_);
  for (std::size_t t = 0; t < sim::kMaxTools; ++t) {
    const std::span<const std::byte> raw = controls.subspan(t * sizeof(ToolControl), sizeof(ToolControl));
    const std::string at = "tool " + std::to_string(t);
    flag(raw, offsetof(ToolControl, grab), at + " grab");
    flag(raw, offsetof(ToolControl, connected), at + " connected");
    ToolControl c;
    std::memcpy(static_cast<void*>(&c), raw.data(), sizeof c);
    for (float v : c.stick)
      if (!(v >= -1.0f && v <= 1.0f)) throw std::invalid_argument("mapper state: " + at + ": stick " + std::to_string(v));
  }
}

void ControlMapper::apply_event(DeviceState& d, const InputEvent& e) {
  const DeviceBinding& b = d.binding;
  if (e.type == EV_ABS) {
    for (std::size_t i = 0; i < b.axis_count; ++i) {
      if (b.axes[i].code != e.code) continue;
      // No second fuzz filter here: the kernel already defuzzed live values,
      // and recorded ones were recorded defuzzed. Filtering again would make
      // an in-process replay differ from the same recording through uinput.
      d.raw[i] = e.value;
      d.value[i] = b.axes[i].calibration.normalize(e.value) * b.axes[i].scale;
    }
  } else if (e.type == EV_KEY) {
    for (std::size_t i = 0; i < b.button_count; ++i) {
      if (b.buttons[i].code != e.code) continue;
      const bool down = e.value != 0;  // 2 = autorepeat: still held, not a new press
      const bool press = down && !d.held[i];
      d.held[i] = down;
      const std::uint8_t t = b.buttons[i].tool;
      if (press && b.buttons[i].action == ButtonAction::undo) ++undo_presses_;
      if (press && b.buttons[i].action == ButtonAction::redo) ++redo_presses_;
      if (!press || t >= tools_) continue;
      switch (b.buttons[i].action) {
        case ButtonAction::shape: ++controls_[t].shape_toggles; break;
        case ButtonAction::grow: ++controls_[t].size_steps; break;
        case ButtonAction::shrink: --controls_[t].size_steps; break;
        default: break;
      }
    }
  }
}

void ControlMapper::recompute() {
  // Counters are kept; everything else is rebuilt from the device states:
  // at most kMaxDevices × (axes + buttons) steps, no allocation.
  for (std::size_t t = 0; t < tools_; ++t) {
    controls_[t].stick = {0.0f, 0.0f, 0.0f};
    controls_[t].grab = false;
    controls_[t].connected = false;
  }
  for (const DeviceState& d : devices_) {
    if (!d.attached) continue;
    const DeviceBinding& b = d.binding;
    for (std::size_t t = 0; t < tools_; ++t)
      if (b.drives(t)) controls_[t].connected = true;
    for (std::size_t i = 0; i < b.axis_count; ++i) {
      const AxisBinding& a = b.axes[i];
      if (a.tool >= tools_ || a.component > 2) continue;
      controls_[a.tool].stick[a.component] += d.value[i];
    }
    for (std::size_t i = 0; i < b.button_count; ++i) {
      const ButtonBinding& k = b.buttons[i];
      if (k.tool >= tools_ || !d.held[i]) continue;
      ToolControl& c = controls_[k.tool];
      if (k.action == ButtonAction::grab) c.grab = true;
      else if (k.action == ButtonAction::depth_plus) c.stick[2] += 1.0f;
      else if (k.action == ButtonAction::depth_minus) c.stick[2] -= 1.0f;
    }
  }
  for (std::size_t t = 0; t < tools_; ++t)
    for (float& s : controls_[t].stick) s = std::clamp(s, -1.0f, 1.0f);
}

}  // namespace sculpt::input
