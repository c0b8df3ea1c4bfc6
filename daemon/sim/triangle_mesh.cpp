#include "sim/triangle_mesh.hpp"

#include <algorithm>
#include <utility>

namespace sculpt::sim {

std::vector<Edge> unique_edges(std::span<const Triangle> triangles) {
  // Sort-and-count beats a hash map here: deterministic order, one allocation.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> half;
  half.reserve(triangles.size() * 3);
  for (const Triangle& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      std::uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a == b) continue;
      if (a > b) std::swap(a, b);
      half.emplace_back(a, b);
    }
  }
  std::sort(half.begin(), half.end());
  std::vector<Edge> edges;
  edges.reserve(half.size() / 2 + 1);
  for (const auto& [a, b] : half) {
    if (!edges.empty() && edges.back().a == a && edges.back().b == b) {
      ++edges.back().faces;
    } else {
      edges.push_back({a, b, 1});
    }
  }
  return edges;
}

}  // namespace sculpt::sim
