#include "haptics/effect_math.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>

namespace sculpt::haptics {

namespace {
double component(const std::array<double, 3>& f, int axis) {
  return axis >= 0 && axis < 3 ? f[static_cast<std::size_t>(axis)] : 0.0;
}
}  // namespace

StickForce project_to_stick(const std::array<double, 3>& tool_force, const StickPlane& plane) {
  StickForce out{plane.x_sign * component(tool_force, plane.x_axis),
                 plane.y_sign * component(tool_force, plane.y_axis)};
  if (!std::isfinite(out.x) || !std::isfinite(out.y)) return {};
  return out;
}

double level_from_force(double newton, bool touching, const ForceScale& scale) {
  if (!touching || !std::isfinite(newton) || !(scale.full_scale_newton > 0)) return 0.0;
  const double floor = std::clamp(scale.min_level, 0.0, 1.0);
  const double exponent = scale.exponent > 0 ? scale.exponent : 1.0;
  const double x = std::clamp(newton / scale.full_scale_newton, 0.0, 1.0);
  return floor + (1.0 - floor) * std::pow(x, exponent);
}

double tuned(double level, const DeviceTuning& tuning) {
  if (!std::isfinite(level)) return 0.0;
  const double gain = std::isfinite(tuning.gain) ? std::clamp(tuning.gain, 0.0, 1.0) : 0.0;
  const double limit = std::isfinite(tuning.limit) ? std::clamp(tuning.limit, 0.0, 1.0) : 0.0;
  return std::min(std::clamp(level, 0.0, 1.0) * gain, limit);
}

ConstantCommand constant_from_level(StickForce f, double level) {
  const double magnitude = std::hypot(f.x, f.y);
  if (!std::isfinite(magnitude) || magnitude <= 0 || !(level > 0)) return {};
  // Rounded down so that a limit is never exceeded by rounding.
  const double units = std::floor(std::min(level, 1.0) * 32767.0);
  if (units <= 0) return {};
  // θ = atan2(fx, −fy) in (−π, π]: the side the force comes from, see the header.
  double turns = std::atan2(f.x, -f.y) / (2 * std::numbers::pi);
  if (turns < 0) turns += 1.0;
  const auto dir = static_cast<long>(std::lround(turns * 65536.0)) % 65536;
  return ConstantCommand{static_cast<std::int16_t>(units), static_cast<std::uint16_t>(dir)};
}

namespace {
std::uint16_t motor(double level) {
  return static_cast<std::uint16_t>(std::floor(std::clamp(level, 0.0, 1.0) * 65535.0));
}
}  // namespace

RumbleCommand rumble_from_level(double level, const RumbleScale& scale) {
  if (!(level > 0)) return {};
  RumbleCommand r;
  r.weak = std::max<std::uint16_t>(1, motor(level));
  r.strong = motor(level * std::clamp(scale.contact_strong_ratio, 0.0, 1.0));
  return r;
}

StickForce force_from_constant(const ConstantCommand& c) {
  const double theta = c.direction / 65536.0 * 2 * std::numbers::pi;
  return StickForce{c.level * std::sin(theta), -c.level * std::cos(theta)};
}

RumbleCommand rumble_from_impulse(double impulse, const RumbleScale& scale, const DeviceTuning& tuning) {
  if (!std::isfinite(impulse) || impulse < scale.min_impulse || impulse <= 0 || !(scale.full_scale_impulse > 0))
    return {};
  const double floor = std::clamp(scale.min_strength, 0.0, 1.0);
  const double strength = tuned(floor + (1.0 - floor) * std::min(impulse / scale.full_scale_impulse, 1.0), tuning);
  if (!(strength > 0)) return {};
  RumbleCommand r;
  r.strong = std::max<std::uint16_t>(1, motor(strength));
  r.weak = motor(strength * std::clamp(scale.weak_ratio, 0.0, 1.0));
  r.length_ms = scale.length_ms;
  return r;
}

bool is_real_change(const ConstantCommand& current, const ConstantCommand& next, const ChangeThreshold& t) {
  if ((current.level == 0) != (next.level == 0)) return true;
  if (current.level == 0) return false;  // both unfelt: the direction does not matter
  if (std::abs(int{next.level} - int{current.level}) >= t.level_step) return true;
  int d = std::abs(int{next.direction} - int{current.direction});
  d = std::min(d, 65536 - d);
  return d >= t.direction_step;
}

}  // namespace sculpt::haptics

namespace sculpt::haptics {
bool is_real_change(const RumbleCommand& current, const RumbleCommand& next, const ChangeThreshold& t) {
  if (current == next) return false;
  if (current.any() != next.any()) return true;
  if (!current.any()) return false;
  const int step = 2 * t.level_step;
  return std::abs(int{next.strong} - int{current.strong}) >= step ||
         std::abs(int{next.weak} - int{current.weak}) >= step;
}
}  // namespace sculpt::haptics
