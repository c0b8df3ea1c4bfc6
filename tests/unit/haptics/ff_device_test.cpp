// The upload state machine against a fake device: id −1 once then the same
// id, play once, gain, EINVAL / ENOSPC fallbacks, ff_effects_max = 1,
// rumble-only and no-FF devices, erase on shutdown, forget on unplug; every
// call one write to the driver, paced and stamped when it returned.
#include <gtest/gtest.h>

#include <optional>

#include "fake_port.hpp"
#include "haptics/ff_device.hpp"

namespace sculpt::haptics {
namespace {

using testing::FakeDeviceState;
using testing::FakePort;
using testing::fake_device;
using Call = FakeDeviceState::Call;

std::unique_ptr<FfDevice> make(const std::shared_ptr<FakeDeviceState>& s, FfCounters* c = nullptr,
                               FfDeviceOptions o = {}) {
  return std::make_unique<FfDevice>(std::make_unique<FakePort>(s), o, c);
}

// The engine's DevicePlayer makes each of these two (paced) writes; here
// they go back to back: upload, then play.
bool set_constant(FfDevice& dev, const ConstantCommand& c) {
  const bool fresh = dev.constant_id() < 0;
  if (!dev.upload_constant(c, 20000)) return false;
  return !fresh || dev.play(FfDevice::Effect::constant);
}
bool kick(FfDevice& dev, const RumbleCommand& r) {
  return dev.upload_rumble(r) && dev.play(FfDevice::Effect::rumble);
}

bool has_write(const FakeDeviceState& s, int code, int value) {
  for (const auto& c : s.of(Call::write))
    if (c.id == code && c.value == value) return true;
  return false;
}

TEST(FfDevice, UploadsWithMinusOneOnceThenUpdatesInPlace) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 16);
  FfCounters counters;
  auto dev = make(s, &counters);
  EXPECT_EQ(dev->mode(), FfMode::constant);
  ASSERT_TRUE(set_constant(*dev, {1000, 0x4000}));
  const std::int16_t id = dev->constant_id();
  EXPECT_GE(id, 0);
  for (int i = 1; i <= 100; ++i) ASSERT_TRUE(set_constant(*dev, {static_cast<std::int16_t>(1000 + i * 10), 0x8000}));
  const auto ups = s->of(Call::upload);
  ASSERT_EQ(ups.size(), 101u);
  EXPECT_EQ(ups[0].effect.id, -1);            // asked for a new id once
  for (std::size_t i = 1; i < ups.size(); ++i) EXPECT_EQ(ups[i].effect.id, id);  // then in place
  EXPECT_EQ(ups.back().effect.type, FF_CONSTANT);
  EXPECT_EQ(ups.back().effect.u.constant.level, 2000);
  EXPECT_EQ(ups.back().effect.direction, 0x8000);
  EXPECT_EQ(ups.back().effect.replay.length, 20000);  // finite: re-armed by the caller
  EXPECT_EQ(s->live(), 1);                    // one id, however many updates
  EXPECT_EQ(counters.uploads.load(), 101u);
  EXPECT_EQ(counters.live_effects.load(), 1);
  EXPECT_EQ(counters.errors.load(), 0u);
  // Started once, right after the first upload.
  int plays = 0;
  for (const auto& w : s->of(Call::write)) plays += (w.id == id && w.value == 1);
  EXPECT_EQ(plays, 1);
}

TEST(FfDevice, SetsGainWhenSupported) {
  auto s = fake_device({FF_CONSTANT, FF_GAIN}, 16);
  FfDeviceOptions o;
  o.gain = 0xc000;
  auto dev = make(s, nullptr, o);
  EXPECT_TRUE(has_write(*s, FF_GAIN, 0xc000));
  dev->set_gain(0x4000);
  EXPECT_TRUE(has_write(*s, FF_GAIN, 0x4000));

  auto no_gain = fake_device({FF_CONSTANT}, 16);
  auto dev2 = make(no_gain);
  EXPECT_TRUE(no_gain->of(Call::write).empty());
}

TEST(FfDevice, RumbleKickUsesItsOwnIdInPlace) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  FfCounters counters;
  auto dev = make(s, &counters);
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  ASSERT_TRUE(kick(*dev, {0x8000, 0x4000, 60}));
  ASSERT_TRUE(kick(*dev, {0xffff, 0x8000, 60}));
  EXPECT_GE(dev->rumble_id(), 0);
  EXPECT_NE(dev->rumble_id(), dev->constant_id());
  const auto ups = s->of(Call::upload);
  ASSERT_EQ(ups.size(), 3u);
  EXPECT_EQ(ups[1].effect.type, FF_RUMBLE);
  EXPECT_EQ(ups[1].effect.id, -1);
  EXPECT_EQ(ups[2].effect.id, dev->rumble_id());
  EXPECT_EQ(ups[2].effect.u.rumble.strong_magnitude, 0xffff);
  EXPECT_EQ(ups[2].effect.replay.length, 60);
  int plays = 0;
  for (const auto& w : s->of(Call::write)) plays += (w.id == dev->rumble_id() && w.value == 1);
  EXPECT_EQ(plays, 2);  // each kick plays once
  EXPECT_EQ(s->live(), 2);
}

TEST(FfDevice, EinvalOnAnUpdateMeansTheIdVanished) {
  auto s = fake_device({FF_CONSTANT}, 16);
  FfCounters counters;
  auto dev = make(s, &counters);
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  // Someone erased it behind our back: the kernel now refuses the id.
  s->used[static_cast<std::size_t>(dev->constant_id())] = false;
  EXPECT_FALSE(dev->upload_constant({2000, 0}, 20000)) << "one write per call: the fresh upload is the next call";
  EXPECT_EQ(dev->constant_id(), -1);
  ASSERT_TRUE(set_constant(*dev, {2000, 0}));
  const auto ups = s->of(Call::upload);
  ASSERT_EQ(ups.size(), 3u);
  EXPECT_EQ(ups[1].result, EINVAL);
  EXPECT_EQ(ups[2].effect.id, -1);  // started over
  EXPECT_EQ(ups[2].result, 0);
  EXPECT_EQ(counters.errors.load(), 1u);
  EXPECT_EQ(counters.live_effects.load(), 1);
  EXPECT_EQ(s->live(), 1);
}

TEST(FfDevice, EinvalOnANewConstantFallsBackToRumble) {
  // Claims FF_CONSTANT but refuses it.
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  s->upload_errors = {EINVAL};
  auto dev = make(s);
  EXPECT_FALSE(set_constant(*dev, {1000, 0}));
  EXPECT_EQ(dev->mode(), FfMode::rumble_only);
  EXPECT_FALSE(set_constant(*dev, {1000, 0}));  // no more constant uploads
  EXPECT_EQ(s->of(Call::upload).size(), 1u);
  EXPECT_TRUE(kick(*dev, {0x8000, 0x8000, 60}));
}

TEST(FfDevice, EnospcForTheConstantTakesTheRumbleId) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 2);
  auto dev = make(s);
  ASSERT_TRUE(kick(*dev, {0x8000, 0x8000, 60}));
  const std::int16_t rumble = dev->rumble_id();
  ASSERT_TRUE(s->playing[static_cast<std::size_t>(rumble)]);
  s->used[1] = true;  // another client holds the other id
  // One write per call: the upload that meets ENOSPC, then the rumble's
  // erase, then the constant's upload.
  auto n = s->calls.size();
  EXPECT_FALSE(dev->upload_constant({1000, 0}, 20000));
  EXPECT_EQ(s->calls.size(), n + 1);
  EXPECT_FALSE(dev->rumble_allowed()) << "no kicks meanwhile";
  n = s->calls.size();
  EXPECT_FALSE(dev->upload_constant({1000, 0}, 20000));
  EXPECT_EQ(s->calls.size(), n + 1);
  const auto erases = s->of(Call::erase);
  ASSERT_EQ(erases.size(), 1u);
  EXPECT_EQ(erases[0].id, rumble);
  EXPECT_FALSE(s->playing[static_cast<std::size_t>(rumble)]) << "stopped as it was erased (by the kernel's erase)";
  EXPECT_FALSE(has_write(*s, rumble, 0)) << "no separate stop: a write the kernel's erase makes anyway";
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  EXPECT_GE(dev->constant_id(), 0);
  EXPECT_EQ(dev->rumble_id(), -1);
  EXPECT_FALSE(dev->rumble_allowed());
}

TEST(FfDevice, EnospcWithNothingToGiveUpIsRetriedLater) {
  auto s = fake_device({FF_CONSTANT}, 1);
  s->used[0] = true;  // someone else has the only id
  FfCounters counters;
  auto dev = make(s, &counters);
  EXPECT_FALSE(set_constant(*dev, {1000, 0}));
  EXPECT_EQ(counters.errors.load(), 1u);
  EXPECT_EQ(dev->mode(), FfMode::constant);
  s->used[0] = false;
  EXPECT_TRUE(set_constant(*dev, {1000, 0}));
}

TEST(FfDevice, OneEffectIdBelongsToTheConstant) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 1);
  auto dev = make(s);
  EXPECT_EQ(dev->mode(), FfMode::constant);
  EXPECT_FALSE(dev->rumble_allowed());
  EXPECT_FALSE(kick(*dev, {0x8000, 0x8000, 60}));
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  EXPECT_EQ(s->of(Call::upload).size(), 1u);
}

TEST(FfDevice, OneEffectIdRumbleOnlyPadKicks) {
  auto s = fake_device({FF_RUMBLE}, 1);
  auto dev = make(s);
  EXPECT_EQ(dev->mode(), FfMode::rumble_only);
  EXPECT_TRUE(dev->rumble_allowed());
  EXPECT_TRUE(kick(*dev, {0x8000, 0x8000, 60}));
  EXPECT_TRUE(kick(*dev, {0x8000, 0x8000, 60}));
  EXPECT_EQ(s->live(), 1);
}

TEST(FfDevice, RumbleOnlyPadNeverGetsAConstant) {
  auto s = fake_device({FF_RUMBLE, FF_GAIN}, 16);
  auto dev = make(s);
  EXPECT_EQ(dev->mode(), FfMode::rumble_only);
  EXPECT_FALSE(set_constant(*dev, {1000, 0}));
  EXPECT_TRUE(s->of(Call::upload).empty());
}

TEST(FfDevice, NoFfMeansInputOnly) {
  auto s = fake_device({}, 0);
  auto dev = make(s);
  EXPECT_EQ(dev->mode(), FfMode::none);
  EXPECT_FALSE(set_constant(*dev, {1000, 0}));
  EXPECT_FALSE(kick(*dev, {1, 1, 1}));
  EXPECT_TRUE(s->calls.empty());
}

TEST(FfDevice, OptionsCanTurnEitherEffectOff) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  FfDeviceOptions o;
  o.constant = false;
  EXPECT_EQ(make(s, nullptr, o)->mode(), FfMode::rumble_only);
  o = {};
  o.rumble = false;
  auto dev = make(s, nullptr, o);
  EXPECT_EQ(dev->mode(), FfMode::constant);
  EXPECT_FALSE(dev->rumble_allowed());
}

TEST(FfDevice, ShutdownErasesEverythingWhichStopsIt) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  FfCounters counters;
  auto dev = make(s, &counters);
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  ASSERT_TRUE(kick(*dev, {1000, 1000, 60}));
  const std::int16_t c = dev->constant_id(), r = dev->rumble_id();
  ASSERT_TRUE(s->playing[static_cast<std::size_t>(c)]);
  ASSERT_TRUE(s->playing[static_cast<std::size_t>(r)]);
  const auto before = s->calls.size();
  dev->shutdown();
  EXPECT_FALSE(s->playing[static_cast<std::size_t>(c)]) << "stopped (the kernel's erase stops it)";
  EXPECT_FALSE(s->playing[static_cast<std::size_t>(r)]);
  EXPECT_EQ(s->calls.size(), before + 2) << "one erase per effect, no separate stops";
  const auto erases = s->of(Call::erase);
  ASSERT_EQ(erases.size(), 2u);
  EXPECT_EQ(s->live(), 0);
  EXPECT_EQ(counters.live_effects.load(), 0);
  // Nothing more after a shutdown; a second one does nothing.
  const auto n = s->calls.size();
  EXPECT_FALSE(set_constant(*dev, {5, 0}));
  dev->shutdown();
  EXPECT_EQ(s->calls.size(), n);
}

TEST(FfDevice, DestructorErasesThenCloses) {
  auto s = fake_device({FF_CONSTANT}, 16);
  {
    auto dev = make(s);
    ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  }
  EXPECT_EQ(s->of(Call::erase).size(), 1u);
  EXPECT_EQ(s->live(), 0);
  EXPECT_TRUE(s->closed);
}

TEST(FfDevice, UnplugIsSeenAndForgetIssuesNothing) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  FfCounters counters;
  auto dev = make(s, &counters);
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  s->unplugged = true;
  EXPECT_FALSE(set_constant(*dev, {3000, 0}));
  EXPECT_TRUE(dev->gone());
  const auto n = s->calls.size();
  dev->forget();
  EXPECT_EQ(dev->constant_id(), -1);
  EXPECT_EQ(counters.live_effects.load(), 0);
  dev.reset();
  EXPECT_EQ(s->calls.size(), n);  // no stop, no erase to a dead node
}

}  // namespace
}  // namespace sculpt::haptics

namespace sculpt::haptics {
namespace {

TEST(FfDevice, EnodevBeforeTheFirstSuccessIsNotReadyWhenWaiting) {
  auto s = fake_device({FF_RUMBLE}, 16);
  FfCounters counters;
  auto dev = make(s, &counters);
  dev->wait_for_ready(true);
  s->upload_errors = {ENODEV, ENODEV};
  EXPECT_FALSE(dev->upload_rumble({0, 100, 20000}));
  EXPECT_TRUE(dev->not_ready());
  EXPECT_FALSE(dev->gone());
  EXPECT_FALSE(dev->upload_rumble({0, 100, 20000}));
  EXPECT_TRUE(dev->upload_rumble({0, 100, 20000}));
  EXPECT_FALSE(dev->not_ready());
  EXPECT_TRUE(dev->ready_seen());
  EXPECT_EQ(counters.errors.load(), 0u);  // not ready is not an error
  // Once something succeeded, ENODEV is an unplug again.
  s->upload_errors = {ENODEV};
  EXPECT_FALSE(dev->upload_rumble({0, 200, 20000}));
  EXPECT_TRUE(dev->gone());
  EXPECT_EQ(counters.errors.load(), 1u);
}

TEST(FfDevice, RumbleOnlyPadHoldsOneRumbleIdUpdatedInPlace) {
  auto s = fake_device({FF_RUMBLE}, 16);
  auto dev = make(s);
  ASSERT_EQ(dev->mode(), FfMode::rumble_only);
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(dev->upload_rumble({static_cast<std::uint16_t>(i * 100), 7, 20000}));
  const auto ups = s->of(Call::upload);
  EXPECT_EQ(ups[0].effect.id, -1);
  for (std::size_t i = 1; i < ups.size(); ++i) EXPECT_EQ(ups[i].effect.id, dev->rumble_id());
  EXPECT_EQ(s->live(), 1);
  EXPECT_EQ(dev->current_rumble().strong, 4900);
}

}  // namespace
}  // namespace sculpt::haptics

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using testing::CallCost;
using testing::FakeClock;

// Every call waits for the pacer and stamps it when the call returned: with
// writes that take 3..5 ms, made back to back, the kernel still sees them
// 10 ms apart, end to start. Uploads, plays, FF_GAIN, ENOSPC's erase, the
// EINVAL retry and shutdown's erases all count; ENODEV reached no driver.
TEST(FfDevice, EveryWriteWaitsForThePacerAndStampsItWhenItReturned) {
  auto s = fake_device({FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 2);
  FakeClock& clock = *s->clock;
  s->cost = CallCost{4ms, 3ms, 3ms, 2ms};
  auto pacer = std::make_shared<WritePacer>(10ms);
  FfCounters counters;
  auto dev = std::make_unique<FfDevice>(std::make_unique<FakePort>(s), FfDeviceOptions{}, &counters, pacer, clock);
  dev->wait_for_ready(true);
  s->upload_errors = {ENODEV};
  EXPECT_FALSE(dev->upload_constant({1000, 0}, 20000));
  EXPECT_TRUE(dev->not_ready());
  ASSERT_TRUE(set_constant(*dev, {1000, 0}));
  ASSERT_TRUE(kick(*dev, {0x8000, 0x8000, 60}));
  dev->set_gain(0x8000);
  s->used[static_cast<std::size_t>(dev->constant_id())] = false;  // vanished: EINVAL, then a fresh upload
  EXPECT_FALSE(dev->upload_constant({2000, 0}, 20000));
  s->used[0] = true;  // another client took it meanwhile: ENOSPC for the fresh upload...
  EXPECT_FALSE(dev->upload_constant({2000, 0}, 20000));
  EXPECT_FALSE(dev->upload_constant({2000, 0}, 20000));  // ...so the rumble's id is erased
  ASSERT_TRUE(set_constant(*dev, {2000, 0}));
  dev->shutdown();

  ASSERT_GE(s->calls.size(), 12u);
  std::optional<Call> prev;
  for (const auto& c : s->calls) {
    if (c.result == ENODEV) continue;  // reached no driver: not stamped, not paced
    if (prev) {
      EXPECT_GE(c.at - prev->end, 10ms) << "call " << (&c - s->calls.data());
    }
    prev = c;
  }
  EXPECT_EQ(pacer->writes(), s->calls.size() - 1);
  EXPECT_EQ(dev->writes(), s->calls.size() - 1);
  EXPECT_GT(clock.sleeps(), 0);
}

}  // namespace
}  // namespace sculpt::haptics
