// daemon/haptics against a kernel device: the uinput virtual joystick answers
// the FF uploads our FfDevice / HapticsThread make through evdev, and records
// them. Facts are waited on (flush(), wait_for()), never slept for; where the
// test paces its own publisher it asserts counts, not timings.
#include <gtest/gtest.h>

#include <linux/input.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <thread>

#include "haptics/ff_device.hpp"
#include "haptics/haptics_thread.hpp"
#include "support/evdev_client.hpp"
#include "support/virtual_joystick.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using support::EvdevClient;
using support::FfLog;
using support::FfUpload;
using support::JoystickSpec;
using support::gamepad_spec;
using support::rumble_pad_spec;
using support::VirtualJoystick;

const StickPlane kPlane{0, 2, 1.0, 1.0};

Felt contact(double fx, double fz, bool onset = false, double impulse = 0) {
  Felt f;
  f.force = {fx, 0, fz};
  f.contacts = 4;
  f.touching = true;
  f.onset = onset;
  f.onset_impulse = impulse;
  return f;
}

std::vector<FfUpload> uploads_of(const FfLog& log, std::uint16_t type) {
  std::vector<FfUpload> out;
  for (const auto& u : log.uploads)
    if (u.effect.type == type) out.push_back(u);
  return out;
}
bool played(const FfLog& log, std::int16_t id, std::int32_t value) {
  for (const auto& p : log.playbacks)
    if (p.id == id && p.value == value) return true;
  return false;
}
bool erased(const FfLog& log, std::int16_t id) {
  for (const auto& e : log.erases)
    if (e.id == id && e.retval == 0) return true;
  return false;
}

// Effect ids still free on the device, as the kernel counts them: another client
// uploads until ENOSPC (its effects go when it closes).
int free_effect_ids(const std::string& node) {
  EvdevClient other(node);
  int n = 0;
  for (;;) {
    ff_effect e = support::rumble_effect(1, 1, 10);
    const int err = other.upload(e);
    if (err == ENOSPC) return n;
    if (err != 0) return -err;
    ++n;
  }
}

HapticsSettings fast_settings() {
  HapticsSettings s;
  s.poll_interval = 2ms;
  s.pacing.usb = 20ms;  // the virtual joystick says BUS_USB
  s.gain = 0xc000;
  s.force = ForceScale{2.0, 0.1, 1.0};
  s.rumble = RumbleScale{0.02, 1e-5, 0.5, 40, 0.0, 0.25};
  return s;
}

TEST(HapticsVm, FfDeviceUploadsOnceThenTenThousandUpdatesInPlace) {
  VirtualJoystick joy(gamepad_spec());
  joy.set_recording(false);  // 10 000 uploads: count them, keep no log
  FfCounters counters;
  {
    auto dev = FfDevice::open(joy.event_node(), {}, &counters);
    ASSERT_EQ(dev->mode(), FfMode::constant);
    ASSERT_TRUE(dev->upload_constant({100, 0x4000}, 20000));
    ASSERT_TRUE(dev->play(FfDevice::Effect::constant));
    const std::int16_t id = dev->constant_id();
    ASSERT_GE(id, 0);
    const int free_before = free_effect_ids(joy.event_node());
    for (int i = 0; i < 10000; ++i) {
      const ConstantCommand c{static_cast<std::int16_t>(i % 0x7fff), static_cast<std::uint16_t>(i * 97)};
      ASSERT_TRUE(dev->upload_constant(c, 20000)) << "update " << i;
      ASSERT_EQ(dev->constant_id(), id) << "update " << i;
    }
    EXPECT_EQ(free_effect_ids(joy.event_node()), free_before);  // the free-id count stayed flat
    EXPECT_EQ(free_before, 15);
    EXPECT_EQ(counters.uploads.load(), 10001u);
    EXPECT_EQ(counters.errors.load(), 0u);
  }
  EXPECT_GE(joy.uploads_answered(), 10001u);
  EXPECT_EQ(counters.live_effects.load(), 0);
}

TEST(HapticsVm, ThreadMakesOneConstantUploadThenPacedInPlaceUpdates) {
  VirtualJoystick joy(gamepad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  haptics.flush();
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) { return !l.uploads.empty(); }));

  // 10 000 sim ticks of a force that changes every tick, paced like a fast
  // loop (a few per millisecond), read by the thread as it likes.
  const auto start = std::chrono::steady_clock::now();
  for (int tick = 0; tick < 10000; ++tick) {
    const double a = tick * 0.003;
    board.publish(0, contact(1.5 * std::sin(a), 1.5 * std::cos(a)));
    if (tick % 4 == 3) std::this_thread::sleep_for(1ms);
  }
  haptics.flush();
  const auto elapsed = std::chrono::steady_clock::now() - start;

  const FfLog log = joy.log();
  const auto constants = uploads_of(log, FF_CONSTANT);
  ASSERT_GE(constants.size(), 2u);
  EXPECT_FALSE(constants[0].old.has_value());  // exactly one new effect ...
  const std::int16_t id = constants[0].id;
  for (std::size_t i = 1; i < constants.size(); ++i) {  // ... then updates in place
    ASSERT_TRUE(constants[i].old.has_value()) << i;
    EXPECT_EQ(constants[i].id, id) << i;
    EXPECT_EQ(constants[i].retval, 0);
  }
  EXPECT_EQ(haptics.bustype(0), BUS_USB);
  // Paced: no more than one write per 20 ms USB interval over the time
  // measured (+ the first).
  const auto intervals = elapsed / 20ms;
  EXPECT_LE(static_cast<long>(constants.size()), static_cast<long>(intervals) + 2);
  EXPECT_TRUE(played(log, id, 1));
  EXPECT_EQ(free_effect_ids(joy.event_node()), 15);
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 1);
  EXPECT_EQ(haptics.stats().ff.errors.load(), 0u);
  haptics.stop();
}

TEST(HapticsVm, ContactDirectionAndLevelReachTheDevice) {
  VirtualJoystick joy(gamepad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  board.publish(0, contact(-1.0, 0));  // pushed back along −x: the stick is pushed left
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    for (const auto& u : l.uploads)
      if (u.effect.type == FF_CONSTANT && u.effect.u.constant.level == 18021) return true;  // 1 N of 2: 0.55
    return false;
  }));
  const auto constants = uploads_of(joy.log(), FF_CONSTANT);
  EXPECT_EQ(constants.back().effect.direction, 0xC000);
  EXPECT_EQ(constants.back().effect.replay.length, 20000);  // finite; re-armed by a play every 5 s
}

TEST(HapticsVm, RumbleKickOnOnset) {
  VirtualJoystick joy(gamepad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  haptics.flush();
  board.publish(0, contact(0.5, 0, /*onset=*/true, 0.01));
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    const auto r = uploads_of(l, FF_RUMBLE);
    return !r.empty() && played(l, r[0].id, 1);
  }));
  const auto rumbles = uploads_of(joy.log(), FF_RUMBLE);
  ASSERT_EQ(rumbles.size(), 1u);
  EXPECT_EQ(rumbles[0].effect.u.rumble.strong_magnitude, 32767);
  EXPECT_GT(rumbles[0].effect.replay.length, 0);
  EXPECT_NE(rumbles[0].id, uploads_of(joy.log(), FF_CONSTANT)[0].id);
  haptics.flush();  // the device saw the play before the thread counted the kick
  EXPECT_EQ(haptics.stats().ff.kicks.load(), 1u);
}

TEST(HapticsVm, RumbleOnlyPadFeelsTheForceAndKicksInOneEffect) {
  VirtualJoystick joy(rumble_pad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    const auto r = uploads_of(l, FF_RUMBLE);
    return !r.empty() && played(l, r[0].id, 1);
  }));
  board.publish(0, contact(1.0, 0, true, 0.02));  // a kick, then the contact level
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    const auto r = uploads_of(l, FF_RUMBLE);
    return r.size() >= 3 && r.back().effect.u.rumble.weak_magnitude > r.back().effect.u.rumble.strong_magnitude;
  }));
  board.publish(0, Felt{});  // released: zero
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    const auto r = uploads_of(l, FF_RUMBLE);
    return !r.back().effect.u.rumble.weak_magnitude && !r.back().effect.u.rumble.strong_magnitude;
  }));
  const FfLog log = joy.log();
  const auto r = uploads_of(log, FF_RUMBLE);
  EXPECT_TRUE(uploads_of(log, FF_CONSTANT).empty());
  EXPECT_FALSE(r[0].old.has_value());
  for (std::size_t i = 1; i < r.size(); ++i) {
    EXPECT_TRUE(r[i].old.has_value()) << i;  // one effect, updated in place
    EXPECT_EQ(r[i].id, r[0].id) << i;
  }
  EXPECT_GT(r[1].effect.u.rumble.strong_magnitude, r[1].effect.u.rumble.weak_magnitude) << "the kick";
  EXPECT_EQ(haptics.stats().ff.errors.load(), 0u);
  EXPECT_EQ(free_effect_ids(joy.event_node()), 15);
}

TEST(HapticsVm, OneEffectIdHoldsTheConstant) {
  VirtualJoystick joy(gamepad_spec().effects_max(1));
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  haptics.flush();
  board.publish(0, contact(1.0, 0, true, 0.02));
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) { return uploads_of(l, FF_CONSTANT).size() >= 2; }));
  haptics.flush();
  const FfLog log = joy.log();
  EXPECT_TRUE(uploads_of(log, FF_RUMBLE).empty());
  for (const auto& u : log.uploads) EXPECT_EQ(u.retval, 0);
  EXPECT_EQ(haptics.stats().ff.errors.load(), 0u);
  EXPECT_EQ(free_effect_ids(joy.event_node()), 0);
}

TEST(HapticsVm, OneEffectIdRumblePadKicks) {
  VirtualJoystick joy(rumble_pad_spec().effects_max(1));
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  haptics.flush();
  board.publish(0, contact(1.0, 0, true, 0.02));
  EXPECT_TRUE(joy.wait_for([](const FfLog& l) { return !uploads_of(l, FF_RUMBLE).empty(); }));
}

TEST(HapticsVm, DeviceWithoutFfIsInputOnly) {
  VirtualJoystick joy(JoystickSpec{}.named("plain stick").axis(ABS_X, -512, 511).axis(ABS_Y, -512, 511).button(BTN_TRIGGER));
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  board.publish(0, contact(1.0, 0, true, 0.02));
  haptics.flush();
  haptics.flush();
  EXPECT_EQ(haptics.stats().devices.load(), 1);
  EXPECT_EQ(haptics.stats().ff_devices.load(), 0);
  EXPECT_EQ(haptics.stats().ff.errors.load(), 0u);
  EXPECT_EQ(haptics.stats().open_failures.load(), 0u);
  EXPECT_TRUE(joy.log().sequence.empty());
}

TEST(HapticsVm, GainIsSet) {
  VirtualJoystick joy(gamepad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) { return !l.gains.empty(); }));
  EXPECT_EQ(joy.gains()[0].gain, 0xc000);
  HapticsSettings s = fast_settings();
  s.gain = 0x4000;
  haptics.configure(s);  // SIGHUP
  EXPECT_TRUE(joy.wait_for([](const FfLog& l) { return l.gains.size() >= 2 && l.gains.back().gain == 0x4000; }));
}

TEST(HapticsVm, StopStopsAndErasesEveryEffect) {
  VirtualJoystick joy(gamepad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  haptics.flush();  // attached (onsets from before the first poll give no kick)
  board.publish(0, contact(1.0, 0, true, 0.02));
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    return !uploads_of(l, FF_CONSTANT).empty() && !uploads_of(l, FF_RUMBLE).empty();
  }));
  const FfLog before = joy.log();
  const std::int16_t c = uploads_of(before, FF_CONSTANT)[0].id;
  const std::int16_t r = uploads_of(before, FF_RUMBLE)[0].id;
  haptics.stop();
  // Erased by us, before our fd closed (the erase answers are recorded before
  // EVIOCRMFF returns).
  const FfLog log = joy.log();
  EXPECT_TRUE(played(log, c, 0));
  EXPECT_TRUE(played(log, r, 0));
  EXPECT_TRUE(erased(log, c));
  EXPECT_TRUE(erased(log, r));
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 0);
  EXPECT_EQ(free_effect_ids(joy.event_node()), 16);
}

TEST(HapticsVm, UnplugForgetsIdsAndReplugUploadsAgain) {
  VirtualJoystick joy(gamepad_spec());
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(5, joy.event_node(), {{0, kPlane}});
  board.publish(0, contact(1.0, 0));
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) { return !uploads_of(l, FF_CONSTANT).empty(); }));
  haptics.flush();
  ASSERT_EQ(haptics.stats().ff.live_effects.load(), 1);

  joy.unplug();
  haptics.detach(5);  // what the io thread does when its read says ENODEV
  haptics.flush();
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 0);
  EXPECT_EQ(haptics.stats().devices.load(), 0);

  // A write the thread made between the unplug and the detach met ENODEV:
  // that is the unplug, not the replug. The replug itself fails nothing.
  const std::uint64_t errors_before_replug = haptics.stats().ff.errors.load();
  joy.clear_log();
  joy.plug();
  haptics.attach(5, joy.event_node(), {{0, kPlane}});
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    const auto c = uploads_of(l, FF_CONSTANT);
    return !c.empty() && played(l, c[0].id, 1);
  }));
  const auto constants = uploads_of(joy.log(), FF_CONSTANT);
  EXPECT_FALSE(constants[0].old.has_value());  // a new effect (id −1), not an update of a dead id
  EXPECT_EQ(constants[0].effect.u.constant.level, 18021);
  haptics.flush();
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 1);
  EXPECT_EQ(haptics.stats().ff.errors.load(), errors_before_replug);
}

TEST(HapticsVm, KernelRefusingTheConstantFallsBackToRumble) {
  // The device claims FF_CONSTANT, but its driver answers EINVAL.
  VirtualJoystick joy(gamepad_spec());
  joy.fail_uploads_with(EINVAL);
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) { return !l.uploads.empty(); }));
  haptics.flush();
  joy.fail_uploads_with(0);
  EXPECT_EQ(haptics.stats().ff.errors.load(), 1u);

  board.publish(0, contact(1.0, 0, true, 0.02));
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) { return !uploads_of(l, FF_RUMBLE).empty(); }));
  haptics.flush();
  board.publish(0, contact(-1.0, 0));
  haptics.flush();
  haptics.flush();
  EXPECT_EQ(uploads_of(joy.log(), FF_CONSTANT).size(), 1u);  // the refused one only
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 1);      // the rumble
}

TEST(HapticsVm, NoFreeIdIsCountedAndRetried) {
  VirtualJoystick joy(gamepad_spec().effects_max(1));
  EvdevClient hog(joy.event_node());  // another program holds the only id
  ff_effect held = support::rumble_effect(1, 1, 10);
  ASSERT_EQ(hog.upload(held), 0);
  FeedbackBoard board(1);
  HapticsThread haptics(board, fast_settings());
  haptics.start();
  haptics.attach(0, joy.event_node(), {{0, kPlane}});
  haptics.flush();
  haptics.flush();
  EXPECT_GE(haptics.stats().ff.errors.load(), 1u);  // ENOSPC from the kernel itself
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 0);
  ASSERT_EQ(hog.erase(held.id), 0);  // the id is free again: the retry gets it
  board.publish(0, contact(1.0, 0));
  ASSERT_TRUE(joy.wait_for([](const FfLog& l) {
    for (const auto& u : l.uploads)
      if (u.effect.type == FF_CONSTANT && u.retval == 0) return true;
    return false;
  }));
  haptics.flush();
  EXPECT_EQ(haptics.stats().ff.live_effects.load(), 1);
}

}  // namespace
}  // namespace sculpt::haptics
