// Force feedback through the kernel's evdev FF interface, seen from both ends:
// a libevdev client on the event node does what sculptd's haptics thread does,
// and the VirtualJoystick records what reached the "hardware".
#include <gtest/gtest.h>

#include <cerrno>
#include <libevdev/libevdev.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "support/evdev_client.hpp"
#include "support/virtual_joystick.hpp"

namespace sculpt::support {
namespace {

bool has_playback(const FfLog& log, std::int16_t id, std::int32_t value) {
  for (const auto& p : log.playbacks)
    if (p.id == id && p.value == value) return true;
  return false;
}
bool has_erase(const FfLog& log, std::int16_t id) {
  for (const auto& e : log.erases)
    if (e.id == id) return true;
  return false;
}

class FfBasics : public ::testing::Test {
 protected:
  VirtualJoystick joy{gamepad_spec()};
  EvdevClient client{joy.event_node()};
};

TEST_F(FfBasics, ClientSeesTheDeviceFfCapabilities) {
  EXPECT_EQ(client.name(), joy.spec().name);
  EXPECT_TRUE(client.has_ff(FF_CONSTANT));
  EXPECT_TRUE(client.has_ff(FF_RUMBLE));
  EXPECT_TRUE(client.has_ff(FF_GAIN));
  EXPECT_EQ(client.ff_effects_max(), 16);
}

TEST_F(FfBasics, UploadsConstantAndRumbleWithKernelAssignedIds) {
  ff_effect constant = constant_effect(12000, 0x4000, 250);
  ff_effect rumble = rumble_effect(0xc000, 0x2000, 80);
  ASSERT_EQ(client.upload(constant), 0);
  ASSERT_EQ(client.upload(rumble), 0);
  EXPECT_GE(constant.id, 0);
  EXPECT_GE(rumble.id, 0);
  EXPECT_NE(constant.id, rumble.id);

  // The answer is recorded before the client's ioctl returns: no wait needed.
  const auto ups = joy.uploads();
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_EQ(ups[0].id, constant.id);
  EXPECT_EQ(ups[0].effect.type, FF_CONSTANT);
  EXPECT_EQ(ups[0].effect.u.constant.level, 12000);
  EXPECT_EQ(ups[0].effect.direction, 0x4000);
  EXPECT_EQ(ups[0].effect.replay.length, 250);
  EXPECT_FALSE(ups[0].old.has_value());
  EXPECT_EQ(ups[0].retval, 0);

  EXPECT_EQ(ups[1].id, rumble.id);
  EXPECT_EQ(ups[1].effect.type, FF_RUMBLE);
  EXPECT_EQ(ups[1].effect.u.rumble.strong_magnitude, 0xc000);
  EXPECT_EQ(ups[1].effect.u.rumble.weak_magnitude, 0x2000);
  EXPECT_EQ(ups[1].effect.replay.length, 80);
  EXPECT_FALSE(ups[1].old.has_value());
}

TEST_F(FfBasics, UpdateInPlaceKeepsTheIdAndHandsTheDeviceTheOldEffect) {
  ff_effect e = constant_effect(1000, 0x0000, 100);
  ASSERT_EQ(client.upload(e), 0);
  const std::int16_t id = e.id;

  e.u.constant.level = -7000;
  e.direction = 0xc000;
  ASSERT_EQ(client.upload(e), 0);
  EXPECT_EQ(e.id, id);

  const auto ups = joy.uploads();
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_EQ(ups[1].id, id);
  EXPECT_EQ(ups[1].effect.u.constant.level, -7000);
  EXPECT_EQ(ups[1].effect.direction, 0xc000);
  ASSERT_TRUE(ups[1].old.has_value());
  EXPECT_EQ(ups[1].old->id, id);
  EXPECT_EQ(ups[1].old->type, FF_CONSTANT);
  EXPECT_EQ(ups[1].old->u.constant.level, 1000);
  EXPECT_EQ(ups[1].old->direction, 0x0000);
}

TEST_F(FfBasics, ManyUpdatesInPlaceAllAnswered) {
  // uinput recycles request ids; every request must still get its own answer.
  ff_effect e = constant_effect(0, 0x4000, 50);
  ASSERT_EQ(client.upload(e), 0);
  for (int i = 1; i <= 200; ++i) {
    e.u.constant.level = static_cast<std::int16_t>(i * 100);
    ASSERT_EQ(client.upload(e), 0) << "update " << i;
  }
  const auto ups = joy.uploads();
  ASSERT_EQ(ups.size(), 201u);
  EXPECT_EQ(ups.back().effect.u.constant.level, 20000);
  EXPECT_EQ(ups.back().old->u.constant.level, 19900);
  for (const auto& u : ups) EXPECT_EQ(u.id, e.id);
}

TEST_F(FfBasics, PlayAndStopReachTheDevice) {
  ff_effect e = rumble_effect(0x8000, 0x8000, 100);
  ASSERT_EQ(client.upload(e), 0);
  ASSERT_EQ(client.play(e.id, 3), 0);
  EXPECT_TRUE(joy.wait_for([&](const FfLog& l) { return has_playback(l, e.id, 3); }));
  ASSERT_EQ(client.stop(e.id), 0);
  EXPECT_TRUE(joy.wait_for([&](const FfLog& l) { return has_playback(l, e.id, 0); }));
  const auto plays = joy.playbacks();
  ASSERT_EQ(plays.size(), 2u);
  EXPECT_EQ(plays[0].value, 3);
  EXPECT_EQ(plays[1].value, 0);
}

TEST_F(FfBasics, EraseStopsThenErasesAndFreesTheId) {
  ff_effect e = constant_effect(5000, 0x4000, 100);
  ASSERT_EQ(client.upload(e), 0);
  ASSERT_EQ(client.erase(e.id), 0);
  // Recorded before the client's ioctl returned.
  const auto log = joy.log();
  ASSERT_EQ(log.erases.size(), 1u);
  EXPECT_EQ(log.erases[0].id, e.id);
  // The kernel stops an effect before erasing it.
  ASSERT_FALSE(log.sequence.empty());
  EXPECT_TRUE(has_playback(log, e.id, 0));
  EXPECT_TRUE(std::holds_alternative<FfErase>(log.sequence.back()));
  // The id is gone: updating it now is refused by the kernel.
  EXPECT_EQ(client.upload(e), EINVAL);
  EXPECT_EQ(client.erase(e.id), EINVAL);
  // And the id is free again for a new effect.
  ff_effect again = rumble_effect(1, 1, 10);
  ASSERT_EQ(client.upload(again), 0);
  EXPECT_EQ(again.id, e.id);
}

TEST_F(FfBasics, GainAndAutocenterAreRecorded) {
  ASSERT_EQ(client.set_gain(0x8000), 0);
  ASSERT_EQ(client.set_autocenter(0x1234), 0);
  EXPECT_TRUE(joy.wait_for([](const FfLog& l) { return !l.gains.empty() && !l.autocenters.empty(); }));
  const auto log = joy.log();
  ASSERT_EQ(log.gains.size(), 1u);
  EXPECT_EQ(log.gains[0].gain, 0x8000);
  ASSERT_EQ(log.autocenters.size(), 1u);
  EXPECT_EQ(log.autocenters[0].strength, 0x1234);
}

TEST_F(FfBasics, DeviceCanRefuseUploadsWithAChosenErrno) {
  joy.fail_uploads_with(EIO);
  ff_effect e = rumble_effect(100, 100, 10);
  EXPECT_EQ(client.upload(e), EIO);
  ASSERT_EQ(joy.uploads().size(), 1u);
  EXPECT_EQ(joy.uploads()[0].retval, -EIO);
  joy.fail_uploads_with(0);
  e.id = -1;
  EXPECT_EQ(client.upload(e), 0);
}

TEST_F(FfBasics, ClosingTheClientErasesOnlyItsOwnEffects) {
  EvdevClient other(joy.event_node());
  ff_effect a = constant_effect(3000, 0, 100);
  ff_effect b = rumble_effect(0x4000, 0, 100);
  ff_effect theirs = rumble_effect(0x1000, 0, 100);
  ASSERT_EQ(client.upload(a), 0);
  ASSERT_EQ(client.upload(b), 0);
  ASSERT_EQ(other.upload(theirs), 0);
  ASSERT_EQ(client.play(a.id), 0);
  ASSERT_TRUE(joy.wait_for([&](const FfLog& l) { return has_playback(l, a.id, 1); }));

  // close() blocks in the kernel until the device answered each erase.
  ASSERT_EQ(client.close(), 0);
  EXPECT_TRUE(joy.wait_for([&](const FfLog& l) { return has_erase(l, a.id) && has_erase(l, b.id); }));
  const auto log = joy.log();
  EXPECT_FALSE(has_erase(log, theirs.id));
  EXPECT_EQ(log.erases.size(), 2u);
  EXPECT_TRUE(has_playback(log, a.id, 0));  // stopped before being erased

  // The other client's effect is still there and still works.
  theirs.u.rumble.strong_magnitude = 0x2000;
  EXPECT_EQ(other.upload(theirs), 0);
}

TEST(FfDevices, RumbleOnlyDeviceRejectsConstant) {
  VirtualJoystick joy(rumble_pad_spec());
  EvdevClient client(joy.event_node());
  EXPECT_FALSE(client.has_ff(FF_CONSTANT));
  EXPECT_TRUE(client.has_ff(FF_RUMBLE));

  ff_effect constant = constant_effect(1000, 0, 100);
  EXPECT_EQ(client.upload(constant), EINVAL);
  EXPECT_TRUE(joy.uploads().empty());  // refused by the kernel, never reached the device

  ff_effect rumble = rumble_effect(0xffff, 0, 50);
  EXPECT_EQ(client.upload(rumble), 0);
  ASSERT_EQ(joy.uploads().size(), 1u);
  EXPECT_EQ(joy.uploads()[0].effect.type, FF_RUMBLE);
}

TEST(FfDevices, SingleEffectDeviceRunsOutOfIdsButUpdatesInPlace) {
  VirtualJoystick joy(rumble_pad_spec().named("one effect pad").effects_max(1));
  EvdevClient client(joy.event_node());
  EXPECT_EQ(client.ff_effects_max(), 1);

  ff_effect first = rumble_effect(0x1000, 0, 100);
  ASSERT_EQ(client.upload(first), 0);
  EXPECT_EQ(first.id, 0);

  ff_effect second = rumble_effect(0x2000, 0, 100);
  EXPECT_EQ(client.upload(second), ENOSPC);

  first.u.rumble.strong_magnitude = 0x3000;
  ASSERT_EQ(client.upload(first), 0);
  EXPECT_EQ(first.id, 0);

  const auto ups = joy.uploads();
  ASSERT_EQ(ups.size(), 2u);  // the ENOSPC never reached the device
  EXPECT_EQ(ups[1].effect.u.rumble.strong_magnitude, 0x3000);
  ASSERT_TRUE(ups[1].old.has_value());
  EXPECT_EQ(ups[1].old->u.rumble.strong_magnitude, 0x1000);
}

TEST(FfDevices, DeviceWithoutFfHasNoFfInterface) {
  VirtualJoystick joy(JoystickSpec{}.named("no ff stick").axis(ABS_X, -100, 100).button(BTN_TRIGGER));
  EvdevClient client(joy.event_node());
  EXPECT_FALSE(libevdev_has_event_type(client.dev(), EV_FF));
  ff_effect e = rumble_effect(1, 1, 1);
  EXPECT_EQ(client.upload(e), ENOSYS);
}

TEST(FfDevices, InconsistentSpecIsRefusedWithAClearError) {
  try {
    VirtualJoystick joy(JoystickSpec{}.ff(FF_RUMBLE).effects_max(0));
    FAIL() << "a device with FF bits but no effect slots was created";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ff_effects_max"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sculpt::support
