// What sculptd knows about an input device: identity, axes with their
// absinfo, buttons, force-feedback bits, and what kind of controller it is.
// Filled from libevdev (live devices) or from a recording (replay).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace sculpt::input {

enum class DeviceKind : std::uint8_t { gamepad, joystick, other };

std::string_view to_string(DeviceKind kind);

// One absolute axis and its kernel absinfo.
struct AxisInfo {
  std::uint16_t code = 0;       // ABS_X, ...
  std::int32_t value = 0;
  std::int32_t minimum = 0;
  std::int32_t maximum = 0;
  std::int32_t fuzz = 0;
  std::int32_t flat = 0;
  std::int32_t resolution = 0;
  bool operator==(const AxisInfo&) const = default;
};

struct DeviceInfo {
  std::string name;
  std::uint16_t bustype = 0;
  std::uint16_t vendor = 0;
  std::uint16_t product = 0;
  std::uint16_t version = 0;
  std::string phys;
  std::string uniq;
  std::string node;                   // /dev/input/eventN (empty for recorded devices)
  std::vector<AxisInfo> axes;         // sorted by code
  std::vector<std::uint16_t> buttons; // EV_KEY codes, sorted
  std::vector<std::uint16_t> ff;      // EV_FF bits (FF_CONSTANT, FF_RUMBLE, FF_GAIN, ...), sorted
  int ff_effects_max = 0;
  bool has_msc_timestamp = false;     // sends EV_MSC/MSC_TIMESTAMP (device clock)
  DeviceKind kind = DeviceKind::other;
  bool kind_from_udev = false;        // udev said ID_INPUT_JOYSTICK (else: from capabilities)

  const AxisInfo* axis(std::uint16_t code) const;
  bool has_button(std::uint16_t code) const;
  bool has_ff(std::uint16_t bit) const;
  // What makes a device "the same one" when it comes back: vendor, product,
  // uniq, phys and name (not the node, which the kernel numbers afresh).
  std::string identity() const;
  bool operator==(const DeviceInfo&) const = default;
};

// Classification from evdev capabilities alone, for nodes udev has no
// properties for (no udevd: containers, the plain test VM). Mirrors the
// spirit of udev's input_id: a pad has gamepad buttons (BTN_SOUTH...) or two
// sticks; a joystick has joystick buttons (BTN_TRIGGER...) or an X/Y pair
// without the marks of a touchpad, tablet or mouse.
DeviceKind classify_capabilities(const DeviceInfo& info);

// A joystick per udev (ID_INPUT_JOYSTICK=1) refined by capabilities into
// gamepad or joystick.
DeviceKind classify_udev_joystick(const DeviceInfo& info);

// "0x046d:0xc21d 'Logitech Gamepad F310' (gamepad, 6 axes, 11 buttons, FF: rumble gain)"
std::string describe(const DeviceInfo& info);

}  // namespace sculpt::input
