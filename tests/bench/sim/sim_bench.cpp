// Microbenchmarks of the simulation core (meson test --benchmark). Numbers
// only; nothing here passes or fails on speed.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sim/baseline.hpp"
#include "sim/body.hpp"
#include "sim/strokes.hpp"
#include "sim/kernel_testing.hpp"
#include "sim/kernels.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace {

using namespace sculpt::sim;

Tool pressing(long tick) {
  Tool t;
  t.radius = 0.02;
  t.position = {0.0, 0.115 - 0.01 * std::min(tick, 50L) / 50.0, 0.0};
  return t;
}

// Over and over: ticks 0-199 press 10 mm in, 200-399 hold on and pull 20 mm out.
Tool press_then_pull(long tick) {
  const long phase = (tick - 1) % 400;
  Tool t;
  t.radius = 0.02;
  const double depth = phase < 200 ? 0.01 * phase / 200.0 : 0.01 - 0.02 * (phase - 200) / 200.0;
  t.position = {0.01 * std::sin(tick * 0.01), 0.115 - depth, 0.0};
  t.grab = phase >= 200;
  return t;
}

// Every vertex awake (sleeping off), a tool pressing: kernel throughput.
template <class S>
void BM_StepAllAwake(benchmark::State& state) {
  SimSettings s;
  s.sleep_speed = 0.0;
  World<S> w(s, 1);
  const TriangleMesh mesh = make_icosphere(0.1f, static_cast<int>(state.range(0)));
  w.add_body(mesh, Material{});
  w.wake_all(0);
  // range(1): 0 = auto (one-pass blocks), 1 = portable kernels, 2 = the fused pass in pieces.
  const kernel::testing::ScopedPortable portable_switch(state.range(1) == 1);
  const kernel::testing::ScopedBlockPieces pieces_switch(state.range(1) == 2);
  long tick = 0;
  for (auto _ : state) {
    const Tool t = pressing(tick++);
    w.step({&t, 1});
  }
  state.counters["vertices"] = static_cast<double>(mesh.positions.size());
  state.counters["ns_per_vertex_step"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * mesh.positions.size() * w.substeps(0),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetLabel(state.range(1) == 1 ? "portable" : state.range(1) == 2 ? "pieces" : "auto");
}
BENCHMARK_TEMPLATE(BM_StepAllAwake, float)
    ->Args({5, 0})
    ->Args({5, 2})
    ->Args({5, 1})
    ->Args({6, 0})
    ->Args({6, 2})
    ->Args({7, 0})
    ->Args({7, 1})  // 164k: the AVX2 gather kernel (auto) against the compiler's loop (portable)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(BM_StepAllAwake, double)->Args({5, 0})->Unit(benchmark::kMillisecond);

// Where a big mesh's force pass goes: the kernel over every block once, each
// neighbour load meeting the memory as a step does (range(2) = 0), against one
// block over and over, everything in L1 (1): the difference is what memory
// costs, the rest the kernel's own work. The same vertex count per iteration.
// range(0): icosphere subdivisions; range(1): 1 = from packed records.
void BM_ForcePass(benchmark::State& state) {
  BodyOptions options;
  options.packed = state.range(1) ? PackedRecords::always : PackedRecords::never;
  Body<float> b = make_body<float>(make_icosphere(0.1f, static_cast<int>(state.range(0))), Material{}, options, 1);
  std::vector<float> ax(b.n), ay(b.n), az(b.n);
  for (std::uint32_t i = 0; i < b.n; ++i)  // some motion, so the dampers have work
    b.wx[i] = 1e-6f * std::sin(0.1f * i), b.wy[i] = 1e-6f * std::cos(0.3f * i), b.wz[i] = 1e-6f * std::sin(0.7f * i);
  kernel::ForceArgs<float> fa = b.network_args();
  fa.packed = nullptr;  // set below, once packed
  fa.stiffness = 200, fa.damping = 0.05f, fa.anchor = 2, fa.anchor_damping = 0.05f, fa.inv_mass = 100, fa.inv_dt = 1000;
  fa.ax = ax.data(), fa.ay = ay.data(), fa.az = az.data();
  if (state.range(1)) {
    kernel::pack(fa, ForceModel::spring, kernel::Velocity::step, b.packed[0].data(), 0, b.n);
    fa.packed = b.packed[0].data();
  }
  const std::uint32_t hot = b.blocks / 2;
  float sink = 0;
  for (auto _ : state) {
    for (std::uint32_t k = 0; k < b.blocks; ++k) {
      const std::uint32_t blk = state.range(2) ? hot : k;
      sink += kernel::forces(fa, ForceModel::spring, kernel::Velocity::step, b.begin_of(blk), b.end_of(blk),
                             b.overflow_begin[blk], b.overflow_begin[blk + 1]);
    }
  }
  benchmark::DoNotOptimize(sink);
  state.counters["ns_per_vertex"] = benchmark::Counter(static_cast<double>(state.iterations()) * b.blocks * kernel::kBlock,
                                                       benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetLabel(std::string(state.range(1) ? "records" : "arrays") + (state.range(2) ? ", one block (L1)" : ", sweep"));
}
BENCHMARK(BM_ForcePass)
    ->Args({7, 0, 0})
    ->Args({7, 0, 1})
    ->Args({7, 1, 0})
    ->Args({7, 1, 1})
    ->Unit(benchmark::kMillisecond);

void BM_StepBaseline(benchmark::State& state) {
  const TriangleMesh mesh = make_icosphere(0.1f, static_cast<int>(state.range(0)));
  BaselineBody b(mesh, Material{}, SimSettings{});
  long tick = 0;
  for (auto _ : state) {
    const Tool t = pressing(tick++);
    b.step(&t);
  }
  state.counters["ns_per_vertex_step"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * mesh.positions.size() * b.substeps(),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_StepBaseline)->Arg(5)->Arg(7)->Unit(benchmark::kMillisecond);

// The realistic tick: sleeping on, one tool sculpting one spot.
void BM_StepSculpting(benchmark::State& state) {
  World<float> w(SimSettings{}, 1);
  w.add_body(make_icosphere(0.1f, static_cast<int>(state.range(0))), Material{});
  long tick = 0;
  for (auto _ : state) {
    const Tool t = pressing(tick++);
    w.step({&t, 1});
  }
}
BENCHMARK(BM_StepSculpting)->Arg(7)->Unit(benchmark::kMicrosecond);

// Clay being sculpted, sleeping on: a tool presses in, then grabs and pulls
// (the clay yields and the grabbed blocks of the fused pass), over and over.
// range(1) as in BM_StepAllAwake: 0 auto, 1 portable kernels, 2 the fused pass in pieces.
void BM_StepClaySculpting(benchmark::State& state) {
  World<float> w(SimSettings{}, 1);
  Material clay;
  clay.plastic = true;
  w.add_body(make_icosphere(0.1f, static_cast<int>(state.range(0))), clay);
  const kernel::testing::ScopedPortable portable_switch(state.range(1) == 1);
  const kernel::testing::ScopedBlockPieces pieces_switch(state.range(1) == 2);
  long tick = 0;
  for (auto _ : state) {
    const Tool t = press_then_pull(++tick);
    w.step({&t, 1});
  }
  state.SetLabel(state.range(1) == 1 ? "portable" : state.range(1) == 2 ? "pieces" : "auto");
}
BENCHMARK(BM_StepClaySculpting)->Args({7, 0})->Args({6, 0})->Args({6, 2})->Args({6, 1})->Unit(benchmark::kMicrosecond);

// Clay, every vertex awake, pressed then grabbed and pulled: the records path
// (the double buffer of packed records, range(1) = 1) against the arrays path
// (0) on the same mesh. range(0): icosphere subdivisions (6: 41k, 7: 164k).
void BM_StepClayPath(benchmark::State& state) {
  World<float> w(SimSettings{}, 1);
  Material clay;
  clay.plastic = true;
  BodyOptions options;
  options.packed = state.range(1) ? PackedRecords::always : PackedRecords::never;
  const TriangleMesh mesh = make_icosphere(0.1f, static_cast<int>(state.range(0)));
  w.add_body(mesh, clay, options);
  long tick = 0;
  for (auto _ : state) {
    w.wake_all(0);
    const Tool t = press_then_pull(++tick);
    w.step({&t, 1});
  }
  state.counters["ns_per_vertex_step"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * mesh.positions.size() * w.substeps(0),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetLabel(name(w.step_path(0)));
}
BENCHMARK(BM_StepClayPath)->Args({6, 1})->Args({6, 0})->Args({7, 1})->Args({7, 0})->Unit(benchmark::kMillisecond);

// Nothing touches the scene: everything sleeps.
void BM_StepIdle(benchmark::State& state) {
  World<float> w(SimSettings{}, 2);
  w.add_body(make_icosphere(0.1f, 7), Material{});
  w.add_body(make_torus(0.3f, 0.05f, 256, 64), Material{});
  for (auto _ : state) w.step({});
}
BENCHMARK(BM_StepIdle)->Unit(benchmark::kNanosecond);

// Keeps the images of body 0's strokes (the latest stroke's, once it closes).
class KeepImages : public StrokeSink {
 public:
  void opened(std::uint32_t, std::uint64_t) override { blocks.clear(), images.clear(), open = true; }
  void captured(std::uint32_t, std::uint32_t block, std::span<const std::byte> image) override {
    blocks.push_back(block);
    images.emplace_back(image.begin(), image.end());
  }
  void closed(std::uint32_t, const StrokeSummary& e) override { open = false, stroke = e; }
  std::vector<std::uint32_t> blocks;
  std::vector<std::vector<std::byte>> images;
  StrokeSummary stroke;
  bool open = false;
};

// A recorded stroke on the 164k sphere: a tool presses 30 mm in over 200
// ticks, holds 100, leaves, and the sphere settles for 200 more (then the
// stroke is closed, as the daemon does before an undo). Built once per
// material: the stroke takes a while, and every repetition swaps the same.
struct RecordedStroke {
  World<float> world{SimSettings{}, 1};
  KeepImages sink;
};
RecordedStroke& recorded_stroke(bool clay) {
  static std::unique_ptr<RecordedStroke> strokes[2];
  std::unique_ptr<RecordedStroke>& r = strokes[clay];
  if (r) return *r;
  r = std::make_unique<RecordedStroke>();
  Material m;
  m.plastic = clay;
  r->world.add_body(make_icosphere(0.1f, 7), m);
  r->world.set_stroke_sink(&r->sink);
  for (long tick = 0; tick < 500; ++tick) {
    Tool t;
    t.radius = 0.02;
    t.position = {0.0, 0.125 - 0.035 * std::min(tick, 200L) / 200.0, 0.0};
    t.active = tick < 300;
    r->world.step({&t, 1});
  }
  r->world.close_strokes();
  r->world.set_stroke_sink(nullptr);
  return *r;
}

// Undo of that stroke: the images it captured swapped back into the world.
// Each iteration swaps them once: undo, then redo, the same work. range(0):
// 0 elastic, 1 clay; range(1): 0 the stroke's blocks, 1 every block of the
// body (the worst case).
void BM_UndoStroke(benchmark::State& state) {
  RecordedStroke& r = recorded_stroke(state.range(0) == 1);
  World<float>& w = r.world;
  std::vector<std::uint32_t> blocks = r.sink.blocks;
  std::vector<std::vector<std::byte>> images = r.sink.images;
  if (state.range(1)) {
    blocks.clear(), images.clear();
    for (std::uint32_t blk = 0; blk < w.body(0).blocks; ++blk) {
      blocks.push_back(blk);
      images.emplace_back(w.block_image_bytes(0));
      w.block_image(0, blk, images.back());
    }
  }
  for (auto _ : state)
    for (std::size_t q = 0; q < blocks.size(); ++q) w.exchange_block_image(0, blocks[q], images[q]);
  if (state.iterations() % 2) // leave the world as recorded for the next run
    for (std::size_t q = 0; q < blocks.size(); ++q) w.exchange_block_image(0, blocks[q], images[q]);
  std::uint32_t vertices = 0;
  for (std::uint32_t blk : blocks) vertices += w.body(0).end_of(blk) - w.body(0).begin_of(blk);
  state.counters["blocks"] = static_cast<double>(blocks.size());
  state.counters["vertices"] = vertices;
  state.counters["image_bytes"] = static_cast<double>(w.block_image_bytes(0));
  state.counters["MB_swapped"] = static_cast<double>(blocks.size() * w.block_image_bytes(0)) / 1e6;
  state.SetLabel(std::string(state.range(0) ? "clay, " : "elastic, ") + (state.range(1) ? "every block" : "the stroke") +
                 ", " + name(w.step_path(0)) + " path");
}
BENCHMARK(BM_UndoStroke)->Args({0, 0})->Args({0, 1})->Args({1, 0})->Args({1, 1})->Unit(benchmark::kMillisecond);

void BM_BuildBody(benchmark::State& state) {
  const TriangleMesh mesh = make_icosphere(0.1f, static_cast<int>(state.range(0)));
  for (auto _ : state) {
    World<float> w(SimSettings{}, 1);
    benchmark::DoNotOptimize(w.add_body(mesh, Material{}));
  }
}
BENCHMARK(BM_BuildBody)->Arg(6)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
