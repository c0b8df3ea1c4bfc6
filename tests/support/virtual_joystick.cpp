#include "support/virtual_joystick.hpp"

#include <linux/input.h>

namespace sculpt::support {

JoystickSpec gamepad_spec() {
  JoystickSpec s;
  s.named("sculpt virtual gamepad")
      .axis(ABS_X, -32768, 32767, 16, 128)
      .axis(ABS_Y, -32768, 32767, 16, 128)
      .axis(ABS_RX, -32768, 32767, 16, 128)
      .axis(ABS_RY, -32768, 32767, 16, 128)
      .axis(ABS_Z, 0, 1023)
      .axis(ABS_RZ, 0, 1023)
      .button(BTN_SOUTH)
      .button(BTN_EAST)
      .button(BTN_NORTH)
      .button(BTN_WEST)
      .button(BTN_TL)
      .button(BTN_TR)
      .button(BTN_START)
      .button(BTN_SELECT)
      .ff({FF_CONSTANT, FF_RUMBLE, FF_PERIODIC, FF_SINE, FF_SQUARE, FF_GAIN, FF_AUTOCENTER})
      .effects_max(16);
  return s;
}

JoystickSpec rumble_pad_spec() {
  JoystickSpec s;
  s.named("sculpt virtual rumble pad")
      .ids(BUS_USB, 0x5c17, 0x0002)
      .axis(ABS_X, -32768, 32767, 16, 128)
      .axis(ABS_Y, -32768, 32767, 16, 128)
      .button(BTN_SOUTH)
      .button(BTN_EAST)
      .ff({FF_RUMBLE, FF_GAIN})
      .effects_max(16);
  return s;
}

}  // namespace sculpt::support
