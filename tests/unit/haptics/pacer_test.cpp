// Transport pacing: the interval per bus, and a WritePacer that lets the
// first write out at once, then no two writes closer than the interval; a
// writer outside the poll waits on the time source.
#include <gtest/gtest.h>

#include <linux/input.h>

#include "fake_port.hpp"
#include "haptics/pacer.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;

TEST(IntervalForBus, UsbBluetoothAndTheRest) {
  const TransportPacing p{10ms, 25ms, 7ms};
  EXPECT_EQ(interval_for_bus(BUS_USB, p), 10ms);
  EXPECT_EQ(interval_for_bus(BUS_BLUETOOTH, p), 25ms);
  EXPECT_EQ(interval_for_bus(BUS_VIRTUAL, p), 7ms);
  EXPECT_EQ(interval_for_bus(0, p), 7ms);  // unknown
  const TransportPacing defaults;
  EXPECT_EQ(defaults.usb, 10ms);
  EXPECT_EQ(defaults.bluetooth, 25ms);
}

TEST(WritePacer, FirstAtOnceThenIntervalApart) {
  WritePacer p(10ms);
  const Clock::time_point t0{};
  EXPECT_TRUE(p.ready(t0));
  p.wrote(t0);
  EXPECT_FALSE(p.ready(t0 + 9999us));
  EXPECT_EQ(p.next_at(t0 + 1ms), t0 + 10ms);
  EXPECT_TRUE(p.ready(t0 + 10ms));
  p.wrote(t0 + 12ms);
  EXPECT_FALSE(p.ready(t0 + 21ms));
  EXPECT_TRUE(p.ready(t0 + 22ms));
  p.set_interval(25ms);
  EXPECT_FALSE(p.ready(t0 + 36ms));
  EXPECT_TRUE(p.ready(t0 + 37ms));
}

TEST(WritePacer, WaitSleepsUntilTheIntervalHasPassedAndWritesAreCounted) {
  testing::FakeClock clock;
  WritePacer p(25ms);
  p.wait(clock);  // the first write: no wait
  EXPECT_EQ(clock.sleeps(), 0);
  clock.advance(3ms);  // the write took 3 ms
  p.wrote(clock.now());
  EXPECT_EQ(p.writes(), 1u);
  p.wait(clock);
  EXPECT_EQ(clock.now(), Clock::time_point{} + 28ms) << "25 ms after the write returned";
  p.wrote(clock.now());
  clock.advance(40ms);
  p.wait(clock);
  EXPECT_EQ(clock.sleeps(), 1) << "no wait once the interval has passed";
  EXPECT_EQ(p.writes(), 2u);
}

}  // namespace
}  // namespace sculpt::haptics
