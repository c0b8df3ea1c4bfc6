// sculptd's real sim-thread stages (input ring → ControlMapper → ToolDriver,
// World::step, FeedbackBoard) allocate nothing once the thread runs, while
// devices attach, frames stream in and a tool presses into a mesh.
#include <gtest/gtest.h>

#include <linux/input.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <new>
#include <thread>

#include "haptics/feedback_board.hpp"
#include "input/input_message.hpp"
#include "loop/sim_thread.hpp"
#include "main/pipeline.hpp"
#include "sim/shapes.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<std::thread::id> g_sim_thread{};
std::atomic<long> g_allocations{0};
void count() {
  if (g_counting.load(std::memory_order_relaxed) && std::this_thread::get_id() == g_sim_thread.load())
    g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

void* operator new(std::size_t n) {
  count();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, std::align_val_t a) {
  count();
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  count();
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  count();
  const std::size_t al = static_cast<std::size_t>(a);
  return std::aligned_alloc(al, (n + al - 1) / al * al);
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t& t) noexcept {
  return operator new(n, a, t);
}
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace sculpt::daemon {
namespace {

using namespace std::chrono_literals;

// Marks the sim thread, then forwards to the real stages.
struct Marking : loop::TickStages {
  explicit Marking(SculptStages& s) : stages(s) {}
  SculptStages& stages;
  void input(std::uint64_t tick, std::span<sim::Tool> tools) override {
    if (g_sim_thread.load() != std::this_thread::get_id()) g_sim_thread = std::this_thread::get_id();
    stages.input(tick, tools);
  }
  void publish(std::uint64_t tick, const sim::World<float>& world) override { stages.publish(tick, world); }
};

TEST(Pipeline, TheSimThreadAllocatesNothingWhileSculpting) {
  sim::World<float> world(sim::SimSettings{}, 1);
  world.add_body(sim::make_icosphere(0.05f, 3), sim::Material{});
  haptics::FeedbackBoard board(1);
  loop::DriverLimits limits;
  limits.bounds = loop::Box{{-1, -1, -1}, {1, 1, 1}};
  loop::ToolSpec spec;
  spec.position = {0, 0.09, 0};
  spec.speed = 0.5;
  SculptStages stages(loop::ToolDriver({spec}, limits, 1000.0), board, 256);
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

  loop::SimThreadOptions o;
  o.max_ticks = 600;
  loop::SimThread thread(world, marking, 1, o);
  g_allocations = 0;
  g_counting = true;
  thread.start();
  // Frames keep arriving while it runs: full deflection down.
  for (int i = 0; i < 200 && !thread.finished(); ++i) {
    input::InputFrame f;
    f.slot = 0;
    f.push({EV_ABS, ABS_Y, 511});
    f.push({EV_SYN, SYN_REPORT, 0});
    stages.ring().try_push(input::InputMessage::of_frame(f));
    std::this_thread::sleep_for(1ms);
  }
  while (!thread.finished()) std::this_thread::sleep_for(1ms);
  thread.stop();
  g_counting = false;
  EXPECT_GT(stages.applied(), 1u);
  EXPECT_GT(board.read(0).onsets, 0u) << "the tool never touched the ball";
  EXPECT_EQ(g_allocations.load(), 0) << "the sim thread allocated";
}

}  // namespace
}  // namespace sculpt::daemon
