// Unplug mid-run and plug back: sculptd keeps running, gives the device its
// old slot (so the same tools) and uploads its effects afresh.
#include <gtest/gtest.h>

#include "sculptd_process.hpp"

namespace sculpt::e2e {
namespace {

TEST(Hotplug, UnplugAndPlugBackRebindsTheToolAndReuploads) {
  support::VirtualJoystick pad(support::gamepad_spec());
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml")});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_TRUE(press_until_felt(pad)) << d.log();

  pad.unplug();
  const auto gone = d.wait_for_log("slot 0 is gone");
  ASSERT_TRUE(gone) << d.log();
  EXPECT_FALSE(d.wait_exit(200ms)) << "the daemon died with the device\n" << d.log();

  pad.clear_log();
  pad.plug();
  ASSERT_TRUE(d.wait_for_log("on slot 0", 20s, *gone + 1)) << "not rebound to its slot\n" << d.log();
  // The tool is still pressed into the ball: the force is felt again, on a
  // fresh effect (the kernel forgot the old ids with the old device).
  ASSERT_TRUE(press_until_felt(pad)) << d.log();
  const support::FfLog log = pad.log();
  EXPECT_GE(count_uploads(log, FF_CONSTANT, /*new_only=*/true) + count_uploads(log, FF_RUMBLE, true), 1u);

  d.signal(SIGTERM);
  ASSERT_EQ(d.wait_exit(), 0) << d.log();
  EXPECT_TRUE(ids_left(pad.log()).empty());
}

}  // namespace
}  // namespace sculpt::e2e
