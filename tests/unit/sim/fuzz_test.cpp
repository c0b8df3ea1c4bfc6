// Bounded fuzzing inside the unit suite: random and degenerate meshes, random
// materials within the valid ranges, random tool paths with teleports and
// grab toggles, and garbage tool input. Everything must stay finite.
#include <gtest/gtest.h>

#include <random>

#include "test_meshes.hpp"

namespace sculpt::sim {
namespace {

TEST(Fuzz, RandomMeshesAndToolPathsStayFinite) {
  std::mt19937 rng(20261121);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int round = 0; round < 40; ++round) {
    SimSettings s;
    s.integrator = static_cast<Integrator>(round % 3);
    s.substeps = round % 4 == 0 ? 1 : 0;  // sometimes forced: may be unstable, the guard must cope
    World<float> w(s, 2);
    for (int b = 0; b < 2; ++b) {
      Material m;
      m.model = u(rng) < 0.5 ? ForceModel::spring : ForceModel::linear;
      m.mass = std::pow(10.0, -3 + 2 * u(rng));
      m.stiffness = std::pow(10.0, 3.3 * u(rng));
      m.damping = u(rng) < 0.3 ? 0.0 : 0.1 * u(rng);
      m.anchor = u(rng) < 0.3 ? 0.0 : 10 * u(rng);
      m.plastic = u(rng) < 0.4;
      m.gravity = u(rng) < 0.3;
      BodyOptions o;
      const TriangleMesh mesh = test::random_mesh(rng);
      if (u(rng) < 0.3) o.pinned = {0};
      w.add_body(mesh, m, o);
    }
    Tool tools[2];
    for (int n = 0; n < 150; ++n) {
      for (Tool& t : tools) {
        const double r = u(rng);
        if (r < 0.05) {  // teleport anywhere, maybe into the middle of a mesh
          t.position = {0.2 * u(rng) - 0.1, 0.2 * u(rng) - 0.1, 0.2 * u(rng) - 0.1};
        } else if (r < 0.06) {
          t.position = {NAN, 0, 0};
        } else if (r < 0.07) {
          t.radius = u(rng) < 0.5 ? 0.0 : 1e9;
        } else {
          for (double& c : t.position) c = std::isfinite(c) ? c + 0.004 * (u(rng) - 0.5) : 0.0;
          t.radius = 0.001 + 0.03 * u(rng);
        }
        t.shape = u(rng) < 0.5 ? ToolShape::sphere : ToolShape::capsule;
        t.half_axis = {0.02 * u(rng), 0.0, 0.01};
        if (u(rng) < 0.05) t.grab = !t.grab;
        t.active = u(rng) > 0.02;
      }
      w.step(tools);
      ASSERT_TRUE(test::all_finite(w)) << "round " << round << " tick " << n;
      for (std::size_t b = 0; b < w.body_count(); ++b) ASSERT_TRUE(std::isfinite(w.energy(b)));
    }
  }
}

}  // namespace
}  // namespace sculpt::sim
