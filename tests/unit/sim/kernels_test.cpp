// The helper kernels the world's hot paths filter with: they may only ever
// skip work the exact code would have found empty, on every code path (the
// AVX2 one and the portable one).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "sim/kernel_testing.hpp"
#include "sim/kernels.hpp"

namespace sculpt::sim {
namespace {

using kernel::kBlock;

TEST(Kernels, OutcodesAreOneBitPerFaceOnEveryPath) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  const std::uint32_t n = 3 * kBlock + 5;  // whole groups of eight and a tail
  std::vector<float> x(n), y(n), z(n);
  const float lo[3] = {-0.5f, -1.0f, 0.25f}, hi[3] = {0.5f, 1.0f, 0.75f};
  for (std::uint32_t i = 0; i < n; ++i) x[i] = u(rng), y[i] = u(rng), z[i] = u(rng);
  // On the faces (not beyond), NaN (beyond nothing), infinities.
  x[1] = lo[0], y[2] = hi[1], z[3] = lo[2];
  x[9] = std::numeric_limits<float>::quiet_NaN();
  y[10] = std::numeric_limits<float>::infinity(), z[11] = -std::numeric_limits<float>::infinity();
  for (bool portable : {false, true}) {
    const kernel::testing::ScopedPortable portable_switch(portable);
    std::vector<std::uint8_t> oc(n, 0xff);
    kernel::outcodes(x.data(), y.data(), z.data(), 2, n, lo, hi, oc.data());
    EXPECT_EQ(oc[0], 0xff) << "wrote outside [begin, end)";
    EXPECT_EQ(oc[1], 0xff);
    for (std::uint32_t i = 2; i < n; ++i) {
      const int want = (x[i] < lo[0]) | (x[i] > hi[0]) << 1 | (y[i] < lo[1]) << 2 | (y[i] > hi[1]) << 3 |
                       (z[i] < lo[2]) << 4 | (z[i] > hi[2]) << 5;
      ASSERT_EQ(oc[i], want) << "vertex " << i << (portable ? " (portable)" : " (auto)");
    }
  }
}

// A ring of n vertices, each with two real springs (i±1) and padding, near the
// edge of yield: every entry the exact test would change must be marked.
TEST(Kernels, YieldCandidatesMarkEverythingTheExactTestWouldYield) {
  const std::uint32_t n = 2 * kBlock + 3;
  const int columns = 3;
  const float yield = 0.01f, edge = 0.002f, limit = yield * edge;
  std::mt19937 rng(11);
  // Strains and anchor displacements straddling the yield thresholds closely.
  std::uniform_real_distribution<float> strain(-1.3f * yield, 1.3f * yield);
  std::uniform_real_distribution<float> near(-3e-4f, 3e-4f);
  std::vector<float> x(n), y(n, 0.0f), z(n, 0.0f), rx(n), ry(n, 0.0f), rz(n, 0.0f);
  for (std::uint32_t i = 0; i < n; ++i) x[i] = static_cast<float>(i) * edge * (1.0f + strain(rng));
  for (std::uint32_t i = 1; i < n; ++i) x[i] = std::max(x[i], x[i - 1] + 0.5f * edge);
  std::vector<std::int16_t> nbr(static_cast<std::size_t>(columns) * n);  // neighbour − vertex
  std::vector<float> rest(nbr.size());
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::int32_t l = i > 0 ? static_cast<std::int32_t>(i - 1) : static_cast<std::int32_t>(i);
    const std::int32_t r = i + 1 < n ? static_cast<std::int32_t>(i + 1) : static_cast<std::int32_t>(i);
    const std::int32_t js[3] = {l, r, static_cast<std::int32_t>(i)};
    for (int s = 0; s < columns; ++s) {
      const std::size_t e = static_cast<std::size_t>(s) * n + i;
      nbr[e] = static_cast<std::int16_t>(js[s] - static_cast<std::int32_t>(i));
      const float len = std::abs(x[js[s]] - x[i]);
      // Rest lengths that put the strain within ±3e-4 of ±yield, or anywhere.
      const float target = (i % 3 == 0) ? strain(rng) : (i % 2 ? yield : -yield) + near(rng);
      rest[e] = js[s] == static_cast<std::int32_t>(i) ? 0.0f : len / (1.0f + target);
    }
    // Anchors within ±3e-4 (relative) of the limit, or well inside it.
    const float d = (i % 4 == 0) ? 0.5f * limit : limit * (1.0f + near(rng));
    rx[i] = x[i] - d;
  }
  kernel::ForceArgs<float> a{};
  a.x = x.data(), a.y = y.data(), a.z = z.data(), a.rx = rx.data(), a.ry = ry.data(), a.rz = rz.data();
  a.nbr = nbr.data(), a.rest_length = rest.data(), a.stride = n, a.columns = columns;
  for (bool portable : {false, true}) {
    const kernel::testing::ScopedPortable portable_switch(portable);
    int exact_yields = 0, marked_total = 0;
    for (std::uint32_t b0 = 0; b0 < n; b0 += kBlock) {
      const std::uint32_t b1 = std::min(n, b0 + kBlock);
      std::vector<std::uint8_t> mask((1 + columns) * (kBlock / 8), 0xff);
      const bool any = kernel::yield_candidates(a, yield, limit, true, b0, b1, mask.data());
      auto bit = [&](int row, std::uint32_t i) { return (mask[row * (kBlock / 8) + (i - b0) / 8] >> ((i - b0) % 8)) & 1; };
      bool seen = false;
      for (std::uint32_t i = b0; i < b1; ++i) {
        // The exact tests of World::plastic_flow.
        const float ux = x[i] - rx[i], uy = y[i] - ry[i], uz = z[i] - rz[i];
        const bool anchor_yields = std::sqrt(ux * ux + uy * uy + uz * uz) > limit;
        exact_yields += anchor_yields;
        if (anchor_yields) {
          EXPECT_TRUE(bit(0, i)) << "anchor " << i;
        }
        seen = seen || bit(0, i);
        marked_total += bit(0, i);
        for (int s = 0; s < columns; ++s) {
          const std::size_t e = static_cast<std::size_t>(s) * n + i;
          const std::int32_t j = static_cast<std::int32_t>(i) + nbr[e];
          const float dx = x[j] - x[i], dy = y[j] - y[i], dz = z[j] - z[i];
          const float len = std::sqrt(dx * dx + dy * dy + dz * dz);
          const bool yields = j != static_cast<std::int32_t>(i) &&
                              (len > rest[e] * (1.0f + yield) || len < rest[e] * (1.0f - yield));
          exact_yields += yields;
          if (yields) {
            EXPECT_TRUE(bit(1 + s, i)) << "spring " << i << " column " << s;
          }
          if (j == static_cast<std::int32_t>(i)) {
            EXPECT_FALSE(bit(1 + s, i)) << "padding marked";
          }
          seen = seen || bit(1 + s, i);
          marked_total += bit(1 + s, i);
        }
      }
      EXPECT_EQ(any, seen);
    }
    // The test means something: many yield, and the filter still skips most of the rest.
    EXPECT_GT(exact_yields, 100);
    EXPECT_LT(marked_total, 4 * n * (1 + columns) / 5);
  }
}

}  // namespace
}  // namespace sculpt::sim
