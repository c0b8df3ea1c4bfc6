// Narrow phase: the outcodes of vertices against a box (see outcode in
// kernels.hpp).
#include <cstdint>

#include "sim/kernels.hpp"
#include "sim/kernels_avx2.hpp"

namespace sculpt::sim::kernel {
namespace {

template <class S>
void outcodes_scalar(const S* x, const S* y, const S* z, std::uint32_t begin, std::uint32_t end, const S* lo,
                     const S* hi, std::uint8_t* out) {
  for (std::uint32_t i = begin; i < end; ++i) out[i] = outcode(x[i], y[i], z[i], lo, hi);
}

}  // namespace

void outcodes(const float* x, const float* y, const float* z, std::uint32_t begin, std::uint32_t end,
              const float* lo, const float* hi, std::uint8_t* out) {
  if (avx2_paths_active()) return avx2::outcodes(x, y, z, begin, end, lo, hi, out);
  outcodes_scalar(x, y, z, begin, end, lo, hi, out);
}

void outcodes(const double* x, const double* y, const double* z, std::uint32_t begin, std::uint32_t end,
              const double* lo, const double* hi, std::uint8_t* out) {
  outcodes_scalar(x, y, z, begin, end, lo, hi, out);
}

}  // namespace sculpt::sim::kernel
