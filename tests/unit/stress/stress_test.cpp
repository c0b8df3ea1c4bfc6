// Stress: the simulation under what people and files throw at it. At the
// default settings (automatic substeps) nothing may go non-finite, energy stays
// bounded by what the tools put in, and the blow-up guard is never needed;
// forced past the stability limit, the guard restores and the mesh settles.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "sim/shapes.hpp"
#include "sim/stability.hpp"
#include "sim/world.hpp"
#include "../sim/test_meshes.hpp"

namespace sculpt::sim {
namespace {

// The tests' all_finite, and every body's energy finite too.
template <class S>
bool all_finite(const World<S>& w) {
  if (!test::all_finite(w)) return false;
  for (std::size_t b = 0; b < w.body_count(); ++b)
    if (!std::isfinite(w.energy(b))) return false;
  return true;
}

// A loose physical ceiling on a body's energy: every vertex moving at twice the
// fastest tool, and every spring stretched by the mesh's whole size.
template <class S>
double energy_ceiling(const World<S>& w, std::size_t b, double tool_speed) {
  const Body<S>& body = w.body(b);
  const Material& m = body.material;
  const double v = 2.0 * tool_speed, L = body.extent;
  return body.n * 0.5 * m.mass * v * v + (body.springs + body.n) * 0.5 * (m.stiffness + m.anchor) * L * L;
}

// Random tool input: smooth moves up to the top speed, teleports, grab toggles
// every few ticks, spheres and capsules, radii from 2 mm to 5 cm.
struct ToolFuzzer {
  std::mt19937_64 rng;
  Vec3d centre, pos;
  double span, top_speed, dt;
  Tool tool;
  ToolFuzzer(std::uint64_t seed, Vec3d c, double size, double speed, double dt_)
      : rng(seed), centre(c), pos(c), span(size), top_speed(speed), dt(dt_) {
    tool.radius = 0.02;
  }
  double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
  const Tool& next() {
    const double r = uni(0, 1);
    if (r < 0.02) {  // teleport somewhere in or around the mesh
      for (int k = 0; k < 3; ++k) pos[k] = centre[k] + uni(-span, span);
    } else {
      // Move at up to the top speed (sometimes exactly at it) towards a random point.
      Vec3d dir{uni(-1, 1), uni(-1, 1), uni(-1, 1)};
      const double n = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]) + 1e-12;
      const double speed = uni(0, 1) < 0.2 ? top_speed * 0.999 : uni(0, top_speed);
      for (int k = 0; k < 3; ++k) {
        pos[k] += dir[k] / n * speed * dt;
        pos[k] = std::clamp(pos[k], centre[k] - span, centre[k] + span);
      }
    }
    if (uni(0, 1) < 0.15) tool.grab = !tool.grab;  // rapid grab and release
    if (uni(0, 1) < 0.01) {
      tool.shape = uni(0, 1) < 0.5 ? ToolShape::sphere : ToolShape::capsule;
      tool.radius = uni(0.002, 0.05);
      tool.half_axis = {uni(-0.03, 0.03), uni(-0.03, 0.03), uni(-0.03, 0.03)};
    }
    tool.position = pos;
    return tool;
  }
};

// Runs fuzzed tools over every body, then lets the scene rest; checks the invariants each tick.
template <class S>
void fuzz_and_settle(World<S>& w, std::uint64_t seed, int ticks, int rest_ticks, Vec3d centre, double span,
                     bool damped = true) {
  const double dt = 1.0 / w.settings().rate_hz;
  ToolFuzzer a(seed, centre, span, w.settings().max_tool_speed, dt), b(seed + 1000, centre, span, 1.0, dt);
  std::vector<double> peak(w.body_count(), 0.0);
  std::string history;  // the last ticks, for the failure message
  for (int n = 0; n < ticks; ++n) {
    const Tool tools[2] = {a.next(), b.next()};
    std::vector<double> before;
    for (std::size_t i = 0; i < w.body_count(); ++i) before.push_back(w.energy(i));
    w.step(tools);
    char line[200];
    std::snprintf(line, sizeof line, "tick %d: energy %g -> %g, contacts %u/%u, grab %d/%d, r %.3f\n", n, before[0],
                  w.energy(0), w.feedback()[0].contacts, w.feedback()[1].contacts, tools[0].grab, tools[1].grab,
                  tools[0].radius);
    history = (history.size() > 1500 ? history.substr(history.find('\n', history.size() - 1500) + 1) : history) + line;
    ASSERT_TRUE(all_finite(w)) << "seed " << seed << " tick " << n;
    ASSERT_EQ(w.stats().blowups_total, 0u) << "the guard was needed: seed " << seed << " tick " << n << "\n" << history;
    for (std::size_t i = 0; i < w.body_count(); ++i) {
      ASSERT_LE(w.energy(i), energy_ceiling(w, i, w.settings().max_tool_speed)) << "seed " << seed << " tick " << n;
      peak[i] = std::max(peak[i], w.energy(i));
    }
  }
  // World::energy() is taken before the last substep's contacts, so the first
  // tick without tools still shows what the last push put in: the reference.
  std::vector<double> released(w.body_count());
  for (int n = 0; n < rest_ticks; ++n) {
    w.step({});
    if (n == 0)
      for (std::size_t i = 0; i < w.body_count(); ++i) released[i] = std::max(peak[i], w.energy(i));
    ASSERT_TRUE(all_finite(w)) << "seed " << seed << " resting tick " << n;
    ASSERT_EQ(w.stats().blowups_total, 0u) << "seed " << seed << " resting tick " << n;
    for (std::size_t i = 0; i < w.body_count(); ++i)
      // Without input energy never grows past what the tools left (Verlet's measured
      // energy wobbles by O(ωdt): a factor 2 of slack).
      ASSERT_LE(w.energy(i), 2.0 * released[i] + 1e-12) << "seed " << seed << " body " << i << " resting tick " << n;
  }
  if (damped) {
    for (std::size_t i = 0; i < w.body_count(); ++i) {
      EXPECT_LT(w.energy(i), 0.05 * peak[i] + 1e-9) << "a damped mesh settles: seed " << seed << " body " << i;
    }
  }
}

// Seeds per case. The sanitized build (meson.build defines
// SCULPT_SANITIZED_BUILD) fuzzes fewer: the same kinds of input (teleports,
// grab toggles, shape and radius changes, every material), fewer of them.
constexpr std::uint64_t kToolPathSeeds = test::kSanitized ? 4 : 8, kMaterialSeeds = test::kSanitized ? 2 : 3;

TEST(Stress, FuzzedToolPathsOnTheDefaultMaterials) {
  for (std::uint64_t seed = 1; seed <= kToolPathSeeds; ++seed) {
    World<float> w(SimSettings{}, 2);
    Material clay;
    clay.plastic = true;
    Material jelly;
    jelly.stiffness = 40.0;
    w.add_body(make_icosphere(0.07f, 2), Material{});
    w.add_body(make_box_grid({0.14f, 0.06f, 0.14f}, 5), clay);
    w.add_body(make_torus(0.07f, 0.028f, 20, 10), jelly);
    fuzz_and_settle(w, seed, 600, 3000, {0, 0, 0}, 0.12);
  }
}

TEST(Stress, ExtremeMaterials) {
  struct Case {
    const char* name;
    double mass, stiffness, damping, anchor_damping;
  };
  const Case cases[] = {
      {"very stiff", 0.01, 2e5, 0.05, 0.05},
      // 0.1 g and 1 mg per vertex, 100× and 10 000× lighter than the default: a
      // 1 mg vertex on a 200 N/m spring stretched 2 cm moves at ~280 m/s, which
      // the guard must not take for divergence (its speed limit scales with the
      // stiffest mode, not only the tool's top speed).
      {"near-zero mass", 1e-4, 200.0, 0.05 * 1e-2, 0.05 * 1e-2},
      {"a milligram per vertex", 1e-6, 200.0, 0.05 * 1e-4, 0.05 * 1e-4},
      {"no damping", 0.01, 200.0, 0.0, 0.0},
      {"stiff and undamped", 0.01, 2e4, 0.0, 0.0},
      {"light and soft", 1e-5, 0.05, 1e-5, 2e-4},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Material m;
    m.mass = c.mass;
    m.stiffness = c.stiffness;
    m.damping = c.damping;
    m.anchor_damping = c.anchor_damping;
    m.grab_stiffness = std::min(50.0, c.stiffness);
    for (std::uint64_t seed = 77; seed < 77 + kMaterialSeeds; ++seed) {
      World<float> w(SimSettings{}, 2);
      w.add_body(make_icosphere(0.05f, 1), m);
      EXPECT_LT(w.substeps(0), kMaxSubsteps) << "the automatic substeps stay below the cap";
      fuzz_and_settle(w, seed, 250, 1500, {0, 0, 0}, 0.08, c.damping > 0);
    }
  }
}

TEST(Stress, DoublePrecisionAndOtherIntegrators) {
  for (Integrator integ : {Integrator::velocity_verlet, Integrator::symplectic_euler}) {
    SimSettings s;
    s.integrator = integ;
    World<double> w(s, 2);
    w.add_body(make_icosphere(0.05f, 2), Material{});
    fuzz_and_settle(w, 5 + int(integ), 400, 2000, {0, 0, 0}, 0.08);
  }
}

TriangleMesh degenerate(int kind) {
  TriangleMesh m;
  switch (kind) {
    case 0:  // zero-length edges: coincident vertices joined by triangles
      m.positions = {{0, 0, 0}, {0, 0, 0}, {0.05f, 0, 0}, {0, 0.05f, 0}, {0.05f, 0.05f, 0}};
      m.triangles = {{0, 1, 2}, {1, 2, 3}, {2, 3, 4}, {0, 3, 4}};
      break;
    case 1:  // isolated vertices and a single triangle
      m.positions = {{0, 0, 0}, {0.05f, 0, 0}, {0, 0.05f, 0}, {0.3f, 0.3f, 0.3f}, {-0.2f, 0, 0}};
      m.triangles = {{0, 1, 2}};
      break;
    case 2: {  // non-manifold fan: 12 triangles on one edge, and a vertex of degree 40
      m.positions = {{0, 0, 0}, {0, 0.05f, 0}};
      for (int i = 0; i < 40; ++i)
        m.positions.push_back({0.04f * std::cos(i * 0.157f), 0.02f, 0.04f * std::sin(i * 0.157f)});
      for (std::uint32_t i = 0; i < 12; ++i) m.triangles.push_back({0, 1, 2 + i});
      for (std::uint32_t i = 0; i + 1 < 40; ++i) m.triangles.push_back({0, 2 + i, 3 + i});
      break;
    }
    case 3:  // needle and sliver triangles (near-collinear), a flat sheet
      m.positions = {{0, 0, 0}, {0.1f, 0, 0}, {0.05f, 1e-7f, 0}, {0.05f, 0, 1e-7f}, {0.1f, 0.1f, 0}};
      m.triangles = {{0, 1, 2}, {0, 1, 3}, {1, 2, 4}, {0, 2, 4}};
      break;
    default: {  // triangle soup: a random mesh with repeated indices
      std::mt19937 rng(kind);
      std::uniform_real_distribution<float> u(-0.05f, 0.05f);
      for (int i = 0; i < 60; ++i) m.positions.push_back({u(rng), u(rng), u(rng)});
      m.positions.push_back(m.positions[3]);  // a duplicate
      for (int i = 0; i < 90; ++i) {
        std::uniform_int_distribution<std::uint32_t> pick(0, 60);
        m.triangles.push_back({pick(rng), pick(rng), pick(rng)});
      }
    }
  }
  return m;
}

TEST(Stress, DegenerateMeshes) {
  for (int kind = 0; kind < 7; ++kind) {
    SCOPED_TRACE(kind);
    World<float> w(SimSettings{}, 2);
    w.add_body(degenerate(kind), Material{});
    fuzz_and_settle(w, 100 + kind, 300, 2000, {0.03, 0.02, 0}, 0.08);
  }
}

TEST(Stress, ForcedBlowUpIsRecovered) {
  // Fixed substeps far past the stability limit: the guard must fire, restore a
  // finite state, raise the substeps, and the mesh must then come to rest.
  for (Integrator integ : {Integrator::position_verlet, Integrator::velocity_verlet, Integrator::symplectic_euler}) {
    SCOPED_TRACE(int(integ));
    Material m;
    m.stiffness = 5000.0;
    const StabilityBound bound = stability_bound(make_icosphere(0.05f, 2), m);
    SimSettings s;
    s.substeps = 1;
    s.rate_hz = 1.0 / (3.0 * bound.dt_critical);  // three times the bound
    s.integrator = integ;
    World<float> w(s, 1);
    w.add_body(make_icosphere(0.05f, 2), m);
    Tool press;
    press.radius = 0.02;
    for (int n = 0; n < 400; ++n) {
      press.position = {0.0, 0.05 + 0.02 - 0.01 * std::min(1.0, n / 50.0), 0.0};
      w.step({&press, n < 200 ? 1u : 0u});
      ASSERT_TRUE(all_finite(w)) << "tick " << n;
    }
    EXPECT_GE(w.stats().blowups_total, 1u) << "three times the limit must diverge";
    EXPECT_GT(w.substeps(0), 1) << "the guard raises the substeps";
    const std::uint64_t after = w.stats().blowups_total;
    for (int n = 0; n < 3000; ++n) {
      w.step({});
      ASSERT_TRUE(all_finite(w));
    }
    EXPECT_EQ(w.stats().blowups_total, after) << "recovered: no further blow-ups";
    EXPECT_EQ(w.stats().awake_blocks, 0u) << "and the mesh came to rest (asleep)";
  }
}

}  // namespace
}  // namespace sculpt::sim
