// The thread around the engine: commands from another thread are applied,
// polls happen on their own, stop() erases everything. Facts are waited on
// with flush(), never with sleeps.
#include <gtest/gtest.h>

#include "fake_port.hpp"
#include "haptics/haptics_thread.hpp"

namespace sculpt::haptics {
namespace {

using testing::FakeDeviceState;
using testing::FakePort;
using testing::fake_device;
using Call = FakeDeviceState::Call;

TEST(HapticsThread, AttachPollUpdateAndStopErases) {
  FeedbackBoard board(1);
  auto pad = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  HapticsSettings settings;
  settings.pacing.other = std::chrono::milliseconds(0);
  HapticsThread thread(board, settings, [&](const std::string& node) -> std::unique_ptr<FfPort> {
    return std::make_unique<FakePort>(pad, node);
  });
  thread.start();
  EXPECT_TRUE(thread.running());
  thread.attach(0, "/dev/input/event9", {{0, StickPlane{0, 2, 1.0, 1.0}}});
  thread.flush();
  EXPECT_EQ(thread.stats().devices.load(), 1);
  EXPECT_EQ(thread.stats().ff.live_effects.load(), 1);

  Felt f;
  f.force = {1.0, 0, 0};
  f.contacts = 1;
  f.touching = true;
  board.publish(0, f);
  thread.flush();
  EXPECT_EQ(thread.stats().ff.uploads.load(), 2u);

  thread.stop();
  EXPECT_FALSE(thread.running());
  // The thread has ended: its fake device can be read now.
  EXPECT_EQ(pad->live(), 0);
  EXPECT_EQ(pad->of(Call::erase).size(), 1u);
  EXPECT_EQ(thread.stats().ff.live_effects.load(), 0);
  EXPECT_EQ(thread.stats().devices.load(), 0);
}

TEST(HapticsThread, DetachFromAnotherThreadForgets) {
  FeedbackBoard board(1);
  auto pad = fake_device({FF_CONSTANT}, 16);
  HapticsThread thread(board, HapticsSettings{}, [&](const std::string& node) -> std::unique_ptr<FfPort> {
    return std::make_unique<FakePort>(pad, node);
  });
  thread.start();
  thread.attach(2, "/dev/input/event4", {{0, StickPlane{}}});
  thread.flush();
  ASSERT_EQ(thread.stats().ff.live_effects.load(), 1);
  thread.detach(2);
  thread.flush();
  EXPECT_EQ(thread.stats().ff.live_effects.load(), 0);
  EXPECT_EQ(thread.stats().devices.load(), 0);
  thread.stop();
  thread.stop();  // idempotent
}

TEST(HapticsThread, TuneFromAnyThreadSeenAtOnceKeptAcrossReplug) {
  FeedbackBoard board(1);
  auto pad = fake_device({FF_RUMBLE}, 16);
  pad->identity.bustype = BUS_BLUETOOTH;
  HapticsThread thread(board, HapticsSettings{}, [&](const std::string& node) -> std::unique_ptr<FfPort> {
    return std::make_unique<FakePort>(pad, node);
  });
  thread.start();
  EXPECT_EQ(thread.bustype(3), 0);
  thread.attach(3, "/dev/input/event4", {{0, StickPlane{}}});
  thread.flush();
  EXPECT_EQ(thread.bustype(3), BUS_BLUETOOTH);
  EXPECT_EQ(thread.tuning(3), DeviceTuning{});
  thread.tune(3, {0.25, 0.5});
  EXPECT_EQ(thread.tuning(3), (DeviceTuning{0.25, 0.5}));
  EXPECT_THROW(thread.tune(3, {0.5, 1.5}), std::invalid_argument);
  EXPECT_THROW(thread.tune(-1, {}), std::invalid_argument);
  EXPECT_EQ(thread.tuning(3), (DeviceTuning{0.25, 0.5}));
  thread.detach(3);
  thread.flush();
  EXPECT_EQ(thread.bustype(3), 0);
  thread.attach(3, "/dev/input/event4", {{0, StickPlane{}}});
  thread.flush();
  EXPECT_EQ(thread.tuning(3), (DeviceTuning{0.25, 0.5}));
  thread.configure(HapticsSettings{});  // SIGHUP: the config again
  thread.flush();
  EXPECT_EQ(thread.tuning(3), DeviceTuning{});
  thread.resumed();  // logind: back from suspend
  thread.flush();
  EXPECT_EQ(thread.stats().resumes.load(), 1u);
  thread.stop();
}

TEST(HapticsThread, StopWithoutStartIsHarmless) {
  FeedbackBoard board(1);
  HapticsThread thread(board, HapticsSettings{});
  thread.flush();
  thread.stop();
  EXPECT_FALSE(thread.running());
}

}  // namespace
}  // namespace sculpt::haptics
