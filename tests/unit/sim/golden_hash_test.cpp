// The same scripted sculpt must give the same bits in every build: GCC and
// clang, the AVX2 clone, the AVX2 packed path and the plain x86-64 code. This
// file is linked twice: against sculpt_sim (target clones; on an AVX2 CPU the
// AVX2 code runs) and against sculpt_sim_noclones (baseline x86-64 only).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/kernels.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace sculpt::sim {
namespace {

std::uint64_t run(Integrator integrator, ForceModel model) {
  SimSettings s;
  s.integrator = integrator;
  World<float> w(s, 1);
  Material m;
  m.model = model;
  m.plastic = true;
  w.add_body(make_icosphere(0.1f, 3), m);
  Tool t;
  t.radius = 0.02;
  for (int n = 0; n < 300; ++n) {
    t.position = {0.01 * std::sin(n * 0.02), 0.125 - 0.02 * std::min(n, 150) / 150.0, 0.0};
    w.step({&t, 1});
  }
  return w.hash();
}

TEST(Determinism, GoldenHashes) {
  for (bool portable : {false, true}) {
    kernel::force_portable(portable);
    EXPECT_EQ(run(Integrator::position_verlet, ForceModel::spring), 0x67cc902b9297d3efull);
    EXPECT_EQ(run(Integrator::position_verlet, ForceModel::linear), 0x39a48e78cdf391afull);
    EXPECT_EQ(run(Integrator::symplectic_euler, ForceModel::spring), 0xf94d87994dde39fdull);
    EXPECT_EQ(run(Integrator::velocity_verlet, ForceModel::spring), 0x6d5696d8162f7e4full);
  }
  kernel::force_portable(false);
  RecordProperty("clone", kernel::active_clone());
}

}  // namespace
}  // namespace sculpt::sim
