// The same scripted sculpt must give the same bits in every build: GCC and
// clang, the AVX2 clone, the AVX2 packed path and the plain x86-64 code. This
// file is linked twice: against sculpt_sim (target clones; on an AVX2 CPU the
// AVX2 code runs) and against sculpt_sim_noclones (baseline x86-64 only).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/kernel_testing.hpp"
#include "sim/kernels.hpp"
#include "sim/shapes.hpp"
#include "sim/world.hpp"
#include "test_meshes.hpp"

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

// The narrow phase's every branch: a capsule sweeping across a coarse clay
// box (faces pushed by the triangle pass, edges and corners, vertices), and a
// tool thinner than the faces pressing through the middle of one.
std::uint64_t run_tools() {
  World<float> w(SimSettings{}, 2);
  Material m;
  m.plastic = true;
  w.add_body(make_box_grid({0.2f, 0.1f, 0.2f}, 6), m);
  Tool capsule;
  capsule.shape = ToolShape::capsule;
  capsule.radius = 0.012;
  capsule.half_axis = {0.0, 0.0, 0.03};
  Tool thin;
  thin.radius = 0.003;
  const Tool none{.active = false};
  std::uint64_t contacts[2] = {0, 0};
  for (int n = 0; n < 300; ++n) {
    capsule.position = {-0.12 + 0.0008 * n, 0.058 - 0.012 * std::min(n, 100) / 100.0, 0.01 * std::sin(n * 0.05)};
    thin.position = {0.013, 0.06 - 0.015 * std::min(n, 200) / 200.0, 0.017};
    const Tool tools[2] = {capsule, n < 250 ? thin : none};
    w.step(tools);
    for (int t = 0; t < 2; ++t) contacts[t] += w.feedback()[t].contacts;
  }
  EXPECT_GT(contacts[0], 100u) << "the capsule never touched the box";
  EXPECT_GT(contacts[1], 0u) << "the thin tool never touched the box";
  return w.hash();
}

// An elastic sphere (no clay: its blocks integrate from the acceleration
// pool as soon as no later block reads them) pushed by one tool while another
// grabs and pulls, and a 164-block body, so blocks wait across Morton seams.
// With records `always` the float bodies keep the double buffer of packed
// records; with `never` (and by default) they step through the ring of packed
// records on AVX2 and gather from the arrays on the portable kernels: the same
// bits again. (These three hashes changed when springs reaching farther than
// kernel::kRingReach blocks moved from the ELL columns to the overflow list,
// which sums them after the columns: the torus has 164 blocks.)
std::uint64_t run_elastic(Integrator integrator, PackedRecords records, ForceModel model = ForceModel::spring) {
  SimSettings s;
  s.integrator = integrator;
  World<float> w(s, 2);
  Material m;
  m.gravity = true;  // every block awake from the start, sagging against its anchor
  m.model = model;
  BodyOptions options;
  options.packed = records;
  w.add_body(make_icosphere(0.1f, 4), m, options);
  w.add_body(make_torus(0.3f, 0.05f, 128, 164), m, options);
  Tool push, grab;
  push.radius = 0.02;
  grab.radius = 0.015;
  for (int n = 0; n < 200; ++n) {
    push.position = {0.01 * std::sin(n * 0.02), 0.125 - 0.03 * std::min(n, 100) / 100.0, 0.0};
    grab.position = {0.0, -0.1 - 0.03 * std::max(0, n - 50) / 150.0, 0.0};
    grab.grab = n >= 40 && n < 170;
    const Tool tools[2] = {push, grab};
    w.step(tools);
  }
  return w.hash();
}

TEST(Determinism, GoldenHashes) {
  // Without the AVX2 paths (sculpt_sim_noclones, or a CPU without AVX2) the
  // portable switch changes nothing: the same code would run twice.
  const bool avx2 = kernel::avx2_paths_active();
  for (bool portable : {false, true}) {
    if (portable && !avx2) break;
    const kernel::testing::ScopedPortable portable_switch(portable);
    EXPECT_EQ(run(Integrator::position_verlet, ForceModel::spring), 0xf7b107560496edd0ull);
    EXPECT_EQ(run(Integrator::position_verlet, ForceModel::linear), 0x17d0af615caadcaeull);
    EXPECT_EQ(run(Integrator::symplectic_euler, ForceModel::spring), 0x12a043c34a76d029ull);
    EXPECT_EQ(run(Integrator::velocity_verlet, ForceModel::spring), 0x6d5696d8162f7e4full);
    EXPECT_EQ(run_tools(), 0xdda2bb4260c02c16ull);
    struct Elastic {
      Integrator integrator;
      ForceModel model;
      std::uint64_t hash;
    };
    const Elastic elastic[] = {{Integrator::position_verlet, ForceModel::spring, 0xe3232ea22f3890d9ull},
                               {Integrator::symplectic_euler, ForceModel::spring, 0x0c1263b0e9ac0cc2ull},
                               {Integrator::position_verlet, ForceModel::linear, 0xa4174e3d4a6ef1e9ull}};
    for (int r = 0; r < 2; ++r)
      for (int e = 0; e < 3; ++e) {
        // Sanitized, each scene once (its bits are the point here): on the
        // AVX2 kernels the first two, the third portable; the layouts
        // alternate. sim_determinism's RingSameBits… and FarSprings… take a
        // torus through every step path and kernel in the sanitized build.
        if (test::kSanitized && ((r + e) % 2 != 0 || portable != (avx2 && e == 2))) continue;
        const PackedRecords records = r == 0 ? PackedRecords::always : PackedRecords::never;
        EXPECT_EQ(run_elastic(elastic[e].integrator, records, elastic[e].model), elastic[e].hash)
            << "elastic " << e << ", records " << (r == 0 ? "always" : "never") << ", portable " << portable;
      }
  }
  RecordProperty("clone", kernel::active_clone());
}

}  // namespace
}  // namespace sculpt::sim
