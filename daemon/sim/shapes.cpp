#include "sim/shapes.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace sculpt::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3f scaled_unit(const std::array<double, 3>& p, double radius) {
  const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  const double s = radius / len;
  return {static_cast<float>(p[0] * s), static_cast<float>(p[1] * s), static_cast<float>(p[2] * s)};
}

}  // namespace

TriangleMesh make_icosphere(float radius, int subdivisions) {
  if (!(radius > 0.0f) || !std::isfinite(radius)) throw std::invalid_argument("icosphere: radius must be > 0");
  if (subdivisions < 0 || subdivisions > 9)
    throw std::invalid_argument("icosphere: subdivisions must be in [0, 9], got " + std::to_string(subdivisions));

  // Unit directions in double so every level normalises from exact midpoints.
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<std::array<double, 3>> dir = {
      {-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
      {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& d : dir) {
    const double l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (double& c : d) c /= l;
  }
  std::vector<Triangle> tris = {
      {0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
      {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};

  for (int level = 0; level < subdivisions; ++level) {
    // Midpoint per edge, keyed by the sorted pair; lookups only, so the
    // vertex numbering depends on triangle order alone (deterministic).
    std::unordered_map<std::uint64_t, std::uint32_t> midpoint;
    midpoint.reserve(tris.size() * 2);
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = a < b ? (std::uint64_t{a} << 32 | b) : (std::uint64_t{b} << 32 | a);
      auto [it, inserted] = midpoint.try_emplace(key, static_cast<std::uint32_t>(dir.size()));
      if (inserted) {
        std::array<double, 3> m{};
        for (int k = 0; k < 3; ++k) m[k] = 0.5 * (dir[a][k] + dir[b][k]);
        const double l = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        for (double& c : m) c /= l;
        dir.push_back(m);
      }
      return it->second;
    };
    std::vector<Triangle> next;
    next.reserve(tris.size() * 4);
    for (const Triangle& tri : tris) {
      const std::uint32_t ab = mid(tri[0], tri[1]), bc = mid(tri[1], tri[2]), ca = mid(tri[2], tri[0]);
      next.push_back({tri[0], ab, ca});
      next.push_back({tri[1], bc, ab});
      next.push_back({tri[2], ca, bc});
      next.push_back({ab, bc, ca});
    }
    tris = std::move(next);
  }

  TriangleMesh mesh;
  mesh.positions.reserve(dir.size());
  for (const auto& d : dir) mesh.positions.push_back(scaled_unit(d, radius));
  mesh.triangles = std::move(tris);
  return mesh;
}

TriangleMesh make_torus(float major_radius, float minor_radius, int rings, int sides) {
  if (!(minor_radius > 0.0f) || !(major_radius > minor_radius) || !std::isfinite(major_radius))
    throw std::invalid_argument("torus: need 0 < minor_radius < major_radius");
  if (rings < 3 || sides < 3 || rings > 100000 || sides > 100000 ||
      static_cast<long long>(rings) * sides > 50'000'000)
    throw std::invalid_argument("torus: rings and sides must be >= 3 (and rings·sides <= 5e7)");
  TriangleMesh mesh;
  mesh.positions.reserve(static_cast<std::size_t>(rings) * sides);
  for (int i = 0; i < rings; ++i) {
    const double u = 2.0 * kPi * i / rings;
    for (int j = 0; j < sides; ++j) {
      const double v = 2.0 * kPi * j / sides;
      const double w = major_radius + minor_radius * std::cos(v);
      mesh.positions.push_back({static_cast<float>(w * std::cos(u)), static_cast<float>(minor_radius * std::sin(v)),
                                static_cast<float>(w * std::sin(u))});
    }
  }
  auto id = [&](int i, int j) { return static_cast<std::uint32_t>((i % rings) * sides + (j % sides)); };
  mesh.triangles.reserve(static_cast<std::size_t>(rings) * sides * 2);
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < sides; ++j) {
      // (i,j) → (i,j+1) → (i+1,j+1) runs counter-clockwise seen from outside the tube.
      const std::uint32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      mesh.triangles.push_back({a, d, c});
      mesh.triangles.push_back({a, c, b});
    }
  }
  return mesh;
}

TriangleMesh make_box_grid(std::array<float, 3> size, int cells) {
  for (float s : size)
    if (!(s > 0.0f) || !std::isfinite(s)) throw std::invalid_argument("box: every size must be > 0");
  if (cells < 1 || cells > 1024)
    throw std::invalid_argument("box: cells_per_axis must be in [1, 1024], got " + std::to_string(cells));
  const int n = cells;
  const std::size_t side = static_cast<std::size_t>(n) + 1;
  // Lattice index → welded vertex; only surface points get one.
  std::vector<std::int32_t> index(side * side * side, -1);
  TriangleMesh mesh;
  auto vertex = [&](std::array<int, 3> g) {
    std::int32_t& cell = index[(static_cast<std::size_t>(g[0]) * side + g[1]) * side + g[2]];
    if (cell < 0) {
      cell = static_cast<std::int32_t>(mesh.positions.size());
      Vec3f p;
      for (int k = 0; k < 3; ++k) p[k] = size[k] * (static_cast<float>(g[k]) / n - 0.5f);
      mesh.positions.push_back(p);
    }
    return static_cast<std::uint32_t>(cell);
  };
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // e_u × e_v = e_axis
    for (int at : {0, n}) {
      const bool outward_positive = at == n;
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          auto g = [&](int di, int dj) {
            std::array<int, 3> p{};
            p[axis] = at;
            p[u] = i + di;
            p[v] = j + dj;
            return vertex(p);
          };
          const std::uint32_t a = g(0, 0), b = g(1, 0), c = g(1, 1), d = g(0, 1);
          if (outward_positive) {
            mesh.triangles.push_back({a, b, c});
            mesh.triangles.push_back({a, c, d});
          } else {
            mesh.triangles.push_back({a, c, b});
            mesh.triangles.push_back({a, d, c});
          }
        }
      }
    }
  }
  return mesh;
}

double signed_volume(const TriangleMesh& mesh) {
  double volume = 0.0;
  for (const Triangle& t : mesh.triangles) {
    const Vec3f& a = mesh.positions[t[0]];
    const Vec3f& b = mesh.positions[t[1]];
    const Vec3f& c = mesh.positions[t[2]];
    const double cx = double(b[1]) * c[2] - double(b[2]) * c[1];
    const double cy = double(b[2]) * c[0] - double(b[0]) * c[2];
    const double cz = double(b[0]) * c[1] - double(b[1]) * c[0];
    volume += (a[0] * cx + a[1] * cy + a[2] * cz) / 6.0;
  }
  return volume;
}

}  // namespace sculpt::sim
