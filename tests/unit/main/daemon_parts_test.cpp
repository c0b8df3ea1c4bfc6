// sculptd's own small parts: the device table `sculptctl devices` lists and
// the watchdog that is fed only while the sim loop moves.
#include <linux/input.h>

#include <gtest/gtest.h>

#include "devices/change_log.hpp"
#include "devices/device_table.hpp"
#include "main/watchdog.hpp"

namespace sculpt::daemon {
namespace {

input::DeviceInfo pad(const std::string& node, std::vector<std::uint16_t> ff) {
  input::DeviceInfo d;
  d.name = "Pad";
  d.node = node;
  d.vendor = 0x045e;
  d.product = 0x028e;
  d.kind = input::DeviceKind::gamepad;
  d.ff = std::move(ff);
  return d;
}

input::DeviceBinding driving(std::initializer_list<std::uint32_t> tools) {
  input::DeviceBinding b;
  for (std::uint32_t t : tools) b.tool_mask |= 1u << t;
  return b;
}

TEST(DeviceTable, ListsWhatAttachedAndKeepsUnpluggedSlots) {
  DeviceTable table;
  table.attached(0, pad("/dev/input/event5", {FF_CONSTANT, FF_RUMBLE}), driving({0, 1}));
  table.attached(2, pad("/dev/input/event7", {FF_RUMBLE}), driving({2}));
  ASSERT_EQ(table.entries().size(), 2u);
  const server::DeviceEntry& first = table.entries().at(0);
  EXPECT_EQ(first.node, "/dev/input/event5");
  EXPECT_EQ(first.ff, 2);
  EXPECT_EQ(first.tools, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_TRUE(first.connected);
  EXPECT_EQ(table.entries().at(2).ff, 1);
  EXPECT_EQ(table.slot_of_tools(4), (std::vector<std::int32_t>{0, 0, 2, -1}));

  table.detached(0);
  EXPECT_FALSE(table.entries().at(0).connected);
  EXPECT_EQ(table.entries().at(0).node, "");
  EXPECT_EQ(table.slot_of_tools(4), (std::vector<std::int32_t>{-1, -1, 2, -1}));
  table.detached(5);  // never seen: nothing to do
  EXPECT_EQ(table.entries().size(), 2u);
}

TEST(Watchdog, PingsOnlyWhileTheLoopMovesAndSaysStalledOnce) {
  using namespace std::chrono_literals;
  Watchdog w(std::chrono::microseconds(2'000'000));  // WatchdogSec=2s, pinged every second at 0.5
  const Watchdog::Clock::time_point t0{};
  EXPECT_EQ(w.check(t0 + 1ms, 10, 0.5), Watchdog::Due::ping);
  EXPECT_EQ(w.check(t0 + 500ms, 20, 0.5), Watchdog::Due::nothing);  // not due yet
  EXPECT_EQ(w.check(t0 + 1001ms, 20, 0.5), Watchdog::Due::ping);
  EXPECT_EQ(w.check(t0 + 2001ms, 20, 0.5), Watchdog::Due::stalled);
  EXPECT_EQ(w.check(t0 + 3001ms, 20, 0.5), Watchdog::Due::still_stalled);
  EXPECT_EQ(w.check(t0 + 4001ms, 21, 0.5), Watchdog::Due::ping);
  EXPECT_EQ(w.check(t0 + 5001ms, 21, 0.5), Watchdog::Due::stalled);  // a new stall is told again
}

TEST(Watchdog, WithoutWatchdogSecNothingIsEverDue) {
  Watchdog w(std::nullopt);
  EXPECT_EQ(w.check(Watchdog::Clock::now(), 1, 0.5), Watchdog::Due::nothing);
}

}  // namespace
}  // namespace sculpt::daemon

namespace sculpt::daemon {
namespace {

TEST(ChangeLog, ATorrentOfChangesIsOneLineThenOnePerIntervalEndingWithTheValueInForce) {
  using namespace std::chrono_literals;
  ChangeLog log(10s);
  const ChangeLog::Clock::time_point t0{};
  std::vector<std::string> lines;
  for (int i = 0; i < 100000; ++i)
    if (auto l = log.changed(0, "slot 0: gain " + std::to_string(i), t0 + std::chrono::microseconds(i)))
      lines.push_back(*l);
  ASSERT_EQ(lines, std::vector<std::string>{"slot 0: gain 0"}) << "one at once";
  EXPECT_TRUE(log.due(t0 + 9s).empty()) << "nothing more within the interval";
  EXPECT_EQ(log.due(t0 + 10s), std::vector<std::string>{"slot 0: gain 99999 (the last of 99999 changes in 10 s)"});
  EXPECT_TRUE(log.due(t0 + 30s).empty()) << "said once";
  // Another key has its own interval; a change after a quiet interval is said at once.
  EXPECT_EQ(log.changed(1, "slot 1: gain 5", t0 + 11s), std::optional<std::string>("slot 1: gain 5"));
  EXPECT_EQ(log.changed(0, "slot 0: gain 7", t0 + 21s), std::optional<std::string>("slot 0: gain 7"));
  EXPECT_FALSE(log.changed(0, "slot 0: gain 8", t0 + 22s));
  EXPECT_EQ(log.changed(0, "slot 0: gain 9", t0 + 32s),
            std::optional<std::string>("slot 0: gain 9 (1 earlier changes not logged)"));
}

}  // namespace
}  // namespace sculpt::daemon
