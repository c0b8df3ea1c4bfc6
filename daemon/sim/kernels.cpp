// Which path a kernel call takes: the hand-written AVX2 kernels
// (kernels_avx2.cpp) or the portable clones (kernels_portable.cpp), and the
// fused pass that strings a block's forces, integration and packing together.
// Also the testing switches of kernel_testing.hpp.
#include "sim/kernels.hpp"

#include <atomic>
#include <cstdint>

#include "sim/kernel_testing.hpp"
#include "sim/kernels_avx2.hpp"

namespace sculpt::sim::kernel {
namespace {

std::atomic<bool> g_portable{false};
std::atomic<bool> g_block_pieces{false};

}  // namespace

void testing::force_portable(bool on) { g_portable.store(on, std::memory_order_relaxed); }
void testing::force_block_pieces(bool on) { g_block_pieces.store(on, std::memory_order_relaxed); }

bool avx2_paths_active() { return avx2::usable && !g_portable.load(std::memory_order_relaxed); }

BlockSums<float> step_block_fused(const ForceArgs<float>& a, const IntegrateArgs<float>& in, ForceModel model,
                                  Integrator integrator, std::uint32_t begin, std::uint32_t end, std::uint32_t ob,
                                  std::uint32_t oe, float* packed_next, float& potential, const YieldArgs* yield) {
  const bool spring = model == ForceModel::spring;
  const bool whole = end - begin == kBlock && !g_block_pieces.load(std::memory_order_relaxed);
  const bool avx2 = avx2_paths_active() && integrator != Integrator::velocity_verlet;
  // Clay (double buffer only: World keeps clay off the ring): the marks come with the forces.
  if (avx2 && !a.ring_mask && yield && spring && whole)
    return avx2::step_whole_block_marking_yield(a, in, integrator, begin, ob, oe, packed_next, potential, *yield);
  // Otherwise from the state before this block moves.
  if (yield) yield_candidates(a, yield->yield, yield->anchor_limit, spring, begin, end, yield->mask);
  if (avx2) return avx2::step_block(a, in, spring, integrator, whole, begin, end, ob, oe, packed_next, potential);
  // The portable clones (the ring's path without AVX2), in the unfused order.
  const Velocity vel = integrator == Integrator::position_verlet ? Velocity::step : Velocity::stored;
  potential = forces(a, model, vel, begin, end, ob, oe);
  const BlockSums<float> sums = integrate(in, integrator, begin, end);
  if (packed_next) pack(a, model, vel, packed_next, begin, end);
  return sums;
}

}  // namespace sculpt::sim::kernel
