// Helpers shared by the simulation tests.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace sculpt::sim::test {

// The sanitized build (ASan + UBSan, tests/unit/sim/meson.build defines
// SCULPT_SANITIZED_BUILD) checks memory safety and undefined behaviour, which
// do not need 164k vertices; it runs the same assertions on smaller meshes
// that still take the same paths. The optimised build keeps the full sizes.
#ifdef SCULPT_SANITIZED_BUILD
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

// A torus whose springs across the Morton order's seams reach past
// kernel::kRingReach blocks (the overflow list, far records behind and
// ahead): 164 blocks (20 992 vertices), or in the sanitized build 112 blocks
// (14 336 vertices, 884 far spring ends), the fewest of this family
// (128 rings) found with far springs at all.
inline TriangleMesh far_spring_torus() { return make_torus(0.3f, 0.05f, 128, kSanitized ? 112 : 164); }

// A mesh with springs reaching past kernel::kRingReach blocks: the
// 163 842-vertex sphere (6 112 far spring ends), or in the sanitized build
// the torus above.
inline TriangleMesh far_spring_mesh() { return kSanitized ? far_spring_torus() : make_icosphere(0.1f, 7); }

// A material with everything off but what a test turns on.
inline Material bare(ForceModel model, double mass, double k) {
  Material m;
  m.model = model;
  m.mass = mass;
  m.stiffness = k;
  m.damping = 0.0;
  m.anchor = 0.0;
  m.anchor_damping = 0.0;
  m.grab_stiffness = 0.0;
  return m;
}

// A closed cone of `rim` rim vertices: its apex and base centre have degree
// `rim`, so their springs overflow the block's ELL rows (the overflow paths).
inline TriangleMesh closed_cone(std::uint32_t rim) {
  TriangleMesh cone;
  cone.positions.push_back({0.0f, 0.15f, 0.0f});
  for (std::uint32_t k = 0; k < rim; ++k) {
    const float a = 6.2831853f * static_cast<float>(k) / static_cast<float>(rim);
    cone.positions.push_back({0.05f * std::cos(a), 0.1f, 0.05f * std::sin(a)});
  }
  cone.positions.push_back({0.0f, 0.1f, 0.0f});
  for (std::uint32_t k = 1; k <= rim; ++k) {
    cone.triangles.push_back({0, k % rim + 1, k});
    cone.triangles.push_back({rim + 1, k, k % rim + 1});
  }
  return cone;
}

// A straight chain 0..n+1 along x (spacing h); triangles {i, i+1, i+1}
// contribute the one edge each. Ends are pinned by the caller.
inline TriangleMesh chain(int free_masses, float h) {
  TriangleMesh mesh;
  for (int i = 0; i < free_masses + 2; ++i) mesh.positions.push_back({h * i, 0.0f, 0.0f});
  for (std::uint32_t i = 0; i + 1 < mesh.positions.size(); ++i) mesh.triangles.push_back({i, i + 1, i + 1});
  return mesh;
}

// A random or degenerate mesh (sim_fuzz, sim_strokes): triangle soup with
// non-manifold edges and isolated vertices, duplicated and coincident
// vertices, zero-length edges, a vertex of degree 80, a flat sheet.
inline TriangleMesh random_mesh(std::mt19937& rng) {
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

template <class S>
bool all_finite(const World<S>& w) {
  for (std::size_t b = 0; b < w.body_count(); ++b) {
    std::vector<Vec3f> p(w.body(b).n);
    w.positions(b, p);
    for (const Vec3f& v : p)
      if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) return false;
  }
  for (const ToolFeedback& f : w.feedback())
    if (!std::isfinite(f.force[0]) || !std::isfinite(f.force[1]) || !std::isfinite(f.force[2]) ||
        !std::isfinite(f.onset_impulse))
      return false;
  return true;
}

// Generalised winding number of a closed mesh around p (≈1 inside, ≈0 outside).
inline double winding_number(const std::vector<Vec3f>& pos, const std::vector<Triangle>& tris, const Vec3d& p) {
  double total = 0;
  for (const Triangle& t : tris) {
    double a[3], b[3], c[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = pos[t[0]][k] - p[k];
      b[k] = pos[t[1]][k] - p[k];
      c[k] = pos[t[2]][k] - p[k];
    }
    const double la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    const double lc = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    const double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                       a[2] * (b[0] * c[1] - b[1] * c[0]);
    const double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const double bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
    const double ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
    total += 2.0 * std::atan2(det, la * lb * lc + ab * lc + bc * la + ca * lb);
  }
  return total / (4.0 * M_PI);
}

}  // namespace sculpt::sim::test
