// Transport pacing. Pad firmware gets stuck or crashes when reports come
// faster than ~10 ms apart over USB or 20–50 ms over Bluetooth, and every
// write that reaches the driver counts: uploads, plays, stops, FF_GAIN and
// erases of every effect of the device, and on a DualSense the trigger
// reports on its hidraw node too (one firmware). So each device has one
// WritePacer, shared by every writer to it; each write waits for it and
// stamps it with the time the write RETURNED, so the interval holds between
// the writes the kernel receives however long a write takes or the thread is
// delayed. Pure decisions with the time passed in; TimeSource is the clock.
#pragma once

#include <chrono>
#include <cstdint>

namespace sculpt::haptics {

using Clock = std::chrono::steady_clock;

// Where the haptics code reads the time and waits: the real clock, or a
// test's clock that only moves when told (and when waited on).
class TimeSource {
 public:
  virtual ~TimeSource() = default;
  virtual Clock::time_point now() = 0;
  virtual void sleep_until(Clock::time_point t) = 0;
};
// steady_clock and std::this_thread::sleep_until.
TimeSource& steady_time();

// The minimum time between two writes, per transport (input_id.bustype).
struct TransportPacing {
  std::chrono::milliseconds usb{10};        // BUS_USB
  std::chrono::milliseconds bluetooth{25};  // BUS_BLUETOOTH
  std::chrono::milliseconds other{10};      // anything else (uinput's BUS_VIRTUAL, unknown = 0, ...)
};
std::chrono::milliseconds interval_for_bus(std::uint16_t bustype, const TransportPacing& pacing);

class WritePacer {
 public:
  explicit WritePacer(std::chrono::nanoseconds interval) : interval_(interval) {}
  // Whether a write may go out now: the first at once, then interval apart.
  bool ready(Clock::time_point now) const { return !has_written_ || now - last_at_ >= interval_; }
  // A write returned at `now` (the time taken after the call, not before).
  void wrote(Clock::time_point now) {
    has_written_ = true;
    last_at_ = now;
    ++writes_;
  }
  // When the next write may go out (now when ready).
  Clock::time_point next_at(Clock::time_point now) const { return ready(now) ? now : last_at_ + interval_; }
  // Waits on `time` until a write may go out.
  void wait(TimeSource& time) const {
    if (const auto now = time.now(); !ready(now)) time.sleep_until(next_at(now));
  }
  void set_interval(std::chrono::nanoseconds interval) { interval_ = interval; }
  std::chrono::nanoseconds interval() const { return interval_; }
  // Writes stamped so far (every writer's): a writer that remembers the count
  // after its own write knows whether it wrote last.
  std::uint64_t writes() const { return writes_; }

 private:
  std::chrono::nanoseconds interval_;
  bool has_written_ = false;
  Clock::time_point last_at_{};
  std::uint64_t writes_ = 0;
};

}  // namespace sculpt::haptics
