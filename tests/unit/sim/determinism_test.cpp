// Determinism: the same scene and inputs give the same bits on every path
// the simulation can take (AVX2 and portable kernels, packed records, the
// ring, block pieces, far springs, clay yields, grabs, pins).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <vector>

#include "sim/kernel_testing.hpp"
#include "sim/kernels.hpp"
#include "test_meshes.hpp"

namespace sculpt::sim {
namespace {

// (Sanitized, a 642-vertex sphere, not 2 562: whole blocks and a partial one
// all the same, on the same step paths.)
std::uint64_t scripted_run(Integrator integrator) {
  SimSettings s;
  s.integrator = integrator;
  World<float> w(s, 2);
  Material clay;
  clay.plastic = true;
  BodyOptions pins;
  pins.pinned = {0, 5, 17, 100, test::kSanitized ? 600u : 2000u};
  w.add_body(make_icosphere(0.1f, test::kSanitized ? 3 : 4), clay, pins);
  Material linear_clay;
  linear_clay.model = ForceModel::linear;
  linear_clay.plastic = true;
  w.add_body(make_torus(0.1f, 0.03f, 48, 24), linear_clay);
  // A cone whose apex has degree 40: the ELL overflow path.
  TriangleMesh cone;
  cone.positions.push_back({0.0f, 0.15f, 0.0f});
  for (int k = 0; k < 40; ++k) cone.positions.push_back({0.05f * std::cos(k * 0.157f), 0.1f, 0.05f * std::sin(k * 0.157f)});
  cone.positions.push_back({0.0f, 0.1f, 0.0f});
  for (std::uint32_t k = 1; k <= 40; ++k) {
    cone.triangles.push_back({0, k % 40 + 1, k});
    cone.triangles.push_back({41, k, k % 40 + 1});
  }
  w.add_body(cone, Material{});
  Tool a, b;
  a.radius = 0.02;
  b.shape = ToolShape::capsule;
  b.radius = 0.01;
  b.half_axis = {0.0, 0.0, 0.03};
  for (int n = 0; n < 400; ++n) {
    a.position = {0.02 * std::sin(n * 0.01), 0.125 - 0.02 * std::min(n, 200) / 200.0, 0.0};
    b.position = {0.1, 0.045 - 0.01 * std::min(n, 100) / 100.0, 0.0};
    b.grab = n > 250;
    const Tool tools[2] = {a, b};
    w.step(tools);
  }
  return w.hash();
}

// scripted_run's hash on the default kernels, run once per integrator for
// all the tests here.
std::uint64_t first_run(Integrator integrator) {
  static std::map<Integrator, std::uint64_t> hashes;
  const auto it = hashes.find(integrator);
  return it != hashes.end() ? it->second : hashes[integrator] = scripted_run(integrator);
}

TEST(Determinism, SameInputsSameBits) {
  for (Integrator i : {Integrator::position_verlet, Integrator::velocity_verlet, Integrator::symplectic_euler})
    EXPECT_EQ(first_run(i), scripted_run(i));
  EXPECT_NE(first_run(Integrator::position_verlet), first_run(Integrator::symplectic_euler))
      << "the hash sees the positions";
}

// The AVX2 packed-gather path and the portable kernels (target clones) do the
// same IEEE operations in the same order: identical bits, not just close.
TEST(Determinism, Avx2PathMatchesPortableKernels) {
  kernel::testing::force_portable(true);
  const std::uint64_t portable = scripted_run(Integrator::position_verlet);
  const std::uint64_t portable_se = scripted_run(Integrator::symplectic_euler);
  kernel::testing::force_portable(false);
  EXPECT_EQ(portable, first_run(Integrator::position_verlet));
  EXPECT_EQ(portable_se, first_run(Integrator::symplectic_euler));
}

// Spring-model clay, pressed and then grabbed and pulled: the fused pass marks
// the yields while it computes the forces (and steps the grabbed blocks in
// pieces inside it); the portable kernels and the pieces path test and step
// separately. All three must give the same bits.
std::uint64_t rest_shape_hash(const Body<float>& b) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a over the bits
  auto mix = [&](float v) { h = (h ^ std::bit_cast<std::uint32_t>(v)) * 1099511628211ull; };
  for (std::uint32_t i = 0; i < b.n; ++i) mix(b.rx[i]), mix(b.ry[i]), mix(b.rz[i]);
  for (std::size_t e = 0; e < b.rest_length.size(); ++e) mix(b.rest_length[e]);
  return h;
}

struct ClayGrabRun {
  std::uint64_t positions = 0, rest_before = 0, rest_after = 0;
  std::uint32_t held_at_end = 0;  // vertices the grab holds on the last tick, 10 mm above the surface
};

ClayGrabRun clay_grab_run() {
  World<float> w(SimSettings{}, 1);
  Material clay;
  clay.plastic = true;
  w.add_body(make_icosphere(0.1f, 4), clay);  // 2562 vertices: whole blocks and a partial one
  ClayGrabRun r;
  r.rest_before = rest_shape_hash(w.body(0));
  Tool t;
  t.radius = 0.02;
  for (int n = 0; n < 400; ++n) {
    // Press 15 mm in, then grab and pull 25 mm out.
    const double depth = n < 150 ? 0.015 * n / 150.0 : 0.015 - 0.025 * std::min(n - 200, 150) / 150.0 * (n >= 200);
    t.position = {0.003 * std::sin(n * 0.05), 0.12 - depth, 0.0};
    t.grab = n >= 180;
    w.step({&t, 1});
  }
  EXPECT_TRUE(test::all_finite(w));
  r.held_at_end = w.body(0).tools[0].grab_count;
  r.rest_after = rest_shape_hash(w.body(0));
  r.positions = w.hash();
  return r;
}

TEST(Determinism, FusedClayYieldsAndGrabsMatchPortableKernels) {
  kernel::testing::force_portable(true);
  const ClayGrabRun portable = clay_grab_run();
  kernel::testing::force_portable(false);
  if (!kernel::avx2_paths_active()) GTEST_SKIP() << "no AVX2 here: the fused pass cannot run";
  EXPECT_GT(portable.held_at_end, 0u) << "the grab must still hold vertices when it has pulled out";
  EXPECT_NE(portable.rest_after, portable.rest_before) << "the clay must have yielded";
  for (bool pieces : {false, true}) {
    kernel::testing::force_block_pieces(pieces);
    const ClayGrabRun r = clay_grab_run();
    EXPECT_EQ(r.positions, portable.positions) << (pieces ? "pieces" : "fused");
    EXPECT_EQ(r.rest_after, portable.rest_after) << (pieces ? "pieces" : "fused");
  }
  kernel::testing::force_block_pieces(false);
}

// A cone with 400 rim vertices: the apex and the base centre have degree 400+,
// so whole (not only partial) blocks carry ELL overflow entries, which the
// one-pass block kernel adds after the columns.
std::uint64_t big_cone_run(Integrator integrator, ForceModel model, bool& full_block_overflow) {
  SimSettings s;
  s.integrator = integrator;
  World<float> w(s, 1);
  const TriangleMesh cone = test::closed_cone(400);
  Material m;
  m.model = model;
  m.plastic = true;
  w.add_body(cone, m);
  const Body<float>& b = w.body(0);
  full_block_overflow = false;
  for (std::uint32_t blk = 0; blk + 1 < b.blocks; ++blk)
    full_block_overflow = full_block_overflow || b.overflow_begin[blk + 1] > b.overflow_begin[blk];
  Tool t;
  t.radius = 0.015;
  for (int n = 0; n < 200; ++n) {
    t.position = {0.01 * std::sin(n * 0.03), 0.16 - 0.02 * std::min(n, 100) / 100.0, 0.0};
    w.step({&t, 1});
  }
  EXPECT_TRUE(test::all_finite(w));
  return w.hash();
}

TEST(Determinism, OneBlockPassMatchesPortableKernelsWithOverflow) {
  for (Integrator i : {Integrator::position_verlet, Integrator::symplectic_euler})
    for (ForceModel m : {ForceModel::spring, ForceModel::linear}) {
      bool overflow = false;
      kernel::testing::force_portable(true);
      const std::uint64_t portable = big_cone_run(i, m, overflow);
      kernel::testing::force_portable(false);
      EXPECT_TRUE(overflow) << "the scene must put overflow entries in a whole block";
      EXPECT_EQ(portable, big_cone_run(i, m, overflow));
      kernel::testing::force_block_pieces(true);
      EXPECT_EQ(portable, big_cone_run(i, m, overflow));
      kernel::testing::force_block_pieces(false);
    }
}

// A body with far springs (in the overflow list) through every path: the
// fused pass on packed records, the AVX2 gathers from the arrays (no records),
// and the portable clones. Elastic and clay, pressed: the same bits.
TEST(Determinism, FarSpringsSameBitsOnEveryPath) {
  const TriangleMesh mesh = test::far_spring_mesh();
  {
    const Body<float> b = make_body<float>(mesh, Material{}, BodyOptions{}, 1);
    ASSERT_GT(b.far_vertices.size(), 0u) << "the mesh must have far spring ends behind their rows";
  }
  for (bool clay : {false, true}) {
    auto run = [&](PackedRecords records, bool portable) {
      kernel::testing::force_portable(portable);
      World<float> w(SimSettings{}, 1);
      Material m;
      m.plastic = clay;
      m.gravity = true;  // every block awake
      BodyOptions options;
      options.packed = records;
      w.add_body(mesh, m, options);
      Tool t;
      t.radius = 0.03;
      // Onto the top of the sphere, or of the torus' tube.
      const Vec3d top = test::kSanitized ? Vec3d{0.3, 0.07, 0.0} : Vec3d{0.0, 0.12, 0.0};
      for (int n = 0; n < 15; ++n) {
        t.position = {top[0], top[1] - 0.002 * n, top[2]};
        w.step({&t, 1});
      }
      kernel::testing::force_portable(false);
      EXPECT_TRUE(test::all_finite(w));
      return w.hash();
    };
    const std::uint64_t want = run(PackedRecords::never, true);
    EXPECT_EQ(run(PackedRecords::never, false), want) << "clay " << clay;
    EXPECT_EQ(run(PackedRecords::always, false), want) << "clay " << clay;
  }
}

// The ring of packed records (elastic float bodies on AVX2; here a torus of
// 164 blocks, sanitized 112, so springs reach past kRingReach) on a body that
// mostly sleeps: a press wakes a region whose sleeping neighbours are packed
// on demand, a grab steps its blocks in pieces, pinned vertices are reset
// after every substep.
// The ring's one pass, its pieces, its portable clones (the testing knob
// turned on after add_body sized the world for the ring), the gathers from
// the arrays (the knob on before: no ring) and the double buffer of packed
// records: the same positions and the same energy, bit for bit.
TEST(Determinism, RingSameBitsOnEveryPathWithSleepGrabsAndPins) {
  if (!kernel::avx2_paths_active()) GTEST_SKIP() << "no AVX2 here: bodies gather from the arrays, no ring";
  const TriangleMesh torus = test::far_spring_torus();
  std::vector<std::uint32_t> pins;
  for (std::uint32_t i = 0; i < torus.positions.size(); i += 97) pins.push_back(i);
  enum class Portable { no, before_add, after_add };
  for (Integrator integrator : {Integrator::position_verlet, Integrator::symplectic_euler})
    for (ForceModel model : {ForceModel::spring, ForceModel::linear}) {
      auto run = [&](PackedRecords records, Portable portable, bool pieces, std::uint64_t* epochs = nullptr) {
        kernel::testing::force_portable(portable == Portable::before_add);
        kernel::testing::force_block_pieces(pieces);
        SimSettings s;
        s.integrator = integrator;
        World<float> w(s, 2);
        Material m;
        m.model = model;
        BodyOptions options;
        options.packed = records;
        options.pinned = pins;
        w.add_body(torus, m, options);
        if (portable == Portable::after_add) kernel::testing::force_portable(true);
        Tool push, grab;
        push.radius = 0.03;
        grab.radius = 0.02;
        int partly_awake = 0;  // ticks with awake blocks next to sleeping ones
        for (int n = 0; n < 120; ++n) {
          push.position = {0.3 + 0.05 * std::sin(n * 0.03), 0.07 - 0.03 * std::min(n, 60) / 60.0, 0.0};
          grab.position = {-0.3, 0.0, 0.04 + 0.02 * std::max(0, n - 30) / 90.0};
          grab.grab = n >= 20 && n < 100;
          const Tool tools[2] = {push, grab};
          w.step(tools);
          partly_awake += w.stats().awake_blocks > 0 && w.stats().awake_blocks < w.body(0).blocks;
        }
        kernel::testing::force_portable(false);
        kernel::testing::force_block_pieces(false);
        EXPECT_TRUE(test::all_finite(w));
        EXPECT_GT(partly_awake, 30) << "the press must wake a region, not the torus";
        if (epochs) *epochs = w.body(0).ring_epoch;
        EXPECT_EQ(w.stats().blowups_total, 0u);
        // The energy the guard tests (each block's potential from its forces) too, not only the positions.
        return w.hash() ^ std::bit_cast<std::uint64_t>(w.energy(0));
      };
      std::uint64_t epochs = 0, none = 0;
      const std::uint64_t want = run(PackedRecords::never, Portable::before_add, false, &none);
      EXPECT_EQ(none, 0u) << "without AVX2 at add_body the body gathers from the arrays";
      EXPECT_EQ(run(PackedRecords::never, Portable::no, false, &epochs), want);
      EXPECT_GT(epochs, 0u) << "the ring must have run";
      EXPECT_EQ(run(PackedRecords::never, Portable::no, true), want) << "pieces";
      epochs = 0;
      EXPECT_EQ(run(PackedRecords::never, Portable::after_add, false, &epochs), want) << "the ring's portable clones";
      EXPECT_GT(epochs, 0u) << "the ring's portable clones must have run";
      EXPECT_EQ(run(PackedRecords::always, Portable::no, false), want) << "double buffer";
    }
}

}  // namespace
}  // namespace sculpt::sim
