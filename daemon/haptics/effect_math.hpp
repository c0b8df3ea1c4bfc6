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

// Measured with the default material (k = 200 N/m) and a 2 cm tool: a light
// touch gives a few mN, a 1–2 cm push 0.1–1.2 N.
struct ForceScale {
  double full_scale_newton = 1.0;  // |f| at which the level saturates (0x7fff)
  double dead_band_newton = 0.02;  // |f| below this: level 0 (contact noise is not felt)
  double max_level = 0x7fff;       // the clamp; lower it to cap the motor
};

// The sim's onset impulse is |force|·dt of the first contact tick, and a first
// contact is shallow: a few µN·s for a slow approach, some mN·s for a hard tap
// (at 1 kHz). So every onset gets at least min_strength, and harder ones more,
// up to full strength at full_scale_impulse.
struct RumbleScale {
  double full_scale_impulse = 0.002;  // N·s for a full strong magnitude
  double min_impulse = 1e-7;          // below this an onset gives no kick
  double weak_ratio = 0.5;            // weak motor = ratio · strong
  std::uint16_t length_ms = 60;       // a short kick
  double min_strength = 0.3;          // of full: the faintest kick (0 = purely proportional)
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

// Stick force → FF_CONSTANT level and direction (dead band, scaling, clamping).
// A zero level keeps direction 0.
ConstantCommand constant_from_force(StickForce f, const ForceScale& scale);

// The stick-frame force a (level, direction) pair makes on a memoryless device
// (the inverse, for tests and docs): x = L·sin θ, y = −L·cos θ.
StickForce force_from_constant(const ConstantCommand& c);

// Onset impulse (N·s) → a short FF_RUMBLE kick: strength min_strength +
// (1 − min_strength)·min(impulse / full_scale_impulse, 1); none below min_impulse.
RumbleCommand rumble_from_impulse(double impulse, const RumbleScale& scale);

// Whether `next` differs enough from what the device already has to be worth
// an upload: the level moved by at least level_step, or (while either is felt)
// the direction turned by at least direction_step (wrapping at 0x10000). Going
// to or from zero is always a change.
struct ChangeThreshold {
  int level_step = 256;           // of 0x7fff
  int direction_step = 0x0200;    // of 0x10000 (≈ 2.8°)
};
bool is_real_change(const ConstantCommand& current, const ConstantCommand& next, const ChangeThreshold& t);

}  // namespace sculpt::haptics
