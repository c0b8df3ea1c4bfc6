// Packing: the records {x, y, z, 0, vx, vy, vz, 0} that let the AVX2 force
// kernels fetch a neighbour with two 16-byte loads.
#include <cstddef>
#include <cstdint>

#include "sim/kernels.hpp"
#include "sim/kernels_avx2.hpp"
#include "sim/kernels_shared.inl"

namespace sculpt::sim::kernel {

void pack(const ForceArgs<float>& A, ForceModel model, Velocity vel, float* packed, std::uint32_t begin,
          std::uint32_t end) {
  pack_into(A, model, vel, packed + 8 * static_cast<std::size_t>(begin), begin, end);
}

// The AVX2 kernel whenever the CPU has it: the records are the same bits either
// way, so the testing switch force_portable leaves this alone.
void pack_into(const ForceArgs<float>& A, ForceModel model, Velocity vel, float* packed, std::uint32_t begin,
               std::uint32_t end) {
  if (avx2::usable) return avx2::pack_into(A, model, vel, packed, begin, end);
  const bool bd = vel == Velocity::step, lin = model == ForceModel::linear;
  if (bd && !lin) pack_loop<Velocity::step, ForceModel::spring>(A, packed, begin, end);
  else if (bd) pack_loop<Velocity::step, ForceModel::linear>(A, packed, begin, end);
  else if (!lin) pack_loop<Velocity::stored, ForceModel::spring>(A, packed, begin, end);
  else pack_loop<Velocity::stored, ForceModel::linear>(A, packed, begin, end);
}

}  // namespace sculpt::sim::kernel
