#include "input/input_message.hpp"

#include <cmath>
#include <cstddef>
#include <cstring>

namespace sculpt::input {

bool DeviceBinding::add_axis(const AxisBinding& a) {
  if (axis_count >= axes.size()) return false;
  axes[axis_count++] = a;
  if (a.tool < 32) tool_mask |= 1u << a.tool;
  return true;
}

bool DeviceBinding::add_button(const ButtonBinding& b) {
  if (button_count >= buttons.size()) return false;
  buttons[button_count++] = b;
  if (b.tool < 32) tool_mask |= 1u << b.tool;
  return true;
}

namespace {

unsigned byte_at(const void* object, std::size_t offset) {
  unsigned char c;
  std::memcpy(&c, static_cast<const unsigned char*>(object) + offset, 1);
  return c;
}

}  // namespace

std::string binding_error(const DeviceBinding& b) {
  if (b.axis_count > kMaxBoundAxes)
    return "binding: " + std::to_string(b.axis_count) + " axes, at most " + std::to_string(kMaxBoundAxes);
  if (b.button_count > kMaxBoundButtons)
    return "binding: " + std::to_string(b.button_count) + " buttons, at most " + std::to_string(kMaxBoundButtons);
  for (std::size_t i = 0; i < b.axes.size(); ++i) {
    const AxisBinding& a = b.axes[i];
    if (byte_at(&a, offsetof(AxisBinding, calibration) + offsetof(AxisCalibration, unipolar)) > 1)
      return "binding: axis " + std::to_string(i) + ": the unipolar flag is not a flag";
    if (i >= b.axis_count) continue;
    if (!std::isfinite(a.scale) || std::abs(a.scale) > 1e3f)
      return "binding: axis " + std::to_string(i) + ": scale " + std::to_string(a.scale);
    if (!(a.calibration.dead_zone >= 0.0f && a.calibration.dead_zone <= 0.95f))
      return "binding: axis " + std::to_string(i) + ": dead zone " + std::to_string(a.calibration.dead_zone) +
             " (0 to 0.95)";
  }
  for (std::size_t i = 0; i < b.button_count; ++i)
    if (static_cast<unsigned>(b.buttons[i].action) > static_cast<unsigned>(ButtonAction::redo))
      return "binding: button " + std::to_string(i) + ": action " +
             std::to_string(static_cast<unsigned>(b.buttons[i].action));
  return {};
}

StickPlane stick_plane(const DeviceBinding& binding, std::size_t tool) {
  StickPlane p;
  bool have_x = false, have_y = false;
  for (std::size_t i = 0; i < binding.axis_count; ++i) {
    const AxisBinding& a = binding.axes[i];
    if (a.tool != tool || a.calibration.unipolar) continue;
    if (!have_x && a.component == 0) {
      p.x_code = a.code, p.x_component = 0, p.x_scale = a.scale, have_x = true;
    } else if (!have_y && a.component == 1) {
      p.y_code = a.code, p.y_component = 1, p.y_scale = a.scale, have_y = true;
    }
  }
  p.valid = have_x && have_y;
  return p;
}

bool InputFrame::push(const InputEvent& e) {
  if (count >= events.size()) return false;
  events[count++] = e;
  return true;
}

InputMessage InputMessage::attach(std::uint8_t slot, const DeviceBinding& binding, std::uint64_t at_tick) {
  InputMessage m;
  m.kind = MessageKind::attach;
  m.slot = slot;
  m.at_tick = at_tick;
  m.binding = binding;
  return m;
}

InputMessage InputMessage::detach(std::uint8_t slot, std::uint64_t at_tick) {
  InputMessage m;
  m.kind = MessageKind::detach;
  m.slot = slot;
  m.at_tick = at_tick;
  return m;
}

InputMessage InputMessage::of_frame(const InputFrame& frame) {
  InputMessage m;
  m.kind = MessageKind::frame;
  m.slot = frame.slot;
  m.at_tick = frame.at_tick;
  m.frame = frame;
  return m;
}

}  // namespace sculpt::input
