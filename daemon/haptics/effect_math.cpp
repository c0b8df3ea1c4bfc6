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

ConstantCommand constant_from_force(StickForce f, const ForceScale& scale) {
  const double magnitude = std::hypot(f.x, f.y);
  if (!std::isfinite(magnitude) || !(scale.full_scale_newton > 0)) return {};
  if (magnitude < scale.dead_band_newton || magnitude <= 0) return {};
  const double max_level = std::clamp(scale.max_level, 0.0, 32767.0);
  const double level = std::round(std::min(magnitude / scale.full_scale_newton, 1.0) * max_level);
  if (level <= 0) return {};
  // θ = atan2(fx, −fy) in (−π, π]: the side the force comes from, see the header.
  double turns = std::atan2(f.x, -f.y) / (2 * std::numbers::pi);
  if (turns < 0) turns += 1.0;
  const auto units = static_cast<long>(std::lround(turns * 65536.0)) % 65536;
  return ConstantCommand{static_cast<std::int16_t>(level), static_cast<std::uint16_t>(units)};
}

StickForce force_from_constant(const ConstantCommand& c) {
  const double theta = c.direction / 65536.0 * 2 * std::numbers::pi;
  return StickForce{c.level * std::sin(theta), -c.level * std::cos(theta)};
}

RumbleCommand rumble_from_impulse(double impulse, const RumbleScale& scale) {
  if (!std::isfinite(impulse) || impulse < scale.min_impulse || impulse <= 0 || !(scale.full_scale_impulse > 0))
    return {};
  const double floor = std::clamp(scale.min_strength, 0.0, 1.0);
  const double s = (floor + (1.0 - floor) * std::min(impulse / scale.full_scale_impulse, 1.0)) * 65535.0;
  const double ratio = std::clamp(scale.weak_ratio, 0.0, 1.0);
  RumbleCommand r;
  r.strong = static_cast<std::uint16_t>(std::max(1.0, std::round(s)));
  r.weak = static_cast<std::uint16_t>(std::round(s * ratio));
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
