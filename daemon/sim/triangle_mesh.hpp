// A welded triangle mesh: the hand-off between daemon/scene (which loads and
// welds files) and daemon/sim (which turns it into a spring network).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace sculpt::sim {

using Vec3f = std::array<float, 3>;
using Triangle = std::array<std::uint32_t, 3>;

struct TriangleMesh {
  std::vector<Vec3f> positions;     // one per welded vertex, scene units (metres)
  std::vector<Triangle> triangles;  // indices into positions, counter-clockwise = outside
};

// An undirected edge, a < b, and how many triangles use it (1 = boundary,
// 2 = manifold interior, more = non-manifold).
struct Edge {
  std::uint32_t a = 0;
  std::uint32_t b = 0;
  std::uint32_t faces = 0;
};

// Unique edges of the triangles, sorted by (a, b): one spring per real edge.
// Triangles with a repeated index contribute only their distinct edges.
std::vector<Edge> unique_edges(std::span<const Triangle> triangles);

}  // namespace sculpt::sim
