// `--input-clock device`: a live frame applies on the tick its device time
// says, not on the tick it arrived. Each device's clock is anchored at its
// first frame (that frame applies `delay` after the current tick); later
// frames keep their recorded spacing, rounded exactly as ReplaySource
// rounds, so a recording replayed through uinput lands on the ticks
// `--input replay:` gives it. Ticks never go backwards per device.
#pragma once

#include <array>
#include <cstdint>

#include "input/input_message.hpp"

namespace sculpt::input {

class DeviceClock {
 public:
  DeviceClock(double rate_hz, double delay_ms) : rate_hz_(rate_hz), delay_ms_(delay_ms) {}

  void set_rate(double rate_hz) { rate_hz_ = rate_hz; }
  void set_delay_ms(double delay_ms) { delay_ms_ = delay_ms; }

  struct Placement {
    std::uint64_t tick = 0;  // 0: no device time, apply in order after what is queued
    bool anchored = false;   // this frame anchored its device's clock
  };
  // Where `frame` applies, `now_tick` being the simulation's current tick.
  Placement place(const InputFrame& frame, std::uint64_t now_tick);
  // The device on `slot` came or went: its next frame anchors anew.
  void forget(std::uint8_t slot) { anchors_[slot % anchors_.size()] = Anchor{}; }

 private:
  struct Anchor {
    bool valid = false;
    std::int64_t base = 0;  // tick of device time 0
    std::int64_t last = 0;  // ticks stay in order
  };

  double rate_hz_;
  double delay_ms_;
  std::array<Anchor, kMaxDevices> anchors_{};
};

}  // namespace sculpt::input
