// Per-device gain and hard limit on every level a device gets (force and
// kicks). A limit protects the user: no level, kicks included, goes above it.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

namespace sculpt::haptics {

struct DeviceTuning {
  double gain = 1.0;   // 0..1: scales every level this device gets (force and kicks)
  double limit = 1.0;  // 0..1 of the motor's full level: never exceeded, kicks included
  friend bool operator==(const DeviceTuning&, const DeviceTuning&) = default;
};

// Throws std::invalid_argument naming the field for NaN, < 0 or > 1.
inline void check_tuning(const DeviceTuning& t) {
  auto check = [](double v, const char* field) {
    if (!std::isfinite(v) || v < 0.0 || v > 1.0)
      throw std::invalid_argument(std::string(field) + " must be within [0, 1], not " + std::to_string(v));
  };
  check(t.gain, "gain");
  check(t.limit, "limit");
}

}  // namespace sculpt::haptics
