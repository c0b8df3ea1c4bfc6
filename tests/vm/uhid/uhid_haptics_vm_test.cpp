// sculptd's haptics thread on the kernel's own gamepad drivers: a
// HapticsThread (in process) reads a FeedbackBoard we publish on like the sim
// thread, drives the pad's evdev FF node, and the tests assert on the motor
// bytes the driver sends to the uhid pad.
//
// These tests state the specified behaviour of the haptics engine (issue #22):
// a rumble-only pad rumbles continuously, in proportion to the felt force,
// while the tool touches; zero force or no contact means motors 0; updates are
// paced per bus (output reports >= 10 ms apart on USB, >= 25 ms on Bluetooth);
// Hold::paused zeroes the motors within 50 ms; stop() leaves them at 0.
// An engine that only kicks on contact onset fails all but the last.
#include <gtest/gtest.h>

#include <linux/input.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>

#include "haptics/haptics_thread.hpp"
#include "support/uhid_pad.hpp"
#include "uhid_test_util.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using support::Motors;
using support::OutputReport;
using support::UhidPad;
using support::UhidPadSpec;
using Clock = std::chrono::steady_clock;

const StickPlane kPlane{0, 2, 1.0, 1.0};

Felt touching(double newton) {
  Felt f;
  f.force = {newton, 0, 0};
  f.contacts = 4;
  f.touching = true;
  return f;
}
Felt free_air() { return Felt{}; }

std::chrono::milliseconds scaled(std::chrono::milliseconds t) {
  return std::chrono::milliseconds(static_cast<long long>(static_cast<double>(t.count()) * support::vm_slowdown()));
}

// The sim thread's part: publishes the current Felt and beats, about once a
// millisecond, until destroyed. The first publish marks a contact onset.
class SimPublisher {
 public:
  explicit SimPublisher(FeedbackBoard& board) : board_(board) {
    thread_ = std::thread([this] {
      bool was_touching = false;
      while (!stop_.load()) {
        Felt f;
        {
          std::lock_guard lock(mutex_);
          f = felt_;
        }
        f.onset = f.touching && !was_touching;
        if (f.onset) f.onset_impulse = 0.001;
        was_touching = f.touching;
        board_.publish(0, f);
        board_.beat();
        std::this_thread::sleep_for(1ms);  // the sim's own pace
      }
    });
  }
  ~SimPublisher() {
    stop_.store(true);
    thread_.join();
  }
  void set(const Felt& f) {
    std::lock_guard lock(mutex_);
    felt_ = f;
  }

 private:
  FeedbackBoard& board_;
  std::mutex mutex_;
  Felt felt_{};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct Rig {
  explicit Rig(const UhidPadSpec& spec) : pad(spec), board(1), haptics(board, HapticsSettings{}), sim(board) {
    haptics.start();
    haptics.attach(0, pad.ff_node(), {{0, kPlane}});
    haptics.flush();
  }
  UhidPad pad;
  FeedbackBoard board;
  HapticsThread haptics;
  SimPublisher sim;
};

// The latest motor byte (strong) once two motor reports in a row agree.
std::optional<std::uint8_t> settled_strong(const UhidPad& pad, std::chrono::milliseconds timeout) {
  std::optional<std::uint8_t> out;
  pad.wait_for(
      [&](const std::vector<OutputReport>& rs) {
        std::optional<Motors> last, before;
        for (auto it = rs.rbegin(); it != rs.rend(); ++it) {
          auto m = pad.spec().motors(*it);
          if (!m) continue;
          if (!last) {
            last = m;
          } else {
            before = m;
            break;
          }
        }
        if (last && before && last->strong == before->strong && last->strong > 0) {
          out = last->strong;
          return true;
        }
        return false;
      },
      timeout);
  return out;
}

class UhidHaptics : public ::testing::TestWithParam<const UhidPadSpec*> {};

// Needs the continuous-rumble engine.
TEST_P(UhidHaptics, SteadyForceRumblesAndALargerForceRumblesHarder) {
  Rig rig(*GetParam());
  rig.sim.set(touching(0.3));
  const auto low = settled_strong(rig.pad, 3000ms);
  ASSERT_TRUE(low.has_value()) << "no steady non-zero motor report for a steady 0.3 N";
  // A steady force keeps the motors running (no kick that ends by itself).
  EXPECT_FALSE(rig.pad.wait_for_motors([](const Motors& m) { return m.strong == 0; }, 200ms))
      << "the motors stopped while the force held";
  rig.sim.set(touching(0.8));
  EXPECT_TRUE(rig.pad.wait_for_motors([&](const Motors& m) { return m.strong > *low; }, 3000ms))
      << "0.8 N did not rumble harder than 0.3 N (" << int(*low) << ")";
}

// Needs the continuous-rumble engine.
TEST_P(UhidHaptics, NoContactOrZeroForceMeansMotorsZero) {
  Rig rig(*GetParam());
  rig.sim.set(touching(0.6));
  ASSERT_TRUE(settled_strong(rig.pad, 3000ms).has_value());
  rig.sim.set(free_air());
  EXPECT_TRUE(rig.pad.wait_for_motors([](const Motors& m) { return m == Motors{0, 0}; }, 1000ms));
  rig.sim.set(touching(0.6));
  ASSERT_TRUE(rig.pad.wait_for_motors([](const Motors& m) { return m.strong > 0; }, 3000ms));
  rig.sim.set(touching(0.0));  // touching, but no force: nothing to feel
  EXPECT_TRUE(rig.pad.wait_for_motors([](const Motors& m) { return m == Motors{0, 0}; }, 1000ms));
}

// Needs the engine's per-bus pacing.
TEST_P(UhidHaptics, OutputReportsArePacedForTheBus) {
  const UhidPadSpec& spec = *GetParam();
  Rig rig(spec);
  const auto pace = spec.bus == BUS_BLUETOOTH ? 25ms : 10ms;
  rig.sim.set(touching(0.2));
  ASSERT_TRUE(rig.pad.wait_for_motors([](const Motors& m) { return m.strong > 0; }, 3000ms));
  rig.pad.clear_outputs();
  // A force that changes every millisecond for a second: every report could
  // differ, so only the pacing limits them.
  const auto start = Clock::now();
  for (int i = 0; Clock::now() - start < 1000ms; ++i) {
    rig.sim.set(touching(0.2 + 0.6 * (0.5 + 0.5 * std::sin(i * 0.05))));
    std::this_thread::sleep_for(1ms);
  }
  const auto reports = rig.pad.motor_reports();
  ASSERT_GE(reports.size(), 5u) << "the motors did not follow a changing force";
  auto min_gap = Clock::duration::max();
  for (std::size_t i = 1; i < reports.size(); ++i) min_gap = std::min(min_gap, reports[i].at - reports[i - 1].at);
  std::printf("%s: %zu motor reports in 1 s, closest %.1f ms apart\n", spec.module.c_str(), reports.size(),
              std::chrono::duration<double, std::milli>(min_gap).count());
  // 1 ms of slack: the times are taken when the reader thread reads the
  // report, not when the driver queued it.
  EXPECT_GE(min_gap, pace - 1ms);
  EXPECT_LE(reports.size(), static_cast<std::size_t>(1000ms / pace) + 2);
}

// Needs the continuous-rumble engine.
TEST_P(UhidHaptics, PausedHoldZeroesTheMotorsWithin50ms) {
  Rig rig(*GetParam());
  rig.sim.set(touching(0.6));
  ASSERT_TRUE(settled_strong(rig.pad, 3000ms).has_value());
  const std::size_t before = rig.pad.output_count();
  const auto held = Clock::now();
  rig.board.set_hold(Hold::paused);
  std::optional<Clock::time_point> zero_at;
  ASSERT_TRUE(rig.pad.wait_for(
      [&](const std::vector<OutputReport>& rs) {
        for (std::size_t i = before; i < rs.size(); ++i)
          if (auto m = rig.pad.spec().motors(rs[i]); m && *m == Motors{0, 0}) {
            zero_at = rs[i].at;
            return true;
          }
        return false;
      },
      1000ms))
      << "no motor-0 report after Hold::paused";
  EXPECT_LE(*zero_at - held, scaled(50ms));
}

// Passes with any engine that leaves the motors at 0; with the continuous one
// the motors are still running when stop() is called.
TEST_P(UhidHaptics, StopLeavesTheMotorsAtZero) {
  Rig rig(*GetParam());
  rig.sim.set(touching(0.6));
  // Any report that ran the motors (an onset kick may be over already).
  ASSERT_TRUE(rig.pad.wait_for(
      [&](const std::vector<OutputReport>& rs) {
        return std::any_of(rs.begin(), rs.end(), [&](const OutputReport& r) {
          const auto m = rig.pad.spec().motors(r);
          return m && m->strong > 0;
        });
      },
      3000ms))
      << "the engine never rumbled on contact";
  rig.haptics.stop();
  ASSERT_TRUE(rig.pad.wait_for_motors([](const Motors& m) { return m == Motors{0, 0}; }, 1000ms));
  // Nothing after: the last motor report stays 0 while the sim keeps publishing.
  EXPECT_FALSE(rig.pad.wait_for_motors([](const Motors& m) { return m.strong > 0; }, 100ms));
}

INSTANTIATE_TEST_SUITE_P(Pads, UhidHaptics, ::testing::ValuesIn(support::uhid_pads::all()),
                         support::uhidtest::PadName{});

}  // namespace
}  // namespace sculpt::haptics
