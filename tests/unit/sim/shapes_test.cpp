#include <gtest/gtest.h>

#include <cmath>

#include "sim/shapes.hpp"
#include "sim/stability.hpp"

namespace sculpt::sim {
namespace {

// Closed and consistently oriented: every edge used by exactly two faces,
// once in each direction.
void expect_closed_oriented(const TriangleMesh& mesh) {
  for (const Edge& e : unique_edges(mesh.triangles)) {
    ASSERT_EQ(e.faces, 2u) << "edge " << e.a << "-" << e.b;
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> directed;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) directed.emplace_back(t[k], t[(k + 1) % 3]);
  std::sort(directed.begin(), directed.end());
  EXPECT_EQ(std::adjacent_find(directed.begin(), directed.end()), directed.end()) << "an edge runs twice the same way";
  EXPECT_GT(signed_volume(mesh), 0.0) << "faces point inwards";
}

TEST(Shapes, IcosphereCountsAndOrientation) {
  for (int n = 0; n <= 3; ++n) {
    const TriangleMesh m = make_icosphere(0.5f, n);
    EXPECT_EQ(m.positions.size(), 10u * (1u << (2 * n)) + 2);
    expect_closed_oriented(m);
    for (const Vec3f& p : m.positions) EXPECT_NEAR(std::hypot(p[0], p[1], p[2]), 0.5, 1e-6);
  }
  EXPECT_NEAR(signed_volume(make_icosphere(1.0f, 4)), 4.0 / 3.0 * M_PI, 0.02);
}

TEST(Shapes, TorusAndBox) {
  const TriangleMesh t = make_torus(1.0f, 0.25f, 24, 12);
  EXPECT_EQ(t.positions.size(), 24u * 12);
  expect_closed_oriented(t);
  EXPECT_NEAR(signed_volume(make_torus(1.0f, 0.25f, 128, 64)), 2 * M_PI * M_PI * 0.25 * 0.25, 0.01);
  for (int n : {1, 2, 5}) {
    const TriangleMesh b = make_box_grid({1.0f, 2.0f, 0.5f}, n);
    EXPECT_EQ(b.positions.size(), static_cast<std::size_t>((n + 1) * (n + 1) * (n + 1) - (n - 1) * (n - 1) * (n - 1)));
    expect_closed_oriented(b);
    EXPECT_NEAR(signed_volume(b), 1.0, 1e-5);
  }
}

TEST(Shapes, RejectNonsense) {
  EXPECT_THROW(make_icosphere(-1.0f, 2), std::invalid_argument);
  EXPECT_THROW(make_icosphere(1.0f, 12), std::invalid_argument);
  EXPECT_THROW(make_torus(0.1f, 0.2f, 8, 8), std::invalid_argument);
  EXPECT_THROW(make_box_grid({1, 0, 1}, 2), std::invalid_argument);
}

TEST(Stability, ChainBoundAndSubsteps) {
  Material m;
  m.mass = 1.0;
  m.stiffness = 1.0;
  m.damping = 0.0;
  m.anchor = 0.0;
  m.anchor_damping = 0.0;
  m.grab_stiffness = 0.0;
  const StabilityBound b = stability_bound_for_degree(2, m);  // chain interior: λ ≤ 4k/m
  EXPECT_DOUBLE_EQ(b.lambda_max_bound, 4.0);
  EXPECT_DOUBLE_EQ(b.dt_critical, 1.0);
  m.damping = 0.5;  // the damper shrinks the limit
  EXPECT_LT(stability_bound_for_degree(2, m).dt_critical, 1.0);

  SimSettings s;
  s.rate_hz = 1.0;
  s.substep_safety = 0.5;
  m.damping = 0.0;
  const SubstepChoice c = choose_substeps_for_degree(2, m, s);
  EXPECT_EQ(c.substeps, 2);
  EXPECT_LE(c.substep_dt, 0.5 * c.bound.dt_critical);
  s.substeps = 7;
  EXPECT_EQ(choose_substeps_for_degree(2, m, s).substeps, 7);
  s.rate_hz = 0.0;
  EXPECT_THROW(choose_substeps_for_degree(2, m, s), std::invalid_argument);
}

TEST(Stability, MeshDefaults) {
  const TriangleMesh sphere = make_icosphere(0.1f, 3);
  const SubstepChoice c = choose_substeps(sphere, Material{}, SimSettings{});
  EXPECT_GE(c.substeps, 1);
  EXPECT_LE(c.substep_dt, SimSettings{}.substep_safety * c.bound.dt_critical);
  Material none;
  none.stiffness = none.damping = none.anchor = none.anchor_damping = none.grab_stiffness = 0.0;
  EXPECT_TRUE(std::isinf(stability_bound(sphere, none).dt_critical));
  EXPECT_EQ(choose_substeps(sphere, none, SimSettings{}).substeps, 1);
}

}  // namespace
}  // namespace sculpt::sim
