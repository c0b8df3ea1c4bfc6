// When to talk to a device. The kernel does not pace FF uploads (the USB
// transport does, by coalescing): send only on a real change, and no more
// often than a per-device interval. Pure decisions with the time passed in:
// unit-tested without clocks.
#pragma once

#include <chrono>
#include <cstdint>

#include "haptics/effect_math.hpp"

namespace sculpt::haptics {

using Clock = std::chrono::steady_clock;

class ConstantPacer {
 public:
  ConstantPacer(std::chrono::nanoseconds min_interval, ChangeThreshold threshold)
      : interval_(min_interval), threshold_(threshold) {}

  // Send `want` now? The first command is sent at once (the device needs its
  // effect), later ones only when they differ really from what was last sent
  // and the interval since that send has passed. A change that has to wait is
  // not lost: it is compared again at the next poll.
  bool should_send(const ConstantCommand& want, Clock::time_point now) const;
  void sent(const ConstantCommand& c, Clock::time_point now);
  // The upload failed: try again (even unchanged) once the interval has passed.
  void failed(Clock::time_point now);
  // The device was replugged or its effect vanished: next command goes out.
  void reset() { has_sent_ = false; }

  const ConstantCommand& last_sent() const { return last_; }
  void set_interval(std::chrono::nanoseconds interval) { interval_ = interval; }
  void set_threshold(ChangeThreshold t) { threshold_ = t; }

 private:
  std::chrono::nanoseconds interval_;
  ChangeThreshold threshold_;
  bool has_sent_ = false;
  bool retry_ = false;
  ConstantCommand last_{};
  Clock::time_point last_at_{};
};

// Onset kicks, per device: an onset on any of its tools asks for one kick,
// but no more often than the interval; onsets that arrive inside it merge into
// the next kick (the largest impulse wins) instead of being dropped.
class KickPacer {
 public:
  explicit KickPacer(std::chrono::nanoseconds min_interval) : interval_(min_interval) {}

  void onset(double impulse);
  bool due(Clock::time_point now) const;
  double pending_impulse() const { return pending_impulse_; }
  void kicked(Clock::time_point now);
  void set_interval(std::chrono::nanoseconds interval) { interval_ = interval; }

 private:
  std::chrono::nanoseconds interval_;
  bool pending_ = false;
  double pending_impulse_ = 0;
  bool has_kicked_ = false;
  Clock::time_point last_at_{};
};

}  // namespace sculpt::haptics
