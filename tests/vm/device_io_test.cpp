// Input and hot-plug through a real event node: what the VirtualJoystick
// emits is what a libevdev client reads, and unplug/plug behave like a cable.
#include <gtest/gtest.h>
#include <libevdev/libevdev.h>

#include <cerrno>
#include <system_error>

#include "support/evdev_client.hpp"
#include "support/virtual_joystick.hpp"

namespace sculpt::support {
namespace {

// Reads events until the next SYN_REPORT; fails the test on a timeout.
void read_frame(EvdevClient& client) {
  for (;;) {
    auto ev = client.next_event();
    ASSERT_TRUE(ev.has_value()) << "no SYN_REPORT within the timeout";
    if (ev->type == EV_SYN && ev->code == SYN_REPORT) return;
  }
}

TEST(DeviceIdentity, ClientSeesNameIdsAxesAndButtons) {
  VirtualJoystick joy(JoystickSpec{}
                          .named("identity stick")
                          .ids(BUS_USB, 0x1234, 0xabcd, 7)
                          .axis(ABS_X, -512, 511, 2, 8, 3)
                          .axis(ABS_THROTTLE, 0, 255)
                          .button(BTN_TRIGGER)
                          .button(BTN_THUMB)
                          .ff(FF_RUMBLE)
                          .effects_max(4));
  EXPECT_EQ(joy.event_node().rfind("/dev/input/event", 0), 0u) << joy.event_node();
  EXPECT_EQ(joy.sysname().rfind("input", 0), 0u) << joy.sysname();

  EvdevClient client(joy.event_node());
  libevdev* d = client.dev();
  EXPECT_STREQ(libevdev_get_name(d), "identity stick");
  EXPECT_EQ(libevdev_get_id_bustype(d), BUS_USB);
  EXPECT_EQ(libevdev_get_id_vendor(d), 0x1234);
  EXPECT_EQ(libevdev_get_id_product(d), 0xabcd);
  EXPECT_EQ(libevdev_get_id_version(d), 7);
  const input_absinfo* x = libevdev_get_abs_info(d, ABS_X);
  ASSERT_NE(x, nullptr);
  EXPECT_EQ(x->minimum, -512);
  EXPECT_EQ(x->maximum, 511);
  EXPECT_EQ(x->fuzz, 2);
  EXPECT_EQ(x->flat, 8);
  EXPECT_EQ(x->resolution, 3);
  EXPECT_TRUE(libevdev_has_event_code(d, EV_ABS, ABS_THROTTLE));
  EXPECT_FALSE(libevdev_has_event_code(d, EV_ABS, ABS_Y));
  EXPECT_TRUE(libevdev_has_event_code(d, EV_KEY, BTN_TRIGGER));
  EXPECT_TRUE(libevdev_has_event_code(d, EV_KEY, BTN_THUMB));
  EXPECT_FALSE(libevdev_has_event_code(d, EV_KEY, BTN_SOUTH));
  EXPECT_TRUE(libevdev_has_event_code(d, EV_FF, FF_RUMBLE));
  EXPECT_EQ(client.ff_effects_max(), 4);
}

TEST(DeviceInput, AxisAndButtonEventsReachTheClient) {
  VirtualJoystick joy(gamepad_spec());
  EvdevClient client(joy.event_node());

  joy.move_axes({{ABS_X, 12345}, {ABS_RY, -20000}});
  read_frame(client);
  EXPECT_EQ(libevdev_get_event_value(client.dev(), EV_ABS, ABS_X), 12345);
  EXPECT_EQ(libevdev_get_event_value(client.dev(), EV_ABS, ABS_RY), -20000);

  joy.press(BTN_SOUTH);
  read_frame(client);
  EXPECT_EQ(libevdev_get_event_value(client.dev(), EV_KEY, BTN_SOUTH), 1);

  joy.release(BTN_SOUTH);
  read_frame(client);
  EXPECT_EQ(libevdev_get_event_value(client.dev(), EV_KEY, BTN_SOUTH), 0);

  joy.move_axis(ABS_Z, 700);
  read_frame(client);
  EXPECT_EQ(libevdev_get_event_value(client.dev(), EV_ABS, ABS_Z), 700);
}

TEST(DeviceInput, EventsArriveInOrderWithinAFrame) {
  VirtualJoystick joy(gamepad_spec());
  EvdevClient client(joy.event_node());
  joy.emit(EV_ABS, ABS_X, 100);
  joy.emit(EV_KEY, BTN_EAST, 1);
  joy.emit(EV_ABS, ABS_Y, -100);
  joy.sync();
  const std::pair<std::uint16_t, std::uint16_t> expected[] = {
      {EV_ABS, ABS_X}, {EV_KEY, BTN_EAST}, {EV_ABS, ABS_Y}, {EV_SYN, SYN_REPORT}};
  for (const auto& [type, code] : expected) {
    auto ev = client.next_event();
    ASSERT_TRUE(ev.has_value());
    EXPECT_EQ(ev->type, type);
    EXPECT_EQ(ev->code, code);
  }
}

TEST(DeviceHotplug, UnplugGivesTheClientEnodev) {
  VirtualJoystick joy(gamepad_spec());
  EvdevClient client(joy.event_node());
  ff_effect e = rumble_effect(0x100, 0x100, 10);
  ASSERT_EQ(client.upload(e), 0);

  joy.unplug();
  EXPECT_FALSE(joy.plugged());
  EXPECT_TRUE(joy.event_node().empty());
  try {
    client.next_event();
    FAIL() << "reading an unplugged device succeeded";
  } catch (const std::system_error& err) {
    EXPECT_EQ(err.code().value(), ENODEV) << err.what();
  }
  EXPECT_EQ(client.upload(e), ENODEV);
  EXPECT_THROW(joy.move_axis(ABS_X, 1), std::logic_error);
}

TEST(DeviceHotplug, PlugBringsTheSameDeviceBack) {
  VirtualJoystick joy(gamepad_spec().ids(BUS_USB, 0x5c17, 0x0042));
  {
    EvdevClient client(joy.event_node());
    ff_effect e = constant_effect(100, 0, 10);
    ASSERT_EQ(client.upload(e), 0);
  }
  joy.unplug();
  joy.plug();
  ASSERT_TRUE(joy.plugged());

  EvdevClient client(joy.event_node());
  EXPECT_EQ(client.name(), joy.spec().name);
  EXPECT_EQ(libevdev_get_id_product(client.dev()), 0x0042);
  EXPECT_TRUE(client.has_ff(FF_CONSTANT));

  // A fresh device: all effect ids free again, FF answered by the new incarnation.
  joy.clear_log();
  ff_effect e = constant_effect(-300, 0x8000, 20);
  ASSERT_EQ(client.upload(e), 0);
  EXPECT_EQ(e.id, 0);
  ASSERT_EQ(joy.uploads().size(), 1u);
  EXPECT_EQ(joy.uploads()[0].effect.u.constant.level, -300);

  joy.move_axis(ABS_X, -20000);  // beyond the axis fuzz, or the kernel drops it
  read_frame(client);
  EXPECT_EQ(libevdev_get_event_value(client.dev(), EV_ABS, ABS_X), -20000);
}

TEST(DeviceHotplug, RepeatedPlugCyclesStayHealthy) {
  VirtualJoystick joy(rumble_pad_spec());
  for (int i = 0; i < 5; ++i) {
    joy.unplug();
    joy.plug();
    EvdevClient client(joy.event_node());
    ff_effect e = rumble_effect(static_cast<std::uint16_t>(i), 0, 10);
    ASSERT_EQ(client.upload(e), 0) << "cycle " << i;
  }
  EXPECT_EQ(joy.uploads().size(), 5u);
}

}  // namespace
}  // namespace sculpt::support
