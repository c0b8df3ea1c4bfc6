// The whole path without a kernel: a real sim::World pushes and pulls a mesh,
// its feedback goes through the FeedbackBoard and the engine to a fake device.
// What the stick would feel (the memoryless driver's reading of our effect)
// must oppose the stick's motion: pushing in, it pushes back; pulling out, it
// pulls back. One onset → one kick, with the default scales.
#include <gtest/gtest.h>

#include <cmath>

#include "fake_port.hpp"
#include "haptics/haptics_engine.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace sculpt::haptics {
namespace {

using namespace std::chrono_literals;
using testing::FakeDeviceState;
using testing::FakePort;
using testing::fake_device;
using Call = FakeDeviceState::Call;

struct Rig {
  Rig() : world(sim::SimSettings{}, 1), board(1) {
    world.add_body(sim::make_icosphere(0.1f, 4), sim::Material{});
    pad = fake_device({FF_CONSTANT, FF_RUMBLE, FF_GAIN}, 16);
    engine = std::make_unique<HapticsEngine>(
        board, HapticsSettings{},
        [this](const std::string& node) { return std::unique_ptr<FfPort>(std::make_unique<FakePort>(pad, node)); },
        stats, LogSink{}, *pad->clock);
    // The stick's x drives the tool along sim x, its y (down = towards the user) along sim z.
    engine->attach(0, "/dev/input/event0", {{0, StickPlane{0, 2, 1.0, 1.0}}});
  }
  // One 1 kHz tick with the tool at x; the haptics thread polls every 4 ticks.
  void tick(double x) {
    tool.position = {x, 0.0, 0.0};
    world.step({&tool, 1});
    const sim::ToolFeedback& f = world.feedback()[0];
    board.publish(0, {f.force, f.contacts, f.contacts > 0, f.onset, f.onset_impulse});
    if (n++ % 4 == 0) {
      pad->clock->advance_to(Clock::time_point{} + n * 1ms);
      engine->poll();
    }
  }
  std::vector<Call> uploads(std::uint16_t type) const {
    std::vector<Call> out;
    for (const auto& c : pad->of(Call::upload))
      if (c.effect.type == type && c.result == 0) out.push_back(c);
    return out;
  }

  sim::World<float> world;
  sim::Tool tool;
  FeedbackBoard board;
  HapticsStats stats;
  std::shared_ptr<FakeDeviceState> pad;
  std::unique_ptr<HapticsEngine> engine;
  long n = 0;
};

StickForce felt(const Call& c) { return force_from_constant({c.effect.u.constant.level, c.effect.direction}); }

TEST(SimToEffect, PushingInIsPushedBack) {
  Rig rig;
  rig.tool.radius = 0.02;
  // The stick is held left (−x): the tool comes from +x into the sphere.
  for (int i = 0; i <= 400; ++i) rig.tick(0.125 - 0.02 * i / 400.0);
  const auto constants = rig.uploads(FF_CONSTANT);
  ASSERT_GE(constants.size(), 2u);
  EXPECT_EQ(constants[0].effect.id, -1);
  int felt_count = 0;
  for (std::size_t i = 1; i < constants.size(); ++i) {
    EXPECT_EQ(constants[i].effect.id, constants[0].id);
    if (constants[i].effect.u.constant.level == 0) continue;
    ++felt_count;
    const StickForce f = felt(constants[i]);
    EXPECT_GT(f.x, 0.0) << "upload " << i << ": the stick moved left, it must be pushed right";
    EXPECT_LT(std::abs(f.y), f.x) << "upload " << i;
  }
  EXPECT_GT(felt_count, 0);
  const auto kicks = rig.uploads(FF_RUMBLE);
  ASSERT_EQ(kicks.size(), 1u) << "one onset, one kick";
  EXPECT_GE(kicks[0].effect.u.rumble.strong_magnitude, 0x4000) << "a slow first touch is still felt";
  EXPECT_EQ(rig.stats.ff.kicks.load(), 1u);
}

TEST(SimToEffect, PullingOutIsPulledBack) {
  Rig rig;
  rig.tool.radius = 0.02;
  const double surface = 0.1;
  rig.tick(surface + 0.01);  // overlapping the surface a little
  rig.tool.grab = true;
  // The stick is held right (+x): the grabbed surface is pulled out.
  for (int i = 1; i <= 300; ++i) rig.tick(surface + 0.01 + 0.02 * std::min(i, 200) / 200.0);
  const auto constants = rig.uploads(FF_CONSTANT);
  ASSERT_GE(constants.size(), 2u);
  const StickForce f = felt(constants.back());
  EXPECT_GT(constants.back().effect.u.constant.level, 0);
  EXPECT_LT(f.x, 0.0) << "the stick moved right, the mesh pulls it back left";
}

}  // namespace
}  // namespace sculpt::haptics
