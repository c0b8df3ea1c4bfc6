// After setup, World::step allocates nothing: every operator new in this
// binary is counted.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "sim_test_util.hpp"

namespace {
std::atomic<long> g_allocations{0};
}

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, std::align_val_t a) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
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
    Tool tools[2];
    tools[0].radius = 0.02;
    tools[1].radius = 0.01;
    tools[1].shape = ToolShape::capsule;
    tools[1].half_axis = {0.02, 0, 0};
    const long before = g_allocations.load();
    for (int n = 0; n < 400; ++n) {
      tools[0].position = {0.0, 0.125 - 0.03 * std::min(n, 200) / 200.0, 0.0};
      tools[1].position = {0.1, 0.04, 0.0};
      tools[1].grab = n > 100 && n < 300;
      if (n == 350) tools[0].position = {0.0, 0.0, 0.0};  // teleport inside
      w.step(tools);
      (void)w.changes();
      (void)w.feedback();
    }
    EXPECT_EQ(g_allocations.load() - before, 0);
    EXPECT_GT(w.body(0).n, 0u);
  }
}

}  // namespace
}  // namespace sculpt::sim
