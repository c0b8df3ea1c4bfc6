#include <gtest/gtest.h>

#include <random>

#include "simloop/histogram.hpp"

namespace sculpt::simloop {
namespace {

TEST(LatencyHistogram, BucketsTileTheLineWithoutGaps) {
  using H = LatencyHistogram;
  for (std::size_t i = 0; i + 2 < H::kBuckets; ++i) {
    EXPECT_EQ(H::upper_bound(i), H::lower_bound(i + 1)) << "bucket " << i;
    EXPECT_EQ(H::index(H::lower_bound(i)), i);
    EXPECT_EQ(H::index(H::upper_bound(i) - 1), i);
  }
  EXPECT_EQ(H::index(0), 0u);
  EXPECT_EQ(H::index(~std::uint64_t{0}), H::kBuckets - 1);  // huge values land in the last bucket
}

TEST(LatencyHistogram, BucketWidthIsWithinThreePercent) {
  using H = LatencyHistogram;
  for (std::size_t i = 2 * H::kSub; i + 1 < H::kBuckets; ++i) {
    const double lo = static_cast<double>(H::lower_bound(i)), hi = static_cast<double>(H::upper_bound(i));
    EXPECT_LE((hi - lo) / lo, 1.0 / H::kSub + 1e-12) << "bucket " << i;
  }
}

TEST(LatencyHistogram, QuantilesOfAKnownDistribution) {
  LatencyHistogram h;
  EXPECT_EQ(h.quantile_ns(0.5), 0.0);
  // 1..100000 ns, each once: p50 ≈ 50000, p99 ≈ 99000.
  for (std::uint64_t v = 1; v <= 100000; ++v) h.record(v);
  EXPECT_EQ(h.count(), 100000u);
  EXPECT_EQ(h.max_ns(), 100000u);
  EXPECT_NEAR(h.quantile_ns(0.5), 50000.0, 50000.0 * 0.035);
  EXPECT_NEAR(h.quantile_ns(0.99), 99000.0, 99000.0 * 0.035);
  EXPECT_LE(h.quantile_ns(1.0), 100000.0);  // never above the exact maximum
  EXPECT_NEAR(h.mean_ns(), 50000.5, 1e-6);
}

TEST(LatencyHistogram, AnOutlierShowsInTheMaxNotTheMedian) {
  LatencyHistogram h;
  for (int i = 0; i < 999; ++i) h.record(2000);
  h.record(5'000'000);
  EXPECT_NEAR(h.quantile_ns(0.5), 2000.0, 2000.0 * 0.035);
  EXPECT_NEAR(h.quantile_ns(0.99), 2000.0, 2000.0 * 0.035);
  EXPECT_EQ(h.max_ns(), 5'000'000u);
}

}  // namespace
}  // namespace sculpt::simloop
