#include "sim/clay.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "sim/stroke_hook.hpp"

namespace sculpt::sim {

using kernel::kBlock;

template <class S>
void yield_block(Body<S>& b, std::uint32_t blk, std::uint8_t* mask) {
  const bool springs = b.material.model == ForceModel::spring;
  kernel::ForceArgs<S> fa = b.network_args();
  // The current packed records match x, y, z here (the step and every push keep them so).
  if (!springs) fa.packed = nullptr;
  if (kernel::yield_candidates(fa, static_cast<S>(b.material.yield_strain), clay_anchor_limit(b), springs, b.begin_of(blk),
                               b.end_of(blk), mask))
    apply_yields(b, blk, mask, static_cast<const S*>(nullptr));
}

template <class S>
void apply_yields(Body<S>& b, std::uint32_t blk, const std::uint8_t* mask, const S* records) {
  const S y = static_cast<S>(b.material.yield_strain);
  const S limit = clay_anchor_limit(b);
  const bool springs = b.material.model == ForceModel::spring;
  const std::uint32_t b0 = b.begin_of(blk);
  auto pos = [&](std::uint32_t i) -> std::array<S, 3> {
    if (records) return {records[8 * static_cast<std::size_t>(i)], records[8 * static_cast<std::size_t>(i) + 1],
                         records[8 * static_cast<std::size_t>(i) + 2]};
    return {b.x[i], b.y[i], b.z[i]};
  };
  constexpr std::uint32_t kRow = kBlock / 8;
  // Calls f(i) for every marked vertex of a row, in ascending order (bit k of
  // byte g is vertex 8g + k: 64 of them per little-endian word).
  auto each_marked = [&](const std::uint8_t* row, auto&& f) {
    for (std::uint32_t w = 0; w < kRow / 8; ++w) {
      std::uint64_t m;
      std::memcpy(&m, row + 8 * w, sizeof m);
      for (; m; m &= m - 1) f(b0 + 64 * w + static_cast<std::uint32_t>(std::countr_zero(m)));
    }
  };
  static_assert(std::endian::native == std::endian::little && kRow % 8 == 0);
  bool moved = false;
  each_marked(mask, [&](std::uint32_t i) {
    const std::array<S, 3> p = pos(i);
    const S ux = p[0] - b.rx[i], uy = p[1] - b.ry[i], uz = p[2] - b.rz[i];
    const S u = std::sqrt(ux * ux + uy * uy + uz * uz);
    if (u > limit) {
      const S keep = limit / u;  // fraction of the displacement that stays elastic
      b.rx[i] = p[0] - ux * keep, b.ry[i] = p[1] - uy * keep, b.rz[i] = p[2] - uz * keep;
      moved = true;
    }
  });
  if (moved) b.block[blk].dirty = true;
  if (!springs) return;
  // Springs: perfect plasticity, strain clamped to ±yield; both directed
  // copies of a spring get the same bits, wherever the other one lives.
  auto set_mirror = [&](std::uint32_t j, std::uint32_t i, S value) {
    will_change(b, j / kBlock);  // the other end may be in a block that sleeps
    for (int s = 0; s < b.columns; ++s) {
      const std::size_t e = static_cast<std::size_t>(s) * b.n + j;
      if (static_cast<std::int32_t>(j) + b.nbr[e] == static_cast<std::int32_t>(i) && j != i) {
        b.rest_length[e] = value;
        b.block[j / kBlock].dirty = true;
        return;
      }
    }
    for (std::uint32_t o = b.overflow_begin[j / kBlock]; o < b.overflow_begin[j / kBlock + 1]; ++o)
      if (b.overflow[o].i == j && b.overflow[o].j == static_cast<std::int32_t>(i)) b.overflow[o].rest_length = value;
  };
  auto yield_spring = [&](std::uint32_t i, std::int32_t j, S& rest) {
    if (static_cast<std::uint32_t>(j) == i) return;
    const std::array<S, 3> pi = pos(i), pj = pos(static_cast<std::uint32_t>(j));
    const S dx = pj[0] - pi[0], dy = pj[1] - pi[1], dz = pj[2] - pi[2];
    const S len = std::sqrt(dx * dx + dy * dy + dz * dz);
    S value = rest;
    if (len > rest * (S(1) + y)) value = len / (S(1) + y);
    else if (len < rest * (S(1) - y)) value = len / (S(1) - y);
    if (value != rest) {
      rest = value;
      set_mirror(static_cast<std::uint32_t>(j), i, value);
      b.block[i / kBlock].dirty = true;
    }
  };
  // An unmarked entry whose mirror yields earlier in this pass gets the value
  // the exact test would have left unchanged (same length, same clamp), so
  // skipping it is still exact.
  for (int s = 0; s < b.columns; ++s)
    each_marked(mask + kRow * (1 + s), [&](std::uint32_t i) {
      const std::size_t e = static_cast<std::size_t>(s) * b.n + i;
      yield_spring(i, static_cast<std::int32_t>(i) + b.nbr[e], b.rest_length[e]);
    });
  for (std::uint32_t o = b.overflow_begin[blk]; o < b.overflow_begin[blk + 1]; ++o)
    yield_spring(b.overflow[o].i, b.overflow[o].j, b.overflow[o].rest_length);
}

template void yield_block(Body<float>&, std::uint32_t, std::uint8_t*);
template void yield_block(Body<double>&, std::uint32_t, std::uint8_t*);
template void apply_yields(Body<float>&, std::uint32_t, const std::uint8_t*, const float*);
template void apply_yields(Body<double>&, std::uint32_t, const std::uint8_t*, const double*);

}  // namespace sculpt::sim
