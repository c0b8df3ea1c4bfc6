// A simulated joystick for device tests. The device itself (uinput, the FF
// answering service thread, the log of what a client did) is production code
// now, shared with `sculptctl replay`: sculpt::uinput::VirtualDevice. The
// test names stay as aliases so tests read as before.
#pragma once

#include "uinput/virtual_device.hpp"

namespace sculpt::support {

using uinput::AxisSpec;
using uinput::FfAutocenter;
using uinput::FfErase;
using uinput::FfGain;
using uinput::FfLog;
using uinput::FfPlayback;
using uinput::FfRecord;
using uinput::FfUpload;
using JoystickSpec = uinput::DeviceSpec;
using VirtualJoystick = uinput::VirtualDevice;

// The devices the tests make (test-only, so not in daemon/uinput).
// A two-stick gamepad with a full set of FF capabilities (constant, rumble,
// periodic sine/square, gain, autocenter) and room for 16 effects.
JoystickSpec gamepad_spec();
// A pad that can only rumble (like most game controllers).
JoystickSpec rumble_pad_spec();

}  // namespace sculpt::support
