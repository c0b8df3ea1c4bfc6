// The DualSense's adaptive triggers end to end: a uhid DualSense bound to the
// kernel's hid-playstation (tests/support/uhid_pad.hpp), sculptd's haptics
// thread finding its hidraw node through the real sysfs, and the output
// reports the pad receives. The right trigger (ABS_RZ) drives tool 0's depth.
#include <gtest/gtest.h>

#include <linux/input.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <thread>

#include "haptics/dualsense_triggers.hpp"
#include "haptics/haptics_thread.hpp"
#include "haptics/hidraw_port.hpp"
#include "support/uhid_pad.hpp"
#include "uhid/pad_cases.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using support::OutputReport;
using support::UhidPad;
using support::uhidtest::BoardPublisher;
using support::uhidtest::free_air;
using support::uhidtest::scaled;
using support::uhidtest::touching;

// The common part starts at byte 1 of the USB report.
constexpr std::size_t kFlag0 = 1;
constexpr std::size_t kRightMode = 1 + dualsense::kRightTriggerBlock;
constexpr std::size_t kRightStart = kRightMode + 1;
constexpr std::size_t kRightForce = kRightMode + 2;
constexpr std::size_t kLeftMode = 1 + dualsense::kLeftTriggerBlock;

bool is_trigger_report(const OutputReport& r) {
  return r.kind == OutputReport::Kind::output && r.data.size() == dualsense::kUsbReportSize && r.data[0] == 0x02 &&
         (r.data[kFlag0] & 0x0c) == 0x0c;
}

std::vector<OutputReport> trigger_reports(const std::vector<OutputReport>& all) {
  std::vector<OutputReport> out;
  for (const auto& r : all)
    if (is_trigger_report(r)) out.push_back(r);
  return out;
}

class DualSenseTriggers : public ::testing::Test {
 protected:
  DualSenseTriggers() : pad(support::uhid_pads::dualsense_usb()) {
    settings.force = ForceScale{1.0, 0.0, 1.0};  // linear, for round numbers: 0.5 N is byte 128
  }
  bool wait_last_trigger(const std::function<bool(const OutputReport&)>& pred,
                         std::chrono::milliseconds timeout = 5000ms) {
    return pad.wait_for(
        [&](const std::vector<OutputReport>& all) {
          for (auto it = all.rbegin(); it != all.rend(); ++it)
            if (is_trigger_report(*it)) return pred(*it);
          return false;
        },
        timeout);
  }
  static bool right_force_is(const OutputReport& r, std::uint8_t force) {
    return r.data[kRightMode] == dualsense::kModeResistance && r.data[kRightForce] == force;
  }
  static bool both_neutral(const OutputReport& r) {
    return r.data[kRightMode] == dualsense::kModeOff && r.data[kLeftMode] == dualsense::kModeOff;
  }

  UhidPad pad;
  FeedbackBoard board{4};
  HapticsSettings settings;
};

TEST_F(DualSenseTriggers, TheHidrawNodeIsFoundThroughSysfs) {
  const auto info = find_hidraw(pad.ff_node());
  ASSERT_TRUE(info) << pad.ff_node();
  EXPECT_EQ(info->node, pad.hidraw_node());
  EXPECT_EQ(info->vendor, 0x054c);
  EXPECT_EQ(info->product, 0x0ce6);
  EXPECT_EQ(info->bus, BUS_USB);
}

TEST_F(DualSenseTriggers, ForceOnTheRightTriggersToolThenZeroThenStop) {
  BoardPublisher sim(board);
  HapticsThread thread(board, settings);
  thread.start();
  thread.attach(0, pad.ff_node(), {}, TriggerBinding{-1, 0});
  thread.flush();
  ASSERT_EQ(thread.stats().triggers.devices.load(), 1) << "hidraw node not opened";

  // Not touching: the first report is neutral.
  ASSERT_TRUE(wait_last_trigger(both_neutral, scaled(5000ms)));

  sim.set(touching(0.5));  // round(0.5 · 255) = 128
  ASSERT_TRUE(wait_last_trigger([](const OutputReport& r) { return right_force_is(r, 128); }, scaled(5000ms)));
  {
    const auto reports = trigger_reports(pad.outputs());
    const auto& r = reports.back();
    EXPECT_EQ(r.data[kFlag0], 0x0c) << "only the trigger flags: the driver's rumble stays as it is";
    EXPECT_EQ(r.data[kFlag0 + 1], 0) << "valid_flag1: lights untouched";
    EXPECT_EQ(r.data[kRightStart], 0);
    EXPECT_EQ(r.data[kLeftMode], dualsense::kModeOff) << "the left trigger drives no tool";
  }

  sim.set(touching(1.5));  // beyond full scale: 255
  ASSERT_TRUE(wait_last_trigger([](const OutputReport& r) { return right_force_is(r, 255); }, scaled(5000ms)));

  sim.set(free_air());
  ASSERT_TRUE(wait_last_trigger(both_neutral, scaled(5000ms)));

  sim.set(touching(0.5));
  ASSERT_TRUE(wait_last_trigger([](const OutputReport& r) { return right_force_is(r, 128); }, scaled(5000ms)));
  const auto written = [&] { return thread.stats().triggers.writes.load() + thread.stats().triggers.errors.load(); };
  const auto before_stop = written();
  thread.stop();
  ASSERT_TRUE(wait_last_trigger(both_neutral, scaled(5000ms))) << "stop leaves the triggers neutral";
  // Stop writes neutral once more, even when the pad has it already (a sim
  // tick late under load may have made a stall, neutral, just before).
  EXPECT_GE(written(), before_stop + 1);
  EXPECT_TRUE(both_neutral(trigger_reports(pad.outputs()).back())) << "nothing after the neutral";
}

TEST_F(DualSenseTriggers, ASimStallOrAHoldIsNeutral) {
  BoardPublisher sim(board);
  HapticsThread thread(board, settings);
  thread.start();
  thread.attach(0, pad.ff_node(), {}, TriggerBinding{-1, 0});
  sim.set(touching(0.5));
  ASSERT_TRUE(wait_last_trigger([](const OutputReport& r) { return right_force_is(r, 128); }, scaled(5000ms)));
  board.set_hold(Hold::paused);
  ASSERT_TRUE(wait_last_trigger(both_neutral, scaled(2000ms)));
  board.set_hold(Hold::none);
  ASSERT_TRUE(wait_last_trigger([](const OutputReport& r) { return right_force_is(r, 128); }, scaled(2000ms)));
  sim.set_beating(false);  // the force stays, the beat stops: a stalled sim
  ASSERT_TRUE(wait_last_trigger(both_neutral, scaled(2000ms)));
  sim.set_beating(true);
  ASSERT_TRUE(wait_last_trigger([](const OutputReport& r) { return right_force_is(r, 128); }, scaled(2000ms)));
  thread.stop();
}

TEST_F(DualSenseTriggers, WritesArePacedOnUsb) {
  BoardPublisher sim(board);
  HapticsThread thread(board, settings);
  thread.start();
  thread.attach(0, pad.ff_node(), {}, TriggerBinding{-1, 0});
  ASSERT_TRUE(wait_last_trigger(both_neutral, scaled(5000ms)));
  // A force that changes every millisecond for 400 ms, and on until three
  // reports came (a slow guest), for seconds at most.
  const auto t0 = std::chrono::steady_clock::now();
  const auto since = [&] { return std::chrono::steady_clock::now() - t0; };
  pad.clear_outputs();
  for (int i = 0; since() < 400ms || (trigger_reports(pad.outputs()).size() < 3 && since() < scaled(10000ms)); ++i) {
    sim.set(touching(0.1 + 0.8 * std::abs(std::sin(i * 0.05))));
    std::this_thread::sleep_for(1ms);
  }
  thread.stop();
  const double elapsed_ms = std::chrono::duration<double, std::milli>(since()).count();
  const auto reports = trigger_reports(pad.outputs());
  ASSERT_GE(reports.size(), 3u);
  // At most one per 10 ms over the time measured (plus the final neutral,
  // one in flight at the clear and one at the edge).
  EXPECT_LE(static_cast<double>(reports.size()), elapsed_ms / 10.0 + 3) << elapsed_ms << " ms";
}

}  // namespace
}  // namespace sculpt::haptics
