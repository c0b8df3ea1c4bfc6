#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "simloop/tool_driver.hpp"

namespace sculpt::simloop {
namespace {

constexpr double kRate = 1000.0;

DriverLimits limits() {
  DriverLimits l;
  l.bounds = Box{{-1, -1, -1}, {1, 1, 1}};
  return l;
}

ToolSpec spec() {
  ToolSpec s;
  s.radius = 0.02;
  s.half_length = 0.04;
  s.position = {0, 0, 0};
  s.speed = 0.5;
  return s;
}

DriveInput connected(float x = 0, float y = 0, float z = 0) {
  DriveInput in;
  in.stick = {x, y, z};
  in.connected = true;
  return in;
}

TEST(ToolDriver, ToolIsInactiveUntilItsDeviceShowsUp) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  d.update({}, out);
  EXPECT_FALSE(out[0].active);
  const DriveInput in = connected();
  d.update({&in, 1}, out);
  EXPECT_TRUE(out[0].active);
  // Unplugged: stays where it was, still in the scene, no longer grabbing.
  DriveInput gone;
  d.update({&gone, 1}, out);
  EXPECT_TRUE(out[0].active);
  EXPECT_FALSE(out[0].grab);
}

TEST(ToolDriver, FullDeflectionMovesAtTheToolsSpeed) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  const DriveInput in = connected(1.0f, -0.5f, 0.0f);
  for (int i = 0; i < 100; ++i) d.update({&in, 1}, out);  // 0.1 s
  EXPECT_NEAR(out[0].position[0], 0.05, 1e-9);
  EXPECT_NEAR(out[0].position[1], -0.025, 1e-9);
  EXPECT_NEAR(out[0].position[2], 0.0, 1e-12);
  EXPECT_NEAR(out[0].velocity[0], 0.5, 1e-9);
  // Released: the tool stays.
  const DriveInput rest = connected();
  d.update({&rest, 1}, out);
  EXPECT_NEAR(out[0].position[0], 0.05, 1e-9);
  EXPECT_EQ(out[0].velocity[0], 0.0);
}

TEST(ToolDriver, DeflectionBeyondOneAndNonFiniteInputAreTamed) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  DriveInput in = connected(5.0f, std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity());
  d.update({&in, 1}, out);
  EXPECT_NEAR(out[0].position[0], 0.5 / kRate, 1e-12);
  EXPECT_EQ(out[0].position[1], 0.0);
  EXPECT_EQ(out[0].position[2], 0.0);  // non-finite counts as centred
}

TEST(ToolDriver, ToolStaysInsideTheBounds) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  const DriveInput in = connected(1.0f, 1.0f, -1.0f);
  for (int i = 0; i < 10000; ++i) d.update({&in, 1}, out);  // 10 s at 0.5 m/s: would be 5 m away
  EXPECT_EQ(out[0].position[0], 1.0);
  EXPECT_EQ(out[0].position[1], 1.0);
  EXPECT_EQ(out[0].position[2], -1.0);
  EXPECT_EQ(out[0].velocity[0], 0.0);  // pinned against the wall: not moving
}

TEST(ToolDriver, EachShapePressSwitchesSphereAndCapsule) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  DriveInput in = connected();
  d.update({&in, 1}, out);
  EXPECT_EQ(out[0].shape, sim::ToolShape::sphere);
  in.shape_toggles = 1;
  d.update({&in, 1}, out);
  EXPECT_EQ(out[0].shape, sim::ToolShape::capsule);
  EXPECT_NEAR(out[0].half_axis[1], 0.04, 1e-12);
  d.update({&in, 1}, out);  // same counter: no new press
  EXPECT_EQ(out[0].shape, sim::ToolShape::capsule);
  in.shape_toggles = 3;  // two presses within one tick: back to a capsule
  d.update({&in, 1}, out);
  EXPECT_EQ(out[0].shape, sim::ToolShape::capsule);
  in.shape_toggles = 4;
  d.update({&in, 1}, out);
  EXPECT_EQ(out[0].shape, sim::ToolShape::sphere);
  EXPECT_EQ(out[0].half_axis[1], 0.0);
}

TEST(ToolDriver, PressesMadeBeforeTheToolWasDrivenDoNotCount) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  DriveInput in = connected();
  in.shape_toggles = 7;
  in.size_steps = 3;
  d.update({&in, 1}, out);
  EXPECT_EQ(out[0].shape, sim::ToolShape::sphere);
  EXPECT_NEAR(out[0].radius, 0.02, 1e-12);
}

TEST(ToolDriver, SizeStepsScaleWithinLimits) {
  DriverLimits l = limits();
  l.size_step = 2.0;
  l.min_scale = 0.25;
  l.max_scale = 4.0;
  ToolDriver d({spec()}, l, kRate);
  std::vector<sim::Tool> out(1);
  DriveInput in = connected();
  d.update({&in, 1}, out);
  in.size_steps = 1;
  d.update({&in, 1}, out);
  EXPECT_NEAR(out[0].radius, 0.04, 1e-12);
  in.size_steps = 10;  // far beyond the limit
  d.update({&in, 1}, out);
  EXPECT_NEAR(out[0].radius, 0.08, 1e-12);
  in.size_steps = 9;   // one shrink from the limit
  d.update({&in, 1}, out);
  EXPECT_NEAR(out[0].radius, 0.04, 1e-12);
  in.size_steps = -20;
  d.update({&in, 1}, out);
  EXPECT_NEAR(out[0].radius, 0.005, 1e-12);
}

TEST(ToolDriver, GrabFollowsTheButtonWhileConnected) {
  ToolDriver d({spec()}, limits(), kRate);
  std::vector<sim::Tool> out(1);
  DriveInput in = connected();
  in.grab = true;
  d.update({&in, 1}, out);
  EXPECT_TRUE(out[0].grab);
  in.grab = false;
  d.update({&in, 1}, out);
  EXPECT_FALSE(out[0].grab);
}

TEST(ToolDriver, ControlsOfAnotherTypeConvert) {
  struct Control {
    std::array<float, 3> stick;
    bool grab;
    std::uint32_t shape_toggles;
    std::int32_t size_steps;
    bool connected;
  };
  ToolDriver d({spec(), spec()}, limits(), kRate);
  std::vector<sim::Tool> out(2);
  const Control c[2] = {{{1, 0, 0}, false, 0, 0, true}, {{0, 0, 0}, true, 0, 0, false}};
  d.update_from(std::span<const Control>(c, 2), out);
  EXPECT_TRUE(out[0].active);
  EXPECT_GT(out[0].position[0], 0.0);
  EXPECT_FALSE(out[1].active);
}

TEST(ToolDriver, BadSpecsAreRejectedByName) {
  ToolSpec bad = spec();
  bad.radius = 0;
  try {
    ToolDriver d({spec(), bad}, limits(), kRate);
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tool 1: radius"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ToolDriver({spec()}, limits(), 0.0), std::invalid_argument);
  DriverLimits l = limits();
  l.size_step = 1.0;
  EXPECT_THROW(ToolDriver({spec()}, l, kRate), std::invalid_argument);
}

TEST(ToolBounds, SceneBoxGrownByTheMarginAndHoldingTheStarts) {
  ToolSpec far = spec();
  far.position = {0, 5, 0};
  const std::vector<ToolSpec> tools{far};
  const Box b = tool_bounds(Box{{-1, -1, -1}, {1, 1, 1}}, tools, 0.5);
  EXPECT_EQ(b.lo[0], -1.5);
  EXPECT_EQ(b.hi[0], 1.5);
  EXPECT_EQ(b.hi[1], 5.0);
}

TEST(ToolDriver, ItsStateComesBackExactly) {
  ToolDriver d({spec(), spec()}, limits(), kRate);
  std::vector<sim::Tool> out(2);
  const DriveInput in[2] = {connected(1, 0.5f, 0), connected(0, 0, -1)};
  for (int i = 0; i < 100; ++i) d.update(in, out);
  ToolDriver back({spec(), spec()}, limits(), kRate);
  back.restore_state(d.state());
  EXPECT_EQ(back.state(), d.state());
  std::vector<sim::Tool> a(2), b(2);
  d.update(in, a);
  back.update(in, b);
  EXPECT_EQ(a[0].position, b[0].position);
  EXPECT_EQ(a[1].position, b[1].position);
  ToolDriver one({spec()}, limits(), kRate);
  EXPECT_THROW(one.restore_state(d.state()), std::invalid_argument);
}

}  // namespace
}  // namespace sculpt::simloop
