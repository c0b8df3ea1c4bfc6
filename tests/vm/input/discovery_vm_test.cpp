// DeviceManager against real kernel devices (uinput): discovery by inotify
// (the plain VM: no udev) or by the udev monitor (the vm-udev suite runs this
// binary again with systemd-udevd in the guest), frames, SYN_DROPPED resync,
// ENODEV unplug and replug into the same slot.
#include <gtest/gtest.h>

#include <linux/input.h>

#include <algorithm>
#include <cstdlib>
#include <memory>

#include "input/control_mapper.hpp"
#include "input/mapping.hpp"
#include "support/virtual_joystick.hpp"
#include "device_pump.hpp"

namespace sculpt::input {
namespace {

using support::JoystickSpec;
using support::gamepad_spec;
using support::rumble_pad_spec;
using support::VirtualJoystick;
using vmtest::pump_until;
using vmtest::Recorded;

class Discovery : public ::testing::Test {
 protected:
  void start() {
    manager = std::make_unique<DeviceManager>(events);
    manager->start();
    EXPECT_EQ(manager->discovery(), vmtest::udev_running() ? "udev" : "inotify");
  }
  bool wait(const std::function<bool()>& pred) { return pump_until(*manager, pred); }
  const Recorded::Attach* wait_attach(const std::string& name) {
    wait([&] { return events.attach_named(name) != nullptr; });
    return events.attach_named(name);
  }
  Recorded events;
  std::unique_ptr<DeviceManager> manager;
};

TEST_F(Discovery, HotPluggedGamepadIsFoundAndClassified) {
  start();
  VirtualJoystick pad(gamepad_spec().named("vm hotplug pad"));
  const auto* a = wait_attach("vm hotplug pad");
  ASSERT_NE(a, nullptr) << "no attach for a gamepad plugged after start()";
  EXPECT_EQ(a->info.kind, DeviceKind::gamepad);
  EXPECT_EQ(a->info.kind_from_udev, vmtest::udev_running()) << "udev gives ID_INPUT_JOYSTICK when it runs";
  EXPECT_EQ(a->info.node, pad.event_node());
  EXPECT_EQ(a->info.vendor, 0x5c17);
  ASSERT_NE(a->info.axis(ABS_X), nullptr);
  EXPECT_EQ(a->info.axis(ABS_X)->minimum, -32768);
  EXPECT_EQ(a->info.axis(ABS_X)->flat, 128);
  EXPECT_TRUE(a->info.has_button(BTN_SOUTH));
  EXPECT_TRUE(a->info.has_ff(FF_CONSTANT));
  EXPECT_EQ(a->info.ff_effects_max, 16);
  EXPECT_EQ(manager->attached(), 1u);
}

TEST_F(Discovery, DevicesPresentAtStartAreEnumeratedInPlugOrder) {
  VirtualJoystick first(gamepad_spec().named("vm first pad"));
  VirtualJoystick second(rumble_pad_spec().named("vm second pad"));
  if (vmtest::udev_running()) {
    // Let udev finish with both (their properties are what enumeration reads).
    const int rc = ::system("/usr/bin/udevadm settle --timeout=10");
    (void)rc;
  }
  start();
  ASSERT_EQ(events.attaches.size(), 2u);
  EXPECT_EQ(events.attaches[0].info.name, "vm first pad");
  EXPECT_EQ(events.attaches[0].slot, 0);
  EXPECT_EQ(events.attaches[1].info.name, "vm second pad");
  EXPECT_EQ(events.attaches[1].slot, 1);
}

TEST_F(Discovery, NonJoysticksAreIgnored) {
  start();
  JoystickSpec keyboard;
  keyboard.named("vm keyboard");
  keyboard.axes.clear();
  keyboard.button(KEY_A).button(KEY_B).button(KEY_ENTER);
  VirtualJoystick kb(keyboard);
  VirtualJoystick pad(gamepad_spec().named("vm pad after keyboard"));
  ASSERT_NE(wait_attach("vm pad after keyboard"), nullptr);
  EXPECT_EQ(events.attach_named("vm keyboard"), nullptr);
  EXPECT_EQ(manager->attached(), 1u);
}

TEST_F(Discovery, FramesCarryEventsAndTimes) {
  start();
  VirtualJoystick pad(gamepad_spec().named("vm frames pad").misc(MSC_TIMESTAMP));
  const auto* a = wait_attach("vm frames pad");
  ASSERT_NE(a, nullptr);
  const std::uint8_t slot = a->slot;
  pad.move_axes({{ABS_X, 1000}, {ABS_Y, -2000}});
  ASSERT_TRUE(wait([&] { return !events.frames.empty(); }));
  const InputFrame& f = events.frames.back();
  EXPECT_EQ(f.slot, slot);
  ASSERT_EQ(f.count, 2);
  EXPECT_EQ(f.events[0], (InputEvent{EV_ABS, ABS_X, 1000}));
  EXPECT_EQ(f.events[1], (InputEvent{EV_ABS, ABS_Y, -2000}));
  EXPECT_FALSE(f.device_clock);
  EXPECT_GT(f.kernel_time_us, 0);
  EXPECT_GE(f.arrival_us, f.kernel_time_us) << "both CLOCK_MONOTONIC";
  EXPECT_EQ(f.device_time_us, f.kernel_time_us);

  // A device clock: MSC_TIMESTAMP, unwrapped across the 32-bit wrap.
  events.frames.clear();
  pad.emit(EV_MSC, MSC_TIMESTAMP, static_cast<std::int32_t>(0xfffffff0u));
  pad.move_axis(ABS_X, 1);
  pad.emit(EV_MSC, MSC_TIMESTAMP, 0x10);
  pad.move_axis(ABS_X, 5000);  // well beyond the fuzz: a change the kernel passes
  ASSERT_TRUE(wait([&] { return events.frames.size() >= 2; }));
  EXPECT_TRUE(events.frames[0].device_clock);
  EXPECT_EQ(events.frames[0].device_time_us, 0xfffffff0LL);
  EXPECT_EQ(events.frames[1].device_time_us, 0x100000010LL);
}

TEST_F(Discovery, SynDroppedResyncsToTheDeviceState) {
  start();
  VirtualJoystick pad(gamepad_spec().named("vm flood pad"));
  ASSERT_NE(wait_attach("vm flood pad"), nullptr);
  // Nobody reads while thousands of reports arrive: evdev's buffer overflows
  // and the reader gets SYN_DROPPED.
  for (int i = 0; i < 4000; ++i) pad.move_axes({{ABS_X, i % 2 ? 100 : -100}, {ABS_RY, i}});
  pad.press(BTN_SOUTH);
  pad.move_axes({{ABS_X, 12345}, {ABS_RY, -777}});
  ASSERT_TRUE(wait([&] {
    auto s = events.state(0);
    return s[{EV_ABS, ABS_X}] == 12345 && s[{EV_ABS, ABS_RY}] == -777;
  }));
  EXPECT_TRUE(std::any_of(events.frames.begin(), events.frames.end(), [](auto& f) { return f.resync; }))
      << "the overflow was not seen as SYN_DROPPED";
  auto s = events.state(0);
  EXPECT_EQ((s[{EV_KEY, BTN_SOUTH}]), 1) << "the press survived the drop";
}

TEST_F(Discovery, UnplugIsDetachAndReplugGetsTheSameSlot) {
  start();
  VirtualJoystick pad(gamepad_spec().named("vm replug pad").ids(BUS_USB, 0x5c17, 0x0042));
  const auto* a = wait_attach("vm replug pad");
  ASSERT_NE(a, nullptr);
  const std::uint8_t slot = a->slot;
  pad.unplug();
  ASSERT_TRUE(wait([&] { return !events.detaches.empty(); })) << "no detach after unplug (ENODEV)";
  EXPECT_EQ(events.detaches.back(), slot);
  EXPECT_EQ(manager->attached(), 0u);
  // Another device meanwhile takes another slot...
  VirtualJoystick other(rumble_pad_spec().named("vm other pad"));
  const auto* o = wait_attach("vm other pad");
  ASSERT_NE(o, nullptr);
  EXPECT_NE(o->slot, slot);
  // ...and the first comes back to its own.
  events.attaches.clear();
  pad.plug();
  const auto* back = wait_attach("vm replug pad");
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(back->slot, slot);
  EXPECT_EQ(back->info.node, pad.event_node());
  // It reads again.
  pad.move_axis(ABS_RX, 4321);
  ASSERT_TRUE(wait([&] { return events.state(slot)[{EV_ABS, ABS_RX}] == 4321; }));
  // fds() follows: discovery fd + two devices.
  EXPECT_EQ(manager->fds().size(), 3u);
}

TEST_F(Discovery, EveryFdChangeIsAnnouncedEvenWhenTheCountStaysTheSame) {
  // sculptd re-registers its fds on the callback only. An unplug and a replug
  // handled in one dispatch leave one device fd (often with the same number)
  // but a different file: both changes must be announced.
  start();
  int announced = 0;
  manager->on_fds_changed([&] { ++announced; });
  VirtualJoystick pad(gamepad_spec().named("vm quick replug pad"));
  ASSERT_NE(wait_attach("vm quick replug pad"), nullptr);
  EXPECT_EQ(announced, 1);
  events.attaches.clear();
  pad.unplug();
  pad.plug();  // no dispatch in between
  ASSERT_NE(wait_attach("vm quick replug pad"), nullptr);
  EXPECT_GE(announced, 3) << "a detach and an attach, each announced";
  EXPECT_EQ(manager->attached(), 1u);
  pad.move_axis(ABS_X, 7777);
  ASSERT_TRUE(wait([&] { return events.state(0)[{EV_ABS, ABS_X}] == 7777; }));
}

TEST_F(Discovery, DrivesToolsEndToEndThroughTheMapper) {
  // The io → sim path of sculptd without the daemon: manager → router →
  // messages → ControlMapper.
  struct Bridge : DeviceListener {
    ToolRouter router{{{0, "", Stick::left}, {0, "", Stick::right}}};
    MappingConfig config;
    ControlMapper mapper{2};
    void on_attach(std::uint8_t slot, const DeviceInfo& info) override {
      mapper.apply(InputMessage::attach(slot, router.attach(slot, info, config)));
    }
    void on_detach(std::uint8_t slot) override {
      router.detach(slot);
      mapper.apply(InputMessage::detach(slot));
    }
    void on_frame(const InputFrame& f) override { mapper.apply(InputMessage::of_frame(f)); }
  } bridge;
  DeviceManager m(bridge);
  m.start();
  VirtualJoystick pad(gamepad_spec().named("vm mapped pad"));
  ASSERT_TRUE(pump_until(m, [&] { return bridge.mapper.controls()[1].connected; }));
  pad.move_axes({{ABS_RX, 32767}, {ABS_Y, -32768}});
  pad.press(BTN_SOUTH);
  ASSERT_TRUE(pump_until(m, [&] { return bridge.mapper.controls()[1].grab; }));
  EXPECT_FLOAT_EQ(bridge.mapper.controls()[1].stick[0], 1.0f);
  EXPECT_FLOAT_EQ(bridge.mapper.controls()[0].stick[1], 1.0f);
  pad.unplug();
  ASSERT_TRUE(pump_until(m, [&] { return !bridge.mapper.controls()[1].connected; }));
  EXPECT_FALSE(bridge.mapper.controls()[1].grab);
}

}  // namespace
}  // namespace sculpt::input
