// `sculptctl replay` through uinput recreates the recorded devices (names,
// ids, absinfo, buttons, FF bits), answers FF uploads, and delivers the
// recorded events with MSC_TIMESTAMP = the recorded time; `sculptctl record`
// captures a live device into a recording that reads back.
#include <gtest/gtest.h>

#include <linux/input.h>
#include <sys/wait.h>

#include <atomic>
#include <filesystem>
#include <map>
#include <thread>

#include "input/recording.hpp"
#include "support/child_process.hpp"
#include "support/evdev_client.hpp"
#include "support/scratch_dir.hpp"
#include "support/timing.hpp"
#include "support/virtual_joystick.hpp"
#include "device_pump.hpp"

#ifndef SCULPTCTL_BIN
#error "SCULPTCTL_BIN must name the sculptctl binary"
#endif
#ifndef SCULPT_RECORDINGS_DIR
#error "SCULPT_RECORDINGS_DIR must name tests/data/recordings"
#endif

namespace sculpt::input {
namespace {

using support::ChildProcess;
using support::scaled;
using vmtest::pump_until;
using vmtest::Recorded;

std::filesystem::path temp(const std::string& name) { return support::scratch_path(name); }

DeviceInfo recorded_pad() {
  DeviceInfo d;
  d.name = "replayed pad";
  d.bustype = BUS_USB;
  d.vendor = 0x5c17;
  d.product = 0x0101;
  d.version = 3;
  d.axes = {{ABS_X, 0, -32768, 32767, 16, 128, 0}, {ABS_Y, 0, -32768, 32767, 16, 128, 0},
            {ABS_Z, 0, 0, 255, 0, 0, 0},           {ABS_RX, 0, -32768, 32767, 16, 128, 0},
            {ABS_RY, 0, -32768, 32767, 16, 128, 0}, {ABS_RZ, 0, 0, 255, 0, 0, 0}};
  d.buttons = {BTN_SOUTH, BTN_EAST, BTN_NORTH, BTN_WEST, BTN_TL, BTN_TR};
  d.ff = {FF_CONSTANT, FF_RUMBLE, FF_GAIN};
  d.ff_effects_max = 4;
  d.kind = DeviceKind::gamepad;
  return d;
}

DeviceInfo recorded_stick() {
  DeviceInfo d;
  d.name = "replayed stick";
  d.bustype = BUS_USB;
  d.vendor = 0x5c17;
  d.product = 0x0102;
  d.axes = {{ABS_X, 512, 0, 1023, 0, 8, 0}, {ABS_Y, 512, 0, 1023, 0, 8, 0}, {ABS_RZ, 128, 0, 255, 0, 0, 0}};
  d.buttons = {BTN_TRIGGER, BTN_THUMB};
  d.kind = DeviceKind::joystick;
  return d;
}

Recording make_recording() {
  Recording s;
  s.header.devices = {recorded_pad(), recorded_stick()};
  std::int64_t t = 0;
  for (int i = 0; i < 150; ++i) {
    t += 2000 + (i % 7) * 300;  // uneven, like a real device
    const int v = (i * 613) % 60000 - 30000;
    s.frames.push_back({t, 0, {{EV_ABS, ABS_X, v}, {EV_ABS, ABS_RY, -v / 2}}});
    if (i % 10 == 5) s.frames.push_back({t, 1, {{EV_ABS, ABS_X, (i * 37) % 1024}, {EV_KEY, BTN_TRIGGER, (i / 10) % 2}}});
    if (i % 25 == 0) s.frames.push_back({t + 100, 0, {{EV_KEY, BTN_SOUTH, (i / 25) % 2}, {EV_ABS, ABS_Z, i}}});
  }
  return s;
}

std::map<std::pair<int, int>, int> final_state(const Recording& s, std::uint32_t device) {
  std::map<std::pair<int, int>, int> m;
  for (const auto& f : s.frames)
    if (f.device == device)
      for (const auto& e : f.events) m[{e.type, e.code}] = e.value;
  return m;
}

// An unplugged device releases its pressed keys (the kernel sends those, with
// no MSC_TIMESTAMP): not part of the recording.
Recorded replayed_only(const Recorded& events) {
  Recorded out;
  for (const auto& f : events.frames) {
    bool release = !f.device_clock;
    for (std::size_t i = 0; i < f.count && release; ++i)
      release = f.events[i].type == EV_KEY && f.events[i].value == 0;
    if (!release) out.frames.push_back(f);
  }
  return out;
}

// How long the replayed devices stay after their last frame. evdev drops what
// a removed device's readers had not read yet, so the reader (in the guest, on
// a host that may be busy) must get to the last release first: seconds, not
// the fraction a quiet machine needs.
constexpr const char* kHoldS = "2";

TEST(UinputReplay, RecreatesDevicesAnswersFfAndDeliversEventsWithRecordedTimes) {
  const Recording recording = make_recording();
  const auto file = temp("replay_vm.jsonl");
  write_recording(file, recording);

  Recorded events;
  DeviceManager manager(events);
  manager.start();
  ChildProcess replay({SCULPTCTL_BIN, "replay", "--settle", "1.0", "--hold", kHoldS, file.string()},
                      {.out = ChildProcess::Output::capture});
  ASSERT_TRUE(pump_until(manager, [&] { return events.attaches.size() >= 2; },
                         scaled(std::chrono::milliseconds(8000))))
      << "replay did not create two devices; its output: " << replay.out().text();

  const auto* pad = events.attach_named("replayed pad");
  const auto* stick = events.attach_named("replayed stick");
  ASSERT_NE(pad, nullptr);
  ASSERT_NE(stick, nullptr);
  EXPECT_EQ(pad->info.vendor, 0x5c17);
  EXPECT_EQ(pad->info.product, 0x0101);
  EXPECT_EQ(pad->info.version, 3);
  EXPECT_EQ(pad->info.kind, DeviceKind::gamepad);
  ASSERT_NE(pad->info.axis(ABS_RY), nullptr);
  EXPECT_EQ(pad->info.axis(ABS_RY)->minimum, -32768);
  EXPECT_EQ(pad->info.axis(ABS_RY)->flat, 128);
  EXPECT_EQ(pad->info.buttons, recorded_pad().buttons);
  EXPECT_TRUE(pad->info.has_ff(FF_CONSTANT));
  EXPECT_EQ(pad->info.ff_effects_max, 4);
  EXPECT_TRUE(pad->info.has_msc_timestamp);
  EXPECT_EQ(stick->info.kind, DeviceKind::joystick);
  EXPECT_TRUE(stick->info.ff.empty());
  // Slots follow plug-in order. Without udev that is creation order; with
  // udevd it is the order udev finishes (replay waits for each, but udev's
  // broadcast may still overtake): only the plain path asserts it.
  if (!vmtest::udev_running()) {
    EXPECT_LT(pad->slot, stick->slot) << "created in the header's order";
  }

  // A force-feedback client (like sculptd's haptics thread, on its own
  // thread) is answered at once instead of blocking for 30 s. Meanwhile this
  // thread keeps reading, as sculptd's io thread would.
  int upload_rc = -1, update_rc = -1;
  std::int16_t first_id = -1, second_id = -2;
  std::atomic<bool> ff_done{false};
  std::thread ff([&, node = pad->info.node] {
    support::EvdevClient client(node);
    ff_effect e = support::constant_effect(0x2000, 0x4000, 100);
    upload_rc = client.upload(e);
    first_id = e.id;
    ff_effect again = support::constant_effect(0x3000, 0x4000, 100, e.id);
    update_rc = client.upload(again);
    second_id = again.id;
    ff_done = true;
  });
  const bool ff_in_time =
      pump_until(manager, [&] { return ff_done.load(); }, scaled(std::chrono::milliseconds(5000)));
  ff.join();
  EXPECT_TRUE(ff_in_time) << "FF uploads to the replayed pad were not answered within 5 s";
  EXPECT_EQ(upload_rc, 0);
  EXPECT_EQ(update_rc, 0);
  EXPECT_GE(first_id, 0);
  EXPECT_EQ(second_id, first_id) << "update in place keeps the id";

  const std::uint8_t pad_slot = pad->slot, stick_slot = stick->slot;
  ASSERT_TRUE(pump_until(manager, [&] { return events.detaches.size() >= 2; },
                         scaled(std::chrono::milliseconds(15000))))
      << "the replay's devices never went away; output: " << replay.out().text();
  const auto status = replay.wait(std::chrono::milliseconds(20000));
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(*status, 0) << replay.out().text();
  EXPECT_NE(replay.out().text().find("replayed " + std::to_string(recording.frames.size()) + " frames"), std::string::npos)
      << replay.out().text();
  EXPECT_NE(replay.out().text().find("answered 2 FF uploads"), std::string::npos) << replay.out().text();

  const Recorded replayed = replayed_only(events);
  // Every device ends where the recording ends.
  for (auto [slot, index] : {std::pair{pad_slot, 0u}, std::pair{stick_slot, 1u}}) {
    auto got = replayed.state(slot);
    for (const auto& [key, value] : final_state(recording, index))
      EXPECT_EQ(got[key], value) << "device " << index << " type " << key.first << " code " << key.second;
  }
  // Each frame carries its recorded time as the device clock.
  std::vector<std::int64_t> recorded;
  for (const auto& f : recording.frames)
    if (f.device == 0) recorded.push_back(f.t_us);
  std::size_t matched = 0, pad_frames = 0;
  std::size_t resyncs = 0;
  for (const auto& f : replayed.frames) {
    if (f.slot != pad_slot) continue;
    if (f.resync) {  // SYN_DROPPED: libevdev's state diff carries no device time
      ++resyncs;
      continue;
    }
    ++pad_frames;
    EXPECT_TRUE(f.device_clock) << "frame " << pad_frames << " of the pad: " << f.count << " events, first "
                                << f.events[0].type << "/" << f.events[0].code << "=" << f.events[0].value;
    if (std::find(recorded.begin(), recorded.end(), f.device_time_us) != recorded.end()) ++matched;
  }
  EXPECT_GT(pad_frames, recorded.size() / 2);
  EXPECT_EQ(matched, pad_frames) << "a frame arrived with a device time that is not a recorded one";
  EXPECT_EQ(events.attaches.size(), 2u);
  if (::testing::Test::HasFailure()) {
    std::string logs;
    for (const auto& l : events.logs) logs += l + "\n";
    std::string keys;
    for (const auto& f : events.frames)
      for (std::size_t i = 0; i < f.count; ++i)
        if (f.events[i].type == EV_KEY)
          keys += "slot " + std::to_string(f.slot) + " t " + std::to_string(f.device_time_us) + " code " +
                  std::to_string(f.events[i].code) + "=" + std::to_string(f.events[i].value) + "\n";
    ADD_FAILURE() << "key events seen:\n" << keys << "diagnostics: " << resyncs << " resync frames, " << events.attaches.size() << " attaches, "
                  << events.detaches.size() << " detaches; manager log:\n" << logs;
  }
}

TEST(UinputReplay, ShippedRecordingsPlay) {
  // The three (bench_sculpt is the same moves, longer: the unit
  // suite reads it, sculptd's benchmark plays it). A sanitized -O0 build in
  // the emulated guest reads ~3000-frame recordings some 20x slower: it plays
  // the shortest only; the plain build plays all three.
  std::vector<std::string> names{"push", "pull", "two_hands"};
  if (scaled(std::chrono::milliseconds(1)).count() > 1) names = {"push"};
  for (const std::string& name : names) {
    const std::filesystem::path file = std::filesystem::path(SCULPT_RECORDINGS_DIR) / (name + ".jsonl");
    const Recording s = read_recording(file);
    ASSERT_FALSE(s.frames.empty()) << file;
    Recorded events;
    DeviceManager manager(events);
    manager.start();
    // Fast (50x): this checks the devices and that it plays to the end.
    ChildProcess replay({SCULPTCTL_BIN, "replay", "--speed", "50", "--settle", "0.3", "--hold", kHoldS, file.string()},
                        {.out = ChildProcess::Output::capture});
    ASSERT_TRUE(pump_until(manager, [&] { return events.detaches.size() >= s.header.devices.size(); },
                           scaled(std::chrono::milliseconds(30000))))
        << file << ": " << replay.out().text();
    ASSERT_EQ(events.attaches.size(), s.header.devices.size()) << file;
    for (std::size_t i = 0; i < s.header.devices.size(); ++i) {
      EXPECT_EQ(events.attaches[i].info.name, s.header.devices[i].name);
      auto got = replayed_only(events).state(events.attaches[i].slot);
      for (const auto& [key, value] : final_state(s, static_cast<std::uint32_t>(i)))
        EXPECT_EQ(got[key], value) << file << " device " << i << " code " << key.second;
    }
    const auto status = replay.wait(scaled(std::chrono::milliseconds(20000)));
    ASSERT_TRUE(status.has_value());
    EXPECT_EQ(*status, 0) << replay.out().text();
  }
}

TEST(Record, CapturesALiveDeviceIntoARecordingThatReadsBack) {
  const auto file = temp("recorded_vm.jsonl");
  std::filesystem::remove(file);
  // No --duration: it records until SIGINT, sent once the moves are made.
  ChildProcess record({SCULPTCTL_BIN, "record", "--wait-devices", "1", file.string()},
                      {.out = ChildProcess::Output::capture});
  support::VirtualJoystick pad(support::gamepad_spec().named("vm recorded pad"));
  auto line = record.out().next(scaled(std::chrono::milliseconds(10000)));
  while (line && line->rfind("recording", 0) != 0) line = record.out().next(std::chrono::milliseconds(10000));
  ASSERT_TRUE(line.has_value()) << "record never started: " << record.out().text();
  pad.move_axes({{ABS_X, 111}, {ABS_Y, 222}});
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // spacing between moves, not a wait for a fact
  pad.press(BTN_SOUTH);
  pad.move_axis(ABS_RX, -333);
  // The events are in the device's queue: what is queued when it stops is recorded too.
  record.signal(SIGINT);
  const auto status = record.wait(scaled(std::chrono::milliseconds(20000)));
  ASSERT_TRUE(status.has_value());
  ASSERT_EQ(*status, 0) << record.out().text();

  const Recording s = read_recording(file);
  ASSERT_EQ(s.header.devices.size(), 1u);
  EXPECT_EQ(s.header.devices[0].name, "vm recorded pad");
  EXPECT_EQ(s.header.devices[0].kind, DeviceKind::gamepad);
  EXPECT_TRUE(s.header.devices[0].has_ff(FF_CONSTANT));
  ASSERT_EQ(s.frames.size(), 3u);
  EXPECT_EQ(s.frames[0].events, (std::vector<InputEvent>{{EV_ABS, ABS_X, 111}, {EV_ABS, ABS_Y, 222}}));
  EXPECT_EQ(s.frames[1].events, (std::vector<InputEvent>{{EV_KEY, BTN_SOUTH, 1}}));
  EXPECT_EQ(s.frames[2].events, (std::vector<InputEvent>{{EV_ABS, ABS_RX, -333}}));
  EXPECT_GE(s.frames[1].t_us - s.frames[0].t_us, 90000) << "times are kept";
}

}  // namespace
}  // namespace sculpt::input
