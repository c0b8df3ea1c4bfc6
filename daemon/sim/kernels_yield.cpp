// Clay: which entries of a block might yield (see yield_candidates in
// kernels.hpp), so that the exact test runs only on those.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "sim/kernels.hpp"
#include "sim/kernels_avx2.hpp"
#include "sim/kernels_shared.inl"

namespace sculpt::sim::kernel {
namespace {

template <class S>
bool yield_candidates_scalar(const ForceArgs<S>& a, S yield, S anchor_limit, bool springs, std::uint32_t begin,
                             std::uint32_t end, std::uint8_t* mask) {
  constexpr std::uint32_t kRow = kBlock / 8;
  std::memset(mask, 0, kRow * (1 + (springs ? a.columns : 0)));
  const S thr2 = (anchor_limit * anchor_limit) * kYieldShrink<S>;
  bool any = false;
  for (std::uint32_t i = begin; i < end; ++i)
    if (!anchor_quiet(a.x[i] - a.rx[i], a.y[i] - a.ry[i], a.z[i] - a.rz[i], thr2)) {
      mask[(i - begin) / 8] |= static_cast<std::uint8_t>(1u << ((i - begin) % 8));
      any = true;
    }
  if (!springs) return any;
  for (int s = 0; s < a.columns; ++s) {
    std::uint8_t* row = mask + kRow * (1 + s);
    const std::size_t o = static_cast<std::size_t>(s) * a.stride;
    for (std::uint32_t i = begin; i < end; ++i) {
      const std::int32_t j = static_cast<std::int32_t>(i) + a.nbr[o + i];
      if (!spring_quiet(a.x[j] - a.x[i], a.y[j] - a.y[i], a.z[j] - a.z[i], a.rest_length[o + i], yield)) {
        row[(i - begin) / 8] |= static_cast<std::uint8_t>(1u << ((i - begin) % 8));
        any = true;
      }
    }
  }
  return any;
}

}  // namespace

bool yield_candidates(const ForceArgs<float>& a, float yield, float anchor_limit, bool springs, std::uint32_t begin,
                      std::uint32_t end, std::uint8_t* mask) {
  if (avx2_paths_active()) return avx2::yield_candidates(a, yield, anchor_limit, springs, begin, end, mask);
  return yield_candidates_scalar(a, yield, anchor_limit, springs, begin, end, mask);
}

bool yield_candidates(const ForceArgs<double>& a, double yield, double anchor_limit, bool springs,
                      std::uint32_t begin, std::uint32_t end, std::uint8_t* mask) {
  return yield_candidates_scalar(a, yield, anchor_limit, springs, begin, end, mask);
}

}  // namespace sculpt::sim::kernel
