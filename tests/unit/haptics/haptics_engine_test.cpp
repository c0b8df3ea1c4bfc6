// The haptics thread's decisions, driven directly with fake devices and an
// explicit clock: uploads on a real change only, paced per device, kicks on
// onset, forget on unplug and re-upload on replug.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <stdexcept>

#include "fake_port.hpp"
#include "haptics/haptics_engine.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using testing::FakeDeviceState;
using testing::FakePort;
using testing::fake_device;
using Call = FakeDeviceState::Call;

const StickPlane kPlane{0, 2, 1.0, 1.0};  // stick x → tool x, stick y → tool z

Felt push(double fx, double fz, bool onset = false, double impulse = 0) {
  Felt f;
  f.force = {fx, 0, fz};
  f.contacts = (fx != 0 || fz != 0) ? 3 : 0;
  f.touching = f.contacts > 0;
  f.onset = onset;
  f.onset_impulse = impulse;
  return f;
}

class Engine : public ::testing::Test {
 protected:
  Engine() {
    settings.min_upload_interval = 25ms;
    settings.force = ForceScale{2.0, 0.05, 0x7fff};
    settings.rumble = RumbleScale{0.02, 1e-5, 0.5, 60, 0.0};
  }
  HapticsEngine& engine() {
    if (!engine_)
      engine_ = std::make_unique<HapticsEngine>(board, settings, [this](const std::string& node) -> std::unique_ptr<FfPort> {
        auto it = devices.find(node);
        if (it == devices.end()) throw std::runtime_error("cannot open " + node);
        ++opens[node];
        return std::make_unique<FakePort>(it->second, node);
      }, stats);
    return *engine_;
  }
  std::vector<Call> constant_uploads(const FakeDeviceState& s) {
    std::vector<Call> out;
    for (const auto& c : s.of(Call::upload))
      if (c.effect.type == FF_CONSTANT) out.push_back(c);
    return out;
  }
  std::vector<Call> rumble_uploads(const FakeDeviceState& s) {
    std::vector<Call> out;
    for (const auto& c : s.of(Call::upload))
      if (c.effect.type == FF_RUMBLE) out.push_back(c);
    return out;
  }

  FeedbackBoard board{2};
  HapticsSettings settings;
  HapticsStats stats;
  std::map<std::string, std::shared_ptr<FakeDeviceState>> devices;
  std::map<std::string, int> opens;
  std::unique_ptr<HapticsEngine> engine_;
  Clock::time_point t0{};
};

TEST_F(Engine, FirstPollUploadsThenOnlyRealChanges) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  EXPECT_EQ(stats.devices.load(), 1);
  EXPECT_EQ(stats.ff_devices.load(), 1);

  engine().poll(t0);
  auto ups = constant_uploads(*pad);
  ASSERT_EQ(ups.size(), 1u);  // the effect exists from the start, at level 0
  EXPECT_EQ(ups[0].effect.id, -1);
  EXPECT_EQ(ups[0].effect.u.constant.level, 0);

  // Same force for a second of polls: nothing more.
  for (int i = 1; i < 250; ++i) engine().poll(t0 + i * 4ms);
  EXPECT_EQ(constant_uploads(*pad).size(), 1u);

  // Contact: pushed back along −x → the stick is pushed left (0xC000).
  board.publish(0, push(-1.0, 0));
  engine().poll(t0 + 1s);
  ups = constant_uploads(*pad);
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_EQ(ups[1].effect.id, ups[0].id);  // in place
  EXPECT_EQ(ups[1].effect.u.constant.level, 16384);
  EXPECT_EQ(ups[1].effect.direction, 0xC000);
  EXPECT_EQ(stats.ff.uploads.load(), 2u);
  EXPECT_EQ(stats.ff.live_effects.load(), 1);
}

TEST_F(Engine, PacingBoundsUploadsOverTenThousandUpdates) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  // The sim publishes 10 000 ticks of a wildly changing force; the haptics
  // thread polls every 4 ms of them.
  for (int tick = 0; tick < 10000; ++tick) {
    const double phase = tick * 0.01;
    board.publish(0, push(1.5 * std::sin(phase), 1.5 * std::cos(phase)));
    if (tick % 4 == 0) engine().poll(t0 + tick * 1ms);
  }
  const auto ups = constant_uploads(*pad);
  EXPECT_LE(ups.size(), 10000u / 25 + 1);  // never more often than 25 ms
  EXPECT_GE(ups.size(), 10000u / 28);      // and it follows the force
  for (std::size_t i = 1; i < ups.size(); ++i) EXPECT_EQ(ups[i].effect.id, ups[0].id);
  EXPECT_EQ(pad->live(), 1);
}

TEST_F(Engine, OnsetKicksEvenWhenItEndedBetweenPolls) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  board.publish(0, push(0.5, 0, true, 0.01));
  board.publish(0, push(0, 0));  // contact already over at the next poll
  engine().poll(t0 + 4ms);
  const auto kicks = rumble_uploads(*pad);
  ASSERT_EQ(kicks.size(), 1u);
  EXPECT_EQ(kicks[0].effect.u.rumble.strong_magnitude, 32768);  // 0.01 of 0.02 N·s
  EXPECT_EQ(stats.ff.kicks.load(), 1u);
  // No new onset: no new kick.
  engine().poll(t0 + 100ms);
  EXPECT_EQ(rumble_uploads(*pad).size(), 1u);
}

TEST_F(Engine, OnsetsBeforeAttachGiveNoKick) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_RUMBLE}, 16);
  board.publish(0, push(0.5, 0, true, 0.01));
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  engine().poll(t0 + 4ms);
  EXPECT_TRUE(rumble_uploads(*pad).empty());
}

TEST_F(Engine, RumbleOnlyPadGetsKicksNoConstant) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  board.publish(0, push(1.0, 0, true, 0.02));
  engine().poll(t0 + 4ms);
  EXPECT_TRUE(constant_uploads(*pad).empty());
  EXPECT_EQ(rumble_uploads(*pad).size(), 1u);
}

TEST_F(Engine, OneEffectDeviceKeepsTheConstant) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 1);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  board.publish(0, push(1.0, 0, true, 0.02));
  engine().poll(t0 + 30ms);
  EXPECT_EQ(constant_uploads(*pad).size(), 2u);
  EXPECT_TRUE(rumble_uploads(*pad).empty());
  EXPECT_EQ(stats.ff.errors.load(), 0u);
}

TEST_F(Engine, NoFfDeviceIsInputOnlyAndNotKeptOpen) {
  auto pad = devices["/dev/input/event1"] = fake_device({}, 0);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  EXPECT_EQ(stats.devices.load(), 1);
  EXPECT_EQ(stats.ff_devices.load(), 0);
  EXPECT_TRUE(pad->calls.empty());
  EXPECT_TRUE(pad->closed);
  EXPECT_EQ(engine().device(0), nullptr);
}

TEST_F(Engine, OpenFailureIsCountedNotThrown) {
  engine().attach(0, "/dev/input/missing", {{0, kPlane}});
  engine().poll(t0);
  EXPECT_EQ(stats.open_failures.load(), 1u);
  EXPECT_NE(engine().last_error().find("/dev/input/missing"), std::string::npos);
  EXPECT_EQ(stats.devices.load(), 1);
}

TEST_F(Engine, MessagesGoToTheLogSink) {
  std::vector<std::pair<int, std::string>> lines;
  auto pad = devices["/dev/input/event1"] = fake_device({FF_RUMBLE}, 1);
  HapticsEngine e(board, settings, [this](const std::string& node) -> std::unique_ptr<FfPort> {
    auto it = devices.find(node);
    if (it == devices.end()) throw std::runtime_error("cannot open " + node);
    return std::make_unique<FakePort>(it->second, node);
  }, stats, [&](int priority, const std::string& m) { lines.emplace_back(priority, m); });
  e.attach(0, "/dev/input/event1", {{0, kPlane}});
  e.attach(1, "/dev/input/missing", {{1, kPlane}});
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].first, 6);
  EXPECT_EQ(lines[0].second, "/dev/input/event1: rumble only, 1 effect slot");
  EXPECT_EQ(lines[1].first, 4);
  EXPECT_EQ(lines[1].second, "no force feedback on /dev/input/missing: cannot open /dev/input/missing");
}

TEST_F(Engine, UnplugForgetsIdsReplugUploadsAgain) {
  auto first = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(3, "/dev/input/event1", {{0, kPlane}});
  board.publish(0, push(1.0, 0));
  engine().poll(t0);
  ASSERT_EQ(constant_uploads(*first).size(), 1u);

  first->unplugged = true;
  engine().detach(3);
  EXPECT_EQ(stats.ff.live_effects.load(), 0);
  EXPECT_EQ(stats.devices.load(), 0);
  EXPECT_TRUE(first->of(Call::erase).empty());  // nothing sent to a dead node
  EXPECT_TRUE(first->closed);

  // Back on another node, same slot: a fresh upload with id −1.
  auto second = devices["/dev/input/event7"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(3, "/dev/input/event7", {{0, kPlane}});
  engine().poll(t0 + 4ms);  // inside the old interval: a new device is not paced by the old one
  const auto ups = constant_uploads(*second);
  ASSERT_EQ(ups.size(), 1u);
  EXPECT_EQ(stats.slot_uploads[3].load(), 2u) << "the slot counts both devices' uploads";
  EXPECT_EQ(stats.slot_uploads[0].load(), 0u);
  EXPECT_EQ(ups[0].effect.id, -1);
  EXPECT_EQ(ups[0].effect.u.constant.level, 16384);
  EXPECT_EQ(stats.ff.live_effects.load(), 1);
}

TEST_F(Engine, UnplugSeenByAnIoctlFirstStopsTraffic) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  pad->unplugged = true;
  board.publish(0, push(1.0, 0));
  engine().poll(t0 + 30ms);  // ENODEV
  const auto n = pad->calls.size();
  board.publish(0, push(-1.0, 0));
  engine().poll(t0 + 60ms);
  EXPECT_EQ(pad->calls.size(), n);
  engine().detach(0);
  EXPECT_EQ(stats.ff.live_effects.load(), 0);
}

TEST_F(Engine, EnodevWithoutAnUnplugReopensTheDevice) {
  // uinput answers ENODEV in the moment between a new node appearing and the
  // device being marked created; no detach follows, so the engine reopens.
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  pad->upload_errors = {ENODEV};
  board.publish(0, push(1.0, 0));
  engine().poll(t0);
  ASSERT_EQ(pad->of(Call::upload).size(), 1u);
  EXPECT_EQ(pad->of(Call::upload)[0].result, ENODEV);
  engine().poll(t0 + 100ms);
  engine().poll(t0 + 300ms);  // < 250 ms since ENODEV was first seen at 100 ms
  EXPECT_EQ(opens["/dev/input/event1"], 1);
  EXPECT_EQ(pad->of(Call::upload).size(), 1u);
  engine().poll(t0 + 360ms);
  EXPECT_EQ(opens["/dev/input/event1"], 2);
  const auto ups = constant_uploads(*pad);
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_EQ(ups[1].effect.id, -1);
  EXPECT_EQ(ups[1].result, 0);
  EXPECT_EQ(stats.ff_devices.load(), 1);
  EXPECT_EQ(stats.ff.live_effects.load(), 1);
}

TEST_F(Engine, AReallyDeadNodeIsReopenedOnlyAFewTimes) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  pad->unplugged = true;
  for (int i = 0; i < 400; ++i) {
    board.publish(0, push(i % 2 ? 1.0 : -1.0, 0));
    engine().poll(t0 + std::chrono::milliseconds(100 * i));
  }
  EXPECT_LE(opens["/dev/input/event1"], 1 + 5);
  EXPECT_GE(opens["/dev/input/event1"], 2);
  engine().detach(0);
  EXPECT_EQ(stats.ff_devices.load(), 0);
  EXPECT_EQ(stats.ff.live_effects.load(), 0);
}

TEST_F(Engine, TwoToolsOnOnePadAddUpInItsPlane) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}, {1, kPlane}});
  board.publish(0, push(0.5, 0));
  board.publish(1, push(0.5, 0));
  engine().poll(t0);
  const auto ups = constant_uploads(*pad);
  ASSERT_EQ(ups.size(), 1u);
  EXPECT_EQ(ups[0].effect.u.constant.level, 16384);  // 1 N of 2
  EXPECT_EQ(ups[0].effect.direction, 0x4000);
}

TEST_F(Engine, ShutdownStopsAndErasesEveryDevice) {
  auto a = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  auto b = devices["/dev/input/event2"] = fake_device({FF_RUMBLE}, 4);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{1, kPlane}});
  engine().poll(t0);
  board.publish(0, push(1.0, 0, true, 0.01));
  board.publish(1, push(1.0, 0, true, 0.01));
  engine().poll(t0 + 30ms);
  EXPECT_EQ(a->live(), 2);
  EXPECT_EQ(b->live(), 1);
  engine().shutdown();
  EXPECT_EQ(a->live(), 0);
  EXPECT_EQ(b->live(), 0);
  EXPECT_EQ(a->of(Call::erase).size(), 2u);
  EXPECT_EQ(b->of(Call::erase).size(), 1u);
  EXPECT_EQ(stats.ff.live_effects.load(), 0);
  EXPECT_EQ(stats.devices.load(), 0);
  EXPECT_EQ(stats.ff_devices.load(), 0);
}

TEST_F(Engine, ConfigureChangesGainAndPacing) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_GAIN}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  HapticsSettings s = settings;
  s.gain = 0x2000;
  s.min_upload_interval = 100ms;
  engine().configure(s);
  bool gain_written = false;
  for (const auto& w : pad->of(Call::write)) gain_written |= (w.id == FF_GAIN && w.value == 0x2000);
  EXPECT_TRUE(gain_written);
  board.publish(0, push(1.0, 0));
  engine().poll(t0 + 50ms);
  EXPECT_EQ(constant_uploads(*pad).size(), 1u);  // 100 ms now
  engine().poll(t0 + 100ms);
  EXPECT_EQ(constant_uploads(*pad).size(), 2u);
}

TEST_F(Engine, DisablingHapticsErasesAndClosesDevices) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().poll(t0);
  HapticsSettings s = settings;
  s.enabled = false;
  engine().configure(s);
  EXPECT_EQ(pad->live(), 0);
  EXPECT_TRUE(pad->closed);
  EXPECT_EQ(stats.ff_devices.load(), 0);
  s.enabled = true;
  engine().configure(s);
  engine().poll(t0 + 1ms);
  EXPECT_EQ(pad->live(), 1);
  EXPECT_EQ(opens["/dev/input/event1"], 2);
}

}  // namespace
}  // namespace sculpt::haptics
