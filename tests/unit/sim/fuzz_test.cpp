// Bounded fuzzing inside the unit suite: random and degenerate meshes, random
// materials within the valid ranges, random tool paths with teleports and
// grab toggles, and garbage tool input. Everything must stay finite.
#include <gtest/gtest.h>

#include <random>

#include "sim_test_util.hpp"

namespace sculpt::sim {
namespace {

TriangleMesh random_mesh(std::mt19937& rng) {
  std::uniform_int_distribution<int> kind(0, 4);
  std::uniform_real_distribution<float> coord(-0.1f, 0.1f);
  TriangleMesh m;
  switch (kind(rng)) {
    case 0:  // triangle soup: non-manifold edges everywhere, isolated vertices
    default: {
      const int n = std::uniform_int_distribution<int>(1, 300)(rng);
      for (int i = 0; i < n; ++i) m.positions.push_back({coord(rng), coord(rng), coord(rng)});
      std::uniform_int_distribution<std::uint32_t> v(0, n - 1);
      const int t = std::uniform_int_distribution<int>(0, 2 * n)(rng);
      for (int i = 0; i < t; ++i) m.triangles.push_back({v(rng), v(rng), v(rng)});
      break;
    }
    case 1: {  // a sphere with duplicated (unwelded) and coincident vertices
      m = make_icosphere(0.05f, 2);
      const std::size_t n = m.positions.size();
      for (std::size_t i = 0; i < n; i += 3) m.positions.push_back(m.positions[i]);
      for (std::size_t t = 0; t < m.triangles.size(); t += 4) m.triangles[t][0] = static_cast<std::uint32_t>(n + t / 12);
      break;
    }
    case 2: {  // zero-length edges: a collapsed region and degenerate triangles
      m = make_box_grid({0.1f, 0.05f, 0.1f}, 4);
      for (std::size_t i = 0; i < m.positions.size(); i += 5) m.positions[i] = m.positions[0];
      m.triangles.push_back({0, 0, 0});
      m.triangles.push_back({1, 1, 2});
      break;
    }
    case 3: {  // a fan: one vertex of very high degree (overflow path)
      m.positions.push_back({0, 0, 0});
      const int n = 80;
      for (int i = 0; i < n; ++i) m.positions.push_back({0.05f * std::cos(i * 0.0785f), 0.05f * std::sin(i * 0.0785f), 0});
      for (std::uint32_t i = 1; i <= n; ++i) m.triangles.push_back({0, i, i % n + 1});
      break;
    }
    case 4: {  // flat sheet, everything in one plane, plus a stray far vertex
      m = make_torus(0.05f, 0.01f, 12, 6);
      for (auto& p : m.positions) p[1] = 0;
      m.positions.push_back({10.0f, 10.0f, 10.0f});
      break;
    }
  }
  return m;
}

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
      const TriangleMesh mesh = random_mesh(rng);
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
