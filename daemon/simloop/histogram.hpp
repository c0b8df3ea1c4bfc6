// A fixed-bucket latency histogram: one writer (the sim thread) records
// nanosecond durations without allocating, locking or looping; any thread
// reads percentiles. Log-linear buckets (32 per power of two) keep every
// reading within ~3 % of the truth from 1 ns to ~18 minutes in 5 KB.
#pragma once

#include <array>
#include <atomic>
#include <bit>
#include <cstdint>

namespace sculpt::simloop {

class LatencyHistogram {
 public:
  static constexpr int kSubBits = 5;                      // 32 sub-buckets per octave
  static constexpr int kSub = 1 << kSubBits;
  static constexpr int kMaxShift = 36;                    // values up to 2^41 ns
  static constexpr std::size_t kBuckets = (kMaxShift + 2) * kSub;

  // Writer only.
  void record(std::uint64_t ns) {
    const std::size_t i = index(ns);
    buckets_[i].store(buckets_[i].load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
    if (ns > max_.load(std::memory_order_relaxed)) max_.store(ns, std::memory_order_relaxed);
    sum_.store(sum_.load(std::memory_order_relaxed) + ns, std::memory_order_relaxed);
    count_.store(count_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  }

  // Readers: a consistent-enough view (counts may trail by a record or two).
  std::uint64_t count() const { return count_.load(std::memory_order_acquire); }
  std::uint64_t max_ns() const { return max_.load(std::memory_order_relaxed); }
  double mean_ns() const {
    const std::uint64_t n = count();
    return n ? static_cast<double>(sum_.load(std::memory_order_relaxed)) / static_cast<double>(n) : 0.0;
  }
  // The value below which a fraction q (0..1) of the records fall, as the
  // middle of its bucket, never above the exact maximum. 0 with no records.
  double quantile_ns(double q) const {
    std::uint64_t total = 0;
    for (const auto& b : buckets_) total += b.load(std::memory_order_relaxed);
    if (total == 0) return 0.0;
    const double target = q * static_cast<double>(total);
    std::uint64_t seen = 0;
    for (std::size_t i = 0; i < kBuckets; ++i) {
      seen += buckets_[i].load(std::memory_order_relaxed);
      if (static_cast<double>(seen) >= target && seen > 0) {
        const double mid = 0.5 * static_cast<double>(lower_bound(i) + upper_bound(i));
        const double mx = static_cast<double>(max_ns());
        return mid < mx ? mid : mx;
      }
    }
    return static_cast<double>(max_ns());
  }

  // Records in bucket i (a reader diffing two moments gets the histogram of
  // what happened in between: the streaming benchmark does).
  std::uint64_t bucket(std::size_t i) const { return buckets_[i].load(std::memory_order_relaxed); }

  // Bucket arithmetic, public for the tests.
  static std::size_t index(std::uint64_t ns) {
    if (ns < static_cast<std::uint64_t>(kSub)) return static_cast<std::size_t>(ns);
    int shift = std::bit_width(ns) - 1 - kSubBits;        // ns >> shift is in [kSub, 2 kSub)
    if (shift > kMaxShift) return kBuckets - 1;
    return static_cast<std::size_t>(shift) * kSub + static_cast<std::size_t>(ns >> shift);
  }
  static std::uint64_t lower_bound(std::size_t i) {
    if (i < static_cast<std::size_t>(2 * kSub)) return i;
    const std::size_t shift = i / kSub - 1;
    return static_cast<std::uint64_t>(i - shift * kSub) << shift;
  }
  static std::uint64_t upper_bound(std::size_t i) {  // exclusive
    if (i < static_cast<std::size_t>(2 * kSub)) return i + 1;
    const std::size_t shift = i / kSub - 1;
    return static_cast<std::uint64_t>(i - shift * kSub + 1) << shift;
  }

 private:
  std::array<std::atomic<std::uint32_t>, kBuckets> buckets_{};
  std::atomic<std::uint64_t> max_{0};
  std::atomic<std::uint64_t> sum_{0};
  std::atomic<std::uint64_t> count_{0};
};

}  // namespace sculpt::simloop
