// What the haptics cost (meson test --benchmark). Numbers only.
//  - FeedbackBoard::publish runs on the real-time sim thread every tick;
//  - constant_from_force and one HapticsEngine::poll run on the haptics
//    thread every poll (fake devices here: the kernel's share is the VM's).
#include <benchmark/benchmark.h>

#include <cmath>

#include "fake_port.hpp"
#include "haptics/effect_math.hpp"
#include "haptics/feedback_board.hpp"
#include "haptics/haptics_engine.hpp"

namespace {

using namespace sculpt::haptics;

void BM_BoardPublish(benchmark::State& state) {
  FeedbackBoard board(2);
  sculpt::haptics::Felt f;
  f.contacts = 12;
  double x = 0;
  for (auto _ : state) {
    f.force = {x, -x, 0.5};
    x += 1e-3;
    board.publish(0, f);
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_BoardPublish);

void BM_BoardRead(benchmark::State& state) {
  FeedbackBoard board(2);
  board.publish(0, {});
  for (auto _ : state) benchmark::DoNotOptimize(board.read(0));
}
BENCHMARK(BM_BoardRead);

void BM_ConstantFromForce(benchmark::State& state) {
  const ForceScale scale;
  const StickPlane plane{0, 2, 1.0, -1.0};
  double a = 0;
  for (auto _ : state) {
    a += 0.01;
    const StickForce s = project_to_stick({std::cos(a), 0.3, std::sin(a)}, plane);
    const double level = tuned(level_from_force(std::hypot(s.x, s.y), true, scale), DeviceTuning{0.8, 0.9});
    benchmark::DoNotOptimize(constant_from_level(s, level));
  }
}
BENCHMARK(BM_ConstantFromForce);

// One poll over N attached FF devices whose force changes every poll (the
// interval set to 0 so every poll uploads: the worst case).
void BM_EnginePoll(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  FeedbackBoard board(n);
  HapticsStats stats;
  HapticsSettings settings;
  settings.pacing.other = std::chrono::milliseconds(0);
  std::vector<std::shared_ptr<sculpt::haptics::testing::FakeDeviceState>> devices;
  HapticsEngine engine(board, settings, [&](const std::string& node) -> std::unique_ptr<FfPort> {
    devices.push_back(sculpt::haptics::testing::fake_device({FF_CONSTANT, FF_RUMBLE}, 16));
    return std::make_unique<sculpt::haptics::testing::FakePort>(devices.back(), node);
  }, stats);
  for (int i = 0; i < n; ++i) engine.attach(i, "/dev/input/event" + std::to_string(i), {{i, StickPlane{}}});
  sculpt::haptics::Felt f;
  double a = 0;
  for (auto _ : state) {
    state.PauseTiming();
    a += 0.5;
    f.force = {1.5 * std::cos(a), 0, 1.5 * std::sin(a)};
    f.touching = true;
    for (int i = 0; i < n; ++i) board.publish(i, f);
    for (auto& d : devices) d->calls.clear();
    state.ResumeTiming();
    engine.poll();
  }
  state.counters["uploads"] = static_cast<double>(stats.ff.uploads.load());
}
BENCHMARK(BM_EnginePoll)->Arg(1)->Arg(4);

}  // namespace

BENCHMARK_MAIN();
