// sculptd end to end on a virtual gamepad: the stick moves a tool into a
// mesh, the contact is felt through ONE FF_CONSTANT effect updated in place
// (same id) plus a rumble kick on onset, and over 10 000 ticks the device
// never holds more than those two effects.
#include <gtest/gtest.h>

#include "sculptd_process.hpp"

namespace sculpt::e2e {
namespace {

TEST(Contact, OneConstantEffectUpdatedInPlaceAndARumbleKickOnOnset) {
  support::VirtualJoystick pad(support::gamepad_spec());
  const std::string stats = temp_path("contact.json");
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml"), "--duration", "10", "--stats-json", stats});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_TRUE(press_until_felt(pad)) << "no force felt\n" << d.log();
  // Hold the tool in the ball and move it sideways: the force changes.
  for (int i = 0; i < 16; ++i) {
    pad.move_axes({{ABS_X, i % 2 ? 9000 : -9000}, {ABS_Y, 3000}});
    std::this_thread::sleep_for(60ms);
  }
  pad.move_axes({{ABS_X, 0}, {ABS_Y, 0}});
  ASSERT_EQ(d.wait_exit(90s), 0) << d.log();

  const support::FfLog log = pad.log();
  EXPECT_EQ(count_uploads(log, FF_CONSTANT, /*new_only=*/true), 1u) << "one constant effect, uploaded once";
  EXPECT_GE(count_uploads(log, FF_CONSTANT), 2u) << "then updated in place";
  std::optional<std::int16_t> id;
  for (const auto& u : log.uploads) {
    if (u.effect.type != FF_CONSTANT || u.retval != 0) continue;
    if (!id) id = u.id;
    EXPECT_EQ(u.id, *id) << "every constant upload reuses the first one's id";
  }
  EXPECT_GE(count_uploads(log, FF_RUMBLE), 1u) << "a rumble kick on contact onset";
  EXPECT_LE(max_live_ids(log), 2u) << "slots stay flat: one constant + one rumble";
  EXPECT_TRUE(ids_left(log).empty()) << "everything erased at exit";

  const auto j = read_json(stats);
  EXPECT_GE(j["ticks"].get<std::uint64_t>(), 10000u);
  EXPECT_EQ(j["devices"], 1);
  EXPECT_GE(j["ff_uploads"].get<std::uint64_t>(), 2u);
  EXPECT_EQ(j["blowups"], 0);
  std::remove(stats.c_str());
}

TEST(Contact, AStickAtRestTouchesNothing) {
  support::VirtualJoystick pad(support::gamepad_spec());
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml"), "--duration", "1"});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_EQ(d.wait_exit(60s), 0) << d.log();
  for (const auto& u : pad.log().uploads) {
    if (u.effect.type == FF_CONSTANT) {
      EXPECT_EQ(u.effect.u.constant.level, 0) << "a force without contact";
    }
  }
  EXPECT_EQ(count_uploads(pad.log(), FF_RUMBLE), 0u) << "a kick without contact";
}

}  // namespace
}  // namespace sculpt::e2e
