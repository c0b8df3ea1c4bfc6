#include "haptics/pacer.hpp"

#include <linux/input.h>

#include <thread>

namespace sculpt::haptics {

namespace {
class SteadyTime final : public TimeSource {
 public:
  Clock::time_point now() override { return Clock::now(); }
  void sleep_until(Clock::time_point t) override { std::this_thread::sleep_until(t); }
};
}  // namespace

TimeSource& steady_time() {
  static SteadyTime time;
  return time;
}

std::chrono::milliseconds interval_for_bus(std::uint16_t bustype, const TransportPacing& pacing) {
  switch (bustype) {
    case BUS_USB: return pacing.usb;
    case BUS_BLUETOOTH: return pacing.bluetooth;
    default: return pacing.other;
  }
}

}  // namespace sculpt::haptics
