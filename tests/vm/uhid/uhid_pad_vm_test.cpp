// The uhid fixture itself: each pad of the table is bound by its kernel
// driver, which finds its feature reports answered and makes an evdev node
// with FF_RUMBLE; a hidraw node exists and what a client writes to it is
// recorded like the driver's own reports.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <linux/hidraw.h>
#include <linux/input.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <string>

#include "support/evdev_client.hpp"
#include "support/uhid_pad.hpp"
#include "support/unique_fd.hpp"

namespace sculpt::support {
namespace {

using namespace std::chrono_literals;

class UhidPadBinds : public ::testing::TestWithParam<const UhidPadSpec*> {};

bool has_bit(const unsigned long* bits, int bit) {
  return (bits[bit / (8 * sizeof(long))] >> (bit % (8 * sizeof(long)))) & 1;
}

TEST_P(UhidPadBinds, DriverBindsAndMakesAnFfRumbleNode) {
  const UhidPadSpec& spec = *GetParam();
  UhidPad pad(spec);
  EXPECT_NE(pad.sysfs_dir().find(":"), std::string::npos) << pad.sysfs_dir();
  UniqueFd ev(::open(pad.ff_node().c_str(), O_RDWR | O_CLOEXEC));
  ASSERT_TRUE(ev.valid()) << pad.ff_node();
  unsigned long ff[(FF_CNT + 8 * sizeof(long) - 1) / (8 * sizeof(long))] = {};
  ASSERT_GE(::ioctl(ev.get(), EVIOCGBIT(EV_FF, sizeof ff), ff), 0);
  EXPECT_TRUE(has_bit(ff, FF_RUMBLE)) << pad.ff_node();
  int effects = 0;
  ASSERT_EQ(::ioctl(ev.get(), EVIOCGEFFECTS, &effects), 0);
  EXPECT_GE(effects, 1);  // ff-memless: FF_MEMLESS_EFFECTS (16)
  std::printf("%s: %s, %zu event nodes, FF on %s, %s, asked for features:", spec.module.c_str(),
              pad.sysfs_dir().c_str(), pad.event_nodes().size(), pad.ff_node().c_str(), pad.hidraw_node().c_str());
  for (auto id : pad.get_report_requests()) std::printf(" 0x%02x", id);
  std::printf("\n");
}

INSTANTIATE_TEST_SUITE_P(Pads, UhidPadBinds, ::testing::ValuesIn(uhid_pads::all()),
                         [](const auto& info) {
                           std::string n = info.param->module.substr(0, info.param->module.find('.'));
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

TEST(UhidPad, DualSenseAnswersTheFeatureReportsTheDriverAsksFor) {
  UhidPad pad(uhid_pads::dualsense_usb());
  const auto asked = pad.get_report_requests();
  for (std::uint8_t id : {0x05, 0x09, 0x20})
    EXPECT_NE(std::find(asked.begin(), asked.end(), id), asked.end()) << "report 0x" << std::hex << int(id);
  EXPECT_GE(pad.event_nodes().size(), 3u);  // gamepad, motion sensors, touchpad
}

TEST_P(UhidPadBinds, InputReportsReachTheGamepadNode) {
  const UhidPadSpec& spec = *GetParam();
  UhidPad pad(spec);
  EvdevClient ev(pad.ff_node());  // the gamepad: sticks and buttons, and the FF
  pad.send_input(spec.idle_input);
  std::vector<std::uint8_t> moved = spec.idle_input;
  moved[spec.bus == BUS_BLUETOOTH ? 2 : 1] = 0xff;  // left stick X to the right (the high byte on Xbox)
  pad.send_input(moved);
  const int want = spec.bus == BUS_BLUETOOTH ? 0xff00 : 0xff;  // at rest 0x8000 / 0x80
  int last_x = -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (last_x != want && std::chrono::steady_clock::now() < deadline) {
    const auto e = ev.next_event(std::chrono::milliseconds(200));
    if (e && e->type == EV_ABS && e->code == ABS_X) last_x = e->value;
  }
  EXPECT_EQ(last_x, want) << "ABS_X did not follow the input report";
}

TEST(UhidPad, TwoPadsOfOneKindAtOnce) {
  UhidPad a(uhid_pads::dualshock4_usb());
  UhidPad b(uhid_pads::dualshock4_usb());  // its own MAC: hid-sony takes both
  EXPECT_NE(a.ff_node(), b.ff_node());
}

TEST(UhidPad, DualSenseHidrawWritesAreRecorded) {
  UhidPad pad(uhid_pads::dualsense_usb());
  const std::string raw = pad.hidraw_node();
  ASSERT_FALSE(raw.empty()) << "no hidraw under " << pad.sysfs_dir();
  UniqueFd fd(::open(raw.c_str(), O_RDWR | O_CLOEXEC));
  ASSERT_TRUE(fd.valid()) << raw;
  std::array<std::uint8_t, 48> report{};
  report[0] = 0x02;
  report[2] = 0x04;   // valid_flag1: right trigger effect
  report[11] = 0x01;  // right trigger: a continuous-resistance mode byte
  report[12] = 0x42;
  ASSERT_EQ(::write(fd.get(), report.data(), report.size()), static_cast<ssize_t>(report.size()));
  ASSERT_TRUE(pad.wait_for([&](const std::vector<OutputReport>& rs) {
    return std::any_of(rs.begin(), rs.end(), [&](const OutputReport& r) {
      return r.kind == OutputReport::Kind::output && r.data.size() == report.size() &&
             std::equal(r.data.begin(), r.data.end(), report.begin());
    });
  }));
  // A feature report set through hidraw reaches the pad as SET_REPORT.
  std::array<std::uint8_t, 4> feature{0x08, 1, 2, 3};
  ASSERT_GE(::ioctl(fd.get(), HIDIOCSFEATURE(feature.size()), feature.data()), 0);
  ASSERT_TRUE(pad.wait_for([&](const std::vector<OutputReport>& rs) {
    return std::any_of(rs.begin(), rs.end(), [&](const OutputReport& r) {
      return r.kind == OutputReport::Kind::set_report && r.data.size() == 4 && r.data[0] == 0x08 && r.data[3] == 3;
    });
  }));
}

}  // namespace
}  // namespace sculpt::support
