// The haptics thread's decisions, driven directly with fake devices and a
// fake clock: continuous force (constant, or rumble on rumble-only pads),
// kicks on onset, one id per effect updated in place, per-bus pacing over
// 10 000 polls, re-arm before the replay length runs out, gain and limit,
// zero on a stall or a hold, neutral after a suspend, first uploads retried
// while a new device is not ready, forget on unplug and re-upload on replug.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
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
    settings.force = ForceScale{2.0, 0.1, 1.0};
    settings.rumble = RumbleScale{0.02, 1e-5, 0.5, 40, 0.0, 0.25};
  }
  // One poll at `t` on the shared clock (later if writes or waits took the
  // clock past it).
  void poll_at(Clock::time_point t, std::optional<std::chrono::nanoseconds> boottime = std::nullopt) {
    clock->advance_to(t);
    engine().poll(boottime);
  }
  std::shared_ptr<FakeDeviceState> pad(const std::string& node, std::initializer_list<std::uint16_t> bits,
                                       int effects, std::uint16_t bus = BUS_USB) {
    auto d = devices[node] = fake_device(bits, effects);
    d->clock = clock;
    d->identity.bustype = bus;
    d->identity.vendor = 0x045e;
    d->identity.product = 0x028e;
    d->identity.name = "Fake " + node;
    return d;
  }
  // Every call that reaches the driver as a report: uploads, plays and FF_GAIN.
  static std::vector<Call> reports(const FakeDeviceState& s) {
    std::vector<Call> out;
    for (const auto& c : s.calls)
      if (c.kind == Call::upload || (c.kind == Call::write && (c.id == FF_GAIN || c.value != 0))) out.push_back(c);
    return out;
  }
  static std::vector<Call> plays(const FakeDeviceState& s) {
    std::vector<Call> out;
    for (const auto& c : s.of(Call::write))
      if (c.id != FF_GAIN && c.value == 1) out.push_back(c);
    return out;
  }
  HapticsEngine& engine() {
    if (!engine_) make_engine({});
    return *engine_;
  }
  // The engine on the test's clock; every device opened shares it.
  void make_engine(LogSink log) {
    engine_ = std::make_unique<HapticsEngine>(
        board, settings,
        [this](const std::string& node) -> std::unique_ptr<FfPort> {
          auto it = devices.find(node);
          if (it == devices.end()) throw std::runtime_error("cannot open " + node);
          ++opens[node];
          it->second->clock = clock;
          return std::make_unique<FakePort>(it->second, node);
        },
        stats, std::move(log), *clock);
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

  std::shared_ptr<testing::FakeClock> clock = std::make_shared<testing::FakeClock>();
  FeedbackBoard board{2};
  HapticsSettings settings;
  HapticsStats stats;
  std::map<std::string, std::shared_ptr<FakeDeviceState>> devices;
  std::map<std::string, int> opens;
  std::unique_ptr<HapticsEngine> engine_;
  Clock::time_point t0{};
};

TEST_F(Engine, ConstantDeviceClaimsItsIdThenPlaysThenUpdatesInPlace) {
  auto d = pad("/dev/input/event1", {FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);  // not touching: the id is claimed at level 0
  auto ups = constant_uploads(*d);
  ASSERT_EQ(ups.size(), 1u);
  EXPECT_EQ(ups[0].effect.id, -1);
  EXPECT_EQ(ups[0].effect.u.constant.level, 0);
  EXPECT_EQ(ups[0].effect.replay.length, 20000);  // finite, re-armed
  poll_at(t0 + 4ms);
  EXPECT_TRUE(plays(*d).empty()) << "USB: 10 ms between writes";
  poll_at(t0 + 12ms);
  ASSERT_EQ(plays(*d).size(), 1u);
  board.publish(0, push(1.0, 0));
  poll_at(t0 + 24ms);
  ups = constant_uploads(*d);
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_EQ(ups[1].effect.id, ups[0].id);
  // 1 N of 2 N full scale, exponent 1, floor 0.1: 0.55.
  EXPECT_EQ(ups[1].effect.u.constant.level, static_cast<int>(0.55 * 32767));
  EXPECT_EQ(ups[1].effect.direction, 0x4000);
  // Not touching: zero.
  board.publish(0, push(0, 0));
  poll_at(t0 + 36ms);
  ups = constant_uploads(*d);
  ASSERT_EQ(ups.size(), 3u);
  EXPECT_EQ(ups[2].effect.u.constant.level, 0);
  EXPECT_EQ(d->live(), 1);
}

TEST_F(Engine, ContinuousRumbleFollowsTheForceOnARumbleOnlyPad) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  std::vector<std::uint16_t> weak_seen;
  for (int i = 0; i < 200; ++i) {
    const double f = i < 100 ? 0.025 * i : 0.0;  // a press building to 2.5 N, then released
    board.publish(0, push(f, 0));
    poll_at(t0 + std::chrono::milliseconds(4 * i));
  }
  const auto ups = rumble_uploads(*d);
  ASSERT_GE(ups.size(), 10u);
  EXPECT_EQ(ups[0].effect.id, -1);
  std::uint16_t last = 0;
  for (std::size_t i = 1; i < ups.size(); ++i) {
    EXPECT_EQ(ups[i].effect.id, ups[0].id) << "one rumble id, updated in place";
    EXPECT_EQ(ups[i].effect.replay.length, 20000);
    const auto& r = ups[i].effect.u.rumble;
    if (i + 1 < ups.size()) {
      EXPECT_GE(r.weak_magnitude, last) << "rises with the force";
      EXPECT_LE(r.strong_magnitude, r.weak_magnitude) << "the contact mix is mostly the weak motor";
      last = r.weak_magnitude;
    }
  }
  EXPECT_EQ(last, 0xffff) << "saturates at full scale";
  EXPECT_FALSE(ups.back().effect.u.rumble.weak_magnitude || ups.back().effect.u.rumble.strong_magnitude)
      << "zero when not touching";
  EXPECT_EQ(d->live(), 1);
  EXPECT_TRUE(constant_uploads(*d).empty());
}

TEST_F(Engine, LightestTouchIsFeltOnARumbleOnlyPad) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  poll_at(t0 + 12ms);  // play
  board.publish(0, push(0.003, 0));  // 3 mN
  poll_at(t0 + 24ms);
  const auto ups = rumble_uploads(*d);
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_GE(ups[1].effect.u.rumble.weak_magnitude, 0.1 * 0xffff);
}

TEST_F(Engine, KickIsDistinctThenBackToTheContactLevelInTheSameEffect) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  poll_at(t0 + 12ms);
  board.publish(0, push(0.4, 0, /*onset=*/true, 0.01));
  poll_at(t0 + 24ms);
  for (int i = 1; i < 30; ++i) {
    board.publish(0, push(0.4, 0));
    poll_at(t0 + 24ms + std::chrono::milliseconds(4 * i));
  }
  const auto ups = rumble_uploads(*d);
  ASSERT_GE(ups.size(), 3u);
  const auto& kick = ups[1].effect.u.rumble;
  const auto& after = ups[2].effect.u.rumble;
  EXPECT_EQ(ups[1].at, t0 + 24ms) << "the kick goes first";
  EXPECT_GT(kick.strong_magnitude, kick.weak_magnitude) << "the kick is mostly the strong motor";
  EXPECT_GT(kick.strong_magnitude, after.strong_magnitude);
  EXPECT_LT(after.strong_magnitude, after.weak_magnitude) << "then the contact mix again";
  EXPECT_GE(ups[2].at - ups[1].at, 40ms) << "after the kick's length";
  EXPECT_LE(ups[2].at - ups[1].at, 52ms);
  for (const auto& u : ups) EXPECT_EQ(u.id, ups[0].id);
  EXPECT_EQ(stats.ff.kicks.load(), 1u);
}

TEST_F(Engine, ConstantDeviceKicksWithItsOwnShortRumble) {
  auto d = pad("/dev/input/event1", {FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  poll_at(t0 + 12ms);
  board.publish(0, push(1.0, 0, true, 0.01));
  for (int i = 0; i < 20; ++i) poll_at(t0 + 24ms + std::chrono::milliseconds(4 * i));
  const auto r = rumble_uploads(*d);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].effect.replay.length, 40);  // ends by itself
  EXPECT_EQ(r[0].effect.u.rumble.strong_magnitude, 32767);
  int rumble_plays = 0;
  for (const auto& p : plays(*d)) rumble_plays += p.id == r[0].id;
  EXPECT_EQ(rumble_plays, 1);
  EXPECT_EQ(stats.ff.kicks.load(), 1u);
  EXPECT_GE(constant_uploads(*d).size(), 2u);
}

TEST_F(Engine, OnsetKicksEvenWhenItEndedBetweenPolls) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  poll_at(t0 + 12ms);
  board.publish(0, push(1.0, 0, true, 0.02));
  board.publish(0, push(0, 0));
  poll_at(t0 + 24ms);
  const auto ups = rumble_uploads(*d);
  ASSERT_EQ(ups.size(), 2u);
  EXPECT_EQ(ups[1].effect.u.rumble.strong_magnitude, 0xffff);
}

TEST_F(Engine, OnsetsBeforeAttachGiveNoKick) {
  board.publish(0, push(1.0, 0, true, 0.02));
  board.publish(0, push(0, 0));
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  for (int i = 0; i < 10; ++i) poll_at(t0 + std::chrono::milliseconds(12 * i));
  EXPECT_EQ(stats.ff.kicks.load(), 0u);
}

TEST_F(Engine, PerBusIntervalsAreNeverViolatedOverTenThousandPolls) {
  auto usb = pad("/dev/input/event1", {FF_RUMBLE, FF_GAIN}, 16, BUS_USB);
  auto bt = pad("/dev/input/event2", {FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 16, BUS_BLUETOOTH);
  auto virt = pad("/dev/input/event3", {FF_RUMBLE, FF_GAIN}, 16, BUS_VIRTUAL);
  settings.pacing.other = 7ms;
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{0, kPlane}});
  engine().attach(2, "/dev/input/event3", {{0, kPlane}});
  for (int i = 0; i < 10000; ++i) {
    const double f = 1.0 + std::sin(i * 0.05);
    board.publish(0, push(f, 0.3 * f, i % 97 == 0, 0.001 * (i % 5)));
    board.beat();
    if (i == 5000) engine().configure(settings);  // SIGHUP: FF_GAIN again, paced too
    poll_at(t0 + std::chrono::milliseconds(2 * i));  // polls faster than any interval
  }
  struct Case { const FakeDeviceState* d; std::chrono::milliseconds interval; };
  for (const Case& c : {Case{usb.get(), 10ms}, Case{bt.get(), 25ms}, Case{virt.get(), 7ms}}) {
    const auto r = reports(*c.d);
    ASSERT_GT(r.size(), 100u);
    for (std::size_t i = 1; i < r.size(); ++i)
      ASSERT_GE(r[i].at - r[i - 1].at, c.interval) << "report " << i << " at interval " << c.interval.count();
  }
  EXPECT_GT(stats.ff.kicks.load(), 100u);
  EXPECT_EQ(stats.ff.errors.load(), 0u);
}

// The floor holds between the writes the kernel receives, however long each
// write takes: every call to a device (uploads, plays, FF_GAIN, erases; the
// ones that failed too) starts at least the bus's interval after the previous
// one RETURNED. Writes take 3..7 ms here, polls come every 2 ms and off the
// grid, and everything that writes happens: attach → first upload → gain,
// kicks (a constant-force Bluetooth pad's upload, then its play), SIGHUP's
// gain, a hold and a stall (zeros first, woken for when due), a reconfigure
// that reopens every device, a re-attach on an occupied slot, EINVAL and
// ENOSPC fallbacks, and shutdown's erases.
TEST_F(Engine, PacingHoldsBetweenTheWritesTheKernelGetsWhenWritesAreSlow) {
  auto usb = pad("/dev/input/event1", {FF_RUMBLE, FF_GAIN}, 16, BUS_USB);
  auto bt = pad("/dev/input/event2", {FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 16, BUS_BLUETOOTH);
  auto virt = pad("/dev/input/event3", {FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 2, BUS_VIRTUAL);
  for (const auto& d : {usb, bt, virt}) d->cost = testing::CallCost{5ms, 4ms, 3ms, 2ms};
  usb->jitter_seed = 7;
  bt->jitter_seed = 11;
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{0, kPlane}});
  engine().attach(2, "/dev/input/event3", {{1, kPlane}});

  bool einval_done = false, enospc_done = false;
  Clock::time_point t = t0;
  for (int i = 0; i < 4000; ++i) {
    const double f = 0.8 + 0.7 * std::sin(i * 0.05);
    const bool onset = i % 37 == 0;
    board.publish(0, push(f, 0.3 * f, onset, 0.001 * (1 + i % 5)));
    board.publish(1, push(0.5 * f, -0.4 * f, onset, 0.002));
    const bool stalled = i >= 2000 && i < 2100;
    if (!stalled) board.beat();
    if (i == 1000) {
      settings.gain = 0x9000;
      engine().configure(settings);  // SIGHUP: FF_GAIN again
    }
    if (i == 1500) board.set_hold(Hold::paused);
    if (i == 1600) board.set_hold(Hold::none);
    if (i == 2500 || i == 2700) {
      settings.constant = i == 2700;
      engine().configure(settings);  // reopens every device: erases, then fresh uploads
    }
    if (i == 3000) engine().attach(1, "/dev/input/event2", {{0, kPlane}});  // again, still plugged in
    if (i == 3200 && engine().device(0)->rumble_id() >= 0) {
      usb->used[static_cast<std::size_t>(engine().device(0)->rumble_id())] = false;  // vanished: EINVAL
      einval_done = true;
    }
    if (i == 3300 && engine().device(2)->constant_id() >= 0 && engine().device(2)->rumble_id() >= 0) {
      // The constant's id vanishes and another client takes it: EINVAL, then
      // ENOSPC, so the kick's id is given up (erased) for the constant.
      virt->used[static_cast<std::size_t>(engine().device(2)->constant_id())] = false;
      virt->upload_errors = {0, ENOSPC};
      enospc_done = true;
    }
    // Every 2 ms, sometimes off the grid, and when a zero is due (the thread's wake-up).
    Clock::time_point next = t + (i % 7 == 3 ? 700us : 2ms);
    if (const auto due = engine().next_due(); due && *due > t && *due < next) next = *due;
    t = std::max(next, clock->now());
    poll_at(t);
  }
  engine().shutdown();
  ASSERT_TRUE(einval_done);
  ASSERT_TRUE(enospc_done);

  struct Case {
    const char* what;
    const FakeDeviceState* d;
    std::chrono::milliseconds floor;
  };
  for (const Case& c :
       {Case{"USB", usb.get(), 10ms}, Case{"Bluetooth", bt.get(), 25ms}, Case{"virtual", virt.get(), 10ms}}) {
    ASSERT_GT(c.d->calls.size(), 100u) << c.what;
    Clock::duration closest = Clock::duration::max();
    for (std::size_t i = 1; i < c.d->calls.size(); ++i) {
      const auto& prev = c.d->calls[i - 1];
      const auto& next = c.d->calls[i];
      ASSERT_NE(next.result, ENODEV);  // every call here reached the "driver"
      ASSERT_GE(next.at - prev.end, c.floor)
          << c.what << ": call " << i << " (kind " << next.kind << ") after kind " << prev.kind;
      closest = std::min(closest, next.at - prev.end);
    }
    std::printf("%-9s %4zu calls, closest %.2f ms end to start (floor %lld ms)\n", c.what, c.d->calls.size(),
                std::chrono::duration<double, std::milli>(closest).count(), static_cast<long long>(c.floor.count()));
  }
  // What the run went through, so the pairs above cover every kind of write.
  auto count = [](const FakeDeviceState& d, auto pred) { return std::count_if(d.calls.begin(), d.calls.end(), pred); };
  auto gain_writes = [&](const FakeDeviceState& d) {
    return count(d, [](const Call& c) { return c.kind == Call::write && c.id == FF_GAIN; });
  };
  for (const auto* d : {usb.get(), bt.get(), virt.get()}) {
    EXPECT_GE(gain_writes(*d), 3) << "at attach, on SIGHUP, after each reopen";
    EXPECT_GE(count(*d, [](const Call& c) { return c.kind == Call::erase; }), 2) << "reopen, re-attach, shutdown";
    EXPECT_EQ(d->live(), 0);
  }
  const auto bt_rumbles = rumble_uploads(*bt);
  ASSERT_GT(bt_rumbles.size(), 10u);
  int kick_plays = 0;
  for (const auto& p : plays(*bt)) kick_plays += p.id == bt_rumbles.back().id;
  EXPECT_GT(kick_plays, 10) << "a constant-force pad's kicks: an upload, then a play";
  EXPECT_GE(count(*usb, [](const Call& c) { return c.result == EINVAL; }), 1);
  EXPECT_GE(count(*virt, [](const Call& c) { return c.result == ENOSPC; }), 1);
  EXPECT_EQ(stats.stalls.load(), 1u);
  EXPECT_EQ(opens["/dev/input/event2"], 4) << "attach, two reopens, the re-attach";
  EXPECT_EQ(stats.ff.live_effects.load(), 0);
}

TEST_F(Engine, ReArmedWellBeforeTheReplayLengthRunsOut) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  board.publish(0, push(0.5, 0));
  for (int i = 0; i < 120 * 250; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));  // 120 s
  const auto p = plays(*d);
  ASSERT_GE(p.size(), 120u / 5);
  for (std::size_t i = 1; i < p.size(); ++i) {
    EXPECT_LT(p[i].at - p[i - 1].at, 20s) << "replayed before the 20 s replay length runs out";
    EXPECT_GE(p[i].at - p[i - 1].at, 5s) << "and not more often than needed";
  }
  EXPECT_GE(t0 + 120s - p.back().at, 0s);
  EXPECT_LT(t0 + 120s - p.back().at, 6s);
  for (const auto& u : rumble_uploads(*d)) EXPECT_LT(u.effect.replay.length, 65000);
}

TEST_F(Engine, GainAndLimitScaleEveryLevelKicksIncluded) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  auto c = pad("/dev/input/event2", {FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{0, kPlane}});
  engine().tune(0, {0.5, 0.3});
  engine().tune(1, {0.5, 0.3});
  EXPECT_EQ(engine().tuning(0), (DeviceTuning{0.5, 0.3}));
  EXPECT_DOUBLE_EQ(stats.slot_limit[0].load(), 0.3);
  for (int i = 0; i < 2000; ++i) {
    board.publish(0, push(0.002 * i, 0, i % 50 == 0, 0.02));
    poll_at(t0 + std::chrono::milliseconds(4 * i));
  }
  for (const auto& u : rumble_uploads(*d)) {
    EXPECT_LE(u.effect.u.rumble.strong_magnitude, 0.3 * 0xffff);
    EXPECT_LE(u.effect.u.rumble.weak_magnitude, 0.3 * 0xffff);
  }
  for (const auto& u : rumble_uploads(*c)) EXPECT_LE(u.effect.u.rumble.strong_magnitude, 0.3 * 0xffff);
  int top = 0;
  for (const auto& u : constant_uploads(*c)) top = std::max(top, int{u.effect.u.constant.level});
  EXPECT_LE(top, 0.3 * 0x7fff);
  EXPECT_GE(top, 0.29 * 0x7fff);
  EXPECT_GE(stats.ff.kicks.load(), 10u);
  // Gain alone scales: a kick of full strength at gain 0.5.
  engine().tune(0, {0.5, 1.0});
  board.publish(0, push(0.1, 0, true, 1.0));
  poll_at(t0 + 9000ms);
  EXPECT_EQ(rumble_uploads(*d).back().effect.u.rumble.strong_magnitude, 32767);
}

TEST_F(Engine, TuneRefusesBadValuesNamingTheField) {
  auto check = [&](DeviceTuning t, const char* field) {
    try {
      engine().tune(0, t);
      ADD_FAILURE() << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  check({std::nan(""), 1}, "gain");
  check({-0.1, 1}, "gain");
  check({1.1, 1}, "gain");
  check({1, std::nan("")}, "limit");
  check({1, -1}, "limit");
  check({1, 2}, "limit");
  EXPECT_THROW(engine().tune(HapticsStats::kSlots, {}), std::invalid_argument);
  EXPECT_EQ(engine().tuning(0), DeviceTuning{});
}

TEST_F(Engine, ConfigOverridesMatchByIdsOrNameRuntimeTuneWinsUntilConfigure) {
  settings.tuning = {0.9, 0.8};
  DeviceOverride by_ids;
  by_ids.match.vendor = 0x054c;
  by_ids.match.product = 0x0ce6;
  by_ids.tuning = {0.4, 0.5};
  DeviceOverride by_name;
  by_name.match.name = "event2";
  by_name.tuning = {0.7, 0.6};
  settings.devices = {by_ids, by_name};
  auto a = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  auto b = pad("/dev/input/event2", {FF_RUMBLE}, 16);
  auto c = pad("/dev/input/event3", {FF_RUMBLE}, 16);
  c->identity.vendor = 0x054c;
  c->identity.product = 0x0ce6;
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{0, kPlane}});
  engine().attach(2, "/dev/input/event3", {{0, kPlane}});
  EXPECT_EQ(engine().tuning(0), (DeviceTuning{0.9, 0.8}));
  EXPECT_EQ(engine().tuning(1), (DeviceTuning{0.7, 0.6}));
  EXPECT_EQ(engine().tuning(2), (DeviceTuning{0.4, 0.5}));
  engine().tune(2, {0.1, 0.1});
  engine().detach(2);
  EXPECT_EQ(engine().tuning(2), (DeviceTuning{0.1, 0.1})) << "kept for the slot across replug";
  engine().attach(2, "/dev/input/event3", {{0, kPlane}});
  EXPECT_EQ(engine().tuning(2), (DeviceTuning{0.1, 0.1}));
  engine().configure(settings);  // SIGHUP: the config rules again
  EXPECT_EQ(engine().tuning(2), (DeviceTuning{0.4, 0.5}));
  EXPECT_DOUBLE_EQ(stats.slot_gain[2].load(), 0.4);
}

// The worst case of the safety budget: a Bluetooth pad (25 ms pacing) that
// wrote just before the stall was detected.
TEST_F(Engine, StallZeroesEveryDeviceWithinFiftyMilliseconds) {
  std::vector<std::pair<int, std::string>> lines;
  auto bt = pad("/dev/input/event1", {FF_RUMBLE}, 16, BUS_BLUETOOTH);
  auto c = pad("/dev/input/event2", {FF_CONSTANT, FF_RUMBLE}, 16, BUS_BLUETOOTH);
  make_engine([&](int p, const std::string& m) { lines.emplace_back(p, m); });
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{0, kPlane}});
  std::chrono::milliseconds worst{0};
  Clock::time_point t = t0;
  for (int round = 0; round < 20; ++round) {
    // Sculpting with a changing force, a tick per millisecond, polled every 4 ms.
    for (int i = 0; i < 100 + round; ++i) {
      t += 1ms;
      board.publish(0, push(0.5 + 0.4 * std::sin(i * 0.3 + round), 0, i % 40 == 0, 0.01));
      board.beat();
      if (i % 4 == 0) poll_at(t);
    }
    const Clock::time_point last_beat = t;
    // The sim thread stalls; the board still says "pushing". Polled every
    // 4 ms, and when a zero waits for a pacer, when it is due (the thread's
    // wake-up).
    for (const Clock::time_point end = t + 100ms; t < end;) {
      Clock::time_point next = t + 4ms;
      if (const auto due = engine().next_due(); due && *due > t && *due < next) next = *due;
      t = next;
      poll_at(t);
    }
    for (const auto& d : {bt, c}) {
      Clock::time_point zero_at{};
      for (const auto& u : d->of(Call::upload))
        if (u.at > last_beat && zero_at == Clock::time_point{}) {
          const bool zero = u.effect.type == FF_CONSTANT ? u.effect.u.constant.level == 0
                                                         : (!u.effect.u.rumble.strong_magnitude &&
                                                            !u.effect.u.rumble.weak_magnitude);
          if (zero && (u.effect.type == FF_CONSTANT || d == bt)) zero_at = u.at;
        }
      ASSERT_NE(zero_at, Clock::time_point{}) << "round " << round;
      worst = std::max(worst, std::chrono::duration_cast<std::chrono::milliseconds>(zero_at - last_beat));
    }
    EXPECT_TRUE(engine().stalled());
  }
  EXPECT_LE(worst, 50ms);
  EXPECT_EQ(stats.stalls.load(), 20u);
  int warnings = 0;
  for (const auto& [p, m] : lines) warnings += p == 4 && m.find("stalled") != std::string::npos;
  EXPECT_EQ(warnings, 20) << "once per stall";
}

TEST_F(Engine, HoldZeroesAndDropsKicksReleaseRestores) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  board.publish(0, push(1.0, 0));
  for (int i = 0; i < 10; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
  ASSERT_TRUE(rumble_uploads(*d).back().effect.u.rumble.weak_magnitude);
  for (Hold h : {Hold::paused, Hold::swapping, Hold::stopped}) {
    board.set_hold(h);
    board.publish(0, push(1.0, 0, true, 0.02));  // an onset while held: no kick, ever
    const auto before = stats.ff.kicks.load();
    for (int i = 10; i < 30; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
    const auto last = rumble_uploads(*d).back();
    EXPECT_FALSE(last.effect.u.rumble.weak_magnitude || last.effect.u.rumble.strong_magnitude);
    EXPECT_EQ(stats.ff.kicks.load(), before);
    board.set_hold(Hold::none);
    for (int i = 30; i < 40; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
    EXPECT_TRUE(rumble_uploads(*d).back().effect.u.rumble.weak_magnitude);
    EXPECT_EQ(stats.ff.kicks.load(), before);
    t0 += 200ms;
  }
  EXPECT_EQ(stats.stalls.load(), 0u) << "a hold is not a stall";
}

TEST_F(Engine, BoottimeJumpReopensAndSendsANeutralState) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  auto boot = [&](Clock::time_point t, std::chrono::nanoseconds slept) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()) + 1000s + slept;
  };
  for (int i = 0; i < 10; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i), boot(t0 + std::chrono::milliseconds(4 * i), 0s));
  ASSERT_EQ(opens["/dev/input/event1"], 1);
  // 0.5 s of drift is no suspend.
  poll_at(t0 + 40ms, boot(t0 + 40ms, 500ms));
  EXPECT_EQ(opens["/dev/input/event1"], 1);
  const auto before = d->calls.size();
  const std::int16_t old_id = engine().device(0)->rumble_id();
  // Slept an hour: BOOTTIME jumped, MONOTONIC did not.
  poll_at(t0 + 44ms, boot(t0 + 44ms, 3600s));
  EXPECT_EQ(opens["/dev/input/event1"], 2);
  EXPECT_EQ(stats.resumes.load(), 1u);
  ASSERT_GT(d->calls.size(), before);
  EXPECT_EQ(d->calls[before].kind, Call::erase) << "the old effect erased first, paced like any write";
  EXPECT_EQ(d->calls[before].id, old_id);
  poll_at(t0 + 60ms);  // the fresh upload waits out the erase's interval
  ASSERT_GT(d->calls.size(), before + 1);
  const auto& neutral = d->calls[before + 1];
  EXPECT_EQ(neutral.kind, Call::upload);
  EXPECT_EQ(neutral.effect.id, -1);  // the driver may have lost everything: a fresh effect
  EXPECT_FALSE(neutral.effect.u.rumble.strong_magnitude || neutral.effect.u.rumble.weak_magnitude);
  EXPECT_EQ(d->live(), 1);
}

TEST_F(Engine, LogindResumeAndTheBoottimeJumpReopenOnce) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  const auto boot = [](Clock::time_point t, std::chrono::nanoseconds slept) {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()) + 1000s + slept;
  };
  poll_at(t0, boot(t0, 0s));
  clock->advance_to(t0 + 4ms);
  engine().resumed("logind PrepareForSleep");  // the signal came first
  EXPECT_EQ(opens["/dev/input/event1"], 2);
  poll_at(t0 + 8ms, boot(t0 + 8ms, 600s));  // the same resume, seen by BOOTTIME
  EXPECT_EQ(opens["/dev/input/event1"], 2);
  EXPECT_EQ(stats.resumes.load(), 1u);
  poll_at(t0 + 60s, boot(t0 + 60s, 1200s));  // a later suspend
  EXPECT_EQ(opens["/dev/input/event1"], 3);
  EXPECT_EQ(stats.resumes.load(), 2u);
  EXPECT_EQ(d->live(), 1);
}

TEST_F(Engine, FirstUploadEnodevIsRetriedUntilReadyWithoutError) {
  std::vector<std::pair<int, std::string>> lines;
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  make_engine([&](int p, const std::string& m) { lines.emplace_back(p, m); });
  d->upload_errors = {ENODEV, ENODEV, ENODEV, ENODEV, ENODEV};
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  for (int i = 0; i < 10; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
  const auto ups = d->of(Call::upload);
  ASSERT_GE(ups.size(), 6u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(ups[i].at, t0 + std::chrono::milliseconds(4 * i)) << "retried every poll";
  EXPECT_EQ(ups[5].result, 0);
  EXPECT_EQ(stats.ff.errors.load(), 0u);
  EXPECT_EQ(stats.first_uploads.load(), 1u);
  EXPECT_EQ(stats.first_upload_failures.load(), 0u);
  EXPECT_EQ(stats.not_ready_retries.load(), 5u);
  EXPECT_EQ(stats.slot_first_upload_ns[0].load(), std::chrono::nanoseconds(20ms).count());
  EXPECT_EQ(opens["/dev/input/event1"], 1);
  for (const auto& [p, m] : lines) EXPECT_NE(p, 4) << m;
  // Later, ENODEV is an unplug again.
  d->unplugged = true;
  board.publish(0, push(1.0, 0));
  for (int i = 10; i < 20; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
  EXPECT_TRUE(engine().device(0)->gone());
}

TEST_F(Engine, ANodeNeverReadyIsGivenUpAfterASecond) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 16);
  d->unplugged = true;
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  for (int i = 0; i < 300; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
  EXPECT_TRUE(engine().device(0) == nullptr || engine().device(0)->gone() || opens["/dev/input/event1"] > 1);
  EXPECT_EQ(stats.first_uploads.load(), 0u);
  EXPECT_GE(stats.not_ready_retries.load(), 240u);
  EXPECT_LE(stats.not_ready_retries.load(), 300u);
}

TEST_F(Engine, BustypeAndPacingComeFromTheDevice) {
  pad("/dev/input/event1", {FF_RUMBLE}, 16, BUS_BLUETOOTH);
  engine().attach(4, "/dev/input/event1", {{0, kPlane}});
  EXPECT_EQ(stats.slot_bustype[4].load(), BUS_BLUETOOTH);
  EXPECT_EQ(engine().device(4)->pacer().interval(), 25ms);
  engine().detach(4);
  EXPECT_EQ(stats.slot_bustype[4].load(), 0);
}

TEST_F(Engine, RumbleOnlyPadWithOneEffectGetsForceAndKicks) {
  auto d = pad("/dev/input/event1", {FF_RUMBLE}, 1);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  board.publish(0, push(1.0, 0, true, 0.01));
  for (int i = 1; i < 30; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
  EXPECT_GE(rumble_uploads(*d).size(), 3u);  // claim, kick, contact level
  EXPECT_EQ(stats.ff.kicks.load(), 1u);
  EXPECT_EQ(d->live(), 1);
  EXPECT_EQ(stats.ff.errors.load(), 0u);
}

TEST_F(Engine, OneEffectConstantDeviceKeepsTheConstant) {
  auto d = pad("/dev/input/event1", {FF_CONSTANT, FF_RUMBLE}, 1);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  board.publish(0, push(1.0, 0, true, 0.01));
  for (int i = 0; i < 20; ++i) poll_at(t0 + std::chrono::milliseconds(4 * i));
  EXPECT_FALSE(constant_uploads(*d).empty());
  EXPECT_TRUE(rumble_uploads(*d).empty());
  EXPECT_EQ(stats.ff.errors.load(), 0u);
}

TEST_F(Engine, NoFfDeviceIsInputOnlyAndNotKeptOpen) {
  auto pad = devices["/dev/input/event1"] = fake_device({}, 0);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  EXPECT_EQ(stats.devices.load(), 1);
  EXPECT_EQ(stats.ff_devices.load(), 0);
  EXPECT_TRUE(pad->calls.empty());
  EXPECT_TRUE(pad->closed);
  EXPECT_EQ(engine().device(0), nullptr);
}

TEST_F(Engine, OpenFailureIsCountedNotThrown) {
  engine().attach(0, "/dev/input/missing", {{0, kPlane}});
  poll_at(t0);
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
  EXPECT_EQ(lines[0].second, "/dev/input/event1: rumble force, 1 effect slot, bus 0x00 paced 10 ms");
  EXPECT_EQ(lines[1].first, 4);
  EXPECT_EQ(lines[1].second, "no force feedback on /dev/input/missing: cannot open /dev/input/missing");
}

TEST_F(Engine, WithoutASinkMessagesArePlainTextWithoutThePriorityPrefix) {
  // stderr may be a terminal: "<4>" is the journal's business (sculptd's log decides).
  ::testing::internal::CaptureStderr();
  engine().attach(1, "/dev/input/missing", {{1, kPlane}});
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(err, "haptics: warning: no force feedback on /dev/input/missing: cannot open /dev/input/missing\n");
}

TEST_F(Engine, UnplugForgetsIdsReplugUploadsAgain) {
  auto first = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  engine().attach(3, "/dev/input/event1", {{0, kPlane}});
  board.publish(0, push(1.0, 0));
  poll_at(t0);
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
  poll_at(t0 + 4ms);  // inside the old interval: a new device is not paced by the old one
  const auto ups = constant_uploads(*second);
  ASSERT_EQ(ups.size(), 1u);
  EXPECT_EQ(stats.slot_uploads[3].load(), 2u) << "the slot counts both devices' uploads";
  EXPECT_EQ(stats.slot_uploads[0].load(), 0u);
  EXPECT_EQ(ups[0].effect.id, -1);
  EXPECT_EQ(ups[0].effect.u.constant.level, static_cast<int>(0.55 * 32767));
  EXPECT_EQ(stats.ff.live_effects.load(), 1);
}

TEST_F(Engine, UnplugSeenByAnIoctlFirstStopsTraffic) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  pad->unplugged = true;
  board.publish(0, push(1.0, 0));
  poll_at(t0 + 30ms);  // ENODEV
  const auto n = pad->calls.size();
  board.publish(0, push(-1.0, 0));
  poll_at(t0 + 60ms);
  EXPECT_EQ(pad->calls.size(), n);
  engine().detach(0);
  EXPECT_EQ(stats.ff.live_effects.load(), 0);
}

TEST_F(Engine, EnodevWithoutAnUnplugReopensTheDevice) {
  // A transport blip after the device worked: no detach follows, so the
  // engine reopens it.
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  pad->upload_errors = {ENODEV};
  board.publish(0, push(1.0, 0));
  poll_at(t0 + 20ms);  // the play (a write) goes first
  poll_at(t0 + 40ms);  // ENODEV
  ASSERT_EQ(pad->of(Call::upload).size(), 2u);
  EXPECT_EQ(pad->of(Call::upload)[1].result, ENODEV);
  poll_at(t0 + 100ms);
  poll_at(t0 + 300ms);  // < 250 ms since ENODEV was first seen at 100 ms
  EXPECT_EQ(opens["/dev/input/event1"], 1);
  poll_at(t0 + 360ms);
  EXPECT_EQ(opens["/dev/input/event1"], 2);
  const auto ups = constant_uploads(*pad);
  ASSERT_EQ(ups.size(), 3u);
  EXPECT_EQ(ups[2].effect.id, -1);
  EXPECT_EQ(ups[2].result, 0);
  EXPECT_EQ(stats.ff_devices.load(), 1);
  EXPECT_EQ(stats.ff.live_effects.load(), 1);
}

TEST_F(Engine, AReallyDeadNodeIsReopenedOnlyAFewTimes) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  pad->unplugged = true;
  for (int i = 0; i < 400; ++i) {
    board.publish(0, push(i % 2 ? 1.0 : -1.0, 0));
    poll_at(t0 + std::chrono::milliseconds(100 * i));
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
  poll_at(t0);
  const auto ups = constant_uploads(*pad);
  ASSERT_EQ(ups.size(), 1u);
  EXPECT_EQ(ups[0].effect.u.constant.level, static_cast<int>(0.55 * 32767));  // 1 N of 2
  EXPECT_EQ(ups[0].effect.direction, 0x4000);
}

TEST_F(Engine, ShutdownStopsAndErasesEveryDevice) {
  auto a = devices["/dev/input/event1"] = fake_device({FF_CONSTANT, FF_RUMBLE}, 16);
  auto b = devices["/dev/input/event2"] = fake_device({FF_RUMBLE}, 4);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  engine().attach(1, "/dev/input/event2", {{1, kPlane}});
  poll_at(t0);
  board.publish(0, push(1.0, 0, true, 0.01));
  board.publish(1, push(1.0, 0, true, 0.01));
  for (int i = 1; i < 20; ++i) poll_at(t0 + std::chrono::milliseconds(12 * i));
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
  poll_at(t0);  // the constant's id first
  EXPECT_TRUE(pad->of(Call::write).empty());
  poll_at(t0 + 10ms);  // then FF_GAIN: a write like any other, paced
  ASSERT_EQ(pad->of(Call::write).size(), 1u);
  EXPECT_EQ(pad->of(Call::write)[0].id, FF_GAIN);
  HapticsSettings s = settings;
  s.gain = 0x2000;
  s.pacing.other = 100ms;
  engine().configure(s);
  auto gain_written = [&] {
    for (const auto& w : pad->of(Call::write))
      if (w.id == FF_GAIN && w.value == 0x2000) return true;
    return false;
  };
  EXPECT_FALSE(gain_written()) << "paced: not inside the interval";
  poll_at(t0 + 50ms);
  EXPECT_FALSE(gain_written()) << "100 ms now";
  poll_at(t0 + 110ms);
  EXPECT_TRUE(gain_written());
  poll_at(t0 + 150ms);
  EXPECT_EQ(plays(*pad).size(), 0u);
  poll_at(t0 + 210ms);
  EXPECT_EQ(plays(*pad).size(), 1u);
}

TEST_F(Engine, DisablingHapticsErasesAndClosesDevices) {
  auto pad = devices["/dev/input/event1"] = fake_device({FF_CONSTANT}, 16);
  engine().attach(0, "/dev/input/event1", {{0, kPlane}});
  poll_at(t0);
  HapticsSettings s = settings;
  s.enabled = false;
  engine().configure(s);
  EXPECT_EQ(pad->live(), 0);
  EXPECT_TRUE(pad->closed);
  EXPECT_EQ(stats.ff_devices.load(), 0);
  s.enabled = true;
  engine().configure(s);
  const auto erased_at = pad->of(Call::erase).back().end;
  poll_at(erased_at + 9ms);  // a reopened device keeps its pacer: the erase was a write
  EXPECT_EQ(pad->live(), 0);
  poll_at(erased_at + 10ms);
  EXPECT_EQ(pad->live(), 1);
  EXPECT_EQ(opens["/dev/input/event1"], 2);
}

}  // namespace
}  // namespace sculpt::haptics
