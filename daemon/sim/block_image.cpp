// Block images (block_image.hpp): one walk over a block's pieces, in image
// order, serves the layout, the copy and the swap, so they cannot disagree.
#include "sim/block_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <type_traits>
#include <cstring>

#include "sim/blocks.hpp"

namespace sculpt::sim {

namespace {

using kernel::kBlock;

// Calls piece(p, bytes, slot) for each piece of block blk's image in order:
// the world's `bytes` bytes at p, which take `slot` bytes of the image (the
// rest is padding). B is Body<S> or const Body<S>.
template <class S, class B, class F>
void for_each_piece(B& b, std::uint32_t overflow_slots, std::uint32_t blk, F&& piece) {
  const std::uint32_t b0 = b.begin_of(blk), count = b.end_of(blk) - b0;
  auto one = [&](auto& v) { piece(&v, sizeof v, sizeof v); };
  // per_vertex values for each of the block's vertices, from p (an array's start).
  auto rows = [&](auto* p, std::size_t per_vertex) {
    piece(p + per_vertex * b0, per_vertex * count * sizeof(*p), per_vertex * kBlock * sizeof(*p));
  };
  one(b.block[blk]);  // first: the recorder patches it in place (stroke_recorder.cpp)
  one(b.checkpoint_grid[blk]);
  for (auto* a : {&b.x, &b.y, &b.z, &b.wx, &b.wy, &b.wz}) rows(a->data(), 1);
  if (b.plastic)
    for (auto* a : {&b.rx, &b.ry, &b.rz, &b.srx, &b.sry, &b.srz}) rows(a->data(), 1);
  if (!b.ax.empty())
    for (auto* a : {&b.ax, &b.ay, &b.az}) rows(a->data(), 1);
  if (b.plastic && !b.rest_length.empty())
    for (int s = 0; s < b.columns; ++s) {
      const std::size_t column = static_cast<std::size_t>(s) * b.n;
      rows(b.rest_length.data() + column, 1);
      rows(b.slen.data() + column, 1);
    }
  if (b.plastic) {  // an overflow spring's rest length yields too; which springs they are never changes
    const std::uint32_t ob = b.overflow_begin[blk], oe = b.overflow_begin[blk + 1];
    for (std::uint32_t o = ob; o < oe; ++o) one(b.overflow[o].rest_length);
    piece(&b.block[blk], 0, (overflow_slots - (oe - ob)) * sizeof(S));
  }
  if (!b.packed[0].empty()) {
    rows(b.packed[b.packed_cur].data(), 8);
    rows(b.packed[b.packed_cur ^ 1].data(), 8);
  }
  for (auto* a : {&b.sx, &b.sy, &b.sz}) rows(a->data(), 1);
}

// Exchanges n bytes through a small buffer on the stack.
void swap_bytes(std::byte* a, std::byte* b, std::size_t n) {
  std::byte tmp[512];
  for (std::size_t at = 0; at < n; at += sizeof tmp) {
    const std::size_t c = std::min(sizeof tmp, n - at);
    std::memcpy(tmp, a + at, c);
    std::memcpy(a + at, b + at, c);
    std::memcpy(b + at, tmp, c);
  }
}

// The body's box after one block's box went from `before` to `after`: the
// bits update_box would give, without its pass over every block unless the
// old box was on an edge (it may have been the extreme) or the new one ties
// with an edge (where −0 and +0 tie, the order of the pass decides).
template <class S>
void refit_body_box(Body<S>& b, const BlockState<S>& before, const BlockState<S>& after) {
  const S g0 = before.grow + before.reach, g1 = after.grow + after.reach;
  std::array<S, 3> lo = b.lo, hi = b.hi;
  for (int k = 0; k < 3; ++k) {
    const S lo0 = before.lo[k] - g0, hi0 = before.hi[k] + g0, lo1 = after.lo[k] - g1, hi1 = after.hi[k] + g1;
    if (lo0 == b.lo[k] || hi0 == b.hi[k] || lo1 == b.lo[k] || hi1 == b.hi[k]) return update_box(b);
    lo[k] = std::min(lo[k], lo1);
    hi[k] = std::max(hi[k], hi1);
  }
  b.lo = lo;
  b.hi = hi;
}

}  // namespace

template <class S>
BlockImageLayout block_image_layout(const Body<S>& b) {
  BlockImageLayout layout;
  if (b.plastic)
    for (std::uint32_t blk = 0; blk < b.blocks; ++blk)
      layout.overflow_slots = std::max(layout.overflow_slots, b.overflow_begin[blk + 1] - b.overflow_begin[blk]);
  if (b.blocks > 0)
    for_each_piece<S>(b, layout.overflow_slots, 0, [&](const auto*, std::size_t, std::size_t slot) {
      layout.bytes += slot;
    });
  return layout;
}

template <class S>
void write_block_image(const Body<S>& b, const BlockImageLayout& layout, std::uint32_t blk, std::byte* out) {
  for_each_piece<S>(b, layout.overflow_slots, blk, [&](const auto* p, std::size_t bytes, std::size_t slot) {
    std::memcpy(out, p, bytes);
    std::memset(out + bytes, 0, slot - bytes);
    out += slot;
  });
}

template <class S>
void exchange_block_state(Body<S>& b, const BlockImageLayout& layout, std::uint32_t blk, std::byte* image) {
  const BlockState<S> before = b.block[blk];
  for_each_piece<S>(b, layout.overflow_slots, blk, [&](auto* p, std::size_t bytes, std::size_t slot) {
    swap_bytes(reinterpret_cast<std::byte*>(p), image, bytes);
    image += slot;
  });
  const BlockState<S>& after = b.block[blk];
  b.awake_blocks = b.awake_blocks - (before.awake ? 1u : 0u) + (after.awake ? 1u : 0u);
  refit_body_box(b, before, after);
}

template <class S>
std::string block_image_error(const Body<S>& b, const BlockImageLayout& layout, std::uint32_t blk,
                              const std::byte* image, const BlockImageBounds& bounds) {
  std::string error;
  auto fail = [&](const std::string& what) {
    if (error.empty()) error = "block " + std::to_string(blk) + ": " + what;
  };
  auto in = [](const auto& a, const void* p) {
    const auto* q = static_cast<const std::byte*>(p);
    const auto* d = reinterpret_cast<const std::byte*>(a.data());
    return !a.empty() && q >= d && q < d + a.size() * sizeof(a[0]);
  };
  const double per = b.velocity == kernel::Velocity::step ? 1.0 / bounds.dts : 1.0;
  BlockState<S> state{};  // the image's, first of its pieces
  bool awake = true;
  for_each_piece<S>(b, layout.overflow_slots, blk, [&](const auto* p, std::size_t bytes, std::size_t slot) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(p)>>;
    const std::byte* at = image;
    image += slot;
    if (bytes == 0 || !error.empty()) return;
    if constexpr (std::is_same_v<T, BlockState<S>>) {
      for (std::size_t off : {offsetof(T, awake), offsetof(T, touched), offsetof(T, changed), offsetof(T, dirty),
                              offsetof(T, accel_current), offsetof(T, grabbed)})
        if (std::to_integer<unsigned>(at[off]) > 1) return fail("a flag is not a flag");
      T s;
      std::memcpy(static_cast<void*>(&s), at, sizeof s);
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(s.lo[k]) || !std::isfinite(s.hi[k]) || std::abs(s.lo[k]) > bounds.max_coordinate ||
            std::abs(s.hi[k]) > bounds.max_coordinate || s.lo[k] > s.hi[k])
          return fail("its box is not within the world");
      if (!std::isfinite(s.grow) || s.grow < 0) return fail("its growth is not finite");
      if (std::memcmp(&s.reach, &b.block[blk].reach, sizeof s.reach) != 0) return fail("its reach is not the body's");
      if (!std::isfinite(s.energy)) return fail("its energy is not finite");
      if (s.quiet_ticks < 0 || s.quiet_ticks > bounds.sleep_ticks) return fail("its quiet ticks are out of range");
      state = s;
      awake = std::to_integer<unsigned>(at[offsetof(T, awake)]) != 0;
    } else if constexpr (std::is_same_v<T, CheckpointGrid<S>>) {
      T g;
      std::memcpy(&g, at, sizeof g);
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(g.lo[k]) || std::abs(g.lo[k]) > bounds.max_coordinate || !std::isfinite(g.step[k]) ||
            g.step[k] < 0 || g.step[k] > bounds.max_coordinate)
          return fail("the guard's grid is not within the world");
    } else if constexpr (std::is_same_v<T, S>) {
      for (std::size_t j = 0; j < bytes / sizeof(S); ++j) {
        S v;
        std::memcpy(&v, at + j * sizeof(S), sizeof v);
        const double x = static_cast<double>(v);
        const S* q = p + j;
        bool ok = std::isfinite(x);
        if (in(b.x, q) || in(b.y, q) || in(b.z, q)) {  // within the block's box, as World::restore_state checks
          ok = ok && within_block_box(state, in(b.x, q) ? 0 : in(b.y, q) ? 1 : 2, x);
        } else if (in(b.rx, q) || in(b.ry, q) || in(b.rz, q) || in(b.srx, q) || in(b.sry, q) || in(b.srz, q)) {
          ok = ok && std::abs(x) <= bounds.max_coordinate;
        } else if (in(b.wx, q) || in(b.wy, q) || in(b.wz, q)) {  // a sleeping block is at rest
          ok = ok && std::abs(x * per) <= bounds.max_speed && (awake || x == 0.0);
        } else if (in(b.rest_length, q) || in(b.slen, q)) {
          const std::size_t e = static_cast<std::size_t>(q - (in(b.slen, q) ? b.slen.data() : b.rest_length.data()));
          ok = ok && (b.nbr[e] == 0 ? v == S(0) : x >= 0 && x <= 2 * bounds.max_coordinate);
        } else if (in(b.packed[0], q) || in(b.packed[1], q)) {
          const std::size_t k = static_cast<std::size_t>(q - (in(b.packed[0], q) ? b.packed[0].data() : b.packed[1].data())) % 8;
          ok = ok && (k == 3 || k == 7 ? x == 0.0
                      : k < 3          ? std::abs(x) <= 2 * bounds.max_coordinate
                                       : std::abs(x) <= bounds.max_speed);
        } else if (!in(b.ax, q) && !in(b.ay, q) && !in(b.az, q)) {  // an overflow spring's rest length
          ok = ok && x >= 0 && x <= 2 * bounds.max_coordinate;
        }
        if (!ok) return fail("a value is " + std::to_string(x) + ", not one a block can hold");
      }
    }
  });
  return error;
}

template std::string block_image_error(const Body<float>&, const BlockImageLayout&, std::uint32_t, const std::byte*,
                                       const BlockImageBounds&);
template std::string block_image_error(const Body<double>&, const BlockImageLayout&, std::uint32_t, const std::byte*,
                                       const BlockImageBounds&);
template BlockImageLayout block_image_layout(const Body<float>&);
template BlockImageLayout block_image_layout(const Body<double>&);
template void write_block_image(const Body<float>&, const BlockImageLayout&, std::uint32_t, std::byte*);
template void write_block_image(const Body<double>&, const BlockImageLayout&, std::uint32_t, std::byte*);
template void exchange_block_state(Body<float>&, const BlockImageLayout&, std::uint32_t, std::byte*);
template void exchange_block_state(Body<double>&, const BlockImageLayout&, std::uint32_t, std::byte*);

}  // namespace sculpt::sim
