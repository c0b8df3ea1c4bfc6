#include "input/device_info.hpp"

#include <linux/input.h>

#include <algorithm>

#include <fmt/format.h>

namespace sculpt::input {
namespace {

bool any_button(const DeviceInfo& d, std::uint16_t first, std::uint16_t last) {
  return std::any_of(d.buttons.begin(), d.buttons.end(), [&](auto b) { return b >= first && b <= last; });
}

bool two_sticks(const DeviceInfo& d) {
  return d.axis(ABS_X) && d.axis(ABS_Y) && d.axis(ABS_RX) && d.axis(ABS_RY);
}

std::string_view ff_name(std::uint16_t bit) {
  switch (bit) {
    case FF_CONSTANT: return "constant";
    case FF_RUMBLE: return "rumble";
    case FF_PERIODIC: return "periodic";
    case FF_SPRING: return "spring";
    case FF_DAMPER: return "damper";
    case FF_GAIN: return "gain";
    case FF_AUTOCENTER: return "autocenter";
    default: return {};
  }
}

}  // namespace

std::string_view to_string(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::gamepad: return "gamepad";
    case DeviceKind::joystick: return "joystick";
    case DeviceKind::other: return "other";
  }
  return "other";
}

const AxisInfo* DeviceInfo::axis(std::uint16_t code) const {
  for (const auto& a : axes)
    if (a.code == code) return &a;
  return nullptr;
}

bool DeviceInfo::has_button(std::uint16_t code) const {
  return std::find(buttons.begin(), buttons.end(), code) != buttons.end();
}

bool DeviceInfo::has_ff(std::uint16_t bit) const { return std::find(ff.begin(), ff.end(), bit) != ff.end(); }

std::string DeviceInfo::identity() const {
  return fmt::format("{:04x}:{:04x}|{}|{}|{}", vendor, product, uniq, phys, name);
}

DeviceKind classify_capabilities(const DeviceInfo& d) {
  // Marks of devices that have absolute X/Y but are not joysticks.
  const bool pointer = d.has_button(BTN_TOUCH) || d.has_button(BTN_LEFT) || d.has_button(BTN_TOOL_PEN) ||
                       d.has_button(BTN_TOOL_FINGER) || d.has_button(BTN_STYLUS) ||
                       d.axis(ABS_MT_POSITION_X) != nullptr;
  if (pointer) return DeviceKind::other;
  const bool xy = d.axis(ABS_X) && d.axis(ABS_Y);
  if (any_button(d, BTN_GAMEPAD, BTN_THUMBR)) return xy ? DeviceKind::gamepad : DeviceKind::other;
  if (xy && two_sticks(d)) return DeviceKind::gamepad;
  if (any_button(d, BTN_JOYSTICK, BTN_DEAD) && xy) return DeviceKind::joystick;
  // Axes only (a bare stick, a flight controller without buttons).
  if (xy && d.buttons.empty()) return DeviceKind::joystick;
  return DeviceKind::other;
}

DeviceKind classify_udev_joystick(const DeviceInfo& d) {
  if (any_button(d, BTN_GAMEPAD, BTN_THUMBR) || two_sticks(d)) return DeviceKind::gamepad;
  return DeviceKind::joystick;
}

std::string describe(const DeviceInfo& d) {
  std::string ff;
  for (auto b : d.ff) {
    const auto n = ff_name(b);
    if (n.empty()) continue;
    ff += ff.empty() ? "" : " ";
    ff += n;
  }
  return fmt::format("{:04x}:{:04x} '{}' ({}, {} axes, {} buttons, FF: {}{})", d.vendor, d.product, d.name,
                     to_string(d.kind), d.axes.size(), d.buttons.size(), ff.empty() ? "none" : ff,
                     d.node.empty() ? "" : ", " + d.node);
}

}  // namespace sculpt::input
