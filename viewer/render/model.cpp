#include "render/model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sculpt::view {

void Aabb::grow(const Vec3f& p) {
  if (empty()) {
    min = max = p;
    return;
  }
  for (int i = 0; i < 3; ++i) {
    min[i] = std::min(min[i], p[i]);
    max[i] = std::max(max[i], p[i]);
  }
}

void Aabb::grow(const Aabb& b) {
  if (b.empty()) return;
  grow(b.min);
  grow(b.max);
}

std::vector<Range> to_ranges(std::span<const std::uint32_t> sorted, std::uint32_t merge_gap) {
  std::vector<Range> out;
  for (std::uint32_t v : sorted) {
    if (!out.empty() && v < out.back().end) continue;  // duplicate
    if (!out.empty() && v - out.back().end <= merge_gap) {
      out.back().end = v + 1;
    } else {
      out.push_back({v, v + 1});
    }
  }
  return out;
}

ViewMesh::ViewMesh(std::uint32_t id, std::string name, std::string material, std::vector<std::uint32_t> triangles,
                   std::vector<float> rest, std::vector<float> positions)
    : id_(id),
      name_(std::move(name)),
      material_(std::move(material)),
      triangles_(std::move(triangles)),
      rest_(std::move(rest)),
      positions_(std::move(positions)) {
  if (positions_.size() % 3 != 0 || rest_.size() != positions_.size() || triangles_.size() % 3 != 0) {
    throw std::invalid_argument(fmt::format("mesh {} '{}': {} rest and {} current coordinates, {} indices",
                                            id_, name_, rest_.size(), positions_.size(), triangles_.size()));
  }
  const std::size_t nv = vertex_count();
  const std::size_t nt = triangle_count();
  for (std::uint32_t i : triangles_) {
    if (i >= nv) throw std::invalid_argument(fmt::format("mesh {} '{}': triangle index {} >= {} vertices", id_, name_, i, nv));
  }
  // CSR vertex -> triangles.
  vt_offsets_.assign(nv + 1, 0);
  for (std::uint32_t i : triangles_) ++vt_offsets_[i + 1];
  for (std::size_t v = 0; v < nv; ++v) vt_offsets_[v + 1] += vt_offsets_[v];
  vt_list_.resize(triangles_.size());
  std::vector<std::uint32_t> fill(vt_offsets_.begin(), vt_offsets_.end() - 1);
  for (std::size_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) vt_list_[fill[triangles_[t * 3 + k]]++] = static_cast<std::uint32_t>(t);
  }
  face_normals_.assign(nt * 3, 0.0f);
  normals_.assign(nv * 3, 0.0f);
  for (std::uint32_t t = 0; t < nt; ++t) face_normal(t);
  for (std::uint32_t v = 0; v < nv; ++v) vertex_normal(v);
  tri_mark_.assign(nt, 0);
  dirty_mark_.assign(nv, 0);
  bounds_ = compute_bounds();
}

const std::vector<std::uint32_t>& ViewMesh::edges() {
  if (edges_.empty() && !triangles_.empty()) {
    std::vector<std::uint64_t> keys;
    keys.reserve(triangles_.size());
    for (std::size_t t = 0; t < triangle_count(); ++t) {
      for (int k = 0; k < 3; ++k) {
        std::uint32_t a = triangles_[t * 3 + k], b = triangles_[t * 3 + (k + 1) % 3];
        if (a == b) continue;
        if (a > b) std::swap(a, b);
        keys.push_back(std::uint64_t{a} << 32 | b);
      }
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    edges_.reserve(keys.size() * 2);
    for (std::uint64_t k : keys) {
      edges_.push_back(static_cast<std::uint32_t>(k >> 32));
      edges_.push_back(static_cast<std::uint32_t>(k));
    }
  }
  return edges_;
}

void ViewMesh::face_normal(std::uint32_t t) {
  const float* a = &positions_[triangles_[t * 3] * 3];
  const float* b = &positions_[triangles_[t * 3 + 1] * 3];
  const float* c = &positions_[triangles_[t * 3 + 2] * 3];
  const float u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const float w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  // Not normalised: the length is twice the area, so larger faces weigh more.
  face_normals_[t * 3 + 0] = u[1] * w[2] - u[2] * w[1];
  face_normals_[t * 3 + 1] = u[2] * w[0] - u[0] * w[2];
  face_normals_[t * 3 + 2] = u[0] * w[1] - u[1] * w[0];
}

void ViewMesh::vertex_normal(std::uint32_t v) {
  float n[3] = {0, 0, 0};
  for (std::uint32_t i = vt_offsets_[v]; i < vt_offsets_[v + 1]; ++i) {
    const float* f = &face_normals_[vt_list_[i] * 3];
    n[0] += f[0];
    n[1] += f[1];
    n[2] += f[2];
  }
  const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  const float inv = len > 0 ? 1.0f / len : 0.0f;
  normals_[v * 3 + 0] = n[0] * inv;
  normals_[v * 3 + 1] = n[1] * inv;
  normals_[v * 3 + 2] = n[2] * inv;
}

void ViewMesh::set_positions(std::span<const std::uint32_t> indices, std::span<const float> xyz) {
  if (xyz.size() != indices.size() * 3) {
    throw std::invalid_argument(fmt::format("mesh {} '{}': {} indices but {} coordinates", id_, name_, indices.size(), xyz.size()));
  }
  const std::size_t nv = vertex_count();
  for (std::size_t i = 0; i < indices.size(); ++i) {
    const std::uint32_t v = indices[i];
    if (v >= nv) throw std::out_of_range(fmt::format("mesh {} '{}': delta index {} >= {} vertices", id_, name_, v, nv));
    positions_[v * 3 + 0] = xyz[i * 3 + 0];
    positions_[v * 3 + 1] = xyz[i * 3 + 1];
    positions_[v * 3 + 2] = xyz[i * 3 + 2];
  }
  update_normals_around(indices);
}

void ViewMesh::set_range(std::uint32_t begin, std::uint32_t end, std::span<const float> xyz) {
  if (begin > end || end > vertex_count() || xyz.size() != std::size_t{end - begin} * 3) {
    throw std::out_of_range(fmt::format("mesh {} '{}': range [{}, {}) with {} coordinates for {} vertices", id_, name_,
                                        begin, end, xyz.size(), vertex_count()));
  }
  std::copy(xyz.begin(), xyz.end(), positions_.begin() + std::ptrdiff_t{begin} * 3);
  range_scratch_.resize(end - begin);
  for (std::uint32_t v = begin; v < end; ++v) range_scratch_[v - begin] = v;
  update_normals_around(range_scratch_);
}

void ViewMesh::set_all_positions(std::span<const float> xyz) {
  if (xyz.size() != positions_.size()) {
    throw std::invalid_argument(fmt::format("mesh {} '{}': {} coordinates for {} vertices", id_, name_, xyz.size(), vertex_count()));
  }
  std::copy(xyz.begin(), xyz.end(), positions_.begin());
  for (std::uint32_t t = 0; t < triangle_count(); ++t) face_normal(t);
  for (std::uint32_t v = 0; v < vertex_count(); ++v) vertex_normal(v);
  bounds_ = compute_bounds();
  all_dirty_ = true;
}

// Only the triangles around moved vertices get new face normals, and only the
// vertices of those triangles new vertex normals: a 10k-vertex delta on a
// 100k mesh costs ~10k, not ~100k.
void ViewMesh::update_normals_around(std::span<const std::uint32_t> indices) {
  touched_tris_.clear();
  for (std::uint32_t v : indices) {
    for (std::uint32_t i = vt_offsets_[v]; i < vt_offsets_[v + 1]; ++i) {
      const std::uint32_t t = vt_list_[i];
      if (!tri_mark_[t]) {
        tri_mark_[t] = 1;
        touched_tris_.push_back(t);
      }
    }
    if (!dirty_mark_[v]) {  // isolated vertices have no triangle but still moved
      dirty_mark_[v] = 1;
      dirty_.push_back(v);
    }
  }
  for (std::uint32_t t : touched_tris_) {
    tri_mark_[t] = 0;
    face_normal(t);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = triangles_[t * 3 + k];
      if (!dirty_mark_[v]) {
        dirty_mark_[v] = 1;
        dirty_.push_back(v);
      }
    }
  }
  // Vertex normals of everything now dirty whose faces may have changed.
  for (std::uint32_t t : touched_tris_) {
    for (int k = 0; k < 3; ++k) vertex_normal(triangles_[t * 3 + k]);
  }
}

Aabb ViewMesh::compute_bounds() const {
  Aabb b = Aabb::none();
  for (std::size_t v = 0; v < vertex_count(); ++v) b.grow(Vec3f{positions_[v * 3], positions_[v * 3 + 1], positions_[v * 3 + 2]});
  return b;
}

ViewMesh::Dirty ViewMesh::take_dirty(std::uint32_t merge_gap) {
  Dirty d;
  d.all = all_dirty_;
  if (!all_dirty_) {
    std::sort(dirty_.begin(), dirty_.end());
    d.ranges = to_ranges(dirty_, merge_gap);
  }
  for (std::uint32_t v : dirty_) dirty_mark_[v] = 0;
  dirty_.clear();
  all_dirty_ = false;
  return d;
}

Aabb ViewTool::bounds() const {
  // Capsule axis: orientation applied to +x (as sculptd's server sends it).
  const float w = orientation[0], x = orientation[1], y = orientation[2], z = orientation[3];
  const Vec3f axis{1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)};
  const float h = shape == ToolShape::capsule ? half_length : 0.0f;
  Aabb b = Aabb::none();
  for (float s : {-1.0f, 1.0f}) {
    const Vec3f c{position[0] + s * h * axis[0], position[1] + s * h * axis[1], position[2] + s * h * axis[2]};
    b.grow(Vec3f{c[0] - radius, c[1] - radius, c[2] - radius});
    b.grow(Vec3f{c[0] + radius, c[1] + radius, c[2] + radius});
  }
  return b;
}

ViewMesh* ViewModel::find_mesh(std::uint32_t id) {
  for (auto& m : meshes) {
    if (m.id() == id) return &m;
  }
  return nullptr;
}

Aabb ViewModel::bounds_now() const {
  Aabb b = Aabb::none();
  for (const auto& m : meshes) b.grow(m.bounds());
  for (const auto& t : tools) b.grow(t.bounds());
  return b;
}

}  // namespace sculpt::view
