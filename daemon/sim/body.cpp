#include "sim/body.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "sim/stability.hpp"

namespace sculpt::sim {

namespace {

using kernel::kBlock;

// 10 bits per axis, interleaved: nearby points get nearby codes.
std::uint32_t spread_bits(std::uint32_t v) {
  v &= 0x3ff;
  v = (v | (v << 16)) & 0x030000ff;
  v = (v | (v << 8)) & 0x0300f00f;
  v = (v | (v << 4)) & 0x030c30c3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

// The ELL width: wide enough that at most ~2% of vertices spill into the
// (scalar) overflow list, never wider than 16.
int choose_columns(const std::vector<int>& degree) {
  if (degree.empty()) return 0;
  std::vector<int> histogram(17, 0);
  for (int d : degree) ++histogram[std::min(d, 16)];
  const std::size_t allowed = degree.size() / 50;
  std::size_t above = degree.size();
  for (int k = 0; k <= 16; ++k) {
    above -= histogram[k];
    if (above <= allowed) return k;
  }
  return 16;
}

// The double buffer of packed records moves more bytes per vertex (the packed
// copies on top of x and w): it wins while a mesh stays in cache and loses
// once memory bandwidth is the limit (100k+ vertices). Elastic bodies of any
// size step through the ring instead, as fast and without the 64 bytes per
// vertex; clay keeps the double buffer up to this size (its yields read the
// whole step-start state after the sweep), and gathers from the arrays above.
constexpr std::uint32_t kPackedMaxVertices = 65536;

}  // namespace

template <class S>
kernel::ForceArgs<S> Body<S>::network_args() const {
  const BodyNetwork<S>& net = *this;
  const BodyState<S>& st = *this;
  const BodyRecords<S>& rec = *this;
  kernel::ForceArgs<S> fa{};
  fa.x = st.x.data(), fa.y = st.y.data(), fa.z = st.z.data();
  fa.wx = st.wx.data(), fa.wy = st.wy.data(), fa.wz = st.wz.data();
  fa.rx = st.rx.data(), fa.ry = st.ry.data(), fa.rz = st.rz.data();
  fa.nbr = net.nbr.data(), fa.rest_length = net.rest_length.data(), fa.stride = net.n, fa.columns = net.columns;
  fa.overflow = net.overflow.data();
  if constexpr (std::is_same_v<S, float>)
    if (!rec.packed[0].empty()) fa.packed = rec.packed[rec.packed_cur].data();
  return fa;
}

namespace {

template <class S>
std::size_t bytes_of(const BodyNetwork<S>& net) {
  return net.nbr.bytes() + net.rest_length.bytes() + net.overflow.capacity() * sizeof(net.overflow[0]) +
         net.overflow_begin.capacity() * 4 + (net.to_original.capacity() + net.to_internal.capacity()) * 4 +
         net.triangles.capacity() * sizeof(BlockTriangle) + net.triangle_begin.capacity() * 4 +
         net.far_triangles.capacity() * sizeof(Triangle) + net.far_triangle_begin.capacity() * 4 +
         net.pinned.capacity() * sizeof(Pinned<S>) + net.pinned_begin.capacity() * 4 +
         (net.block_neighbour_begin.capacity() + net.block_neighbours.capacity()) * 4;
}

template <class S>
std::size_t bytes_of(const BodyState<S>& st) {
  std::size_t b = 0;
  for (const auto* buf : {&st.x, &st.y, &st.z, &st.wx, &st.wy, &st.wz, &st.rx, &st.ry, &st.rz, &st.ax, &st.ay, &st.az})
    b += buf->bytes();
  return b;
}

template <class S>
std::size_t bytes_of(const BodyRecords<S>& rec) {
  return rec.packed[0].bytes() + rec.packed[1].bytes() +
         (rec.far_vertices.capacity() + rec.far_vertex_begin.capacity()) * 4 + rec.far_records.bytes() +
         rec.ring_stamp.capacity() * 8;
}

template <class S>
std::size_t bytes_of(const BodyBlocks<S>& bl) {
  std::size_t b = bl.block.capacity() * sizeof(BlockState<S>) + bl.awake_list.capacity() * 4;
  for (const auto& t : bl.tools) b += t.candidates.capacity() * 4 + t.grabs.capacity() * sizeof(Grab<S>);
  return b;
}

template <class S>
std::size_t bytes_of(const BodyGuard<S>& g) {
  return g.sx.bytes() + g.sy.bytes() + g.sz.bytes() + g.checkpoint_grid.capacity() * sizeof(CheckpointGrid<S>) +
         g.srx.bytes() + g.sry.bytes() + g.srz.bytes() + g.slen.bytes();
}

}  // namespace

template <class S>
std::size_t Body<S>::bytes() const {
  return sizeof(*this) + bytes_of(static_cast<const BodyNetwork<S>&>(*this)) + bytes_of(static_cast<const BodyState<S>&>(*this)) +
         bytes_of(static_cast<const BodyRecords<S>&>(*this)) + bytes_of(static_cast<const BodyBlocks<S>&>(*this)) +
         bytes_of(static_cast<const BodyGuard<S>&>(*this));
}

template <class S>
bool Body<S>::save_positions(std::uint32_t blk) {
  const BodyState<S>& st = *this;
  BodyGuard<S>& guard = *this;
  const std::uint32_t b0 = this->begin_of(blk), b1 = this->end_of(blk);
  const S* src[3] = {st.x.data(), st.y.data(), st.z.data()};
  std::uint16_t* dst[3] = {guard.sx.data(), guard.sy.data(), guard.sz.data()};
  for (int a = 0; a < 3; ++a)
    for (std::uint32_t i = b0; i < b1; ++i)
      if (!std::isfinite(src[a][i])) return false;
  CheckpointGrid<S> g;
  for (int a = 0; a < 3; ++a) {
    S lo = src[a][b0], hi = lo;
    for (std::uint32_t i = b0; i < b1; ++i) lo = std::min(lo, src[a][i]), hi = std::max(hi, src[a][i]);
    g.lo[a] = lo, g.step[a] = (hi - lo) / S(65535);
    if (!std::isfinite(g.step[a])) return false;  // a box wider than the type's range
  }
  // Round to nearest by truncating q + ½ (q ≥ 0): a conversion the compiler
  // vectorizes, where nearbyint is a library call on baseline x86-64.
  for (int a = 0; a < 3; ++a) {
    const S to_grid = g.step[a] > S(0) ? S(1) / g.step[a] : S(0), lo = g.lo[a];
    for (std::uint32_t i = b0; i < b1; ++i)
      dst[a][i] = static_cast<std::uint16_t>(std::min(S(65535), (src[a][i] - lo) * to_grid + S(0.5)));
  }
  guard.checkpoint_grid[blk] = g;
  return true;
}

template <class S>
std::array<S, 3> Body<S>::saved_position(std::uint32_t i) const {
  const BodyGuard<S>& guard = *this;
  const CheckpointGrid<S>& g = guard.checkpoint_grid[i / kBlock];
  return {g.lo[0] + S(guard.sx[i]) * g.step[0], g.lo[1] + S(guard.sy[i]) * g.step[1],
          g.lo[2] + S(guard.sz[i]) * g.step[2]};
}

namespace {

// Throws std::invalid_argument naming the first bad input, in this order.
void validate_input(const TriangleMesh& mesh, const Material& material, const BodyOptions& options) {
  validate(material);
  const std::size_t n_in = mesh.positions.size();
  if (n_in >= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    throw std::invalid_argument("mesh: too many vertices (" + std::to_string(n_in) + ")");
  for (std::size_t i = 0; i < n_in; ++i)
    for (float c : mesh.positions[i])
      if (!std::isfinite(c)) throw std::invalid_argument("mesh: vertex " + std::to_string(i) + " is not finite");
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t v : mesh.triangles[t])
      if (v >= n_in)
        throw std::invalid_argument("mesh: triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) +
                                    " but there are only " + std::to_string(n_in) + " vertices");
  for (std::uint32_t p : options.pinned)
    if (p >= n_in) throw std::invalid_argument("mesh: pinned vertex " + std::to_string(p) + " does not exist");
  if (options.max_grabbed < 0) throw std::invalid_argument("body: max_grabbed must be >= 0");
}

// Address space for the most the per-vertex arrays can take; only what they
// use is ever touched, and World::add_body trims the rest. Anything that does
// not fit falls back to the heap (Layout.BigBodiesKeepTheirArraysInOneArena
// checks that nothing does). A small body's arena stays empty: the heap.
template <class S>
void reserve_arena(Body<S>& b) {
  if (b.n < kArenaMinVertices) return;
  constexpr std::size_t kMaxColumns = 16;  // choose_columns' widest ELL
  constexpr std::size_t scalars = 9       // x..z, wx..wz, rx..rz
                                  + 3     // ax..az
                                  + 3     // clay: srx..srz
                                  + 2 * kMaxColumns  // rest_length, clay: slen
                                  + 16;   // two packed records
  constexpr std::size_t shorts = 3 + kMaxColumns;  // checkpoint sx..sz, nbr
  b.arena = PageArena(std::size_t{b.n} * (scalars * sizeof(S) + shorts * 2) + 32 * AlignedBuffer<S>::kAlignment);
}

// Morton order of the rest shape (to_original, to_internal), and its extent.
template <class S>
void order_vertices(Body<S>& b, const TriangleMesh& mesh) {
  const std::uint32_t n = b.n;
  std::array<double, 3> lo{}, hi{};
  if (n) {
    lo = hi = {mesh.positions[0][0], mesh.positions[0][1], mesh.positions[0][2]};
    for (const Vec3f& p : mesh.positions)
      for (int k = 0; k < 3; ++k) lo[k] = std::min<double>(lo[k], p[k]), hi[k] = std::max<double>(hi[k], p[k]);
  }
  const double span = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30});
  b.extent = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
  std::vector<std::uint64_t> key(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    std::uint32_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const auto q = static_cast<std::uint32_t>(std::clamp((mesh.positions[i][k] - lo[k]) / span * 1023.0, 0.0, 1023.0));
      code |= spread_bits(q) << k;
    }
    key[i] = (std::uint64_t{code} << 32) | i;  // ties broken by index: deterministic
  }
  std::sort(key.begin(), key.end());
  b.to_original.resize(n);
  b.to_internal.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    b.to_original[i] = static_cast<std::uint32_t>(key[i] & 0xffffffffu);
    b.to_internal[b.to_original[i]] = i;
  }
}

// Positions and rest shape in internal order, at rest, and the guard's first
// checkpoint. ax..az: World::add_body decides (only velocity Verlet and clay keep them).
template <class S>
void place_at_rest(Body<S>& b, const TriangleMesh& mesh) {
  const std::uint32_t n = b.n;
  for (auto* buf : {&b.x, &b.y, &b.z, &b.wx, &b.wy, &b.wz, &b.rx, &b.ry, &b.rz}) buf->resize(n, S(0), &b.arena);
  for (auto* buf : {&b.sx, &b.sy, &b.sz}) buf->resize(n, 0, &b.arena);
  b.checkpoint_grid.resize(b.blocks);
  for (std::uint32_t i = 0; i < n; ++i) {  // at rest: no step, no velocity (w = 0 for every integrator)
    const Vec3f& p = mesh.positions[b.to_original[i]];
    b.x[i] = b.rx[i] = static_cast<S>(p[0]);
    b.y[i] = b.ry[i] = static_cast<S>(p[1]);
    b.z[i] = b.rz[i] = static_cast<S>(p[2]);
    b.wx[i] = b.wy[i] = b.wz[i] = S(0);
  }
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) b.save_positions(blk);  // the rest shape: finite, validated
}

// Adjacency as a temporary CSR (a vector per vertex would double the peak
// memory of building a big mesh), in internal indices.
struct Csr {
  std::vector<std::uint32_t> off;
  std::vector<std::int32_t> nb;
  std::span<const std::int32_t> operator[](std::uint32_t i) const { return {nb.data() + off[i], nb.data() + off[i + 1]}; }
};

// The springs as adjacency rows, each sorted (a fixed summation order); also
// the spring count, mean rest edge, highest degree and the ELL width.
template <class S>
Csr connect_springs(Body<S>& b, const TriangleMesh& mesh) {
  const std::uint32_t n = b.n;
  Csr adj;
  double edge_sum = 0;
  {
    const std::vector<Edge> edges = unique_edges(mesh.triangles);
    adj.off.assign(n + 1, 0);
    for (const Edge& e : edges) ++adj.off[b.to_internal[e.a] + 1], ++adj.off[b.to_internal[e.b] + 1];
    std::partial_sum(adj.off.begin(), adj.off.end(), adj.off.begin());
    adj.nb.resize(adj.off[n]);
    std::vector<std::uint32_t> cursor(adj.off.begin(), adj.off.end() - 1);
    for (const Edge& e : edges) {
      const std::uint32_t a = b.to_internal[e.a], c = b.to_internal[e.b];
      adj.nb[cursor[a]++] = static_cast<std::int32_t>(c);
      adj.nb[cursor[c]++] = static_cast<std::int32_t>(a);
      ++b.springs;
      const double dx = double(b.rx[c]) - b.rx[a], dy = double(b.ry[c]) - b.ry[a], dz = double(b.rz[c]) - b.rz[a];
      edge_sum += std::sqrt(dx * dx + dy * dy + dz * dz);
    }
    b.mean_edge = static_cast<S>(edges.empty() ? b.extent : edge_sum / edges.size());
  }
  std::vector<int> degree(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    std::sort(adj.nb.begin() + adj.off[i], adj.nb.begin() + adj.off[i + 1]);
    degree[i] = static_cast<int>(adj.off[i + 1] - adj.off[i]);
    b.max_degree = std::max(b.max_degree, degree[i]);
  }
  b.columns = choose_columns(degree);
  return adj;
}

template <class S>
bool has_rest_lengths(const Body<S>& b) {
  return b.material.model == ForceModel::spring;
}

template <class S>
S rest_distance(const Body<S>& b, std::uint32_t i, std::int32_t j) {
  const S dx = b.rx[j] - b.rx[i], dy = b.ry[j] - b.ry[i], dz = b.rz[j] - b.rz[i];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Whether a spring fits the ELL by distance: its ends at most kRingReach
// blocks apart, which also keeps the offset within 16 bits.
static_assert((kernel::kRingReach + 1) * kBlock <= INT16_MAX);
bool within_ring_reach(std::uint32_t i, std::int32_t j) {
  const std::uint32_t bi = i / kBlock, bj = static_cast<std::uint32_t>(j) / kBlock;
  return (bi > bj ? bi - bj : bj - bi) <= kernel::kRingReach;
}

// Each row in sorted order: the near neighbours fill the columns, the rest (past
// the width, or beyond ring reach) go to the overflow list; padding is the
// vertex itself (offset 0, rest length 0: zero force).
template <class S>
void build_ell(Body<S>& b, const Csr& adj) {
  const std::uint32_t n = b.n;
  const bool spring_model = has_rest_lengths(b);
  b.nbr.resize(static_cast<std::size_t>(b.columns) * n, 0, &b.arena);
  if (spring_model) b.rest_length.resize(static_cast<std::size_t>(b.columns) * n, S(0), &b.arena);
  b.overflow_begin.assign(b.blocks + 1, 0);
  for (std::uint32_t i = 0; i < n; ++i) {
    int s = 0;
    for (const std::int32_t j : adj[i]) {
      if (s < b.columns && within_ring_reach(i, j)) {
        b.nbr[static_cast<std::size_t>(s) * n + i] = static_cast<std::int16_t>(std::int64_t{j} - i);
        if (spring_model) b.rest_length[static_cast<std::size_t>(s) * n + i] = rest_distance(b, i, j);
        ++s;
      } else {
        b.overflow.push_back({i, j, rest_distance(b, i, j)});
      }
    }
    for (; s < b.columns; ++s) {
      b.nbr[static_cast<std::size_t>(s) * n + i] = 0;
      if (spring_model) b.rest_length[static_cast<std::size_t>(s) * n + i] = S(0);
    }
  }
  b.overflow.shrink_to_fit();  // grown by push_back: up to twice its size
  for (const auto& o : b.overflow) ++b.overflow_begin[o.i / kBlock + 1];
  std::partial_sum(b.overflow_begin.begin(), b.overflow_begin.end(), b.overflow_begin.begin());
}

// The CSR of blocks that share a spring.
template <class S>
void link_blocks(Body<S>& b, const Csr& adj) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> bpairs;
  for (std::uint32_t i = 0; i < b.n; ++i)
    for (std::int32_t j : adj[i])
      if (i / kBlock != static_cast<std::uint32_t>(j) / kBlock) bpairs.emplace_back(i / kBlock, j / kBlock);
  std::sort(bpairs.begin(), bpairs.end());
  bpairs.erase(std::unique(bpairs.begin(), bpairs.end()), bpairs.end());
  b.block_neighbour_begin.assign(b.blocks + 1, 0);
  for (const auto& [a, c] : bpairs) {
    ++b.block_neighbour_begin[a + 1];
    b.block_neighbours.push_back(c);
  }
  std::partial_sum(b.block_neighbour_begin.begin(), b.block_neighbour_begin.end(), b.block_neighbour_begin.begin());
}

// Triangles, owned by the block of their lowest vertex: as 16-bit offsets from
// the block's first vertex where they fit, whole where they do not.
template <class S>
void group_triangles(Body<S>& b, const TriangleMesh& mesh) {
  std::vector<Triangle> all;
  all.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) all.push_back({b.to_internal[t[0]], b.to_internal[t[1]], b.to_internal[t[2]]});
  auto owner = [](const Triangle& t) { return std::min({t[0], t[1], t[2]}) / kBlock; };
  std::stable_sort(all.begin(), all.end(), [&](const Triangle& p, const Triangle& q) { return owner(p) < owner(q); });
  auto fits = [&](const Triangle& t) {
    const std::uint32_t base = owner(t) * kBlock;
    return std::max({t[0], t[1], t[2]}) - base <= std::numeric_limits<std::uint16_t>::max();
  };
  b.triangle_begin.assign(b.blocks + 1, 0);
  b.far_triangle_begin.assign(b.blocks + 1, 0);
  for (const Triangle& t : all) ++(fits(t) ? b.triangle_begin : b.far_triangle_begin)[owner(t) + 1];
  std::partial_sum(b.triangle_begin.begin(), b.triangle_begin.end(), b.triangle_begin.begin());
  std::partial_sum(b.far_triangle_begin.begin(), b.far_triangle_begin.end(), b.far_triangle_begin.begin());
  b.triangles.reserve(b.triangle_begin.back());
  b.far_triangles.reserve(b.far_triangle_begin.back());
  for (const Triangle& t : all) {
    const std::uint32_t base = owner(t) * kBlock;
    if (fits(t))
      b.triangles.push_back({{static_cast<std::uint16_t>(t[0] - base), static_cast<std::uint16_t>(t[1] - base),
                              static_cast<std::uint16_t>(t[2] - base)}});
    else
      b.far_triangles.push_back(t);
  }
}

// Each block's box at rest and the reach of its triangles; room for the awake list.
template <class S>
void fit_blocks(Body<S>& b) {
  b.block.resize(b.blocks);
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    BlockState<S>& s = b.block[blk];
    const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
    s.lo = {b.x[b0], b.y[b0], b.z[b0]};
    s.hi = s.lo;
    for (std::uint32_t i = b0; i < b1; ++i) {
      s.lo = {std::min(s.lo[0], b.x[i]), std::min(s.lo[1], b.y[i]), std::min(s.lo[2], b.z[i])};
      s.hi = {std::max(s.hi[0], b.x[i]), std::max(s.hi[1], b.y[i]), std::max(s.hi[2], b.z[i])};
    }
    S reach = 0;
    b.for_each_triangle(blk, [&](const Triangle& t) {
      for (int k = 0; k < 3; ++k)
        reach = std::max(reach, rest_distance(b, t[k], static_cast<std::int32_t>(t[(k + 1) % 3])));
    });
    s.reach = S(1.5) * reach;
  }
  b.awake_list.resize(b.blocks);
}

// Pinned vertices at their rest position, sorted, once each, grouped by block.
template <class S>
void place_pins(Body<S>& b, const BodyOptions& options) {
  for (std::uint32_t p : options.pinned) {
    const std::uint32_t i = b.to_internal[p];
    b.pinned.push_back({i, b.rx[i], b.ry[i], b.rz[i]});
  }
  std::sort(b.pinned.begin(), b.pinned.end(), [](const Pinned<S>& p, const Pinned<S>& q) { return p.i < q.i; });
  b.pinned.erase(std::unique(b.pinned.begin(), b.pinned.end(),
                             [](const Pinned<S>& p, const Pinned<S>& q) { return p.i == q.i; }),
                 b.pinned.end());
  b.pinned_begin.assign(b.blocks + 1, 0);
  for (const auto& p : b.pinned) ++b.pinned_begin[p.i / kBlock + 1];
  std::partial_sum(b.pinned_begin.begin(), b.pinned_begin.end(), b.pinned_begin.begin());
}

// Clay yields its rest shape: the guard keeps the last good one to restore.
template <class S>
void copy_rest_shape_for_clay(Body<S>& b) {
  if (!b.plastic) return;
  for (auto* buf : {&b.srx, &b.sry, &b.srz}) buf->resize(b.n, S(0), &b.arena);
  for (std::uint32_t i = 0; i < b.n; ++i) b.srx[i] = b.rx[i], b.sry[i] = b.ry[i], b.srz[i] = b.rz[i];
  if (has_rest_lengths(b)) {
    b.slen.resize(b.rest_length.size(), S(0), &b.arena);
    std::copy_n(b.rest_length.data(), b.rest_length.size(), b.slen.data());
  }
}

// The double buffer of packed records (float only), at rest.
template <class S>
void allocate_packed_records(Body<S>& b, const BodyOptions& options) {
  const bool want = std::is_same_v<S, float> &&
                    (options.packed == PackedRecords::always ||
                     (options.packed == PackedRecords::by_size && b.plastic && b.n <= kPackedMaxVertices));
  if (!want) return;
  for (auto& buf : b.packed) {
    buf.resize(8 * static_cast<std::size_t>(b.n), S(0), &b.arena);  // zeros: at rest the velocity and (linear) u are 0
    if (has_rest_lengths(b))
      for (std::uint32_t i = 0; i < b.n; ++i) buf[8 * i + 0] = b.x[i], buf[8 * i + 1] = b.y[i], buf[8 * i + 2] = b.z[i];
  }
}

// The ring's far table (elastic float bodies without the packed buffers): the
// far ends that a row reads after their own block has stepped (blocks step in
// ascending order, so the ends behind).
template <class S>
void build_far_table(Body<S>& b, const BodyOptions& options) {
  if (!(std::is_same_v<S, float> && b.packed[0].empty() && !b.plastic && options.ring)) return;
  auto behind = [](const kernel::Overflow<S>& o) {
    return !within_ring_reach(o.i, o.j) && static_cast<std::uint32_t>(o.j) < o.i;
  };
  for (const auto& o : b.overflow)
    if (behind(o)) b.far_vertices.push_back(static_cast<std::uint32_t>(o.j));
  std::sort(b.far_vertices.begin(), b.far_vertices.end());
  b.far_vertices.erase(std::unique(b.far_vertices.begin(), b.far_vertices.end()), b.far_vertices.end());
  b.far_vertices.shrink_to_fit();
  for (auto& o : b.overflow)
    if (!within_ring_reach(o.i, o.j) && !behind(o))
      o.far = kernel::kFarAhead;
    else if (behind(o))
      o.far = static_cast<std::uint32_t>(
          std::lower_bound(b.far_vertices.begin(), b.far_vertices.end(), static_cast<std::uint32_t>(o.j)) -
          b.far_vertices.begin());
  b.far_vertex_begin.assign(b.blocks + 1, 0);
  for (std::uint32_t v : b.far_vertices) ++b.far_vertex_begin[v / kBlock + 1];
  std::partial_sum(b.far_vertex_begin.begin(), b.far_vertex_begin.end(), b.far_vertex_begin.begin());
  b.far_records.resize(8 * b.far_vertices.size(), S(0));
  b.ring_stamp.assign(b.blocks, 0);
  // A body of fewer blocks than the ring takes the next power of two: every
  // block its own place, and no more memory than it needs.
  b.ring_blocks = std::min(kernel::kRingBlocks, std::bit_ceil(b.blocks));
}

// Per tool slot: room for every block as a candidate and a full grab.
template <class S>
void allocate_tool_contacts(Body<S>& b, const BodyOptions& options, int tool_slots) {
  b.tools.resize(static_cast<std::size_t>(std::max(0, tool_slots)));
  for (auto& t : b.tools) {
    t.candidates.resize(b.blocks);
    t.grabs.resize(static_cast<std::size_t>(options.max_grabbed));
  }
}

}  // namespace

template <class S>
Body<S> make_body(const TriangleMesh& mesh, const Material& material, const BodyOptions& options, int tool_slots) {
  validate_input(mesh, material, options);
  Body<S> b;
  b.material = material;
  b.plastic = material.plastic;
  b.n = static_cast<std::uint32_t>(mesh.positions.size());
  b.blocks = (b.n + kBlock - 1) / kBlock;
  reserve_arena(b);
  order_vertices(b, mesh);
  place_at_rest(b, mesh);
  {
    const Csr adj = connect_springs(b, mesh);
    build_ell(b, adj);
    link_blocks(b, adj);
  }
  group_triangles(b, mesh);
  fit_blocks(b);
  place_pins(b, options);
  copy_rest_shape_for_clay(b);
  allocate_packed_records(b, options);
  build_far_table(b, options);
  allocate_tool_contacts(b, options, tool_slots);
  return b;
}

template struct Body<float>;
template struct Body<double>;
template Body<float> make_body(const TriangleMesh&, const Material&, const BodyOptions&, int);
template Body<double> make_body(const TriangleMesh&, const Material&, const BodyOptions&, int);

}  // namespace sculpt::sim
