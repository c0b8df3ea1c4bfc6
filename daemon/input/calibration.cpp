#include "input/calibration.hpp"

#include <algorithm>
#include <cmath>

namespace sculpt::input {

float AxisCalibration::normalize(std::int32_t raw) const {
  if (maximum <= minimum) return 0.0f;
  const double lo = minimum, hi = maximum;
  const double v = std::clamp<double>(raw, lo, hi);
  double x, range;
  if (unipolar) {
    range = hi - lo;
    x = (v - lo) / range;                       // 0..1
  } else {
    range = (hi - lo) / 2.0;
    x = (v - (lo + hi) / 2.0) / range;          // -1..1
  }
  // The kernel's flat is in raw units of the (half) range; the configured
  // dead zone is a fraction. Take the larger, keep it below full deflection.
  const double dead = std::clamp(std::max<double>(flat / range, dead_zone), 0.0, 0.95);
  const double mag = std::fabs(x);
  if (mag <= dead) return 0.0f;
  const double out = (mag - dead) / (1.0 - dead);
  return static_cast<float>(std::copysign(std::min(out, 1.0), x));
}

bool AxisCalibration::moved(std::int32_t last, std::int32_t raw) const {
  if (fuzz <= 0) return raw != last;
  // As the kernel's input_defuzz_abs_event at its finest level: changes
  // within half the fuzz are noise.
  const std::int64_t d = static_cast<std::int64_t>(raw) - last;
  return d > fuzz / 2 || d < -(fuzz / 2);
}

AxisCalibration calibrate(const AxisInfo& axis, float dead_zone, bool unipolar) {
  AxisCalibration c;
  c.minimum = axis.minimum;
  c.maximum = axis.maximum;
  c.flat = std::max(0, axis.flat);
  c.fuzz = std::max(0, axis.fuzz);
  c.dead_zone = std::clamp(dead_zone, 0.0f, 0.95f);
  c.unipolar = unipolar;
  return c;
}

}  // namespace sculpt::input
