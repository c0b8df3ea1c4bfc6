// Shared by the uhid VM tests: the pads as gtest parameters, and the motor
// bytes each driver makes of an FF_RUMBLE magnitude.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

#include "support/uhid_pad.hpp"

namespace sculpt::support::uhidtest {

// What the driver writes for a (gain-scaled) FF_RUMBLE magnitude:
// hid-playstation and hid-sony take the high byte (magnitude / 256),
// hid-microsoft scales to 0..100 (magnitude * 100 / 0xffff).
inline std::uint8_t motor_byte(const UhidPadSpec& spec, std::uint16_t magnitude) {
  if (spec.motor_max == 100) return static_cast<std::uint8_t>(std::uint32_t{magnitude} * 100 / 0xffff);
  return static_cast<std::uint8_t>(magnitude / 256);
}

// The gtest name of a pad parameter: the module without ".ko", '_' for '-'.
struct PadName {
  template <class Info>
  std::string operator()(const Info& info) const {
    std::string n = info.param->module.substr(0, info.param->module.find('.'));
    std::replace(n.begin(), n.end(), '-', '_');
    return n;
  }
};

}  // namespace sculpt::support::uhidtest
