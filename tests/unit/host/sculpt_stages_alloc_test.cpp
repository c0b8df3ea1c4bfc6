// sculptd's real sim-thread stages (input ring → ControlMapper → ToolDriver,
// World::step, FeedbackBoard, the streaming server's PublishedState) allocate
// nothing once the thread runs, while devices attach, frames stream in, the
// loop is paused and resumed and a tool presses into a mesh.
#include <gtest/gtest.h>

#include <linux/input.h>

#include <array>
#include <atomic>
#include <chrono>
#include <thread>

#include "haptics/feedback_board.hpp"
#include "input/input_message.hpp"
#include "simloop/sim_thread.hpp"
#include "host/sculpt_stages.hpp"
#include "server/published_state.hpp"
#include "sim/shapes.hpp"
#include "support/allocation_counter.hpp"

namespace sculpt::daemon {
namespace {

using namespace std::chrono_literals;

// Marks the sim thread, then forwards to the real stages.
struct Marking : simloop::TickStages {
  explicit Marking(SculptStages& s) : stages(s) {}
  SculptStages& stages;
  void input(std::uint64_t tick, std::span<sim::Tool> tools) override {
    support::count_allocations_on_this_thread(true);
    stages.input(tick, tools);
  }
  void publish(std::uint64_t tick, const sim::World<float>& world) override { stages.publish(tick, world); }
};

TEST(Pipeline, TheSimThreadAllocatesNothingWhileSculpting) {
  sim::World<float> world(sim::SimSettings{}, 1);
  world.add_body(sim::make_icosphere(0.05f, 3), sim::Material{});
  haptics::FeedbackBoard board(1);
  simloop::DriverLimits limits;
  limits.bounds = simloop::Box{{-1, -1, -1}, {1, 1, 1}};
  simloop::ToolSpec spec;
  spec.position = {0, 0.09, 0};
  spec.speed = 0.5;
  SculptStages stages(simloop::ToolDriver({spec}, limits, 1000.0), board, 256);
  server::PublishedState published(world, 1000.0);
  stages.set_published(&published);
  Marking marking(stages);

  // A one-stick device driving tool 0: ABS_Y pushes the tool down (-y).
  input::DeviceBinding b;
  input::AxisBinding y;
  y.code = ABS_Y;
  y.tool = 0;
  y.component = 1;
  y.scale = -1.0f;
  y.calibration.minimum = -512;
  y.calibration.maximum = 511;
  b.add_axis(y);
  b.tool_mask = 1;
  ASSERT_TRUE(stages.ring().try_push(input::InputMessage::attach(0, b)));
  // Full deflection down from the first tick: the tool reaches the ball
  // within the run however late this thread sends the frames that follow.
  const auto full_down = [] {
    input::InputFrame f;
    f.slot = 0;
    f.push({EV_ABS, ABS_Y, 511});
    f.push({EV_SYN, SYN_REPORT, 0});
    return input::InputMessage::of_frame(f);
  };
  ASSERT_TRUE(stages.ring().try_push(full_down()));

  simloop::SimThreadOptions o;
  o.max_ticks = 600;
  simloop::SimThread thread(world, marking, 1, o);
  support::reset_counted_allocations();
  thread.start();
  // Frames keep arriving while it runs.
  for (int i = 0; i < 200 && !thread.finished(); ++i) {
    stages.ring().try_push(full_down());
    std::this_thread::sleep_for(1ms);
    if (i == 100) {
      EXPECT_TRUE(thread.request_pause(true));
    } else if (i == 110) {
      EXPECT_TRUE(thread.request_pause(false));
    }
  }
  while (!thread.finished()) std::this_thread::sleep_for(1ms);
  thread.stop();
  EXPECT_GT(stages.applied(), 1u);
  EXPECT_GT(board.read(0).onsets, 0u) << "the tool never touched the ball";
  EXPECT_EQ(support::counted_allocations(), 0) << "the sim thread allocated";
  server::PublishedReader viewer(published);
  EXPECT_EQ(viewer.sync().tick, 600u) << "the publish stage did not reach the streaming state";
}

// The board gets the rendered contact, not the world's raw reaction: a tool
// resting on the ball, where the raw contacts toggle tick to tick, is
// touching steadily with one onset and a force that is never zero.
TEST(Pipeline, TheBoardFeelsARestingToolSteadily) {
  sim::World<float> world(sim::SimSettings{}, 1);
  world.add_body(sim::make_icosphere(0.05f, 3), sim::Material{});
  haptics::FeedbackBoard board(1);
  simloop::DriverLimits limits;
  limits.bounds = simloop::Box{{-1, -1, -1}, {1, 1, 1}};
  simloop::ToolSpec spec;
  spec.position = {0, 0.05 + 0.02 - 0.0003, 0};  // 0.3 mm into the rest surface
  SculptStages stages(simloop::ToolDriver({spec}, limits, 1000.0), board, 256);
  input::DeviceBinding b;
  input::AxisBinding y;
  y.code = ABS_Y;
  y.tool = 0;
  y.component = 1;
  y.calibration.minimum = -511;  // centred on 0: the tool stays put
  y.calibration.maximum = 511;
  b.add_axis(y);
  b.tool_mask = 1;
  ASSERT_TRUE(stages.ring().try_push(input::InputMessage::attach(0, b)));
  input::InputFrame f;  // the stick at rest
  f.slot = 0;
  f.push({EV_ABS, ABS_Y, 0});
  f.push({EV_SYN, SYN_REPORT, 0});
  ASSERT_TRUE(stages.ring().try_push(input::InputMessage::of_frame(f)));

  std::array<sim::Tool, 1> tools{};
  int raw_onsets = 0, untouched = 0, unfelt = 0;
  for (std::uint64_t tick = 1; tick <= 2500; ++tick) {
    stages.input(tick, tools);
    world.step(tools);
    stages.publish(tick, world);
    raw_onsets += world.feedback()[0].onset;
    if (tick > 100) {
      const haptics::ToolForce felt = board.read(0);
      untouched += !felt.touching;
      unfelt += !(felt.force[1] > 0.0);
    }
  }
  EXPECT_EQ(board.read(0).onsets, 1u);
  EXPECT_EQ(untouched, 0);
  EXPECT_EQ(unfelt, 0);
  EXPECT_GT(raw_onsets, 100) << "the raw contacts no longer toggle here: the test shows nothing";
}

}  // namespace
}  // namespace sculpt::daemon
