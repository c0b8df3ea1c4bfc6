// The DualSense trigger module without a pad: report bytes (USB and BT, the
// CRC against zlib's), force → resistance, the stall watch, pacing, hidraw
// discovery in a fake sysfs tree, the renderer and the engine's trigger slots
// against a fake hidraw port.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <vector>

#include "fake_port.hpp"
#include "haptics/dualsense_triggers.hpp"
#include "haptics/haptics_engine.hpp"
#include "haptics/hidraw_port.hpp"
#include "haptics/trigger_renderer.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using namespace dualsense;
namespace fs = std::filesystem;

std::vector<std::uint8_t> report(Transport t, const TriggerPair& p, std::uint8_t seq = 0) {
  std::array<std::uint8_t, kMaxReportSize> buf{};
  const std::size_t n = build_trigger_report(t, p, seq, buf);
  return {buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n)};
}

TEST(DualSenseReport, UsbSetsOnlyTheTriggerFlagsAndBlocks) {
  const TriggerPair p{resistance_effect(0x10, 0x80), resistance_effect(0, 200)};
  const auto r = report(Transport::usb, p);
  ASSERT_EQ(r.size(), 63u);
  std::vector<std::uint8_t> want(63, 0);
  want[0] = 0x02;            // DS_OUTPUT_REPORT_USB
  want[1] = 0x0c;            // valid_flag0: right (bit 2) + left (bit 3) trigger; no motor bits 0/1
  want[11] = 0x01;           // right trigger: continuous resistance
  want[12] = 0x00;           //   from the rest position
  want[13] = 200;            //   force
  want[22] = 0x01;           // left trigger
  want[23] = 0x10;
  want[24] = 0x80;
  EXPECT_EQ(r, want);
  EXPECT_EQ(r[2], 0) << "valid_flag1 (lights, mute LED, power save) untouched";
  EXPECT_EQ(r[3], 0);
  EXPECT_EQ(r[4], 0);
}

TEST(DualSenseReport, NeutralIsTheOffEffectOnBothTriggers) {
  const auto r = report(Transport::usb, TriggerPair{});
  EXPECT_EQ(r[1], 0x0c);
  EXPECT_EQ(r[11], 0x05);
  EXPECT_EQ(r[22], 0x05);
  for (int i = 12; i < 22; ++i) EXPECT_EQ(r[i], 0) << i;
  EXPECT_EQ(resistance_effect(0, 0), neutral_effect());
  EXPECT_TRUE(resistance_effect(30, 0).neutral());
}

TEST(DualSenseReport, Crc32MatchesTheStandardCheckValue) {
  const std::string s = "123456789";
  EXPECT_EQ(crc32(0, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size())),
            0xcbf43926u);
}

TEST(DualSenseReport, BluetoothHeaderSequenceAndCrc) {
  const TriggerPair p{neutral_effect(), resistance_effect(0, 200)};
  const auto r = report(Transport::bluetooth, p, 3);
  // Built independently with Python: r = header + common; crc = zlib.crc32(b'\xa2' + r[:74]).
  const std::string hex =
      "3130100c0000000000000000000100c80000000000000000050000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000179c0927";
  ASSERT_EQ(r.size(), 78u);
  std::vector<std::uint8_t> want;
  for (std::size_t i = 0; i < hex.size(); i += 2) want.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  EXPECT_EQ(r, want);
  EXPECT_EQ(bt_output_crc(std::span<const std::uint8_t>(r.data(), 74)), 0x27099c17u);
  // The sequence number is the high nibble and wraps.
  EXPECT_EQ(report(Transport::bluetooth, p, 15)[1], 0xf0);
  EXPECT_EQ(report(Transport::bluetooth, p, 16)[1], 0x00);
}

TEST(DualSenseReport, KnowsTheDualSenseAndTheEdge) {
  EXPECT_TRUE(is_dualsense(0x054c, 0x0ce6));
  EXPECT_TRUE(is_dualsense(0x054c, 0x0df2));
  EXPECT_FALSE(is_dualsense(0x054c, 0x09cc));  // DualShock 4
  EXPECT_FALSE(is_dualsense(0x045e, 0x0ce6));
}

ToolForce touching(double newton) {
  ToolForce f;
  f.force = {0, newton * 0.6, newton * 0.8};
  f.touching = true;
  f.contacts = 3;
  return f;
}

TEST(Resistance, MonotonicClampedAndNeutralWhenNotTouching) {
  const TriggerScale s{ForceScale{2.0, 0.0, 1.0}, {}, 1.0, 0};  // linear, no felt minimum
  std::uint8_t last = 0;
  for (double n = 0.0; n <= 3.0; n += 0.01) {
    const std::uint8_t r = resistance_from_force(touching(n), s);
    EXPECT_GE(r, last) << n;
    last = r;
  }
  EXPECT_EQ(resistance_from_force(touching(0.04), s), 5);  // round(0.02·255): no dead band
  EXPECT_EQ(resistance_from_force(touching(0.06), s), 8);  // round(0.03·255)
  EXPECT_EQ(resistance_from_force(touching(1.0), s), 128);
  EXPECT_EQ(resistance_from_force(touching(2.0), s), 255);
  EXPECT_EQ(resistance_from_force(touching(50.0), s), 255);
  ToolForce lifted = touching(1.0);
  lifted.touching = false;
  EXPECT_EQ(resistance_from_force(lifted, s), 0);
  ToolForce nan = touching(1.0);
  nan.force[0] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(resistance_from_force(nan, s), 0);
  // Strength scales the byte; a faint felt force still gives at least 1.
  EXPECT_EQ(resistance_from_force(touching(2.0), TriggerScale{ForceScale{2.0, 0.0, 1.0}, {}, 0.5, 0}), 128);
  EXPECT_EQ(resistance_from_force(touching(0.06), TriggerScale{ForceScale{2.0, 0.0, 1.0}, {}, 0.01, 0}), 1);
  EXPECT_EQ(resistance_from_force(touching(2.0), TriggerScale{ForceScale{2.0, 0.0, 1.0}, {}, 0.0, 0}), 0);
}

// The motors' curve and the pad's tuning: the lightest touch is felt, the
// gain scales and the hard limit caps the trigger as it does the motors.
TEST(Resistance, TheLightestTouchIsFeltAndTheLimitHolds) {
  TriggerScale s;  // the default level curve (felt minimum)
  EXPECT_GE(resistance_from_force(touching(0.001), s), static_cast<std::uint8_t>(std::floor(s.force.min_level * 255)));
  s.tuning = DeviceTuning{0.5, 0.25};
  for (double n = 0.0; n <= 5.0; n += 0.05)
    EXPECT_LE(resistance_from_force(touching(n), s), static_cast<std::uint8_t>(std::lround(0.25 * 255))) << n;
  EXPECT_EQ(resistance_from_force(touching(5.0), s), static_cast<std::uint8_t>(std::lround(0.25 * 255)));
}

TEST(StallWatch, AliveWhileTheBeatMoves) {
  StallWatch w(100ms);
  const Clock::time_point t0{};
  EXPECT_TRUE(w.alive(5, t0));
  EXPECT_TRUE(w.alive(5, t0 + 100ms));
  EXPECT_FALSE(w.alive(5, t0 + 101ms));
  EXPECT_TRUE(w.alive(6, t0 + 150ms));
  EXPECT_TRUE(w.alive(6, t0 + 200ms));
}

TEST(TriggerPacer, OnlyOnChangeAndNoMoreOftenThanTheInterval) {
  EXPECT_EQ(TriggerPacer::min_interval(Transport::usb), 10ms);
  EXPECT_EQ(TriggerPacer::min_interval(Transport::bluetooth), 25ms);
  TriggerPacer p(10ms);
  const Clock::time_point t0{};
  const TriggerPair off{}, on{neutral_effect(), resistance_effect(0, 100)};
  EXPECT_TRUE(p.should_send(off, t0));  // first: the pad's state is unknown
  p.sent(off, t0);
  EXPECT_FALSE(p.should_send(off, t0 + 50ms));  // no change
  EXPECT_FALSE(p.should_send(on, t0 + 9ms));    // too soon
  EXPECT_TRUE(p.should_send(on, t0 + 10ms));    // the waiting change is not lost
  p.sent(on, t0 + 10ms);
  EXPECT_FALSE(p.should_send(on, t0 + 30ms));
  p.failed(t0 + 30ms);
  EXPECT_FALSE(p.should_send(on, t0 + 35ms));
  EXPECT_TRUE(p.should_send(on, t0 + 40ms));  // retried unchanged
  // 10 000 changing wants over 1 s of 1 ms polls: at most one send per 10 ms.
  TriggerPacer q(10ms);
  int sends = 0;
  for (int i = 0; i < 10000; ++i) {
    const Clock::time_point now = t0 + std::chrono::microseconds(100 * i);
    const TriggerPair want{neutral_effect(), resistance_effect(0, static_cast<std::uint8_t>(1 + i % 200))};
    if (q.should_send(want, now)) {
      q.sent(want, now);
      ++sends;
    }
  }
  EXPECT_LE(sends, 101);
  EXPECT_GE(sends, 99);
}

// A fake sysfs: /sys/class/input/eventN → the input device under the HID
// device, whose hidraw child names the node; the real layout's symlinks.
class FakeSysfs : public ::testing::Test {
 protected:
  FakeSysfs() {
    root = fs::temp_directory_path() / ("sculptd-sysfs-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root);
    fs::create_directories(root / "class" / "input");
    fs::create_directories(root / "dev");
  }
  ~FakeSysfs() override { fs::remove_all(root); }

  // e.g. add("event7", "0003:054C:0CE6.0004", "hidraw2")
  void add(const std::string& event, const std::string& hid_name, const std::string& hidraw) {
    const fs::path hid = root / "devices" / "pci0000:00" / "usb1" / hid_name;
    const fs::path input = hid / "input" / ("input" + event.substr(5));
    fs::create_directories(input / event);
    fs::create_directory_symlink(hid, input / "device");
    fs::create_directory_symlink(input, input / event / "device");
    fs::create_directory_symlink(input / event, root / "class" / "input" / event);
    if (!hidraw.empty()) fs::create_directories(hid / "hidraw" / hidraw);
  }
  fs::path root;
};

TEST_F(FakeSysfs, FindsTheHidrawNodeOfAnEventNode) {
  add("event7", "0003:054C:0CE6.0004", "hidraw2");
  add("event9", "0005:054C:0DF2.0005", "hidraw3");
  const auto usb = find_hidraw("/dev/input/event7", root, root / "dev");
  ASSERT_TRUE(usb);
  EXPECT_EQ(usb->node, (root / "dev" / "hidraw2").string());
  EXPECT_EQ(usb->bus, 0x03);
  EXPECT_EQ(usb->vendor, 0x054c);
  EXPECT_EQ(usb->product, 0x0ce6);
  const auto bt = find_hidraw("/dev/input/event9", root, root / "dev");
  ASSERT_TRUE(bt);
  EXPECT_EQ(bt->node, (root / "dev" / "hidraw3").string());
  EXPECT_EQ(bt->bus, 0x05);
  EXPECT_EQ(bt->product, 0x0df2);
}

TEST_F(FakeSysfs, NothingForANonHidDeviceOrOneWithoutHidraw) {
  // A uinput pad: its input device's parent is the uinput misc device.
  const fs::path misc = root / "devices" / "virtual" / "misc" / "uinput";
  const fs::path input = root / "devices" / "virtual" / "input" / "input3";
  fs::create_directories(misc);
  fs::create_directories(input / "event3");
  fs::create_directory_symlink(misc, input / "device");
  fs::create_directory_symlink(input, input / "event3" / "device");
  fs::create_directory_symlink(input / "event3", root / "class" / "input" / "event3");
  EXPECT_FALSE(find_hidraw("/dev/input/event3", root, root / "dev"));
  add("event4", "0003:046D:C21D.0001", "");  // a HID pad, hidraw not built
  EXPECT_FALSE(find_hidraw("/dev/input/event4", root, root / "dev"));
  EXPECT_FALSE(find_hidraw("/dev/input/event5", root, root / "dev"));  // not there at all
  EXPECT_FALSE(find_hidraw("/dev/input/js0", root, root / "dev"));
}

TEST_F(FakeSysfs, OpensOnlyADualSense) {
  add("event4", "0003:046D:C21D.0001", "hidraw0");  // an F310: not a DualSense
  std::ofstream(root / "dev" / "hidraw0").put('\0');
  EXPECT_FALSE(open_dualsense_hidraw("/dev/input/event4", root, root / "dev"));
  add("event7", "0005:054C:0CE6.0004", "hidraw2");
  std::ofstream(root / "dev" / "hidraw2").put('\0');  // a plain file stands in for the node
  auto ds = open_dualsense_hidraw("/dev/input/event7", root, root / "dev");
  ASSERT_TRUE(ds);
  EXPECT_EQ(ds->transport, Transport::bluetooth);
  EXPECT_EQ(ds->port->node(), (root / "dev" / "hidraw2").string());
  const std::vector<std::uint8_t> bytes{0x31, 0x00, 0x10};
  EXPECT_EQ(ds->port->write_report(bytes), 0);
  // Missing node (or no access): the error names it.
  add("event8", "0003:054C:0CE6.0006", "hidraw5");
  try {
    open_dualsense_hidraw("/dev/input/event8", root, root / "dev");
    FAIL() << "expected a system_error";
  } catch (const std::system_error& e) {
    EXPECT_EQ(e.code().value(), ENOENT);
    EXPECT_NE(std::string(e.what()).find("hidraw5"), std::string::npos);
  }
}

struct FakeHidrawState {
  std::vector<std::vector<std::uint8_t>> reports;
  int fail_with = 0;  // errno for the next writes
  // Optional: a clock each write takes `cost` on, and when each started and returned.
  std::shared_ptr<testing::FakeClock> clock;
  Clock::duration cost{};
  std::vector<std::pair<Clock::time_point, Clock::time_point>> times;
};

class FakeHidraw final : public HidrawPort {
 public:
  FakeHidraw(std::shared_ptr<FakeHidrawState> s, std::string node) : s_(std::move(s)), node_(std::move(node)) {}
  int write_report(std::span<const std::uint8_t> r) override {
    if (s_->clock) {
      const auto at = s_->clock->now();
      s_->clock->advance(s_->cost);
      s_->times.emplace_back(at, s_->clock->now());
    }
    if (s_->fail_with) return s_->fail_with;
    s_->reports.emplace_back(r.begin(), r.end());
    return 0;
  }
  const std::string& node() const override { return node_; }

 private:
  std::shared_ptr<FakeHidrawState> s_;
  std::string node_;
};

DualSenseHidraw fake_hidraw(const std::shared_ptr<FakeHidrawState>& s, Transport t = Transport::usb) {
  return DualSenseHidraw{std::make_unique<FakeHidraw>(s, "/dev/hidraw9"), t};
}

std::uint8_t right_mode(const std::vector<std::uint8_t>& r) { return r[kUsbCommonOffset + kRightTriggerBlock]; }
std::uint8_t right_force(const std::vector<std::uint8_t>& r) { return r[kUsbCommonOffset + kRightTriggerBlock + 2]; }
std::uint8_t left_force(const std::vector<std::uint8_t>& r) { return r[kUsbCommonOffset + kLeftTriggerBlock + 2]; }

Felt felt(double newton) {
  Felt f;
  f.force = {0, 0, newton};
  f.contacts = newton != 0 ? 2 : 0;
  f.touching = newton != 0;
  return f;
}

class Renderer : public ::testing::Test {
 protected:
  // A poll at `t` on the renderer's clock.
  void poll_at(TriggerRenderer& r, Clock::time_point t) {
    clock.advance_to(t);
    r.poll(board, t);
  }
  testing::FakeClock clock;
  FeedbackBoard board{4};
  std::shared_ptr<FakeHidrawState> pad = std::make_shared<FakeHidrawState>();
  TriggerCounters counters;
  const TriggerScale scale{ForceScale{2.0, 0.0, 1.0}, {}, 1.0, 0};
  const Clock::time_point t0{};
};

TEST_F(Renderer, EachTriggerFeelsItsOwnTool) {
  TriggerRenderer r(fake_hidraw(pad), TriggerBinding{1, 2}, scale, &counters, TriggerRenderer::kStallAfter, nullptr,
                    clock);
  EXPECT_EQ(counters.devices.load(), 1);
  poll_at(r, t0);  // first poll: neutral, the pad's state is ours from now on
  ASSERT_EQ(pad->reports.size(), 1u);
  EXPECT_EQ(right_mode(pad->reports[0]), kModeOff);
  board.publish(2, felt(1.0));
  board.publish(1, felt(2.0));
  board.beat();
  poll_at(r, t0 + 5ms);
  EXPECT_EQ(pad->reports.size(), 1u) << "10 ms apart on USB";
  poll_at(r, t0 + 10ms);
  ASSERT_EQ(pad->reports.size(), 2u);
  EXPECT_EQ(right_mode(pad->reports[1]), kModeResistance);
  EXPECT_EQ(right_force(pad->reports[1]), 128);
  EXPECT_EQ(left_force(pad->reports[1]), 255);
  board.beat();
  poll_at(r, t0 + 30ms);
  EXPECT_EQ(pad->reports.size(), 2u) << "no change, no write";
  board.publish(2, felt(0));
  board.publish(1, felt(0));
  board.beat();
  poll_at(r, t0 + 40ms);
  ASSERT_EQ(pad->reports.size(), 3u);
  EXPECT_EQ(right_mode(pad->reports[2]), kModeOff);
  EXPECT_EQ(counters.writes.load(), 3u);
}

TEST_F(Renderer, NeutralWhileHeldOrStalled) {
  TriggerRenderer r(fake_hidraw(pad), TriggerBinding{-1, 0}, scale, nullptr, TriggerRenderer::kStallAfter, nullptr,
                    clock);
  board.publish(0, felt(1.0));
  board.beat();
  poll_at(r, t0);
  ASSERT_EQ(pad->reports.size(), 1u);
  EXPECT_EQ(right_force(pad->reports.back()), 128);
  EXPECT_EQ(pad->reports.back()[kUsbCommonOffset + kLeftTriggerBlock], kModeOff) << "unbound trigger";
  for (Hold h : {Hold::paused, Hold::swapping, Hold::stopped}) {
    board.set_hold(h);
    board.beat();
    poll_at(r, t0 + 20ms * (1 + static_cast<int>(h)));
    EXPECT_EQ(right_mode(pad->reports.back()), kModeOff) << static_cast<int>(h);
    board.set_hold(Hold::none);
    board.beat();
    poll_at(r, t0 + 20ms * (1 + static_cast<int>(h)) + 10ms);
    EXPECT_EQ(right_force(pad->reports.back()), 128);
  }
  // The sim stops beating: neutral once 100 ms passed without a beat.
  const auto t1 = t0 + 200ms;
  board.beat();
  poll_at(r, t1);
  poll_at(r, t1 + 100ms);
  EXPECT_EQ(right_force(pad->reports.back()), 128);
  poll_at(r, t1 + 101ms);
  EXPECT_EQ(right_mode(pad->reports.back()), kModeOff);
  board.beat();
  poll_at(r, t1 + 120ms);
  EXPECT_EQ(right_force(pad->reports.back()), 128) << "beating again";
}

TEST_F(Renderer, ShutdownWritesNeutralOnceForgetWritesNothing) {
  {
    TriggerRenderer r(fake_hidraw(pad), TriggerBinding{0, 0}, scale, nullptr, TriggerRenderer::kStallAfter, nullptr,
                      clock);
    board.publish(0, felt(1.0));
    board.beat();
    poll_at(r, t0);
    r.shutdown();
    ASSERT_EQ(pad->reports.size(), 2u);
    EXPECT_EQ(right_mode(pad->reports.back()), kModeOff);
    EXPECT_EQ(pad->reports.back()[kUsbCommonOffset + kLeftTriggerBlock], kModeOff);
    poll_at(r, t0 + 1s);
  }  // the destructor does not write again
  EXPECT_EQ(pad->reports.size(), 2u);
  {
    TriggerRenderer r(fake_hidraw(pad), TriggerBinding{0, 0}, scale, nullptr, TriggerRenderer::kStallAfter, nullptr,
                      clock);
    r.forget();
  }
  EXPECT_EQ(pad->reports.size(), 2u);
}

TEST_F(Renderer, EnodevStopsWritingOtherErrorsRetry) {
  TriggerRenderer r(fake_hidraw(pad), TriggerBinding{-1, 0}, scale, &counters, TriggerRenderer::kStallAfter, nullptr,
                    clock);
  pad->fail_with = EAGAIN;
  poll_at(r, t0);
  EXPECT_EQ(counters.errors.load(), 1u);
  pad->fail_with = 0;
  poll_at(r, t0 + 5ms);
  EXPECT_EQ(pad->reports.size(), 0u);
  poll_at(r, t0 + 10ms);
  EXPECT_EQ(pad->reports.size(), 1u) << "retried after the interval";
  pad->fail_with = ENODEV;
  board.publish(0, felt(1.0));
  board.beat();
  poll_at(r, t0 + 20ms);
  EXPECT_TRUE(r.gone());
  pad->fail_with = 0;
  poll_at(r, t0 + 40ms);
  r.shutdown();
  EXPECT_EQ(pad->reports.size(), 1u);
}

TEST_F(Renderer, BluetoothReportsCarryASequenceAndA25msPace) {
  TriggerRenderer r(fake_hidraw(pad, Transport::bluetooth), TriggerBinding{-1, 0}, scale, nullptr,
                    TriggerRenderer::kStallAfter, nullptr, clock);
  for (int i = 0; i < 20; ++i) {
    board.publish(0, felt(0.1 * (i + 1)));
    board.beat();
    poll_at(r, t0 + 25ms * i);
  }
  ASSERT_EQ(pad->reports.size(), 20u);
  for (std::size_t i = 0; i < pad->reports.size(); ++i) {
    const auto& rep = pad->reports[i];
    ASSERT_EQ(rep.size(), kBtReportSize);
    EXPECT_EQ(rep[0], 0x31);
    EXPECT_EQ(rep[1], (i % 16) << 4);
    EXPECT_EQ(rep[2], 0x10);
    const std::uint32_t crc = rep[74] | rep[75] << 8 | rep[76] << 16 | static_cast<std::uint32_t>(rep[77]) << 24;
    EXPECT_EQ(crc, bt_output_crc(std::span<const std::uint8_t>(rep.data(), 74)));
  }
  board.publish(0, felt(0.05 * 3));
  board.beat();
  poll_at(r, t0 + 25ms * 19 + 24ms);
  EXPECT_EQ(pad->reports.size(), 20u);
}

// The engine's trigger slots: a fake opener stands for sysfs + /dev/hidraw.
class EngineTriggers : public ::testing::Test {
 protected:
  EngineTriggers() {
    settings.force = ForceScale{2.0, 0.0, 1.0};  // linear: 1 N is half the level
    engine = std::make_unique<HapticsEngine>(
        board, settings,
        [](const std::string& node) -> std::unique_ptr<FfPort> { throw std::runtime_error("no FF on " + node); }, stats,
        [this](int, const std::string& m) { log.push_back(m); }, *clock);
    engine->set_trigger_opener([this](const std::string& node) -> std::optional<DualSenseHidraw> {
      ++opens;
      if (node == "/dev/input/denied") throw std::system_error(EACCES, std::generic_category(), "/dev/hidraw4");
      if (node != "/dev/input/ds") return std::nullopt;
      return fake_hidraw(pad);
    });
  }
  void poll_at(Clock::time_point t) {
    clock->advance_to(t);
    engine->poll();
  }
  std::shared_ptr<testing::FakeClock> clock = std::make_shared<testing::FakeClock>();
  FeedbackBoard board{4};
  HapticsSettings settings;
  HapticsStats stats;
  std::vector<std::string> log;
  int opens = 0;
  std::shared_ptr<FakeHidrawState> pad = std::make_shared<FakeHidrawState>();
  std::unique_ptr<HapticsEngine> engine;
  const Clock::time_point t0{};
};

TEST_F(EngineTriggers, DrivesADualSenseEvenWithoutFf) {
  engine->attach(0, "/dev/input/ds", {}, TriggerBinding{-1, 1});
  ASSERT_NE(engine->triggers(0), nullptr);
  EXPECT_EQ(stats.triggers.devices.load(), 1);
  board.publish(1, felt(1.0));
  board.beat();
  poll_at(t0);
  ASSERT_EQ(pad->reports.size(), 1u);
  EXPECT_EQ(right_force(pad->reports[0]), 128);
  engine->shutdown();
  ASSERT_EQ(pad->reports.size(), 2u);
  EXPECT_EQ(right_mode(pad->reports[1]), kModeOff) << "neutral on stop";
  EXPECT_EQ(stats.triggers.devices.load(), 0);
}

TEST_F(EngineTriggers, NoBindingOrNotADualSenseOpensNothingQuietly) {
  engine->attach(0, "/dev/input/ds", {}, TriggerBinding{});
  engine->attach(1, "/dev/input/f310", {}, TriggerBinding{0, 1});
  EXPECT_EQ(opens, 1);
  EXPECT_EQ(engine->triggers(0), nullptr);
  EXPECT_EQ(engine->triggers(1), nullptr);
  for (const auto& m : log) EXPECT_EQ(m.find("triggers"), std::string::npos) << m;
}

TEST_F(EngineTriggers, NoAccessIsSaidOnce) {
  engine->attach(0, "/dev/input/denied", {}, TriggerBinding{0, 1});
  engine->detach(0);
  engine->attach(0, "/dev/input/denied", {}, TriggerBinding{0, 1});
  int said = 0;
  for (const auto& m : log) said += m.find("udev rule") != std::string::npos;
  EXPECT_EQ(said, 1);
  EXPECT_EQ(engine->triggers(0), nullptr);
}

TEST_F(EngineTriggers, UnplugWritesNothingReplaceWritesNeutral) {
  engine->attach(0, "/dev/input/ds", {}, TriggerBinding{-1, 1});
  board.publish(1, felt(1.0));
  board.beat();
  poll_at(t0);
  engine->detach(0);
  EXPECT_EQ(pad->reports.size(), 1u);
  engine->attach(0, "/dev/input/ds", {}, TriggerBinding{-1, 1});
  poll_at(t0 + 1s);
  EXPECT_EQ(pad->reports.size(), 2u);
  engine->attach(0, "/dev/input/ds", {}, TriggerBinding{-1, 1});  // replaced while plugged in
  ASSERT_EQ(pad->reports.size(), 3u);
  EXPECT_EQ(right_mode(pad->reports[2]), kModeOff);
}

TEST_F(EngineTriggers, SighupTurnsThemOffAndOnAndRescales) {
  engine->attach(0, "/dev/input/ds", {}, TriggerBinding{-1, 1});
  board.publish(1, felt(1.0));
  board.beat();
  poll_at(t0);
  EXPECT_EQ(right_force(pad->reports.back()), 128);
  settings.triggers.strength = 0.5;
  engine->configure(settings);
  board.beat();
  poll_at(t0 + 20ms);
  EXPECT_EQ(right_force(pad->reports.back()), 64);
  settings.triggers.enabled = false;
  engine->configure(settings);
  EXPECT_EQ(engine->triggers(0), nullptr);
  EXPECT_EQ(right_mode(pad->reports.back()), kModeOff);
  settings.triggers.enabled = true;
  engine->configure(settings);
  ASSERT_NE(engine->triggers(0), nullptr);
  board.beat();
  poll_at(t0 + 1s);
  EXPECT_EQ(right_force(pad->reports.back()), 64);
}

// One DualSense, one firmware: its FF node (rumble through hid-playstation)
// and its hidraw node (the triggers) share one pacer. With both wanting to
// write all the time and every write taking time, no two writes to the pad
// come closer than the floor, end to start, and neither starves the other.
TEST_F(EngineTriggers, MotorsAndTriggersOfOneDualSenseShareOneFloor) {
  auto ff = testing::fake_device({FF_RUMBLE, FF_GAIN}, 16);
  ff->identity.bustype = BUS_USB;
  ff->clock = clock;
  ff->cost = testing::CallCost{4ms, 3ms, 2ms, 2ms};
  pad->clock = clock;
  pad->cost = 3ms;
  engine = std::make_unique<HapticsEngine>(
      board, settings,
      [&](const std::string& node) -> std::unique_ptr<FfPort> { return std::make_unique<testing::FakePort>(ff, node); },
      stats, [this](int, const std::string& m) { log.push_back(m); }, *clock);
  engine->set_trigger_opener([this](const std::string&) -> std::optional<DualSenseHidraw> { return fake_hidraw(pad); });
  engine->attach(0, "/dev/input/ds", {{1, StickPlane{}}}, TriggerBinding{-1, 1});
  Clock::time_point t = t0;
  for (int i = 0; i < 2000; ++i) {
    board.publish(1, felt(1.0 + 0.9 * std::sin(i * 0.05)));  // every report could differ
    if (i < 1500 || i > 1600) board.beat();                  // a stall between
    t = std::max(t + 2ms, clock->now());
    poll_at(t);
  }
  engine->shutdown();

  std::vector<std::pair<Clock::time_point, Clock::time_point>> writes = pad->times;
  for (const auto& c : ff->calls) writes.emplace_back(c.at, c.end);
  std::sort(writes.begin(), writes.end());
  for (std::size_t i = 1; i < writes.size(); ++i)
    ASSERT_GE(writes[i].first - writes[i - 1].second, 10ms) << "write " << i;
  EXPECT_GT(pad->reports.size(), 100u) << "the triggers got their turns";
  EXPECT_GT(ff->of(testing::FakeDeviceState::Call::upload).size(), 100u) << "and so did the motors";
  EXPECT_EQ(right_mode(pad->reports.back()), kModeOff) << "neutral on shutdown";
}

}  // namespace
}  // namespace sculpt::haptics
