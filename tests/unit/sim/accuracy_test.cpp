// The linear model against analytic solutions, order of convergence, and
// energy behaviour of position Verlet.
#include <gtest/gtest.h>

#include <cmath>

#include "test_meshes.hpp"
#include "sim/stability.hpp"

namespace sculpt::sim {
namespace {

using test::bare;

constexpr double kPi = 3.14159265358979323846;

// One free vertex held by two linear springs to pinned vertices: ω² = 2k/m.
struct Oscillator {
  explicit Oscillator(double dt, double damping = 0.0) : world(settings(dt)) {
    TriangleMesh mesh;
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.triangles = {{0, 1, 2}};
    Material m = bare(ForceModel::linear, 1.0, 2.0 * kPi * kPi);  // ω = 2π: one period per second
    m.damping = damping;
    BodyOptions o;
    o.pinned = {1, 2};
    world.add_body(mesh, m, o);
    // Exact start: the previous position is the solution one step back.
    world.set_state(0, 0, {amplitude, 0, 0}, {amplitude * (1.0 - std::cos(omega * dt)) / dt, 0, 0});
  }
  static SimSettings settings(double dt) {
    SimSettings s;
    s.rate_hz = 1.0 / dt;
    s.substeps = 1;
    s.sleep_speed = 0.0;
    return s;
  }
  double x() const { return world.position(0, 0)[0]; }
  static constexpr double amplitude = 0.1;
  static constexpr double omega = 2.0 * kPi;
  World<double> world;
};

double oscillator_error(double dt, double t_end) {
  Oscillator o(dt);
  double worst = 0;
  const int steps = static_cast<int>(std::lround(t_end / dt));
  for (int n = 1; n <= steps; ++n) {
    o.world.step({});
    worst = std::max(worst, std::abs(o.x() - Oscillator::amplitude * std::cos(Oscillator::omega * n * dt)));
  }
  return worst;
}

TEST(Accuracy, OscillatorMatchesCosine) {
  EXPECT_LT(oscillator_error(1.0 / 1000, 2.0), 2e-4 * Oscillator::amplitude);
}

TEST(Accuracy, OscillatorSecondOrder) {
  const double coarse = oscillator_error(1.0 / 50, 2.0);
  const double fine = oscillator_error(1.0 / 100, 2.0);
  const double ratio = coarse / fine;
  EXPECT_GT(ratio, 3.5) << coarse << " vs " << fine;
  EXPECT_LT(ratio, 4.5) << coarse << " vs " << fine;
}

// Fixed-fixed chain of N masses: modes u_j = sin(jqπ/(N+1)), ω_q = 2√(k/m) sin(qπ/(2(N+1))).
struct Chain {
  static constexpr int N = 10;
  static constexpr double k = 100.0, m = 0.5, A = 0.01;
  static double omega(int q) { return 2.0 * std::sqrt(k / m) * std::sin(q * kPi / (2.0 * (N + 1))); }
  static double shape(int j, int q) { return std::sin(j * q * kPi / (N + 1)); }
  // Modes 1 and 3, transverse (y): the linear model is the same on every axis.
  static double exact(int j, double t) {
    return A * shape(j, 1) * std::cos(omega(1) * t) + 0.5 * A * shape(j, 3) * std::cos(omega(3) * t);
  }

  explicit Chain(double dt, double damping = 0.0) : dt(dt), world(Oscillator::settings(dt)) {
    Material mat = bare(ForceModel::linear, m, k);
    mat.damping = damping;
    BodyOptions o;
    o.pinned = {0, N + 1};
    world.add_body(test::chain(N, 0.1f), mat, o);
    for (int j = 1; j <= N; ++j) {
      const Vec3d p = world.position(0, j);
      const double prev = exact(j, -dt);
      world.set_state(0, j, {p[0], exact(j, 0), 0}, {0, (exact(j, 0) - prev) / dt, 0});
    }
  }
  double y(int j) const { return world.position(0, j)[1]; }
  double dt;
  World<double> world;
};

double chain_error(double dt, double t_end) {
  Chain c(dt);
  double worst = 0;
  const int steps = static_cast<int>(std::lround(t_end / dt));
  for (int n = 1; n <= steps; ++n) {
    c.world.step({});
    for (int j = 1; j <= Chain::N; ++j) worst = std::max(worst, std::abs(c.y(j) - Chain::exact(j, n * dt)));
  }
  return worst;
}

TEST(Accuracy, ChainMatchesModalSolution) {
  const double period = 2.0 * kPi / Chain::omega(1);
  EXPECT_LT(chain_error(period / 2000, 2 * period), 1e-3 * Chain::A);
  const double ratio = chain_error(period / 100, 2 * period) / chain_error(period / 200, 2 * period);
  EXPECT_GT(ratio, 3.5);
  EXPECT_LT(ratio, 4.5);
}

// Verlet's staggered energy ½m|x_n − x_{n−1}|²/dt² + ½ Σ k u_n·u_{n−1} is what it conserves.
double staggered_energy(const Chain& c, const std::vector<double>& prev) {
  double e = 0;
  for (int j = 1; j <= Chain::N; ++j) {
    const double v = (c.y(j) - prev[j]) / c.dt;
    e += 0.5 * Chain::m * v * v;
  }
  for (int j = 0; j <= Chain::N; ++j) {
    const double now = c.y(j + 1) - c.y(j), before = prev[j + 1] - prev[j];
    e += 0.5 * Chain::k * now * before;
  }
  return e;
}

// (Sanitized, 100 000 steps: a million repeat the same path for a size the
// optimised build checks.)
TEST(Energy, UndampedBoundedOverAMillionSteps) {
  const double period = 2.0 * kPi / Chain::omega(3);
  Chain c(period / 20);  // coarse on purpose: any drift would show
  std::vector<double> prev(Chain::N + 2);
  for (int j = 0; j <= Chain::N + 1; ++j) prev[j] = c.y(j);
  c.world.step({});
  const double e0 = staggered_energy(c, prev);
  double lo = e0, hi = e0;
  for (int n = 0; n < (test::kSanitized ? 100'000 : 1'000'000); ++n) {
    for (int j = 0; j <= Chain::N + 1; ++j) prev[j] = c.y(j);
    c.world.step({});
    if (n % 16 == 0) {
      const double e = staggered_energy(c, prev);
      lo = std::min(lo, e), hi = std::max(hi, e);
    }
  }
  EXPECT_LT((hi - lo) / e0, 1e-6) << "energy drifted: " << lo << " .. " << hi;
  EXPECT_EQ(c.world.stats().blowups_total, 0u);
}

TEST(Energy, DampedNeverGrows) {
  const double period = 2.0 * kPi / Chain::omega(1);
  Chain c(period / 200, /*damping=*/0.2);
  std::vector<double> prev(Chain::N + 2);
  for (int j = 0; j <= Chain::N + 1; ++j) prev[j] = c.y(j);
  c.world.step({});
  const double e0 = staggered_energy(c, prev);
  double window_max = e0, last_window_max = e0 * (1 + 1e-12);
  const int per_window = 50;
  for (int n = 1; n <= 200 * 20; ++n) {
    for (int j = 0; j <= Chain::N + 1; ++j) prev[j] = c.y(j);
    c.world.step({});
    const double e = staggered_energy(c, prev);
    ASSERT_LE(e, e0 * (1 + 1e-9)) << "tick " << n;
    window_max = std::max(window_max, e);
    if (n % per_window == 0) {
      ASSERT_LE(window_max, last_window_max) << "energy grew between windows at tick " << n;
      last_window_max = window_max;
      window_max = 0;
    }
  }
  EXPECT_LT(last_window_max, 0.2 * e0);
}

// --- stability bound and the guard ---------------------------------------------

World<float> wobbly_sphere(SimSettings s, Material m) {
  World<float> w(s, 1);
  w.add_body(make_icosphere(0.1f, 2), m);
  // Kick every vertex with a different velocity: all modes, including the stiffest.
  for (std::uint32_t i = 0; i < w.body(0).n; ++i) {
    const Vec3d p = w.position(0, i);
    const double s1 = std::sin(i * 12.9898) * 0.2, s2 = std::sin(i * 78.233) * 0.2, s3 = std::sin(i * 37.719) * 0.2;
    w.set_state(0, i, p, {s1, s2, s3});
  }
  return w;
}

TEST(Stability, AutomaticSubstepsAreStable) {
  Material m;
  m.stiffness = 2000.0;  // stiff enough to need several substeps at 1 kHz
  SimSettings s;
  World<float> w = wobbly_sphere(s, m);
  EXPECT_GT(w.substeps(0), 1);
  for (int n = 0; n < 3000; ++n) {
    w.step({});
    ASSERT_TRUE(test::all_finite(w));
  }
  EXPECT_EQ(w.stats().blowups_total, 0u);
  EXPECT_LT(w.energy(0), 1e-6) << "a damped mesh comes to rest";
}

TEST(Stability, TooLargeDtBlowsUpAndTheGuardRecovers) {
  Material m;
  m.stiffness = 2000.0;
  SimSettings s;
  const StabilityBound bound = stability_bound(make_icosphere(0.1f, 2), m);
  s.rate_hz = 1.0 / (3.0 * bound.dt_critical);  // well past the true limit (the bound is within ~30%)
  s.substeps = 1;
  World<float> w(s, 1);
  w.add_body(make_icosphere(0.1f, 2), m);
  Tool tool;
  tool.radius = 0.03;
  std::uint64_t blowups_after_half = 0;
  for (int n = 0; n < 4000; ++n) {
    // Press into the top, then hold: the tool keeps feeding the unstable modes.
    tool.position = {0.0, 0.13 - 0.02 * std::min(n, 200) / 200.0, 0.0};
    w.step({&tool, 1});
    ASSERT_TRUE(test::all_finite(w)) << "tick " << n;
    if (n == 2000) blowups_after_half = w.stats().blowups_total;
  }
  EXPECT_GT(w.stats().blowups_total, 0u) << "dt beyond the critical value must diverge";
  EXPECT_EQ(w.stats().blowups_total, blowups_after_half) << "after the guard raised the substeps it stays stable";
  EXPECT_GT(w.substeps(0), 1);
  EXPECT_GT(w.feedback()[0].contacts, 0u) << "and the tool still presses on the mesh";
  EXPECT_GT(w.feedback()[0].force[1], 0.0);
}

}  // namespace
}  // namespace sculpt::sim
