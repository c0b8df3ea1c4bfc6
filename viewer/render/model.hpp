// What a viewer shows, CPU side: meshes (topology, rest and current positions,
// normals recomputed from the current positions), tools, boxes, the daemon's
// stats. Filled from a scene file (offline) or from the stream (live); the
// renderer uploads only the vertex ranges marked dirty here.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace sculpt::view {

using Vec3f = std::array<float, 3>;

struct Aabb {
  Vec3f min{0, 0, 0};
  Vec3f max{0, 0, 0};
  bool empty() const { return min[0] > max[0]; }
  static Aabb none() { return {{1, 1, 1}, {-1, -1, -1}}; }
  void grow(const Vec3f& p);
  void grow(const Aabb& b);
};

// Half-open [begin, end) vertex range.
struct Range {
  std::uint32_t begin = 0;
  std::uint32_t end = 0;
  bool operator==(const Range&) const = default;
};

// Sorted indices -> ranges; gaps of at most `merge_gap` unchanged vertices are
// folded in (one larger upload beats many tiny ones).
std::vector<Range> to_ranges(std::span<const std::uint32_t> sorted_indices, std::uint32_t merge_gap);

class ViewMesh {
 public:
  // `triangles`: 3 indices per triangle; `rest`, `positions`: xyz per vertex.
  // Throws std::invalid_argument when sizes disagree or an index is out of range.
  ViewMesh(std::uint32_t id, std::string name, std::string material, std::vector<std::uint32_t> triangles,
           std::vector<float> rest, std::vector<float> positions);

  std::uint32_t id() const { return id_; }
  const std::string& name() const { return name_; }
  const std::string& material() const { return material_; }
  std::size_t vertex_count() const { return positions_.size() / 3; }
  std::size_t triangle_count() const { return triangles_.size() / 3; }
  std::span<const std::uint32_t> triangles() const { return triangles_; }
  std::span<const float> rest() const { return rest_; }
  std::span<const float> positions() const { return positions_; }
  std::span<const float> normals() const { return normals_; }
  const Aabb& bounds() const { return bounds_; }
  void set_bounds(const Aabb& b) { bounds_ = b; }
  // Unique edges (2 indices each) for the wireframe, built on first use.
  const std::vector<std::uint32_t>& edges();

  // New positions for `indices` (ascending or not, no duplicates needed):
  // xyz triples in the same order. Normals around them are recomputed and
  // both are marked dirty. Indices out of range throw std::out_of_range.
  void set_positions(std::span<const std::uint32_t> indices, std::span<const float> xyz);
  // Vertices [begin, end) from `xyz` (3 floats per vertex of the range).
  void set_range(std::uint32_t begin, std::uint32_t end, std::span<const float> xyz);
  // Every vertex at once (a new keyframe of the same topology).
  void set_all_positions(std::span<const float> xyz);
  Aabb compute_bounds() const;

  // Vertex ranges whose position/normal changed since the last take; clears them.
  // `all` is true when everything must be uploaded (new mesh).
  struct Dirty {
    bool all = false;
    std::vector<Range> ranges;
  };
  Dirty take_dirty(std::uint32_t merge_gap = 32);
  bool dirty() const { return all_dirty_ || !dirty_.empty(); }

 private:
  void update_normals_around(std::span<const std::uint32_t> indices);
  void face_normal(std::uint32_t t);
  void vertex_normal(std::uint32_t v);

  std::uint32_t id_;
  std::string name_;
  std::string material_;
  std::vector<std::uint32_t> triangles_;
  std::vector<float> rest_;
  std::vector<float> positions_;
  std::vector<float> normals_;
  std::vector<float> face_normals_;     // area-weighted, per triangle
  std::vector<std::uint32_t> vt_offsets_;  // CSR: triangles around each vertex
  std::vector<std::uint32_t> vt_list_;
  std::vector<std::uint32_t> edges_;
  Aabb bounds_;
  // Scratch and dirty tracking (no allocation per delta once warmed up).
  std::vector<std::uint8_t> tri_mark_;
  std::vector<std::uint8_t> dirty_mark_;
  std::vector<std::uint32_t> touched_tris_;
  std::vector<std::uint32_t> dirty_;
  std::vector<std::uint32_t> range_scratch_;
  bool all_dirty_ = true;
};

enum class ToolShape { sphere, capsule };

struct ViewTool {
  std::uint32_t id = 0;
  ToolShape shape = ToolShape::sphere;
  float radius = 0.02f;
  float half_length = 0.0f;                    // capsule: along orientation·(1,0,0)
  Vec3f position{0, 0, 0};
  std::array<float, 4> orientation{1, 0, 0, 0};  // w, x, y, z
  bool grabbing = false;
  Vec3f force{0, 0, 0};                        // N, the mesh's reaction on the tool
  std::uint32_t contacts = 0;
  Aabb bounds() const;
};

struct ViewStats {
  float rate_hz = 0;
  float jitter_p99_us = 0;
  std::uint64_t overruns = 0;
  std::uint64_t vertices_total = 0;
  std::uint64_t vertices_awake = 0;
  std::uint32_t viewers = 0;
  std::uint32_t devices = 0;
  bool paused = false;
};

struct ViewModel {
  std::string scene;                 // "builtin:default", a path
  std::vector<ViewMesh> meshes;
  std::vector<ViewTool> tools;
  Aabb scene_bounds = Aabb::none();
  std::optional<ViewStats> stats;    // the daemon's, when live
  std::uint64_t sequence = 0;        // sim tick shown
  std::uint64_t generation = 0;      // bumped on every new keyframe (GPU buffers are rebuilt)

  ViewMesh* find_mesh(std::uint32_t id);
  Aabb bounds_now() const;           // meshes and tools as they are
};

}  // namespace sculpt::view
