// What the io thread hands the simulation thread, through a
// concurrency::SpscRing<InputMessage>: plain, fixed-size, trivially copyable.
//   attach: a device came (back) into a slot, with its resolved binding
//   detach: the device in a slot went away
//   frame:  the events of one SYN_REPORT, to be applied at tick `at_tick`
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <type_traits>

#include "input/calibration.hpp"
#include "sim/limits.hpp"  // sim::kMaxTools

namespace sculpt::input {

inline constexpr std::size_t kMaxDevices = 8;       // device slots (haptics counts per slot too)
static_assert(kMaxDevices <= 255, "a slot is a byte in InputMessage and the journal");
inline constexpr std::size_t kMaxBoundAxes = 16;    // per device
inline constexpr std::size_t kMaxBoundButtons = 24; // per device
inline constexpr std::size_t kMaxFrameEvents = 48;  // longer reports are split into several frames

inline constexpr std::uint8_t kNoTool = 0xff;

// One evdev event without its timestamp (the frame carries the time).
struct InputEvent {
  std::uint16_t type = 0;
  std::uint16_t code = 0;
  std::int32_t value = 0;
  bool operator==(const InputEvent&) const = default;
};

// One axis of a device and what it drives: tool `tool`'s stick component
// `component` (0 = x, 1 = y, 2 = depth), times `scale` (±1, the sign says
// which way is "forward").
struct AxisBinding {
  std::uint16_t code = 0;
  std::uint8_t tool = kNoTool;
  std::uint8_t component = 0;
  float scale = 1.0f;
  AxisCalibration calibration;
};

enum class ButtonAction : std::uint8_t {
  grab,         // held: the tool pulls what it touches
  shape,        // press: switch sphere <-> capsule
  grow,         // press: one size step up
  shrink,       // press: one size step down
  depth_plus,   // held: depth component +1 (pads without an analog depth axis)
  depth_minus,  // held: depth component -1
  undo,         // press: undo the last stroke (any tool's)
  redo,         // press: redo the last undone stroke
};

struct ButtonBinding {
  std::uint16_t code = 0;
  ButtonAction action = ButtonAction::grab;
  std::uint8_t tool = kNoTool;
};

// Everything the simulation thread needs to turn a device's events into tool
// controls, resolved on the io thread from the mapping config.
struct DeviceBinding {
  std::uint8_t axis_count = 0;
  std::uint8_t button_count = 0;
  std::array<AxisBinding, kMaxBoundAxes> axes{};
  std::array<ButtonBinding, kMaxBoundButtons> buttons{};
  std::uint32_t tool_mask = 0;  // bit t: this device drives tool t

  bool add_axis(const AxisBinding& a);      // false when full
  bool add_button(const ButtonBinding& b);  // false when full
  bool drives(std::size_t tool) const { return tool < 32 && (tool_mask >> tool) & 1u; }
};

// "" for a binding the io thread could have made (counts within the arrays,
// flags and actions one of their values, finite scales, dead zones in
// [0, 0.95]); else what is wrong. A binding read from a store or a recording
// file is checked before the mapper uses it. Looks at flags as bytes.
std::string binding_error(const DeviceBinding& binding);

// The plane a device's stick moves tool `tool` in, for the haptics: which
// axis code moves the tool along which component, with which sign. A force
// projected on (x_component, y_component) pushes back against the stick.
struct StickPlane {
  bool valid = false;
  std::uint16_t x_code = 0, y_code = 0;        // e.g. ABS_X, ABS_Y
  std::uint8_t x_component = 0, y_component = 1;
  float x_scale = 1.0f, y_scale = 1.0f;
};
StickPlane stick_plane(const DeviceBinding& binding, std::size_t tool);

struct InputFrame {
  std::uint8_t slot = 0;
  bool partial = false;              // split from a longer report; more follows
  bool resync = false;               // after SYN_DROPPED: the device state, re-read
  std::uint16_t count = 0;
  std::int64_t device_time_us = 0;   // MSC_TIMESTAMP (unwrapped) or the kernel event time
  bool device_clock = false;         // device_time_us came from MSC_TIMESTAMP
  std::int64_t kernel_time_us = 0;   // the kernel's event time (CLOCK_MONOTONIC), always set for live devices
  std::int64_t arrival_us = 0;       // CLOCK_MONOTONIC when read
  std::uint64_t at_tick = 0;         // 0 = apply now; else the tick to apply it on
  std::array<InputEvent, kMaxFrameEvents> events{};

  bool push(const InputEvent& e);    // false when full
};

enum class MessageKind : std::uint8_t { attach, detach, frame };

struct InputMessage {
  MessageKind kind = MessageKind::frame;
  std::uint8_t slot = 0;
  std::uint64_t at_tick = 0;  // 0 = apply now (attach/detach: also honoured, for replays)
  DeviceBinding binding{};    // attach only
  InputFrame frame{};         // frame only

  static InputMessage attach(std::uint8_t slot, const DeviceBinding& binding, std::uint64_t at_tick = 0);
  static InputMessage detach(std::uint8_t slot, std::uint64_t at_tick = 0);
  static InputMessage of_frame(const InputFrame& frame);  // at_tick from the frame
};

static_assert(std::is_trivially_copyable_v<InputMessage>, "InputMessage travels through an SpscRing");

}  // namespace sculpt::input
