// Transport pacing. Pad firmware gets stuck or crashes when rumble reports
// come faster than ~10 ms apart over USB or 20–50 ms over Bluetooth, and any
// write that makes the driver send a report counts: uploads and plays of
// every effect of the device. So each device has one WritePacer, and every
// write to it waits for it. Pure decisions with the time passed in.
#pragma once

#include <chrono>
#include <cstdint>

namespace sculpt::haptics {

using Clock = std::chrono::steady_clock;

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
  void wrote(Clock::time_point now) {
    has_written_ = true;
    last_at_ = now;
  }
  // When the next write may go out (now when ready).
  Clock::time_point next_at(Clock::time_point now) const { return ready(now) ? now : last_at_ + interval_; }
  void set_interval(std::chrono::nanoseconds interval) { interval_ = interval; }
  std::chrono::nanoseconds interval() const { return interval_; }

 private:
  std::chrono::nanoseconds interval_;
  bool has_written_ = false;
  Clock::time_point last_at_{};
};

}  // namespace sculpt::haptics
