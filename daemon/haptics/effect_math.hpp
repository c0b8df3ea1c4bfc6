// Force → force-feedback effect maths. Pure functions, no I/O: unit-tested.
//
// Linux FF_CONSTANT direction (include/uapi/linux/input.h): 0x0000 down,
// 0x4000 left, 0x8000 up, 0xC000 right — the side the force comes FROM. The
// memoryless driver core (ff-memless ml_combine_effects) turns (direction θ,
// level L) into the stick-frame force x = L·sin θ, y = −L·cos θ, with evdev's
// axes: x grows to the right, y grows downwards (towards the user). So a force
// (fx, fy) that should push the stick is θ = atan2(fx, −fy), L = |f|.
#pragma once

#include <array>
#include <cstdint>

#include "haptics/device_tuning.hpp"

namespace sculpt::haptics {

// Which tool axes the stick's x and y drive, and with which sign: moving the
// stick towards +x moves the tool along x_sign · e[x_axis]. The force the
// meshes exert on the tool, projected back through the same map, is the force
// the stick should feel.
struct StickPlane {
  int x_axis = 0;          // 0, 1, 2 = sim x, y, z; -1 = the stick's x drives nothing
  int y_axis = 2;
  double x_sign = 1.0;
  double y_sign = 1.0;
};

// The contact renderer's range: a light touch gives a few mN to 0.05 N, a
// 1–2 cm press 0.1–1.2 N. Level (0..1 of the motor) from |f| while touching:
//   min_level + (1 − min_level) · min(|f| / full_scale_newton, 1)^exponent
// so the first touch is felt (no dead band), the level rises monotonically
// with the force, and saturates at full_scale_newton. exponent < 1 spreads
// the light end (0.05 N of 1.2 N is 20 % of the span at 0.5, not 4 %).
struct ForceScale {
  double full_scale_newton = 1.2;  // |f| at which the level saturates
  double min_level = 0.12;         // the level of the lightest touch: felt
  double exponent = 0.5;           // the curve; 1 = linear
};

// The onset kick: every onset gets at least min_strength, harder ones more,
// up to full strength at full_scale_impulse. It is a short burst of mostly
// the strong (low, thudding) motor, distinct from the continuous contact
// rumble, which is mostly the weak (fine, buzzing) motor.
struct RumbleScale {
  double full_scale_impulse = 0.002;  // N·s for a full strong magnitude
  double min_impulse = 1e-7;          // below this an onset gives no kick
  double weak_ratio = 0.5;            // kick: weak motor = ratio · strong
  std::uint16_t length_ms = 40;       // a short kick
  double min_strength = 0.5;          // of full: the faintest kick (0 = purely proportional)
  double contact_strong_ratio = 0.25; // continuous rumble: strong motor = ratio · weak
};

// The stick-frame force (x right, y down), N.
struct StickForce {
  double x = 0;
  double y = 0;
};

struct ConstantCommand {
  std::int16_t level = 0;       // 0..0x7fff (direction carries the sign)
  std::uint16_t direction = 0;  // Linux FF direction
  friend bool operator==(const ConstantCommand&, const ConstantCommand&) = default;
};

struct RumbleCommand {
  std::uint16_t strong = 0;
  std::uint16_t weak = 0;
  std::uint16_t length_ms = 0;
  bool any() const { return strong != 0 || weak != 0; }
  friend bool operator==(const RumbleCommand&, const RumbleCommand&) = default;
};

// Tool force (sim axes) → the force the stick should feel. Non-finite → zero.
StickForce project_to_stick(const std::array<double, 3>& tool_force, const StickPlane& plane);

// |f| (N) while touching → level 0..1 (see ForceScale). Not touching, or a
// non-finite force: 0.
double level_from_force(double newton, bool touching, const ForceScale& scale);

// Gain, then the hard limit: min(level · gain, limit), in 0..1.
double tuned(double level, const DeviceTuning& tuning);

// Stick force and a tuned level (0..1) → FF_CONSTANT level and direction.
// A zero level, or no direction (zero force), gives {0, 0}.
ConstantCommand constant_from_level(StickForce f, double level);

// Continuous contact rumble at a tuned level (0..1): weak motor at the level,
// strong at contact_strong_ratio of it.
RumbleCommand rumble_from_level(double level, const RumbleScale& scale);

// The stick-frame force a (level, direction) pair makes on a memoryless device
// (the inverse, for tests and docs): x = L·sin θ, y = −L·cos θ.
StickForce force_from_constant(const ConstantCommand& c);

// Onset impulse (N·s) → a short FF_RUMBLE kick: strength min_strength +
// (1 − min_strength)·min(impulse / full_scale_impulse, 1), then tuned (gain,
// limit: never above the limit); none below min_impulse.
RumbleCommand rumble_from_impulse(double impulse, const RumbleScale& scale, const DeviceTuning& tuning = {});

// Whether `next` differs enough from what the device already has to be worth
// an upload: the level moved by at least level_step, or (while either is felt)
// the direction turned by at least direction_step (wrapping at 0x10000). Going
// to or from zero is always a change.
struct ChangeThreshold {
  int level_step = 256;           // of 0x7fff
  int direction_step = 0x0200;    // of 0x10000 (≈ 2.8°)
};
bool is_real_change(const ConstantCommand& current, const ConstantCommand& next, const ChangeThreshold& t);
// The same for rumble magnitudes: either motor moved by 2 · level_step (of
// 0xffff), or to or from zero.
bool is_real_change(const RumbleCommand& current, const RumbleCommand& next, const ChangeThreshold& t);

}  // namespace sculpt::haptics
