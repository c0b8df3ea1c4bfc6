// The sim loop's wake-up jitter as Stats.jitterHistogram reports it, diffed
// over a window and read back as quantiles: what the daemon benchmarks that
// compare windows side by side (stream_bench, export_jitter_bench) share.
#pragma once

#include <cstdint>
#include <map>
#include <utility>

#include "sculpt.capnp.h"

namespace sculpt::bench {

using JitterHistogram = std::map<std::uint64_t, std::pair<std::uint64_t, std::uint64_t>>;  // lower → (upper, count)

inline JitterHistogram jitter_of(proto::Stats::Reader stats) {
  JitterHistogram h;
  for (const auto b : stats.getJitterHistogram()) h[b.getLowerNs()] = {b.getUpperNs(), b.getCount()};
  return h;
}

// acc += after − before, bucket by bucket.
inline void add_diff(JitterHistogram& acc, const JitterHistogram& before, const JitterHistogram& after) {
  for (const auto& [lo, uc] : after) {
    std::uint64_t prev = 0;
    if (auto it = before.find(lo); it != before.end()) prev = it->second.second;
    auto& slot = acc[lo];
    slot.first = uc.first;
    slot.second += uc.second - prev;
  }
}

// As LatencyHistogram::quantile_ns: the middle of the bucket holding the quantile, in µs.
inline double quantile_us(const JitterHistogram& h, double q) {
  std::uint64_t total = 0;
  for (const auto& [lo, uc] : h) total += uc.second;
  if (total == 0) return 0;
  std::uint64_t seen = 0;
  for (const auto& [lo, uc] : h) {
    seen += uc.second;
    if (static_cast<double>(seen) >= q * static_cast<double>(total) && seen > 0)
      return 0.5 * static_cast<double>(lo + uc.first) * 1e-3;
  }
  return 0;
}

}  // namespace sculpt::bench
