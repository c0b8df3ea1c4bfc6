// What the input unit tests share: device descriptions, and files in the
// test process's scratch directory.
#pragma once

#include <linux/input.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "input/device_info.hpp"
#include "support/scratch_dir.hpp"

namespace sculpt::input::testing {

inline DeviceInfo gamepad() {
  DeviceInfo d;
  d.name = "Test Gamepad";
  d.bustype = BUS_USB;
  d.vendor = 0x046d;
  d.product = 0xc21d;
  d.version = 1;
  d.phys = "usb-0000:00:14.0-1/input0";
  for (std::uint16_t c : {ABS_X, ABS_Y, ABS_RX, ABS_RY})
    d.axes.push_back({c, 0, -32768, 32767, 16, 128, 0});
  d.axes.push_back({ABS_Z, 0, 0, 255, 0, 0, 0});
  d.axes.push_back({ABS_RZ, 0, 0, 255, 0, 0, 0});
  std::sort(d.axes.begin(), d.axes.end(), [](auto& a, auto& b) { return a.code < b.code; });
  d.buttons = {BTN_SOUTH, BTN_EAST, BTN_NORTH, BTN_WEST, BTN_TL, BTN_TR, BTN_SELECT, BTN_START, BTN_THUMBL,
               BTN_THUMBR};
  std::sort(d.buttons.begin(), d.buttons.end());
  d.ff = {FF_RUMBLE, FF_PERIODIC, FF_SQUARE, FF_TRIANGLE, FF_SINE, FF_GAIN};
  d.ff_effects_max = 16;
  d.kind = DeviceKind::gamepad;
  return d;
}

inline DeviceInfo flight_stick() {
  DeviceInfo d;
  d.name = "Test Flight Stick";
  d.bustype = BUS_USB;
  d.vendor = 0x044f;
  d.product = 0xb10a;
  d.axes = {{ABS_X, 512, 0, 1023, 0, 0, 0}, {ABS_Y, 512, 0, 1023, 0, 0, 0},
            {ABS_RZ, 128, 0, 255, 0, 8, 0}, {ABS_THROTTLE, 0, 0, 255, 0, 0, 0}};
  d.buttons = {BTN_TRIGGER, BTN_THUMB, BTN_THUMB2, BTN_TOP};
  d.ff = {FF_CONSTANT, FF_GAIN};
  d.ff_effects_max = 1;
  d.kind = DeviceKind::joystick;
  return d;
}

inline std::filesystem::path temp_file(const std::string& name) { return support::scratch_path(name); }

inline std::filesystem::path write_file(const std::string& name, const std::string& text) {
  const auto p = temp_file(name);
  std::ofstream(p) << text;
  return p;
}

}  // namespace sculpt::input::testing
