// Stopping: SIGTERM stops and erases every effect and exits 0; after
// SIGKILL the kernel erases them (the joystick sees it); SIGHUP re-reads the
// config without stopping, and a broken config is refused, not applied.
#include <gtest/gtest.h>

#include <fstream>

#include "sculptd_process.hpp"

namespace sculpt::e2e {
namespace {

TEST(Shutdown, SigtermStopsAndErasesEveryEffect) {
  support::VirtualJoystick pad(support::gamepad_spec());
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml")});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_TRUE(press_until_felt(pad)) << d.log();
  ASSERT_FALSE(ids_left(pad.log()).empty());
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait_exit(), 0) << d.log();
  const support::FfLog log = pad.log();
  EXPECT_TRUE(ids_left(log).empty()) << "an effect left on the device";
  // The constant force was stopped (EV_FF id 0) before it was erased.
  for (const auto& u : log.uploads) {
    if (u.effect.type != FF_CONSTANT || u.old) continue;
    bool stopped = false;
    for (const auto& p : log.playbacks) stopped = stopped || (p.id == u.id && p.value == 0);
    EXPECT_TRUE(stopped) << "effect " << u.id << " never stopped";
  }
}

TEST(Shutdown, AfterSigkillTheKernelErasesTheEffects) {
  support::VirtualJoystick pad(support::gamepad_spec());
  Sculptd d({"--scene", data_path("scenes/e2e_ball.toml")});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  ASSERT_TRUE(press_until_felt(pad)) << d.log();
  ASSERT_FALSE(ids_left(pad.log()).empty());
  d.signal(SIGKILL);
  ASSERT_EQ(d.wait_exit(), 128 + SIGKILL);
  EXPECT_TRUE(pad.wait_for([](const support::FfLog& log) { return ids_left(log).empty(); }))
      << "the kernel did not erase the dead daemon's effects";
}

TEST(Shutdown, SighupReloadsAndABrokenConfigIsRefused) {
  const std::string conf = temp_path("hup.conf");
  std::ofstream(conf) << "[haptics]\ngain = 30000\n";
  support::VirtualJoystick pad(support::gamepad_spec());
  Sculptd d({"--config", conf, "--scene", data_path("scenes/e2e_ball.toml")});
  ASSERT_TRUE(d.wait_for_log("on slot 0")) << d.log();
  std::ofstream(conf) << "[haptics]\ngain = 40000\n[input]\ndead_zone = 0.1\n";
  d.signal(SIGHUP);
  ASSERT_TRUE(d.wait_for_log("SIGHUP: reloaded")) << d.log();
  std::ofstream(conf) << "[haptics]\ngain = \"loud\"\n";
  d.signal(SIGHUP);
  ASSERT_TRUE(d.wait_for_log("keeping the running configuration")) << d.log();
  EXPECT_TRUE(d.wait_for_log("haptics.gain")) << "the error names the key\n" << d.log();
  // Still sculpting, still feeling.
  ASSERT_TRUE(press_until_felt(pad)) << d.log();
  d.signal(SIGTERM);
  ASSERT_EQ(d.wait_exit(), 0) << d.log();
  std::remove(conf.c_str());
}

}  // namespace
}  // namespace sculpt::e2e
