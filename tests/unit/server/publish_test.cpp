// The sim thread's hand-off to the server: the reader's copy equals the
// world's positions (file order) after any tick; only changed blocks get a
// new serial; publishing allocates nothing on the sim thread (the real
// stages, with a reader syncing on another thread meanwhile); stats travel
// through the protocol and back to the same JSON.
#include <linux/input.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <thread>

#include <capnp/message.h>
#include <gtest/gtest.h>

#include "haptics/feedback_board.hpp"
#include "simloop/sim_thread.hpp"
#include <nlohmann/json.hpp>

#include "simloop/stats_json.hpp"
#include "host/sculpt_stages.hpp"
#include "server/encode.hpp"
#include "server/published_state.hpp"
#include "sim/shapes.hpp"
#include "support/allocation_counter.hpp"

namespace sculpt::server {
namespace {

using namespace std::chrono_literals;

void expect_reader_matches(const PublishedReader& r, const sim::World<float>& world) {
  for (std::size_t b = 0; b < world.body_count(); ++b) {
    std::vector<sim::Vec3f> truth(world.body(b).n);
    world.positions(b, truth);
    const auto got = r.positions(b);
    ASSERT_EQ(got.size(), truth.size() * 3);
    for (std::size_t i = 0; i < truth.size(); ++i)
      for (int a = 0; a < 3; ++a) ASSERT_EQ(got[i * 3 + a], truth[i][a]) << "body " << b << " vertex " << i;
  }
}

TEST(Published, TheReaderHoldsTheWorldsPositionsInFileOrderAndOnlyChangedBlocksMove) {
  sim::World<float> world(sim::SimSettings{}, 1);
  world.add_body(sim::make_icosphere(0.05f, 3), sim::Material{});
  world.add_body(sim::make_icosphere(0.05f, 2), sim::Material{});
  PublishedState state(world, 1000.0);
  PublishedReader reader(state);
  expect_reader_matches(reader, world);
  const std::uint64_t s0 = reader.serial();

  // Push vertex 5 of body 0: only its neighbourhood wakes.
  world.set_state(0, 5, {0.0, 0.08, 0.0}, {0, 0, 0});
  std::vector<sim::Tool> tools(1);
  tools[0].active = false;
  for (std::uint64_t t = 0; t < 20; ++t) {
    world.step(tools);
    state.publish(t, world, tools, 1000 + static_cast<std::int64_t>(t));
  }
  reader.sync();
  expect_reader_matches(reader, world);
  EXPECT_EQ(reader.header().tick, 20u);
  EXPECT_EQ(reader.header().published_ns, 1019);
  std::uint32_t moved = 0;
  for (std::uint32_t k = 0; k < reader.blocks(0); ++k) moved += reader.block_serial(0, k) > s0;
  EXPECT_GT(moved, 0u);
  for (std::uint32_t k = 0; k < reader.blocks(1); ++k) EXPECT_EQ(reader.block_serial(1, k), 1u) << "body 1 never moved";
  // Nothing new: nothing changes.
  const std::uint64_t before = reader.serial();
  reader.sync();
  for (std::uint32_t k = 0; k < reader.blocks(0); ++k) EXPECT_LE(reader.block_serial(0, k), before);
}

TEST(Published, TheReadersBoundsFollowTheBodyAfterItMoves) {
  sim::World<float> world(sim::SimSettings{}, 1);
  world.add_body(sim::make_icosphere(0.05f, 3), sim::Material{});
  PublishedState state(world, 1000.0);
  PublishedReader reader(state);
  const auto expect_bounds = [&] {
    std::vector<sim::Vec3f> p(world.body(0).n);
    world.positions(0, p);
    std::array<float, 6> want{p[0][0], p[0][1], p[0][2], p[0][0], p[0][1], p[0][2]};
    for (const auto& v : p)
      for (int a = 0; a < 3; ++a) {
        want[a] = std::min(want[a], v[a]);
        want[3 + a] = std::max(want[3 + a], v[a]);
      }
    const auto got = reader.bounds(0);
    for (int a = 0; a < 6; ++a) EXPECT_EQ(got[a], want[a]) << "bound " << a;
  };
  expect_bounds();
  // Pull a vertex far out: the next bounds after a sync must include it.
  world.set_state(0, 5, {0.0, 0.3, 0.0}, {0, 0, 0});
  std::vector<sim::Tool> tools(1);
  tools[0].active = false;
  for (std::uint64_t t = 0; t < 3; ++t) {
    world.step(tools);
    state.publish(t, world, tools, 0);
    reader.sync();
  }
  expect_bounds();
  EXPECT_GT(reader.bounds(0)[4], 0.06f);
}

struct Marking : simloop::TickStages {
  explicit Marking(daemon::SculptStages& s) : stages(s) {}
  daemon::SculptStages& stages;
  void input(std::uint64_t tick, std::span<sim::Tool> tools) override {
    support::count_allocations_on_this_thread(true);
    stages.input(tick, tools);
  }
  void publish(std::uint64_t tick, const sim::World<float>& world) override { stages.publish(tick, world); }
};

TEST(Published, PublishingAllocatesNothingOnTheSimThreadWhileAReaderSyncs) {
  sim::World<float> world(sim::SimSettings{}, 1);
  world.add_body(sim::make_icosphere(0.05f, 3), sim::Material{});
  haptics::FeedbackBoard board(1);
  simloop::DriverLimits limits;
  limits.bounds = simloop::Box{{-1, -1, -1}, {1, 1, 1}};
  simloop::ToolSpec spec;
  spec.position = {0, 0.09, 0};
  daemon::SculptStages stages(simloop::ToolDriver({spec}, limits, 1000.0), board, 256);
  PublishedState state(world, 1000.0);
  stages.set_published(&state);
  Marking marking(stages);
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
  PublishedReader reader(state);
  support::reset_counted_allocations();
  // It starts paused (commands too: no allocation) and ticks once this
  // thread has synced a few times: the reader syncs while it publishes,
  // however late this thread runs.
  ASSERT_TRUE(thread.request_pause(true));
  thread.start();
  std::uint64_t syncs = 0;
  for (int i = 0; i < 200 && !thread.finished(); ++i) {
    stages.ring().try_push(full_down());
    if (i == 20) thread.request_pause(false);
    if (i == 100) thread.request_pause(true);
    if (i == 120) thread.request_pause(false);
    reader.sync();
    ++syncs;
    std::this_thread::sleep_for(1ms);
  }
  while (!thread.finished()) {
    reader.sync();
    std::this_thread::sleep_for(1ms);
  }
  thread.stop();
  EXPECT_EQ(support::counted_allocations(), 0) << "the sim thread allocated";
  EXPECT_GT(board.read(0).onsets, 0u) << "the tool never touched the ball";
  reader.sync();
  expect_reader_matches(reader, world);
  EXPECT_EQ(reader.header().tick, 600u);
  EXPECT_GT(syncs, 10u);
}

TEST(Encode, StatsTravelThroughTheProtocolToTheSameJson) {
  DaemonStatus d;
  d.stats.rate_hz = 1000;
  d.stats.ticks = 12345;
  d.stats.overruns = 2;
  d.stats.jitter_us = {10, 50, 90};
  d.stats.stage_us[2] = {1.5, 2.5, 3.5};
  d.stats.vertices_total = 50000;
  d.stats.vertices_awake = 300;
  d.stats.viewers = 3;
  d.stats.devices = 1;
  d.stats.ff_uploads = 7;
  d.stats.bytes_sent = 1 << 20;
  d.stats.blowups = 0;
  capnp::MallocMessageBuilder m;
  fill_stats(m.initRoot<proto::Stats>(), d);
  const auto back = stats_from(m.getRoot<proto::Stats>().asReader());
  EXPECT_EQ(simloop::stats_json(back).dump(), simloop::stats_json(d.stats).dump());
}

}  // namespace
}  // namespace sculpt::server
