// Axis calibration: absinfo range, the kernel's flat, the configured dead
// zone, triggers, fuzz; and classification of devices from capabilities.
#include <gtest/gtest.h>

#include "input/calibration.hpp"
#include "input/device_info.hpp"
#include "test_devices.hpp"

namespace sculpt::input {
namespace {

TEST(Calibration, BipolarEndsAndCentre) {
  const auto c = calibrate({ABS_X, 0, -32768, 32767, 0, 0, 0}, 0.0f, false);
  EXPECT_FLOAT_EQ(c.normalize(-32768), -1.0f);
  EXPECT_FLOAT_EQ(c.normalize(32767), 1.0f);
  EXPECT_NEAR(c.normalize(0), 0.0f, 1e-4);
  EXPECT_NEAR(c.normalize(16384), 0.5f, 1e-3);
}

TEST(Calibration, OffsetRangeIsCentredOnItsMiddle) {
  const auto c = calibrate({ABS_X, 0, 0, 1024, 0, 0, 0}, 0.0f, false);
  EXPECT_FLOAT_EQ(c.normalize(512), 0.0f);
  EXPECT_FLOAT_EQ(c.normalize(0), -1.0f);
  EXPECT_FLOAT_EQ(c.normalize(1024), 1.0f);
  EXPECT_FLOAT_EQ(c.normalize(768), 0.5f);
}

TEST(Calibration, OutOfRangeClamps) {
  const auto c = calibrate({ABS_X, 0, -100, 100, 0, 0, 0}, 0.0f, false);
  EXPECT_FLOAT_EQ(c.normalize(5000), 1.0f);
  EXPECT_FLOAT_EQ(c.normalize(-5000), -1.0f);
}

TEST(Calibration, FlatReadsAsZeroAndTheRestIsRescaled) {
  // flat 10 of a half range of 100: |v| <= 0.1 reads 0, full still reads 1.
  const auto c = calibrate({ABS_X, 0, -100, 100, 0, 10, 0}, 0.0f, false);
  EXPECT_EQ(c.normalize(10), 0.0f);
  EXPECT_EQ(c.normalize(-10), 0.0f);
  EXPECT_GT(c.normalize(11), 0.0f);
  EXPECT_FLOAT_EQ(c.normalize(100), 1.0f);
  EXPECT_NEAR(c.normalize(55), 0.5f, 1e-5);  // (0.55 - 0.1) / 0.9
  EXPECT_NEAR(c.normalize(-55), -0.5f, 1e-5);
}

TEST(Calibration, DeadZoneWinsWhenLargerThanFlat) {
  const auto c = calibrate({ABS_X, 0, -100, 100, 0, 10, 0}, 0.2f, false);
  EXPECT_EQ(c.normalize(19), 0.0f);
  EXPECT_GT(c.normalize(21), 0.0f);
  EXPECT_NEAR(c.normalize(60), 0.5f, 1e-5);  // (0.6 - 0.2) / 0.8
}

TEST(Calibration, TriggerReadsZeroToOne) {
  const auto c = calibrate({ABS_Z, 0, 0, 255, 0, 0, 0}, 0.0f, true);
  EXPECT_FLOAT_EQ(c.normalize(0), 0.0f);
  EXPECT_FLOAT_EQ(c.normalize(255), 1.0f);
  EXPECT_NEAR(c.normalize(51), 0.2f, 1e-6);
  const auto d = calibrate({ABS_Z, 0, 0, 100, 0, 0, 0}, 0.1f, true);
  EXPECT_EQ(d.normalize(9), 0.0f);
  EXPECT_NEAR(d.normalize(55), 0.5f, 1e-5);
}

TEST(Calibration, DegenerateRangeReadsZero) {
  const auto c = calibrate({ABS_X, 0, 5, 5, 0, 0, 0}, 0.0f, false);
  EXPECT_EQ(c.normalize(5), 0.0f);
  EXPECT_EQ(c.normalize(100), 0.0f);
  const auto d = calibrate({ABS_X, 0, 10, -10, 0, 0, 0}, 0.0f, false);
  EXPECT_EQ(d.normalize(0), 0.0f);
}

TEST(Calibration, HugeFlatNeverSwallowsFullDeflection) {
  const auto c = calibrate({ABS_X, 0, -100, 100, 0, 1000, 0}, 0.0f, false);
  EXPECT_FLOAT_EQ(c.normalize(100), 1.0f);
}

TEST(Calibration, FuzzFiltersSmallChanges) {
  const auto c = calibrate({ABS_X, 0, -100, 100, 8, 0, 0}, 0.0f, false);
  EXPECT_FALSE(c.moved(50, 53));
  EXPECT_FALSE(c.moved(50, 46));
  EXPECT_TRUE(c.moved(50, 55));
  EXPECT_TRUE(c.moved(50, 45));
  const auto none = calibrate({ABS_X, 0, -100, 100, 0, 0, 0}, 0.0f, false);
  EXPECT_TRUE(none.moved(50, 51));
  EXPECT_FALSE(none.moved(50, 50));
}

TEST(Classification, GamepadByButtonsOrTwoSticks) {
  EXPECT_EQ(classify_capabilities(testing::gamepad()), DeviceKind::gamepad);
  DeviceInfo sticks_only = testing::gamepad();
  sticks_only.buttons.clear();
  EXPECT_EQ(classify_capabilities(sticks_only), DeviceKind::gamepad);
  DeviceInfo buttons_one_stick = testing::gamepad();
  buttons_one_stick.axes = {{ABS_X, 0, -1, 1, 0, 0, 0}, {ABS_Y, 0, -1, 1, 0, 0, 0}};
  EXPECT_EQ(classify_capabilities(buttons_one_stick), DeviceKind::gamepad);
}

TEST(Classification, JoystickByTriggerButtonsOrBareAxes) {
  EXPECT_EQ(classify_capabilities(testing::flight_stick()), DeviceKind::joystick);
  DeviceInfo bare = testing::flight_stick();
  bare.buttons.clear();
  EXPECT_EQ(classify_capabilities(bare), DeviceKind::joystick);
}

TEST(Classification, PointersAndKeyboardsAreOther) {
  DeviceInfo touchpad;
  touchpad.axes = {{ABS_X, 0, 0, 1000, 0, 0, 0}, {ABS_Y, 0, 0, 1000, 0, 0, 0}};
  touchpad.buttons = {BTN_LEFT, BTN_TOUCH, BTN_TOOL_FINGER};
  EXPECT_EQ(classify_capabilities(touchpad), DeviceKind::other);
  DeviceInfo tablet;
  tablet.axes = touchpad.axes;
  tablet.buttons = {BTN_TOOL_PEN, BTN_STYLUS};
  EXPECT_EQ(classify_capabilities(tablet), DeviceKind::other);
  DeviceInfo keyboard;
  keyboard.buttons = {KEY_A, KEY_B, KEY_ENTER};
  EXPECT_EQ(classify_capabilities(keyboard), DeviceKind::other);
  DeviceInfo mt;
  mt.axes = {{ABS_X, 0, 0, 1, 0, 0, 0}, {ABS_Y, 0, 0, 1, 0, 0, 0}, {ABS_MT_POSITION_X, 0, 0, 1, 0, 0, 0}};
  EXPECT_EQ(classify_capabilities(mt), DeviceKind::other);
  DeviceInfo nothing;
  EXPECT_EQ(classify_capabilities(nothing), DeviceKind::other);
}

TEST(Classification, UdevJoystickIsRefinedByCapabilities) {
  EXPECT_EQ(classify_udev_joystick(testing::gamepad()), DeviceKind::gamepad);
  EXPECT_EQ(classify_udev_joystick(testing::flight_stick()), DeviceKind::joystick);
}

TEST(DeviceInfo, IdentityIgnoresTheNode) {
  DeviceInfo a = testing::gamepad(), b = testing::gamepad();
  a.node = "/dev/input/event3";
  b.node = "/dev/input/event9";
  EXPECT_EQ(a.identity(), b.identity());
  b.uniq = "serial-2";
  EXPECT_NE(a.identity(), b.identity());
  EXPECT_NE(describe(a).find("gamepad"), std::string::npos);
  EXPECT_NE(describe(a).find("rumble"), std::string::npos);
}

}  // namespace
}  // namespace sculpt::input
