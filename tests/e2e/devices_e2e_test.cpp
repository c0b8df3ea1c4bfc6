// Devices with less force feedback: a rumble-only pad gets rumble and no
// constant force, a pad with one effect slot never holds two, a device with
// no FF at all still sculpts. Each run ends with a clean exit.
#include <gtest/gtest.h>

#include "sculptd_process.hpp"

namespace sculpt::e2e {
namespace {

TEST(Devices, RumbleOnlyPadGetsRumbleAndNoConstantForce) {
  support::VirtualJoystick pad(support::rumble_pad_spec());
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml")});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_TRUE(press_until_felt(pad)) << d.log();
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait_exit(), 0) << d.log();
  const support::FfLog log = pad.log();
  EXPECT_GE(count_uploads(log, FF_RUMBLE), 1u);
  for (const auto& u : log.uploads) EXPECT_NE(u.effect.type, FF_CONSTANT) << "the pad has no FF_CONSTANT";
  EXPECT_TRUE(ids_left(log).empty());
}

TEST(Devices, OneEffectPadNeverHoldsTwoEffects) {
  support::VirtualJoystick pad(support::gamepad_spec().named("one effect pad").effects_max(1));
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml")});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_TRUE(press_until_felt(pad)) << d.log();
  for (int i = 0; i < 8; ++i) {
    pad.move_axes({{ABS_X, i % 2 ? 9000 : -9000}, {ABS_Y, 3000}});
    std::this_thread::sleep_for(60ms);
  }
  pad.move_axes({{ABS_X, 0}, {ABS_Y, 0}});
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait_exit(), 0) << d.log();
  const support::FfLog log = pad.log();
  EXPECT_LE(max_live_ids(log), 1u);
  for (const auto& u : log.uploads) EXPECT_EQ(u.retval, 0) << "an upload the device had no room for";
  EXPECT_TRUE(ids_left(log).empty());
}

TEST(Devices, ADeviceWithoutForceFeedbackStillSculpts) {
  support::JoystickSpec spec = support::gamepad_spec().named("no ff pad");
  spec.ff_bits.clear();
  spec.effects_max(0);
  support::VirtualJoystick pad(spec);
  const std::string stats = temp_path("noff.json");
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml"), "--stats-json", stats});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  pad.move_axis(ABS_Y, 12000);
  std::this_thread::sleep_for(500ms);
  pad.move_axis(ABS_Y, 0);
  EXPECT_FALSE(d.wait_exit(100ms)) << d.log();
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait_exit(), 0) << d.log();
  EXPECT_TRUE(pad.log().uploads.empty());
  const auto j = read_json(stats);
  EXPECT_EQ(j["devices"], 1);
  EXPECT_EQ(j["ff_uploads"], 0);
  std::remove(stats.c_str());
}

}  // namespace
}  // namespace sculpt::e2e
