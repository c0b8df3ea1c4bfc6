#include "scene/mesh_report.hpp"

#include <algorithm>
#include <cstdint>
#include <numeric>

#include <fmt/format.h>

namespace sculpt::scene {
namespace {

struct DisjointSets {
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];  // path halving
    return x;
  }
  void join(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<std::uint32_t> parent;
};

}  // namespace

void measure(const sim::TriangleMesh& mesh, MeshReport& r) {
  r.vertices = mesh.positions.size();
  r.triangles = mesh.triangles.size();
  const std::vector<sim::Edge> edges = sim::unique_edges(mesh.triangles);
  r.edges = edges.size();
  r.boundary_edges = 0;
  r.nonmanifold_edges = 0;
  DisjointSets sets(mesh.positions.size());
  for (const sim::Edge& e : edges) {
    if (e.faces == 1) ++r.boundary_edges;
    if (e.faces > 2) ++r.nonmanifold_edges;
    sets.join(e.a, e.b);
  }
  // A vertex no triangle uses would be a piece of its own; count only used ones.
  std::vector<char> used(mesh.positions.size(), 0);
  for (const sim::Triangle& t : mesh.triangles)
    for (std::uint32_t v : t) used[v] = 1;
  // Winding: a consistently oriented surface uses each shared edge once in
  // each direction. Key the directed edges by their undirected pair.
  {
    std::vector<std::uint64_t> directed;
    directed.reserve(mesh.triangles.size() * 3);
    for (const sim::Triangle& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = t[k], b = t[(k + 1) % 3];
        if (a == b) continue;
        const std::uint64_t lo = std::min(a, b), hi = std::max(a, b);
        directed.push_back((lo << 33) | (hi << 1) | (a < b ? 1u : 0u));
      }
    }
    std::sort(directed.begin(), directed.end());
    r.inconsistent_edges = 0;
    for (std::size_t i = 0; i + 1 < directed.size(); ++i) {
      // Exactly two uses in the same direction: same key including the direction bit.
      if (directed[i] == directed[i + 1] && (i + 2 >= directed.size() || directed[i + 2] >> 1 != directed[i] >> 1) &&
          (i == 0 || directed[i - 1] >> 1 != directed[i] >> 1)) {
        ++r.inconsistent_edges;
      }
    }
  }
  r.components = 0;
  for (std::uint32_t v = 0; v < mesh.positions.size(); ++v)
    if (used[v] && sets.find(v) == v) ++r.components;

  if (mesh.positions.empty()) {
    r.bbox_min = r.bbox_max = {0, 0, 0};
    return;
  }
  r.bbox_min = r.bbox_max = mesh.positions.front();
  for (const sim::Vec3f& p : mesh.positions) {
    for (int k = 0; k < 3; ++k) {
      r.bbox_min[k] = std::min(r.bbox_min[k], p[k]);
      r.bbox_max[k] = std::max(r.bbox_max[k], p[k]);
    }
  }
}

std::vector<std::string> describe_problems(const MeshReport& r) {
  std::vector<std::string> w;
  if (r.boundary_edges)
    w.push_back(fmt::format("open surface: {} boundary edges (their springs have one side only)",
                            r.boundary_edges));
  if (r.nonmanifold_edges)
    w.push_back(fmt::format("{} non-manifold edges (shared by three or more triangles)",
                            r.nonmanifold_edges));
  if (r.inconsistent_edges)
    w.push_back(fmt::format("inconsistent winding on {} edges: inside and outside disagree there, pushes may "
                            "pull",
                            r.inconsistent_edges));
  if (r.flipped)
    w.push_back("the surface was inside out: its triangles were turned so that they face outwards");
  if (r.components > 1)
    w.push_back(fmt::format("{} separate pieces: they move independently", r.components));
  if (r.degenerate_dropped)
    w.push_back(fmt::format("dropped {} degenerate triangles (repeated corner or zero area)",
                            r.degenerate_dropped));
  if (r.duplicates_dropped)
    w.push_back(fmt::format("dropped {} duplicate triangles", r.duplicates_dropped));
  if (r.skipped_primitives)
    w.push_back(fmt::format("ignored {} points and lines (only triangles are simulated)",
                            r.skipped_primitives));
  if (r.unreferenced_dropped)
    w.push_back(fmt::format("dropped {} vertices no triangle uses", r.unreferenced_dropped));
  return w;
}

}  // namespace sculpt::scene
