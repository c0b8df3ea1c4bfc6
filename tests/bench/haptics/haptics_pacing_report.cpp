// Prints what the transport pacing and the stall guard do in real time: the
// real HapticsThread drives fake USB, Bluetooth and virtual-bus pads through
// a simulated sculpt whose force changes every 1 ms tick with an onset every
// 300 ms, then the sim thread stalls repeatedly.
//
// Every call the kernel would receive is recorded (uploads, plays, stops,
// FF_GAIN, erases) with the time it started and the time it returned; each
// call can be made to take `write_ms` (a uinput pad's process answering, a
// driver's transport). The interval a pad is promised is the one between the
// kernel's writes: from one call's return to the next call's start. Printed
// per device: the minimum, p50 and p99 of those intervals against the bus's
// floor, and the time from the sim thread's last beat to the return of the
// zero write.
//
//   build/tests/bench/haptics/haptics_pacing_report [seconds=10] [stalls=20] [write_ms=0]
#include <linux/input.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fake_port.hpp"
#include "haptics/haptics_thread.hpp"

using namespace std::chrono_literals;
using namespace sculpt::haptics;
using Clock = std::chrono::steady_clock;

namespace {

struct Write {
  Clock::time_point start;
  Clock::time_point end;
  bool zero;  // an upload that zeroes the main effect
};

// The fake device on the real clock, each call taking `cost` (slept), and a
// log readable while the thread runs.
class TimedPort final : public FfPort {
 public:
  TimedPort(std::shared_ptr<testing::FakeDeviceState> s, std::string node, Clock::duration cost, std::mutex& m,
            std::vector<Write>& log)
      : inner_(std::move(s), std::move(node)), cost_(cost), m_(m), log_(log) {}
  FfCaps caps() override { return inner_.caps(); }
  DeviceIdentity identity() override { return inner_.identity(); }
  int upload(ff_effect& e) override {
    const bool zero = e.type == FF_CONSTANT ? e.u.constant.level == 0
                                            : (!e.u.rumble.strong_magnitude && !e.u.rumble.weak_magnitude);
    const bool kick = e.type == FF_RUMBLE && e.replay.length < 1000;  // a constant device's own kick effect
    return timed(!kick && zero, [&] { return inner_.upload(e); });
  }
  int erase(std::int16_t id) override {
    return timed(false, [&] { return inner_.erase(id); });
  }
  int write_ff(std::uint16_t code, std::int32_t value) override {
    return timed(false, [&] { return inner_.write_ff(code, value); });
  }
  const std::string& node() const override { return inner_.node(); }

 private:
  template <class Call>
  int timed(bool zero, Call call) {
    const auto start = Clock::now();
    const int r = call();
    if (cost_.count() > 0) std::this_thread::sleep_for(cost_);
    const auto end = Clock::now();
    std::lock_guard lock(m_);
    log_.push_back({start, end, zero});
    return r;
  }
  testing::FakePort inner_;
  Clock::duration cost_;
  std::mutex& m_;
  std::vector<Write>& log_;
};

double ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

Felt pressing(double f, bool onset) {
  Felt felt;
  felt.force = {f, 0, 0.3 * f};
  felt.contacts = 3;
  felt.touching = true;
  felt.onset = onset;
  felt.onset_impulse = onset ? 0.001 : 0;
  return felt;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const int stalls = argc > 2 ? std::atoi(argv[2]) : 20;
  const double write_ms = argc > 3 ? std::atof(argv[3]) : 0.0;
  if (!(seconds > 0) || stalls < 0 || !(write_ms >= 0)) {
    std::fprintf(stderr, "usage: %s [seconds > 0] [stalls >= 0] [write_ms >= 0]\n", argv[0]);
    return 2;
  }
  const auto cost = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(write_ms));
  struct Pad {
    std::string node;
    std::uint16_t bus;
    bool constant;
    const char* what;
  };
  const std::vector<Pad> pads = {{"/dev/input/usb", BUS_USB, false, "USB rumble pad"},
                                 {"/dev/input/bt", BUS_BLUETOOTH, false, "Bluetooth rumble pad"},
                                 {"/dev/input/btc", BUS_BLUETOOTH, true, "Bluetooth constant"},
                                 {"/dev/input/virt", BUS_VIRTUAL, true, "virtual (uinput)"}};
  std::mutex m;
  std::map<std::string, std::vector<Write>> logs;
  std::map<std::string, std::shared_ptr<testing::FakeDeviceState>> states;
  for (const auto& p : pads) {
    auto s = p.constant ? testing::fake_device({FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 16)
                        : testing::fake_device({FF_RUMBLE, FF_GAIN}, 16);
    s->identity.bustype = p.bus;
    states[p.node] = s;
    logs[p.node];
  }
  FeedbackBoard board(1);
  HapticsSettings settings;  // the defaults: 4 ms polls, 10/25/10 ms pacing, 15 ms stall
  HapticsThread thread(board, settings, [&](const std::string& node) -> std::unique_ptr<FfPort> {
    return std::make_unique<TimedPort>(states.at(node), node, cost, m, logs.at(node));
  });
  thread.start();
  for (std::size_t i = 0; i < pads.size(); ++i) thread.attach(static_cast<int>(i), pads[i].node, {{0, StickPlane{}}});

  // The sculpt: a 1 kHz sim thread, the force swinging 0.05..1.2 N.
  auto tick_for = [&](Clock::duration d, int& tick) {
    const auto end = Clock::now() + d;
    auto next = Clock::now();
    while (Clock::now() < end) {
      const double f = 0.625 + 0.575 * std::sin(tick * 0.004);
      board.publish(0, pressing(f, tick % 300 == 0));
      board.beat();
      ++tick;
      next += 1ms;
      std::this_thread::sleep_until(next);
    }
  };
  int tick = 0;
  tick_for(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds)), tick);

  // Stalls: the sim thread stops beating while the board says "pressing".
  std::map<std::string, std::vector<double>> to_zero;
  for (int s = 0; s < stalls; ++s) {
    tick_for(150ms + std::chrono::milliseconds(7 * s), tick);
    const Clock::time_point last_beat = Clock::now();
    std::this_thread::sleep_for(120ms);
    std::lock_guard lock(m);
    for (const auto& p : pads)
      for (const auto& w : logs[p.node])
        if (w.start > last_beat && w.zero) {
          to_zero[p.node].push_back(ms(w.end - last_beat));
          break;
        }
  }
  thread.stop();  // shutdown's erases are writes too

  std::printf(
      "kernel-side intervals (one write's return to the next one's start, every upload, play, stop,\n"
      "FF_GAIN and erase) over a %.0f s sculpt (force changing every 1 ms tick, an onset every 300 ms),\n"
      "%d stalls and shutdown; each write taking %.1f ms:\n",
      seconds, stalls, write_ms);
  std::printf("%-22s %8s %9s %9s %9s %9s %7s\n", "device", "writes", "min ms", "p50 ms", "p99 ms", "floor ms", "short");
  for (const auto& p : pads) {
    const auto floor = interval_for_bus(p.bus, settings.pacing);
    std::vector<double> gaps;
    int short_gaps = 0;
    const auto& l = logs[p.node];  // the thread has stopped: no lock needed
    for (std::size_t i = 1; i < l.size(); ++i) {
      gaps.push_back(ms(l[i].start - l[i - 1].end));
      short_gaps += l[i].start - l[i - 1].end < floor;
    }
    std::printf("%-22s %8zu %9.2f %9.2f %9.2f %9lld %7d\n", p.what, l.size(),
                gaps.empty() ? 0 : *std::min_element(gaps.begin(), gaps.end()), percentile(gaps, 0.5),
                percentile(gaps, 0.99), static_cast<long long>(floor.count()), short_gaps);
  }
  std::printf("\nstall to zero (last beat to the zero write's return; %d stalls; budget: docs/haptics.md):\n", stalls);
  std::printf("%-22s %8s %9s %9s\n", "device", "zeroed", "p50 ms", "max ms");
  for (const auto& p : pads) {
    const auto& v = to_zero[p.node];
    std::printf("%-22s %8zu %9.2f %9.2f\n", p.what, v.size(), percentile(v, 0.5),
                v.empty() ? 0 : *std::max_element(v.begin(), v.end()));
  }
  std::printf("stalls seen by the engine: %llu\n", static_cast<unsigned long long>(thread.stats().stalls.load()));
  return 0;
}
