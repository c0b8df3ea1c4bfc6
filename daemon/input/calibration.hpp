// Raw axis value → -1..1 (or 0..1 for a trigger), from the kernel's absinfo
// (min/max/flat/fuzz) and a configured dead zone. POD: it travels in the
// attach message to the simulation thread, which applies it per event.
#pragma once

#include <cstdint>

#include "input/device_info.hpp"

namespace sculpt::input {

struct AxisCalibration {
  std::int32_t minimum = -1;
  std::int32_t maximum = 1;
  std::int32_t flat = 0;       // kernel's dead band around the centre (raw units)
  std::int32_t fuzz = 0;       // the kernel's noise filter (informative: evdev already applied it)
  float dead_zone = 0.0f;      // configured dead zone, fraction of the half range (0..<1)
  bool unipolar = false;       // trigger/throttle pedal: min..max → 0..1, dead zone at min

  // The normalised value: bipolar -1..1 around the centre of min..max, or
  // unipolar 0..1; the larger of flat and the dead zone reads as 0 and the
  // rest is rescaled so full deflection still reads ±1. Out-of-range raw
  // values clamp. A degenerate range (max <= min) always reads 0.
  float normalize(std::int32_t raw) const;

  // Kernel-style fuzz test: whether `raw` is a real move away from `last`
  // (for tools that read raw values; evdev clients get defuzzed ones).
  bool moved(std::int32_t last, std::int32_t raw) const;
};

// From an axis's absinfo plus the dead zone configured for it.
AxisCalibration calibrate(const AxisInfo& axis, float dead_zone, bool unipolar);

}  // namespace sculpt::input
