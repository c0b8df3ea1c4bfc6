// Force → FF effect maths: directions in every quadrant (the Linux convention,
// checked against the memoryless driver's inverse), force → level (felt
// minimum, monotonic, saturating), gain and limit, projection through the
// stick's mapping, contact rumble, kicks from impulse.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "haptics/effect_math.hpp"

namespace sculpt::haptics {
namespace {

TEST(ConstantFromForce, CardinalDirectionsFollowLinuxConvention) {
  // The stick is pushed up (y < 0): the force comes from below: 0x0000 "down".
  EXPECT_EQ(constant_from_level({0, -1}, 1.0).direction, 0x0000);
  // Pushed right (x > 0): comes from the left: 0x4000.
  EXPECT_EQ(constant_from_level({1, 0}, 1.0).direction, 0x4000);
  // Pushed down (y > 0, towards the user): comes from above: 0x8000.
  EXPECT_EQ(constant_from_level({0, 1}, 1.0).direction, 0x8000);
  // Pushed left: comes from the right: 0xC000.
  EXPECT_EQ(constant_from_level({-1, 0}, 1.0).direction, 0xC000);
}

TEST(ConstantFromForce, EachQuadrantDiagonal) {
  EXPECT_EQ(constant_from_level({1, -1}, 1.0).direction, 0x2000);   // up-right
  EXPECT_EQ(constant_from_level({1, 1}, 1.0).direction, 0x6000);    // down-right
  EXPECT_EQ(constant_from_level({-1, 1}, 1.0).direction, 0xA000);   // down-left
  EXPECT_EQ(constant_from_level({-1, -1}, 1.0).direction, 0xE000);  // up-left
}

TEST(ConstantFromForce, InverseOfTheMemorylessDriverInEveryDirection) {
  // ff-memless plays (θ, L) as x = L·sin θ, y = −L·cos θ; our command must
  // point the played force where we wanted it.
  for (int deg = 0; deg < 360; deg += 7) {
    const double a = deg * M_PI / 180.0;
    const StickForce want{1.5 * std::cos(a), 1.5 * std::sin(a)};
    const ConstantCommand c = constant_from_level(want, 1.0);
    const StickForce played = force_from_constant(c);
    const double cosine = (played.x * want.x + played.y * want.y) /
                          (std::hypot(played.x, played.y) * std::hypot(want.x, want.y));
    EXPECT_GT(cosine, 0.99999) << deg << " degrees";
  }
}

TEST(LevelFromForce, FirstTouchFeltMonotonicSaturating) {
  const ForceScale scale{/*full_scale_newton=*/1.2, /*min_level=*/0.12, /*exponent=*/0.5};
  // Not touching: nothing, whatever the force says.
  EXPECT_EQ(level_from_force(0.5, false, scale), 0.0);
  // Touching: the lightest touch is felt (no dead band), even at 0 N.
  EXPECT_DOUBLE_EQ(level_from_force(0.0, true, scale), 0.12);
  EXPECT_GT(level_from_force(0.003, true, scale), 0.12);
  // The renderer's range: a light touch (few mN..0.05 N) is clearly above
  // the floor, a 1–2 cm press (0.1..1.2 N) spans most of the range.
  EXPECT_GT(level_from_force(0.05, true, scale), 0.25);
  EXPECT_GT(level_from_force(0.1, true, scale), 0.3);
  EXPECT_DOUBLE_EQ(level_from_force(1.2, true, scale), 1.0);
  EXPECT_DOUBLE_EQ(level_from_force(50.0, true, scale), 1.0);  // saturates
  double last = 0;
  for (double f = 0; f < 2.0; f += 0.001) {
    const double l = level_from_force(f, true, scale);
    EXPECT_GE(l, last) << f;
    last = l;
  }
  EXPECT_EQ(level_from_force(std::nan(""), true, scale), 0.0);
  EXPECT_EQ(level_from_force(INFINITY, true, scale), 0.0);
}

TEST(Tuned, GainThenLimitNeverAbove) {
  EXPECT_DOUBLE_EQ(tuned(0.8, {0.5, 1.0}), 0.4);
  EXPECT_DOUBLE_EQ(tuned(0.8, {1.0, 0.3}), 0.3);
  EXPECT_DOUBLE_EQ(tuned(0.8, {0.5, 0.3}), 0.3);
  EXPECT_DOUBLE_EQ(tuned(2.0, {1.0, 1.0}), 1.0);
  EXPECT_EQ(tuned(std::nan(""), {1.0, 1.0}), 0.0);
  EXPECT_EQ(tuned(1.0, {std::nan(""), 1.0}), 0.0);
}

TEST(ConstantFromLevel, LevelInUnitsRoundedDownZeroWithoutDirection) {
  EXPECT_EQ(constant_from_level({1.0, 0}, 1.0).level, 0x7fff);
  EXPECT_EQ(constant_from_level({1.0, 0}, 0.5).level, 16383);
  EXPECT_EQ(constant_from_level({1.0, 0}, 7.0).level, 0x7fff);
  EXPECT_EQ(constant_from_level({0, 0}, 1.0), ConstantCommand{});
  EXPECT_EQ(constant_from_level({1.0, 0}, 0.0), ConstantCommand{});
  EXPECT_EQ(constant_from_level({std::nan(""), 1}, 1.0), ConstantCommand{});
}

TEST(RumbleFromLevel, ContactMixIsMostlyTheWeakMotor) {
  RumbleScale scale;
  scale.contact_strong_ratio = 0.25;
  const RumbleCommand r = rumble_from_level(0.5, scale);
  EXPECT_EQ(r.weak, 32767);
  EXPECT_EQ(r.strong, 8191);
  EXPECT_FALSE(rumble_from_level(0.0, scale).any());
  EXPECT_GE(rumble_from_level(1e-9, scale).weak, 1);  // touching is never a zero rumble
}

TEST(RumbleFromImpulse, KicksNeverExceedTheLimit) {
  RumbleScale scale;
  for (double impulse : {1e-6, 1e-4, 1e-3, 1.0}) {
    const RumbleCommand k = rumble_from_impulse(impulse, scale, {1.0, 0.4});
    EXPECT_LE(k.strong, 0.4 * 65535) << impulse;
    EXPECT_LE(k.weak, 0.4 * 65535) << impulse;
    EXPECT_GT(k.strong, 0) << impulse;
  }
  const RumbleCommand half_gain = rumble_from_impulse(1.0, scale, {0.5, 1.0});
  EXPECT_EQ(half_gain.strong, 32767);
}

TEST(IsRealChange, RumbleStepsAndZero) {
  const ChangeThreshold t{256, 0x200};
  EXPECT_FALSE(is_real_change(RumbleCommand{1000, 1000, 0}, RumbleCommand{1000, 1511, 0}, t));
  EXPECT_TRUE(is_real_change(RumbleCommand{1000, 1000, 0}, RumbleCommand{1000, 1512, 0}, t));
  EXPECT_TRUE(is_real_change(RumbleCommand{0, 1, 0}, RumbleCommand{}, t));
  EXPECT_FALSE(is_real_change(RumbleCommand{}, RumbleCommand{}, t));
}

TEST(ProjectToStick, PicksTheDrivenAxesWithTheirSigns) {
  const std::array<double, 3> f{1.0, 2.0, 3.0};
  const StickForce a = project_to_stick(f, StickPlane{0, 2, 1.0, 1.0});
  EXPECT_DOUBLE_EQ(a.x, 1.0);
  EXPECT_DOUBLE_EQ(a.y, 3.0);
  // Stick forward (y negative) drives the tool along +z: y_sign −1.
  const StickForce b = project_to_stick(f, StickPlane{1, 2, -1.0, -1.0});
  EXPECT_DOUBLE_EQ(b.x, -2.0);
  EXPECT_DOUBLE_EQ(b.y, -3.0);
  // An axis that drives nothing feels nothing.
  const StickForce c = project_to_stick(f, StickPlane{-1, 0, 1.0, 1.0});
  EXPECT_DOUBLE_EQ(c.x, 0.0);
  EXPECT_DOUBLE_EQ(c.y, 1.0);
  const StickForce d = project_to_stick({std::nan(""), 0, 0}, StickPlane{0, 1, 1.0, 1.0});
  EXPECT_DOUBLE_EQ(d.x, 0.0);
  EXPECT_DOUBLE_EQ(d.y, 0.0);
}

TEST(ProjectToStick, ResistanceIsFeltAgainstTheMotion) {
  // Tool pushed into a wall along +x: the mesh pushes back along −x; the stick
  // that moved right is pushed left (direction 0xC000, the force comes from the right).
  const StickForce s = project_to_stick({-1.0, 0, 0}, StickPlane{0, 2, 1.0, 1.0});
  EXPECT_EQ(constant_from_level(s, 1.0).direction, 0xC000);
}

TEST(RumbleFromImpulse, ScalesClampsAndIgnoresTinyOnes) {
  const RumbleScale scale{/*full_scale_impulse=*/0.02, /*min_impulse=*/1e-5, /*weak_ratio=*/0.5, 60,
                          /*min_strength=*/0.0};
  const RumbleCommand half = rumble_from_impulse(0.01, scale);
  EXPECT_EQ(half.strong, 32767);  // rounded down: a limit is never exceeded by rounding
  EXPECT_EQ(half.weak, 16383);
  EXPECT_EQ(half.length_ms, 60);
  const RumbleCommand full = rumble_from_impulse(5.0, scale);
  EXPECT_EQ(full.strong, 0xffff);
  EXPECT_EQ(full.weak, 32767);
  EXPECT_FALSE(rumble_from_impulse(1e-6, scale).any());
  EXPECT_FALSE(rumble_from_impulse(0, scale).any());
  EXPECT_FALSE(rumble_from_impulse(-1, scale).any());
  EXPECT_FALSE(rumble_from_impulse(std::nan(""), scale).any());
  // Just above the threshold: still a (faint) kick, never a zero one.
  EXPECT_GE(rumble_from_impulse(1.1e-5, scale).strong, 1);
}

TEST(RumbleFromImpulse, EveryOnsetIsFeltAtLeastAtTheFloor) {
  const RumbleScale scale{0.002, 1e-7, 0.5, 60, /*min_strength=*/0.25};
  // A slow approach: a few µN·s. Still a kick worth feeling.
  const RumbleCommand faint = rumble_from_impulse(2e-6, scale);
  EXPECT_NEAR(faint.strong, 0.25 * 65535 + 0.75 * 65535 * 0.001, 1.0);
  EXPECT_NEAR(faint.weak, faint.strong * 0.5, 1.0);
  EXPECT_EQ(rumble_from_impulse(0.001, scale).strong, std::lround(0.625 * 65535));
  EXPECT_EQ(rumble_from_impulse(0.5, scale).strong, 0xffff);
  EXPECT_FALSE(rumble_from_impulse(5e-8, scale).any());  // below min_impulse: none
  // Harder taps kick harder.
  EXPECT_LT(rumble_from_impulse(1e-4, scale).strong, rumble_from_impulse(1e-3, scale).strong);
}

TEST(IsRealChange, LevelStepDirectionStepAndZero) {
  const ChangeThreshold t{256, 0x200};
  const ConstantCommand base{10000, 0x4000};
  EXPECT_FALSE(is_real_change(base, base, t));
  EXPECT_FALSE(is_real_change(base, {10255, 0x4000}, t));
  EXPECT_TRUE(is_real_change(base, {10256, 0x4000}, t));
  EXPECT_TRUE(is_real_change(base, {9744, 0x4000}, t));
  EXPECT_FALSE(is_real_change(base, {10000, 0x41ff}, t));
  EXPECT_TRUE(is_real_change(base, {10000, 0x4200}, t));
  // Direction wraps around 0.
  EXPECT_FALSE(is_real_change(ConstantCommand{10000, 0xff00}, ConstantCommand{10000, 0x0080}, t));
  EXPECT_TRUE(is_real_change(ConstantCommand{10000, 0xff00}, ConstantCommand{10000, 0x0100}, t));
  // To and from zero is always a change, however small the level.
  EXPECT_TRUE(is_real_change(ConstantCommand{0, 0}, ConstantCommand{1, 0x4000}, t));
  EXPECT_TRUE(is_real_change(ConstantCommand{1, 0x4000}, ConstantCommand{0, 0}, t));
  // Both zero: nothing to send.
  EXPECT_FALSE(is_real_change(ConstantCommand{0, 0}, ConstantCommand{0, 0}, t));
}

}  // namespace
}  // namespace sculpt::haptics
