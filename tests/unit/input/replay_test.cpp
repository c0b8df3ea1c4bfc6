// ReplaySource schedules each recorded frame on its tick; ControlMapper turns
// messages into tool controls.
#include <gtest/gtest.h>

#include "input/control_mapper.hpp"
#include "input/mapping.hpp"
#include "input/replay_source.hpp"
#include "test_devices.hpp"

namespace sculpt::input {
namespace {

std::filesystem::path two_device_recording() {
  Recording s;
  s.header.devices = {testing::gamepad(), testing::flight_stick()};
  s.frames = {
      {0, 0, {{EV_ABS, ABS_X, 32767}}},
      {400, 0, {{EV_ABS, ABS_Y, -32768}}},     // 0.4 ms: tick +0 at 1 kHz
      {500, 1, {{EV_KEY, BTN_TRIGGER, 1}}},    // 0.5 ms rounds up: +1
      {1499, 0, {{EV_KEY, BTN_SOUTH, 1}}},     // +1
      {2000000, 1, {{EV_KEY, BTN_TRIGGER, 0}}},  // 2 s: +2000
  };
  const auto p = testing::temp_file("replay.jsonl");
  write_recording(p, s);
  return p;
}

ReplaySource::Binder router_binder(ToolRouter& router, const MappingConfig& cfg) {
  return [&router, &cfg](std::uint8_t slot, const DeviceInfo& info) { return router.attach(slot, info, cfg); };
}

TEST(ReplaySource, AttachesThenFramesOnTheirTicks) {
  ToolRouter router({{0, "", Stick::left}, {1, "", Stick::main}});
  MappingConfig cfg;
  ReplaySource src(two_device_recording(), 1000.0, router_binder(router, cfg));
  src.start(100);
  std::vector<InputMessage> out;
  while (auto m = src.next()) out.push_back(*m);
  ASSERT_EQ(out.size(), 7u);
  EXPECT_EQ(out[0].kind, MessageKind::attach);
  EXPECT_EQ(out[0].slot, 0);
  EXPECT_TRUE(out[0].binding.drives(0));
  EXPECT_EQ(out[1].kind, MessageKind::attach);
  EXPECT_EQ(out[1].slot, 1);
  EXPECT_TRUE(out[1].binding.drives(1));
  EXPECT_EQ(out[0].at_tick, 100u);
  const std::uint64_t ticks[] = {100, 100, 101, 101, 2100};
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(out[2 + i].kind, MessageKind::frame);
    EXPECT_EQ(out[2 + i].at_tick, ticks[i]) << i;
    EXPECT_EQ(out[2 + i].frame.at_tick, ticks[i]) << i;
  }
  EXPECT_EQ(out[4].slot, 1);
  EXPECT_TRUE(src.finished());
  EXPECT_EQ(src.last_tick(), 2100u);
}

TEST(ReplaySource, OtherRates) {
  ReplaySource src(two_device_recording(), 500.0, {});
  src.start(1);
  EXPECT_EQ(src.tick_of(0), 1u);
  EXPECT_EQ(src.tick_of(999), 1u);    // 0.4995 ticks
  EXPECT_EQ(src.tick_of(1000), 2u);   // 0.5 rounds up
  EXPECT_EQ(src.tick_of(2000000), 1001u);
  ReplaySource frac(two_device_recording(), 333.5, {});
  frac.start(10);
  EXPECT_EQ(frac.tick_of(3000000), 10u + 1001u);  // 1000.5 → 1001
  EXPECT_THROW(ReplaySource(two_device_recording(), 0.0, {}), RecordingError);
  // The free function gives the same ticks (for device-clock scheduling).
  EXPECT_EQ(replay_tick(1, 1000, 500.0), 2u);
  EXPECT_EQ(replay_tick(5, 1499, 1000.0), 6u);
  EXPECT_EQ(replay_tick(5, 1500, 1000.0), 7u);
  EXPECT_EQ(replay_tick(5, -3, 1000.0), 5u);
}

TEST(ReplaySource, LongReportsAreSplitOnOneTick) {
  Recording s;
  s.header.devices = {testing::gamepad()};
  RecordingFrame f{3000, 0, {}};
  for (int i = 0; i < 100; ++i) f.events.push_back({EV_ABS, ABS_X, i});
  s.frames = {f};
  const auto p = testing::temp_file("long.jsonl");
  write_recording(p, s);
  ReplaySource src(p, 1000.0, {});
  src.start(1);
  ASSERT_EQ(src.next()->kind, MessageKind::attach);
  std::size_t events = 0, parts = 0;
  while (auto m = src.next()) {
    EXPECT_EQ(m->at_tick, 4u);
    events += m->frame.count;
    ++parts;
    EXPECT_EQ(m->frame.partial, events < 100);
  }
  EXPECT_EQ(events, 100u);
  EXPECT_EQ(parts, (100 + kMaxFrameEvents - 1) / kMaxFrameEvents);
}

TEST(ReplaySource, PumpFillsTheRingAndRespectsTheHorizon) {
  ReplaySource src(two_device_recording(), 1000.0, {});
  src.start(1);
  concurrency::SpscRing<InputMessage> ring(4);
  EXPECT_EQ(src.pump(ring), 4u);  // full
  EXPECT_FALSE(src.finished());
  ring.try_pop();
  ring.try_pop();
  ring.try_pop();
  ring.try_pop();
  EXPECT_EQ(src.pump(ring, 500), 2u);  // the 2 s frame is beyond the horizon
  while (ring.try_pop()) {
  }
  EXPECT_EQ(src.pump(ring), 1u);
  EXPECT_TRUE(src.finished());
}

TEST(ControlMapper, DrainAppliesOnlyWhatIsDue) {
  ToolRouter router({{0, "", Stick::left}, {1, "", Stick::main}});
  MappingConfig cfg;
  cfg.dead_zone = 0.0f;
  ReplaySource src(two_device_recording(), 1000.0, router_binder(router, cfg));
  src.start(100);
  concurrency::SpscRing<InputMessage> ring(64);
  src.pump(ring);
  ControlMapper mapper(2);
  EXPECT_EQ(mapper.drain(ring, 99), 0u);
  EXPECT_EQ(mapper.drain(ring, 100), 4u);  // 2 attaches + 2 frames
  EXPECT_TRUE(mapper.controls()[0].connected);
  EXPECT_FLOAT_EQ(mapper.controls()[0].stick[0], 1.0f);
  EXPECT_FLOAT_EQ(mapper.controls()[0].stick[1], 1.0f);  // stick fully up
  EXPECT_FALSE(mapper.controls()[1].grab);
  EXPECT_EQ(mapper.drain(ring, 101), 2u);
  EXPECT_TRUE(mapper.controls()[1].grab) << "the flight stick's trigger grabs with its tool";
  EXPECT_TRUE(mapper.controls()[0].grab) << "a pad with one tool: BTN_SOUTH grabs with it";
  EXPECT_EQ(mapper.drain(ring, 2099), 0u);
  EXPECT_EQ(mapper.late(), 0u) << "everything so far came on its tick";
  EXPECT_EQ(mapper.drain(ring, 5000), 1u);
  EXPECT_EQ(mapper.late(), 1u) << "the 2.1 s frame applied at tick 5000 came late";
}

class MapperTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ToolRouter router({{0, "", Stick::left}, {0, "", Stick::right}});
    MappingConfig cfg;
    cfg.dead_zone = 0.0f;
    binding = router.attach(0, testing::gamepad(), cfg);
    mapper.apply(InputMessage::attach(0, binding));
  }
  void frame(std::initializer_list<InputEvent> events) {
    InputFrame f;
    f.slot = 0;
    for (auto e : events) f.push(e);
    mapper.apply(InputMessage::of_frame(f));
  }
  const ToolControl& tool(std::size_t t) const { return mapper.controls()[t]; }
  ControlMapper mapper{2};
  DeviceBinding binding;
};

TEST_F(MapperTest, SticksTriggersAndShoulders) {
  frame({{EV_ABS, ABS_RX, -32768}, {EV_ABS, ABS_RY, 32767}});
  EXPECT_FLOAT_EQ(tool(1).stick[0], -1.0f);
  EXPECT_FLOAT_EQ(tool(1).stick[1], -1.0f);
  EXPECT_FLOAT_EQ(tool(0).stick[0], 0.0f);
  frame({{EV_ABS, ABS_Z, 255}});
  EXPECT_FLOAT_EQ(tool(0).stick[2], 1.0f);
  frame({{EV_KEY, BTN_TL, 1}});
  EXPECT_FLOAT_EQ(tool(0).stick[2], 0.0f) << "trigger in and shoulder out cancel";
  frame({{EV_ABS, ABS_Z, 0}});
  EXPECT_FLOAT_EQ(tool(0).stick[2], -1.0f);
  frame({{EV_ABS, ABS_X, 64}});
  EXPECT_FLOAT_EQ(tool(0).stick[0], 0.0f) << "inside the kernel's flat (128)";
}

TEST_F(MapperTest, ButtonCountersAreMonotonicAndCountPressesOnly) {
  for (int i = 0; i < 3; ++i) {
    frame({{EV_KEY, BTN_EAST, 1}});
    frame({{EV_KEY, BTN_EAST, 2}});  // autorepeat is not a press
    frame({{EV_KEY, BTN_EAST, 0}});
  }
  EXPECT_EQ(tool(1).shape_toggles, 3u);
  frame({{EV_KEY, BTN_NORTH, 1}, {EV_KEY, BTN_NORTH, 0}, {EV_KEY, BTN_NORTH, 1}});
  frame({{EV_KEY, BTN_WEST, 1}});
  EXPECT_EQ(tool(1).size_steps, 1);
  EXPECT_EQ(tool(0).size_steps, 0);
}

TEST_F(MapperTest, DetachCentresAndReleasesButKeepsCounters) {
  frame({{EV_ABS, ABS_RX, 32767}, {EV_KEY, BTN_SOUTH, 1}, {EV_KEY, BTN_EAST, 1}});
  EXPECT_TRUE(tool(1).grab);
  mapper.apply(InputMessage::detach(0));
  EXPECT_FALSE(tool(1).grab);
  EXPECT_FALSE(tool(1).connected);
  EXPECT_FLOAT_EQ(tool(1).stick[0], 0.0f);
  EXPECT_EQ(tool(1).shape_toggles, 1u);
  frame({{EV_KEY, BTN_SOUTH, 1}});  // frames for a detached slot are ignored
  EXPECT_FALSE(tool(1).grab);
  mapper.apply(InputMessage::attach(0, binding));  // back: same tools
  EXPECT_TRUE(tool(1).connected);
  frame({{EV_KEY, BTN_EAST, 1}});
  EXPECT_EQ(tool(1).shape_toggles, 2u);
}

TEST_F(MapperTest, TwoDevicesOnOneToolAdd) {
  ToolRouter router({{0, "", Stick::main}});
  const DeviceBinding b = router.attach(1, testing::flight_stick(), MappingConfig{});
  (void)b;
  DeviceBinding second = make_binding(testing::flight_stick(), default_mapping(testing::flight_stick()),
                                      {{1, Stick::main}});
  mapper.apply(InputMessage::attach(1, second));
  InputFrame f;
  f.slot = 1;
  f.push({EV_ABS, ABS_X, 1023});
  mapper.apply(InputMessage::of_frame(f));
  frame({{EV_ABS, ABS_RX, 32767}});
  EXPECT_FLOAT_EQ(tool(1).stick[0], 1.0f) << "sum clamps to 1";
  frame({{EV_ABS, ABS_RX, -32768}});
  EXPECT_NEAR(tool(1).stick[0], 0.0f, 1e-3);
}

TEST(ControlMapper, OutOfRangeSlotsAndToolsAreIgnored) {
  ControlMapper mapper(1);
  InputMessage m = InputMessage::detach(200);
  mapper.apply(m);
  DeviceBinding b;
  AxisBinding a;
  a.code = ABS_X;
  a.tool = 5;  // beyond the mapper's one tool
  a.calibration = calibrate({ABS_X, 0, -1, 1, 0, 0, 0}, 0, false);
  b.add_axis(a);
  mapper.apply(InputMessage::attach(0, b));
  InputFrame f;
  f.push({EV_ABS, ABS_X, 1});
  mapper.apply(InputMessage::of_frame(f));
  EXPECT_FLOAT_EQ(mapper.controls()[0].stick[0], 0.0f);
  EXPECT_EQ(mapper.controls().size(), 1u);
}

}  // namespace
}  // namespace sculpt::input
