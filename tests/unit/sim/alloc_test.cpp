// After setup, World::step allocates nothing: every operator new in this
// binary is counted.
#include <gtest/gtest.h>

#include "sim/strokes.hpp"
#include "sim/kernels.hpp"
#include "test_meshes.hpp"
#include "support/allocation_counter.hpp"


namespace sculpt::sim {
namespace {

TEST(RealTime, StepDoesNotAllocate) {
  for (Integrator integrator : {Integrator::position_verlet, Integrator::velocity_verlet}) {
    SimSettings s;
    s.integrator = integrator;
    World<float> w(s, 2);
    Material clay;
    clay.plastic = true;
    w.add_body(make_icosphere(0.1f, 4), clay);
    w.add_body(make_torus(0.1f, 0.03f, 32, 16), Material{});
    // Elastic and sagging, so every block steps through the ring each tick (on
    // AVX2, Verlet): 164 blocks (sanitized 112), springs past its reach, far records.
    Material sagging;
    sagging.gravity = true;
    w.add_body(test::far_spring_torus(), sagging);
    Tool tools[2];
    tools[0].radius = 0.02;
    tools[1].radius = 0.01;
    tools[1].shape = ToolShape::capsule;
    tools[1].half_axis = {0.02, 0, 0};
    support::count_allocations_on_this_thread(true);
    const long before = support::counted_allocations();
    for (int n = 0; n < 400; ++n) {
      tools[0].position = {0.0, 0.125 - 0.03 * std::min(n, 200) / 200.0, 0.0};
      tools[1].position = {0.1, 0.04, 0.0};
      tools[1].grab = n > 100 && n < 300;
      if (n == 350) tools[0].position = {0.0, 0.0, 0.0};  // teleport inside
      w.step(tools);
      (void)w.changes();
      (void)w.feedback();
    }
    EXPECT_EQ(support::counted_allocations() - before, 0);
    support::count_allocations_on_this_thread(false);
    EXPECT_GT(w.body(0).n, 0u);
    if (kernel::avx2_paths_active() && integrator == Integrator::position_verlet) {
      EXPECT_GT(w.body(1).ring_epoch, 0u) << "the small elastic torus must have stepped through the ring";
      EXPECT_GT(w.body(2).ring_epoch, 0u);
      EXPECT_FALSE(w.body(2).far_vertices.empty());
    }
  }
}

// A stroke sink that keeps nothing (a checksum), so what is counted is the
// world's own capture, and undo's exchanges.
class ChecksumSink : public StrokeSink {
 public:
  void opened(std::uint32_t, std::uint64_t) override { ++opened_; }
  void captured(std::uint32_t, std::uint32_t, std::span<const std::byte> image) override {
    ++captured_;
    for (std::byte c : image) sum_ += static_cast<unsigned>(c);
  }
  void closed(std::uint32_t, const StrokeSummary&) override { ++closed_; }
  long opened_ = 0, captured_ = 0, closed_ = 0;
  unsigned long sum_ = 0;
};

TEST(RealTime, CapturingStrokesAndExchangingImagesDoNotAllocate) {
  World<float> w(SimSettings{}, 2);
  Material clay;
  clay.plastic = true;
  w.add_body(make_icosphere(0.1f, 4), clay);
  w.add_body(test::far_spring_torus(), Material{});  // the ring path, far springs
  ChecksumSink sink;
  w.set_stroke_sink(&sink);
  std::vector<std::byte> images[2];
  for (std::uint32_t b = 0; b < 2; ++b) {
    images[b].resize(w.block_image_bytes(b));
    w.block_image(b, 3, images[b]);
  }
  Tool tools[2];
  tools[0].radius = 0.02;
  tools[1].radius = 0.03;
  support::count_allocations_on_this_thread(true);
  const long before = support::counted_allocations();
  for (int n = 0; n < 400; ++n) {
    tools[0].position = {0.0, 0.125 - 0.03 * std::min(n, 200) / 200.0, 0.0};
    tools[1].position = {0.3, 0.05, 0.0};
    tools[1].grab = n > 100 && n < 200;
    if (n > 300) tools[0].active = tools[1].active = false;
    w.step(tools);
  }
  w.close_strokes();
  for (int k = 0; k < 10; ++k)
    for (std::uint32_t b = 0; b < 2; ++b) w.exchange_block_image(b, 3, images[b]);
  for (int n = 0; n < 20; ++n) w.step({});
  EXPECT_EQ(support::counted_allocations() - before, 0);
  support::count_allocations_on_this_thread(false);
  EXPECT_GE(sink.opened_, 2);
  EXPECT_GT(sink.captured_, 0);
  EXPECT_EQ(sink.closed_, sink.opened_);
  w.set_stroke_sink(nullptr);
}

}  // namespace
}  // namespace sculpt::sim
