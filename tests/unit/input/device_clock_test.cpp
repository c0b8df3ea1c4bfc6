// DeviceClock places live frames on the ticks their device time says, as
// ReplaySource does for a recording.
#include <gtest/gtest.h>

#include "input/device_clock.hpp"
#include "input/replay_source.hpp"

namespace sculpt::input {
namespace {

InputFrame at(std::uint8_t slot, std::int64_t t_us, bool device_clock = true) {
  InputFrame f;
  f.slot = slot;
  f.device_time_us = t_us;
  f.device_clock = device_clock;
  return f;
}

TEST(DeviceClock, TheFirstFrameAnchorsAfterTheDelayAndTheRestKeepTheirSpacing) {
  DeviceClock clock(1000.0, 5.0);  // 5 ms: 5 ticks at 1 kHz
  const auto first = clock.place(at(0, 7'000'000), 100);
  EXPECT_TRUE(first.anchored);
  EXPECT_EQ(first.tick, 105u);
  const auto later = clock.place(at(0, 7'000'000 + 2'500), 100);  // 2.5 ms on: rounds as replay_tick does
  EXPECT_FALSE(later.anchored);
  EXPECT_EQ(later.tick, 105u + (replay_tick(0, 7'002'500, 1000.0) - replay_tick(0, 7'000'000, 1000.0)));
}

TEST(DeviceClock, TicksNeverGoBackwardsPerDevice) {
  DeviceClock clock(1000.0, 0.0);
  EXPECT_EQ(clock.place(at(0, 10'000), 50).tick, 50u);
  EXPECT_EQ(clock.place(at(0, 5'000), 50).tick, 50u);  // an older stamp: not before the last
  EXPECT_EQ(clock.place(at(0, 12'000), 50).tick, 52u);
}

TEST(DeviceClock, DevicesHaveTheirOwnAnchorsAndForgettingReanchors) {
  DeviceClock clock(1000.0, 0.0);
  EXPECT_EQ(clock.place(at(0, 1'000'000), 10).tick, 10u);
  EXPECT_TRUE(clock.place(at(1, 9'000'000), 20).anchored);
  EXPECT_EQ(clock.place(at(1, 9'003'000), 20).tick, 23u);
  clock.forget(0);
  const auto again = clock.place(at(0, 2'000'000), 40);
  EXPECT_TRUE(again.anchored);
  EXPECT_EQ(again.tick, 40u);
}

TEST(DeviceClock, FramesWithoutADeviceClockApplyInOrder) {
  DeviceClock clock(1000.0, 5.0);
  const auto p = clock.place(at(0, 123, false), 77);
  EXPECT_EQ(p.tick, 0u);
  EXPECT_FALSE(p.anchored);
}

TEST(DeviceClock, TheRateFollowsTheScene) {
  DeviceClock clock(1000.0, 0.0);
  clock.set_rate(500.0);
  EXPECT_EQ(clock.place(at(0, 0), 1).tick, 1u);
  EXPECT_EQ(clock.place(at(0, 10'000), 1).tick, 6u);  // 10 ms at 500 Hz: 5 ticks
}

}  // namespace
}  // namespace sculpt::input
