// Tools, clay, sleeping, the layout of big bodies and the rigid-motion
// invariance of the spring model (determinism_test.cpp: the same bits on
// every path).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <random>

#include "test_meshes.hpp"

namespace sculpt::sim {
namespace {

double max_displacement(const World<double>& w, const std::vector<Vec3d>& ref) {
  double worst = 0;
  for (std::uint32_t i = 0; i < ref.size(); ++i) {
    const Vec3d p = w.position(0, i);
    worst = std::max({worst, std::abs(p[0] - ref[i][0]), std::abs(p[1] - ref[i][1]), std::abs(p[2] - ref[i][2])});
  }
  return worst;
}

TEST(SpringModel, RigidMotionGivesNoForce) {
  SimSettings s;
  s.substeps = 1;
  s.sleep_speed = 0.0;
  Material m;  // spring model with dampers; the anchor is not rotation-invariant by design
  m.anchor = 0.0;
  m.anchor_damping = 0.0;
  const TriangleMesh mesh = make_torus(0.1f, 0.03f, 24, 12);
  for (int motion = 0; motion < 2; ++motion) {
    World<double> w(s, 0);
    w.add_body(mesh, m);
    // A rotation by 0.7 rad about (1,2,3)/√14 plus a translation, at zero velocity.
    const double a = 0.7, ux = 1 / std::sqrt(14.0), uy = 2 / std::sqrt(14.0), uz = 3 / std::sqrt(14.0);
    const double c = std::cos(a), sn = std::sin(a), t = 1 - c;
    const double R[3][3] = {{c + ux * ux * t, ux * uy * t - uz * sn, ux * uz * t + uy * sn},
                            {uy * ux * t + uz * sn, c + uy * uy * t, uy * uz * t - ux * sn},
                            {uz * ux * t - uy * sn, uz * uy * t + ux * sn, c + uz * uz * t}};
    std::vector<Vec3d> moved(mesh.positions.size());
    for (std::uint32_t i = 0; i < mesh.positions.size(); ++i) {
      const Vec3f& p = mesh.positions[i];
      for (int r = 0; r < 3; ++r) {
        moved[i][r] = motion == 0 ? p[r] + 0.37 * (r + 1) : R[r][0] * p[0] + R[r][1] * p[1] + R[r][2] * p[2];
      }
      w.set_state(0, i, moved[i], {0, 0, 0});
    }
    for (int n = 0; n < 10; ++n) w.step({});
    EXPECT_LT(max_displacement(w, moved), 1e-12) << (motion == 0 ? "translation" : "rotation");
  }
}

// The linear model is not rotation-invariant: the same rotation does move it.
TEST(LinearModel, RotationDoesMoveIt) {
  SimSettings s;
  s.sleep_speed = 0.0;
  Material m;
  m.model = ForceModel::linear;
  m.anchor = 0.0;
  const TriangleMesh mesh = make_icosphere(0.1f, 1);
  World<double> w(s, 0);
  w.add_body(mesh, m);
  std::vector<Vec3d> moved(mesh.positions.size());
  for (std::uint32_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3f& p = mesh.positions[i];
    moved[i] = {-p[1], p[0], p[2]};
    w.set_state(0, i, moved[i], {0, 0, 0});
  }
  w.step({});
  EXPECT_GT(max_displacement(w, moved), 1e-6);
}

struct Press {
  static constexpr double radius = 0.1, tool_r = 0.02, depth = 0.015;
  explicit Press(Material m = {}, int subdivisions = 4) : world(SimSettings{}, 1) {
    world.add_body(make_icosphere(static_cast<float>(radius), subdivisions), m);
    tool.radius = tool_r;
  }
  // Tool above the north pole, moving down to `depth` below the surface over `ticks`.
  void press(int ticks) {
    for (int n = 1; n <= ticks; ++n) {
      tool.position = {0.0, radius + tool_r + 0.002 - (depth + 0.002) * n / ticks, 0.0};
      world.step({&tool, 1});
    }
  }
  void lift_and_wait(int ticks) {
    tool.position = {0.0, 1.0, 0.0};
    for (int n = 0; n < ticks; ++n) world.step({&tool, 1});
  }
  double pole_height() const {
    double top = -1;
    const Body<float>& b = world.body(0);
    for (std::uint32_t i = 0; i < b.n; ++i)
      if (std::abs(b.x[i]) < 0.004 && std::abs(b.z[i]) < 0.004) top = std::max(top, double(b.y[i]));
    return top;
  }
  World<float> world;
  Tool tool;
};

TEST(Push, NoVertexInsideAndForceOpposesPenetration) {
  Press p;
  bool touched = false, onset_seen = false;
  for (int n = 1; n <= 200; ++n) {
    p.tool.position = {0.0, Press::radius + Press::tool_r - Press::depth * n / 200.0, 0.0};
    p.world.step({&p.tool, 1});
    const ToolFeedback& f = p.world.feedback()[0];
    if (f.contacts > 0) {
      touched = true;
      EXPECT_GT(f.force[1], 0.0) << "tick " << n << ": the mesh pushes the tool back up";
      EXPECT_LT(std::abs(f.force[0]) + std::abs(f.force[2]), f.force[1]) << "tick " << n;
    }
    if (f.onset) {
      EXPECT_FALSE(onset_seen) << "one onset per contact";
      onset_seen = true;
    }
    const Body<float>& b = p.world.body(0);
    for (std::uint32_t i = 0; i < b.n; ++i) {
      const double dx = b.x[i] - p.tool.position[0], dy = b.y[i] - p.tool.position[1], dz = b.z[i] - p.tool.position[2];
      ASSERT_GE(std::sqrt(dx * dx + dy * dy + dz * dz), Press::tool_r * (1 - 1e-5)) << "vertex " << i << " tick " << n;
    }
  }
  EXPECT_TRUE(touched);
  EXPECT_TRUE(onset_seen);
  EXPECT_LT(p.pole_height(), Press::radius - 0.5 * Press::depth) << "the surface gave way";
}

TEST(Push, CapsuleAlsoPushes) {
  World<float> w(SimSettings{}, 1);
  w.add_body(make_icosphere(0.1f, 4), Material{});
  Tool t;
  t.shape = ToolShape::capsule;
  t.radius = 0.01;
  t.half_axis = {0.05, 0.0, 0.0};  // lying across the north pole
  for (int n = 1; n <= 100; ++n) {
    t.position = {0.0, 0.115 - 0.02 * n / 100.0, 0.0};
    w.step({&t, 1});
  }
  EXPECT_GT(w.feedback()[0].contacts, 0u);
  EXPECT_GT(w.feedback()[0].force[1], 0.0);
  const Body<float>& b = w.body(0);
  for (std::uint32_t i = 0; i < b.n; ++i) {
    const double px = std::clamp(double(b.x[i]), -0.05, 0.05);
    const double dx = b.x[i] - px, dy = b.y[i] - t.position[1], dz = b.z[i];
    ASSERT_GE(std::sqrt(dx * dx + dy * dy + dz * dz), 0.01 * (1 - 1e-5));
  }
}

TEST(Push, ThinToolDoesNotPassThroughACoarseFace) {
  // A 20 cm cube made of 12 triangles, a 3 mm tool driven into the middle of a face.
  const TriangleMesh cube = make_box_grid({0.2f, 0.2f, 0.2f}, 1);
  for (double speed : {0.05, 2.0}) {  // slow, and fast enough to need the sweep
    World<float> w(SimSettings{}, 1);
    w.add_body(cube, Material{});
    Tool t;
    t.radius = 0.003;
    const double start = 0.12, end = 0.05;  // x of the tool centre; the face sits at x = 0.1
    const int ticks = static_cast<int>((start - end) / speed * 1000);
    std::uint32_t contacts = 0;
    double push_back = 0;
    std::vector<Vec3f> pos(cube.positions.size());
    for (int n = 0; n <= ticks; ++n) {
      t.position = {start - (start - end) * n / ticks, 0.0, 0.0};
      w.step({&t, 1});
      ASSERT_TRUE(test::all_finite(w));
      contacts = std::max(contacts, w.feedback()[0].contacts);
      push_back = std::max(push_back, w.feedback()[0].force[0]);
      w.positions(0, pos);
      ASSERT_LT(test::winding_number(pos, cube.triangles, t.position), 0.5)
          << "speed " << speed << ", tick " << n << ": the tool got inside the mesh";
    }
    EXPECT_GT(contacts, 0u);
    EXPECT_GT(push_back, 0.0) << "the face pushes back along +x";
    double face_x = 0;
    for (const Vec3f& p : pos) face_x = std::max<double>(face_x, p[0]);
    EXPECT_LT(face_x, 0.1) << "the face was pushed in";
  }
}

TEST(Pull, FollowsWhileGrabbingAndLetsGo) {
  Press p;
  const double surface = Press::radius;
  p.tool.position = {0.0, surface + 0.5 * Press::tool_r, 0.0};  // overlapping the surface a little
  p.world.step({&p.tool, 1});
  p.tool.grab = true;
  for (int n = 1; n <= 300; ++n) {
    p.tool.position = {0.0, surface + 0.5 * Press::tool_r + 0.02 * std::min(n, 200) / 200.0, 0.0};
    p.world.step({&p.tool, 1});
  }
  EXPECT_GT(p.world.feedback()[0].contacts, 0u);
  EXPECT_LT(p.world.feedback()[0].force[1], 0.0) << "the mesh pulls the tool back down";
  EXPECT_GT(p.pole_height(), surface + 0.01) << "the grabbed surface followed the tool up";
  p.tool.grab = false;
  p.lift_and_wait(3000);
  EXPECT_EQ(p.world.feedback()[0].contacts, 0u);
  EXPECT_NEAR(p.pole_height(), surface, 0.001) << "released, the elastic surface returns";
}

TEST(Clay, KeepsADentAndElasticRecovers) {
  Material clay;
  clay.plastic = true;
  clay.yield_strain = 0.02;
  Press soft(clay);
  soft.press(300);
  soft.lift_and_wait(3000);
  const double dent = Press::radius - soft.pole_height();
  EXPECT_GT(dent, 0.5 * Press::depth) << "clay keeps most of the dent";
  EXPECT_EQ(soft.world.stats().blowups_total, 0u);

  Press elastic;
  elastic.press(300);
  elastic.lift_and_wait(3000);
  EXPECT_LT(Press::radius - elastic.pole_height(), 0.05 * Press::depth) << "rubber springs back";
}

TEST(Sleeping, IdleSceneIntegratesNothing) {
  World<float> w(SimSettings{}, 2);
  w.add_body(make_icosphere(0.1f, 4), Material{});
  w.add_body(make_torus(0.2f, 0.05f, 64, 32), Material{});
  for (int n = 0; n < 100; ++n) {
    w.step({});
    ASSERT_EQ(w.stats().vertex_steps, 0u);
    ASSERT_TRUE(w.changes().empty());
  }
}

TEST(Sleeping, ApproachingToolWakesOnlyItsRegion) {
  World<float> w(SimSettings{}, 1);
  w.add_body(make_icosphere(0.1f, 5), Material{});
  const std::uint32_t n = w.body(0).n;
  Tool t;
  t.radius = 0.01;
  t.position = {0.0, 0.5, 0.0};
  w.step({&t, 1});
  EXPECT_EQ(w.stats().vertex_steps, 0u) << "far away: nothing wakes";
  t.position = {0.0, 0.1 + t.radius + 0.001, 0.0};  // just above the north pole
  // A fast approach is a teleport: the tool shows up there.
  w.step({&t, 1});
  EXPECT_GT(w.stats().awake_vertices, 0u);
  EXPECT_LT(w.stats().awake_vertices, n / 10) << "only the blocks the tool box reaches";
  // The south pole sleeps.
  const Body<float>& b = w.body(0);
  for (std::uint32_t i = 0; i < b.n; ++i) {
    if (b.y[i] < 0.0f) {
      ASSERT_FALSE(b.block[i / kernel::kBlock].awake) << "vertex " << i;
    }
  }
  // Retreat: everything goes back to sleep and streams nothing.
  t.position = {0.0, 0.5, 0.0};
  for (int k = 0; k < 200; ++k) w.step({&t, 1});
  EXPECT_EQ(w.stats().vertex_steps, 0u);
  EXPECT_TRUE(w.changes().empty());
}

TEST(WorldChanges, ListsWhatMoved) {
  Press p;
  p.press(50);
  ASSERT_FALSE(p.world.changes().empty());
  std::uint32_t covered = 0;
  for (const ChangeRange& r : p.world.changes()) {
    EXPECT_LT(r.begin, r.end);
    EXPECT_LE(r.end, p.world.body(0).n);
    covered += r.end - r.begin;
  }
  EXPECT_GE(covered, p.world.stats().awake_vertices);
  EXPECT_LT(covered, p.world.body(0).n);
}

// Triangles are stored as 16-bit offsets from their block's first vertex;
// on a 163 842-vertex sphere some span farther and are kept whole (so the
// sanitized build takes this size too: a smaller mesh has no far triangles).
// Every triangle of the mesh must come out of for_each_triangle once, with
// its winding, in the block of its lowest vertex.
TEST(Layout, EveryTriangleOnceNearOrFar) {
  const TriangleMesh sphere = make_icosphere(0.1f, 7);
  const Body<float> b = make_body<float>(sphere, Material{}, BodyOptions{}, 1);
  EXPECT_GT(b.far_triangles.size(), 0u) << "the sphere must have triangles beyond a 16-bit offset";
  EXPECT_LT(b.far_triangles.size(), sphere.triangles.size() / 100);
  // The mesh's triangles by their first vertex, each to be met once (not two
  // sorts of 327 680 triangles: seconds in the unoptimised sanitized build).
  std::vector<std::uint32_t> first(sphere.positions.size() + 1, 0), by_first(sphere.triangles.size());
  for (const Triangle& t : sphere.triangles) ++first[t[0] + 1];
  for (std::size_t v = 1; v < first.size(); ++v) first[v] += first[v - 1];
  std::vector<std::uint32_t> next(first.begin(), first.end() - 1);
  for (std::uint32_t k = 0; k < sphere.triangles.size(); ++k) by_first[next[sphere.triangles[k][0]]++] = k;
  std::vector<bool> met(sphere.triangles.size());
  std::size_t misplaced = 0, unknown = 0;
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk)
    b.for_each_triangle(blk, [&](const Triangle& t) {
      misplaced += std::min({t[0], t[1], t[2]}) / kernel::kBlock != blk;
      const Triangle o{b.to_original[t[0]], b.to_original[t[1]], b.to_original[t[2]]};
      bool found = false;
      for (std::uint32_t q = first[o[0]]; q < first[o[0] + 1] && !found; ++q)
        if (!met[by_first[q]] && sphere.triangles[by_first[q]] == o) met[by_first[q]] = found = true;
      unknown += !found;
    });
  EXPECT_EQ(misplaced, 0u) << "triangles not in the block of their lowest vertex";
  EXPECT_EQ(unknown, 0u) << "triangles not in the mesh (or not with its winding), or met twice";
  EXPECT_EQ(std::count(met.begin(), met.end(), true), std::ssize(sphere.triangles)) << "triangles never met";
}

// The guard's checkpoint keeps 16 bits per coordinate on a grid over each
// block's box: a saved position comes back within half a grid step (plus
// rounding), and a block with a non-finite vertex keeps its older checkpoint.
TEST(Layout, CheckpointComesBackWithinItsGrid) {
  Body<float> b = make_body<float>(make_icosphere(0.1f, 3), Material{}, BodyOptions{}, 1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> jiggle(-0.004f, 0.004f);
  for (std::uint32_t i = 0; i < b.n; ++i) b.x[i] += jiggle(rng), b.y[i] += jiggle(rng), b.z[i] += jiggle(rng);
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) b.save_positions(blk);
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    const CheckpointGrid<float>& g = b.checkpoint_grid[blk];
    for (std::uint32_t i = b.begin_of(blk); i < b.end_of(blk); ++i) {
      const std::array<float, 3> p = b.saved_position(i);
      const float want[3] = {b.x[i], b.y[i], b.z[i]};
      for (int a = 0; a < 3; ++a) EXPECT_LE(std::abs(p[a] - want[a]), 0.5f * g.step[a] + 1e-7f) << i << " axis " << a;
    }
  }
  const std::array<float, 3> before = b.saved_position(5);
  b.x[3] = std::numeric_limits<float>::quiet_NaN();
  b.x[5] += 0.01f;
  EXPECT_FALSE(b.save_positions(0));
  EXPECT_EQ(b.saved_position(5), before) << "a block with a NaN keeps its older checkpoint";
}

// Each body takes one step path, chosen when it is added (stepper.hpp), and
// only the arrays path keeps accelerations for every vertex.
TEST(Layout, EachBodyTakesTheStepPathItsOptionsAllow) {
  // 40 962 vertices: clay keeps packed records (up to kPackedMaxVertices).
  // Sanitized, 2 562: the same side of that size, so the same paths.
  const TriangleMesh sphere = make_icosphere(0.1f, test::kSanitized ? 4 : 6);
  const bool avx2 = kernel::avx2_paths_active();
  for (Integrator integ : {Integrator::position_verlet, Integrator::symplectic_euler, Integrator::velocity_verlet})
    for (bool clay : {false, true}) {
      SimSettings s;
      s.integrator = integ;
      World<float> w(s, 1);
      Material m;
      m.plastic = clay;
      w.add_body(sphere, m);
      StepPath want = StepPath::arrays;
      if (avx2 && integ != Integrator::velocity_verlet) want = clay ? StepPath::records : StepPath::ring;
      EXPECT_EQ(w.step_path(0), want) << "clay " << clay << " integrator " << int(integ);
      const bool arrays = want == StepPath::arrays;
      EXPECT_EQ(w.body(0).ax.size(), arrays ? w.body(0).n : 0u) << "clay " << clay;
      EXPECT_EQ(w.body(0).ring_blocks > 0, want == StepPath::ring) << "only ring bodies build the far table";
    }
  World<float> gather(SimSettings{}, 1);
  BodyOptions no_ring;
  no_ring.ring = false;
  gather.add_body(sphere, Material{}, no_ring);
  EXPECT_EQ(gather.step_path(0), StepPath::arrays);
  World<double> precise(SimSettings{}, 1);
  precise.add_body(sphere, Material{});
  EXPECT_EQ(precise.step_path(0), StepPath::arrays) << "double has neither packed records nor the ring";
  EXPECT_EQ(precise.body(0).ax.size(), precise.body(0).n);
}

// Big bodies keep their per-vertex arrays in one huge-page arena (fewer TLB
// misses for the neighbour loads); small ones stay on the heap.
TEST(Layout, BigBodiesKeepTheirArraysInOneArena) {
  for (bool clay : {false, true}) {
    World<float> w(SimSettings{}, 1);
    Material m;
    m.plastic = clay;
    w.add_body(make_icosphere(0.1f, 6), m);  // 40 962 vertices: clay has packed records, elastic the ring
    w.add_body(make_icosphere(0.1f, 3), m);  // 642
    const Body<float>& big = w.body(0);
    ASSERT_GE(big.n, kArenaMinVertices);
    for (const void* p : {static_cast<const void*>(big.x.data()), static_cast<const void*>(big.wz.data()),
                          static_cast<const void*>(big.rz.data()), static_cast<const void*>(big.sz.data()),
                          static_cast<const void*>(big.nbr.data()), static_cast<const void*>(big.rest_length.data())})
      EXPECT_TRUE(big.arena.contains(p)) << "clay " << clay;
    EXPECT_EQ(big.packed[1].empty(), !clay);
    if (clay) {
      EXPECT_TRUE(big.arena.contains(big.packed[1].data()));
      EXPECT_TRUE(big.arena.contains(big.slen.data()));
    }
    if (w.step_path(0) == StepPath::arrays) {
      EXPECT_TRUE(big.arena.contains(big.az.data()));
    }
    EXPECT_EQ(big.arena.capacity(), (big.arena.used() + 4095) / 4096 * 4096) << "trimmed after add_body";
    EXPECT_EQ(w.body(1).arena.capacity(), 0u);
    EXPECT_FALSE(w.body(1).arena.contains(w.body(1).x.data()));
  }
  SimSettings verlet;
  verlet.integrator = Integrator::velocity_verlet;  // the arrays path: accelerations for every vertex
  World<float> w(verlet, 1);
  w.add_body(make_icosphere(0.1f, 6), Material{});
  ASSERT_EQ(w.step_path(0), StepPath::arrays);
  EXPECT_TRUE(w.body(0).arena.contains(w.body(0).az.data()));
}

// A spring whose ends lie more than kRingReach blocks apart in the Morton
// order (which also bounds the 16-bit offsets) is kept whole in the overflow
// list. Each directed spring is in exactly one of the two.
TEST(Layout, FarSpringsGoToTheOverflow) {
  const Body<float> b = make_body<float>(test::far_spring_mesh(), Material{}, BodyOptions{}, 1);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> seen;
  for (int s = 0; s < b.columns; ++s)
    for (std::uint32_t i = 0; i < b.n; ++i) {
      const std::int32_t j = static_cast<std::int32_t>(i) + b.nbr[static_cast<std::size_t>(s) * b.n + i];
      if (j == static_cast<std::int32_t>(i)) continue;
      seen.emplace_back(i, static_cast<std::uint32_t>(j));
      EXPECT_LE(std::abs(j / std::int64_t{kernel::kBlock} - i / std::int64_t{kernel::kBlock}), kernel::kRingReach);
    }
  std::size_t far = 0, behind = 0;
  for (const auto& o : b.overflow) {
    const bool beyond = std::abs(o.j / std::int64_t{kernel::kBlock} - o.i / std::int64_t{kernel::kBlock}) >
                        std::int64_t{kernel::kRingReach};
    far += beyond;
    seen.emplace_back(o.i, static_cast<std::uint32_t>(o.j));
    // The ring's far table: the ends behind (stepped before the row's block) have a saved record.
    if (beyond && static_cast<std::uint32_t>(o.j) < o.i) {
      ++behind;
      ASSERT_LT(o.far, b.far_vertices.size());
      EXPECT_EQ(b.far_vertices[o.far], static_cast<std::uint32_t>(o.j));
    } else {
      EXPECT_EQ(o.far, beyond ? kernel::kFarAhead : kernel::kNotFar);
    }
  }
  EXPECT_GT(far, 0u) << "the mesh must have springs beyond the ring's reach";
  EXPECT_GT(behind, 0u);
  EXPECT_EQ(b.far_records.size(), 8 * b.far_vertices.size());
  EXPECT_EQ(seen.size(), 2u * b.springs);
  // std::less<>, not the default: a default std::sort of these pairs is the
  // very instantiation make_body's unique_edges uses, the linker keeps one
  // copy (this file's, unoptimised in the sanitized build), and every
  // add_body in this binary then sorted its edges several times slower.
  std::sort(seen.begin(), seen.end(), std::less<>{});
  EXPECT_TRUE(std::adjacent_find(seen.begin(), seen.end()) == seen.end()) << "a spring end listed twice";
  for (const auto& [i, j] : seen)
    EXPECT_TRUE(std::binary_search(seen.begin(), seen.end(), std::pair{j, i}, std::less<>{}))
        << i << "→" << j << " has no mirror";
}

TEST(Integrators, AllThreeAgreeOnAPress) {
  // Same scene, three integrators: the dent differs by far less than its depth.
  double height[3];
  int k = 0;
  for (Integrator i : {Integrator::position_verlet, Integrator::velocity_verlet, Integrator::symplectic_euler}) {
    SimSettings s;
    s.integrator = i;
    World<float> w(s, 1);
    w.add_body(make_icosphere(0.1f, 3), Material{});
    Tool t;
    t.radius = 0.02;
    for (int n = 0; n < 300; ++n) {
      t.position = {0.0, 0.12 - 0.01 * std::min(n, 150) / 150.0, 0.0};
      w.step({&t, 1});
    }
    double top = -1;
    for (std::uint32_t v = 0; v < w.body(0).n; ++v) top = std::max(top, w.position(0, v)[1]);
    height[k++] = top;
    EXPECT_EQ(w.stats().blowups_total, 0u);
  }
  EXPECT_NEAR(height[0], height[1], 0.001);
  EXPECT_NEAR(height[0], height[2], 0.001);
}

TEST(Input, BadToolsAndMeshesAreRejectedClearly) {
  World<float> w(SimSettings{}, 1);
  TriangleMesh bad;
  bad.positions = {{0, 0, 0}, {1, 0, 0}};
  bad.triangles = {{0, 1, 7}};
  try {
    w.add_body(bad, Material{});
    FAIL() << "an out-of-range index must be rejected";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 0"), std::string::npos) << e.what();
  }
  Material m;
  m.mass = 0;
  EXPECT_THROW(w.add_body(make_icosphere(1.0f, 1), m), std::invalid_argument);
  SimSettings s;
  s.rate_hz = -1;
  EXPECT_THROW(World<float>(s, 1), std::invalid_argument);

  w.add_body(make_icosphere(0.1f, 2), Material{});
  Tool t;
  t.position = {0.0, NAN, 0.0};
  w.step({&t, 1});
  EXPECT_TRUE(w.feedback()[0].ignored);
  EXPECT_EQ(w.stats().ignored_tools, 1u);
  t.position = {0, 0, 0};
  t.radius = -1;
  w.step({&t, 1});
  EXPECT_TRUE(w.feedback()[0].ignored);
  EXPECT_TRUE(test::all_finite(w));
  const Tool three[3] = {};
  w.step(three);
  EXPECT_EQ(w.stats().ignored_tools, 2u) << "one slot, three tools: two are ignored, and say so";
}

TEST(Pinned, PinnedVerticesStayPut) {
  World<float> w(SimSettings{}, 1);
  BodyOptions o;
  o.pinned = {0, 1, 2, 3};
  const TriangleMesh mesh = make_icosphere(0.1f, 3);
  w.add_body(mesh, Material{}, o);
  Tool t;
  t.radius = 0.08;
  for (int n = 0; n < 200; ++n) {
    t.position = {0.0, 0.0, 0.0};  // a tool inside everything: a worst case
    w.step({&t, 1});
  }
  for (std::uint32_t i : o.pinned)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(w.position(0, i)[k], mesh.positions[i][k]);
}

}  // namespace
}  // namespace sculpt::sim
