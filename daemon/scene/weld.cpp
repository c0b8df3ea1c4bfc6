#include "scene/weld.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

#include <fmt/format.h>

namespace sculpt::scene {
namespace {

using sim::Triangle;
using sim::Vec3f;

// Open-addressing map from a cell key to the newest representative vertex in
// that cell (older ones hang off `next`). Faster and leaner than
// std::unordered_map for the millions of probes a big STL needs.
class CellTable {
 public:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();

  explicit CellTable(std::size_t expected) {
    std::size_t cap = 64;
    while (cap < expected * 2) cap <<= 1;
    keys_.assign(cap, 0);
    values_.assign(cap, kEmpty);
  }

  std::uint32_t find(std::uint64_t key) const {
    for (std::size_t i = hash(key) & mask();; i = (i + 1) & mask()) {
      if (values_[i] == kEmpty) return kEmpty;
      if (keys_[i] == key) return values_[i];
    }
  }

  // Sets the head of `key`'s chain, returning the previous head (or kEmpty).
  std::uint32_t push(std::uint64_t key, std::uint32_t value) {
    if ((size_ + 1) * 2 > keys_.size()) grow();
    for (std::size_t i = hash(key) & mask();; i = (i + 1) & mask()) {
      if (values_[i] == kEmpty) {
        keys_[i] = key;
        values_[i] = value;
        ++size_;
        return kEmpty;
      }
      if (keys_[i] == key) return std::exchange(values_[i], value);
    }
  }

 private:
  static std::size_t hash(std::uint64_t k) {
    k ^= k >> 33;  // murmur3 finaliser: cell keys are highly regular
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ULL;
    k ^= k >> 33;
    return static_cast<std::size_t>(k);
  }
  std::size_t mask() const { return keys_.size() - 1; }

  void grow() {
    std::vector<std::uint64_t> keys(keys_.size() * 2, 0);
    std::vector<std::uint32_t> values(keys_.size() * 2, kEmpty);
    keys.swap(keys_);
    values.swap(values_);
    size_ = 0;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      if (values[i] != kEmpty) push(keys[i], values[i]);
    }
  }

  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> values_;
  std::size_t size_ = 0;
};

// 21 bits per axis; aliasing of far-apart cells only adds candidates that the
// distance test rejects, so it costs time, never correctness.
std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::uint64_t m = (1u << 21) - 1;
  return (static_cast<std::uint64_t>(x) & m) | ((static_cast<std::uint64_t>(y) & m) << 21) |
         ((static_cast<std::uint64_t>(z) & m) << 42);
}

std::uint64_t exact_key(const Vec3f& p) {
  // +0.0f folds -0.0f into 0 so the two zeros weld.
  std::uint32_t b[3];
  for (int k = 0; k < 3; ++k) {
    float v = p[k] + 0.0f;
    std::memcpy(&b[k], &v, sizeof v);
  }
  std::uint64_t h = b[0];
  h = h * 0x9E3779B97F4A7C15ULL ^ b[1];
  h = h * 0x9E3779B97F4A7C15ULL ^ b[2];
  return h;
}

bool within(const Vec3f& a, const Vec3f& b, float tol) {
  const double dx = double(a[0]) - b[0], dy = double(a[1]) - b[1], dz = double(a[2]) - b[2];
  return dx * dx + dy * dy + dz * dz <= double(tol) * tol;
}

double twice_area(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const double ux = double(b[0]) - a[0], uy = double(b[1]) - a[1], uz = double(b[2]) - a[2];
  const double vx = double(c[0]) - a[0], vy = double(c[1]) - a[1], vz = double(c[2]) - a[2];
  const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
  return std::sqrt(cx * cx + cy * cy + cz * cz);
}

}  // namespace

std::optional<std::string> find_raw_problem(const sim::TriangleMesh& raw) {
  if (raw.triangles.empty()) return std::string("the file holds no triangles");
  if (raw.positions.size() >= std::numeric_limits<std::uint32_t>::max()) {
    return fmt::format("{} vertices is more than this program supports", raw.positions.size());
  }
  for (std::size_t i = 0; i < raw.positions.size(); ++i) {
    for (float c : raw.positions[i]) {
      if (!std::isfinite(c)) {
        return fmt::format("vertex {} has a non-finite coordinate ({} {} {})", i, raw.positions[i][0],
                           raw.positions[i][1], raw.positions[i][2]);
      }
    }
  }
  for (std::size_t t = 0; t < raw.triangles.size(); ++t) {
    for (std::uint32_t v : raw.triangles[t]) {
      if (v >= raw.positions.size()) {
        return fmt::format("triangle {} refers to vertex {} but there are only {} vertices", t, v,
                           raw.positions.size());
      }
    }
  }
  return std::nullopt;
}

WeldResult weld(const sim::TriangleMesh& raw, float tolerance) {
  const std::size_t n = raw.positions.size();
  WeldResult out;
  std::vector<std::uint32_t> rep_of(n);     // raw vertex -> representative (welded) index
  std::vector<Vec3f> reps;                  // representative positions, in first-occurrence order
  std::vector<std::uint32_t> next;          // chain of representatives sharing a cell
  reps.reserve(n / 4 + 16);
  next.reserve(n / 4 + 16);
  CellTable table(n / 4 + 16);

  if (!(tolerance > 0.0f)) {
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3f p = raw.positions[i];
      const std::uint64_t key = exact_key(p);
      std::uint32_t found = CellTable::kEmpty;
      for (std::uint32_t r = table.find(key); r != CellTable::kEmpty; r = next[r]) {
        if (reps[r][0] == p[0] && reps[r][1] == p[1] && reps[r][2] == p[2]) {
          found = r;
          break;
        }
      }
      if (found == CellTable::kEmpty) {
        found = static_cast<std::uint32_t>(reps.size());
        reps.push_back(p);
        next.push_back(table.push(key, found));
      }
      rep_of[i] = found;
    }
  } else {
    // Cells as wide as the tolerance: a match lies in the same or a neighbouring cell.
    const double inv = 1.0 / tolerance;
    auto cell = [&](float c) { return static_cast<std::int64_t>(std::floor(double(c) * inv)); };
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3f p = raw.positions[i];
      const std::int64_t cx = cell(p[0]), cy = cell(p[1]), cz = cell(p[2]);
      std::uint32_t found = CellTable::kEmpty;
      auto scan = [&](std::uint64_t key) {
        for (std::uint32_t r = table.find(key); r != CellTable::kEmpty; r = next[r]) {
          if (within(reps[r], p, tolerance) && (found == CellTable::kEmpty || r < found)) found = r;
        }
      };
      scan(cell_key(cx, cy, cz));  // the common case: an exact repeat in the own cell
      if (found == CellTable::kEmpty) {
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
              if (dx || dy || dz) scan(cell_key(cx + dx, cy + dy, cz + dz));
      }
      if (found == CellTable::kEmpty) {
        found = static_cast<std::uint32_t>(reps.size());
        reps.push_back(p);
        next.push_back(table.push(cell_key(cx, cy, cz), found));
      }
      rep_of[i] = found;
    }
  }
  out.stats.welded_away = n - reps.size();

  // Triangles: remap, drop degenerate ones (a tolerance-sized sliver carries no spring worth having).
  const double min_twice_area = double(tolerance) * tolerance;
  std::vector<Triangle> tris;
  tris.reserve(raw.triangles.size());
  for (const Triangle& t : raw.triangles) {
    const Triangle w{rep_of[t[0]], rep_of[t[1]], rep_of[t[2]]};
    if (w[0] == w[1] || w[1] == w[2] || w[0] == w[2] ||
        twice_area(reps[w[0]], reps[w[1]], reps[w[2]]) <= min_twice_area) {
      ++out.stats.degenerate_dropped;
      continue;
    }
    tris.push_back(w);
  }

  // Duplicates (either winding): sort by the sorted corner triple, keep the first occurrence.
  {
    std::vector<std::pair<Triangle, std::uint32_t>> keyed(tris.size());
    for (std::size_t i = 0; i < tris.size(); ++i) {
      Triangle k = tris[i];
      std::sort(k.begin(), k.end());
      keyed[i] = {k, static_cast<std::uint32_t>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<char> keep(tris.size(), 1);
    for (std::size_t i = 1; i < keyed.size(); ++i) {
      if (keyed[i].first == keyed[i - 1].first) {
        keep[keyed[i].second] = 0;
        ++out.stats.duplicates_dropped;
      }
    }
    if (out.stats.duplicates_dropped) {
      std::size_t w = 0;
      for (std::size_t i = 0; i < tris.size(); ++i)
        if (keep[i]) tris[w++] = tris[i];
      tris.resize(w);
    }
  }

  // Compact: keep referenced representatives, in their order.
  std::vector<std::uint32_t> new_index(reps.size(), CellTable::kEmpty);
  for (const Triangle& t : tris)
    for (std::uint32_t v : t) new_index[v] = 0;
  std::uint32_t count = 0;
  out.mesh.positions.reserve(reps.size());
  for (std::size_t r = 0; r < reps.size(); ++r) {
    if (new_index[r] == CellTable::kEmpty) continue;
    new_index[r] = count++;
    out.mesh.positions.push_back(reps[r]);
  }
  out.stats.unreferenced_dropped = reps.size() - count;
  for (Triangle& t : tris)
    for (std::uint32_t& v : t) v = new_index[v];
  out.mesh.triangles = std::move(tris);
  return out;
}

}  // namespace sculpt::scene
