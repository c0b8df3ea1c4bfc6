#include "haptics/pacer.hpp"

#include <linux/input.h>

namespace sculpt::haptics {

std::chrono::milliseconds interval_for_bus(std::uint16_t bustype, const TransportPacing& pacing) {
  switch (bustype) {
    case BUS_USB: return pacing.usb;
    case BUS_BLUETOOTH: return pacing.bluetooth;
    default: return pacing.other;
  }
}

}  // namespace sculpt::haptics
