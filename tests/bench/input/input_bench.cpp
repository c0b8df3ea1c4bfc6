// What the input path costs: the sim thread's per-frame ControlMapper work,
// and reading a shipped recording (the io thread's ReplaySource). Numbers only.
#include <benchmark/benchmark.h>

#include <linux/input.h>

#include "input/control_mapper.hpp"
#include "input/mapping.hpp"
#include "input/recording.hpp"
#include "input/replay_source.hpp"

namespace sculpt::input {
namespace {

DeviceInfo pad() {
  DeviceInfo d;
  d.name = "bench pad";
  for (std::uint16_t c : {ABS_X, ABS_Y, ABS_RX, ABS_RY}) d.axes.push_back({c, 0, -32768, 32767, 16, 128, 0});
  d.axes.push_back({ABS_Z, 0, 0, 1023, 0, 0, 0});
  d.axes.push_back({ABS_RZ, 0, 0, 1023, 0, 0, 0});
  d.buttons = {BTN_SOUTH, BTN_EAST, BTN_NORTH, BTN_WEST, BTN_TL, BTN_TR};
  d.kind = DeviceKind::gamepad;
  return d;
}

// A typical report: two axes of one stick move.
void BM_ControlMapperFrame(benchmark::State& state) {
  ToolRouter router({{0, "", Stick::left}, {0, "", Stick::right}});
  ControlMapper mapper(2);
  mapper.apply(InputMessage::attach(0, router.attach(0, pad(), MappingConfig{})));
  InputFrame f;
  f.push({EV_ABS, ABS_X, 1000});
  f.push({EV_ABS, ABS_Y, -2000});
  InputMessage m = InputMessage::of_frame(f);
  std::int32_t v = 0;
  for (auto _ : state) {
    m.frame.events[0].value = (v += 7919) % 32768;
    mapper.apply(m);
    benchmark::DoNotOptimize(mapper.controls()[0].stick[0]);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ControlMapperFrame);

void BM_Normalize(benchmark::State& state) {
  const AxisCalibration c = calibrate({ABS_X, 0, -32768, 32767, 16, 128, 0}, 0.05f, false);
  std::int32_t v = 0;
  for (auto _ : state) {
    v = (v + 7919) % 65536 - 32768;
    benchmark::DoNotOptimize(c.normalize(v));
  }
}
BENCHMARK(BM_Normalize);

// Reading a whole shipped recording through ReplaySource, per frame.
void BM_ReplaySourceRecording(benchmark::State& state) {
  const std::string file = std::string(SCULPT_RECORDINGS_DIR) + "/bench_sculpt.jsonl";
  std::size_t frames = 0;
  for (auto _ : state) {
    ReplaySource src(file, 1000.0, {});
    src.start(1);
    while (auto m = src.next()) {
      benchmark::DoNotOptimize(m->at_tick);
      ++frames;
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(frames));
}
BENCHMARK(BM_ReplaySourceRecording)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace sculpt::input

BENCHMARK_MAIN();
