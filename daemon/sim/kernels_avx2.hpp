// Internal to the kernels: the hand-written AVX2 kernels (kernels_avx2.cpp),
// float only, as the dispatch in the other kernel files calls them. Each
// computes the same bits as the portable path it stands in for.
// In a build without them (not x86-64, or -DSCULPT_SIM_NO_CLONES) `usable` is
// false and the functions are stubs that are never called.
#pragma once

#include <cstdint>

#include "sim/kernels.hpp"

namespace sculpt::sim::kernel::avx2 {

// Built in, and the CPU has AVX2. Decided once at load time, so the real-time
// thread never meets a function-local static's first-use guard.
extern const bool usable;

// forces(): neighbours from a.packed (a ring if a.ring_mask), else lane by
// lane from the arrays.
float forces(const ForceArgs<float>& a, ForceModel model, Velocity vel, std::uint32_t begin, std::uint32_t end,
             std::uint32_t ob, std::uint32_t oe);

// pack_into().
void pack_into(const ForceArgs<float>& a, ForceModel model, Velocity vel, float* out, std::uint32_t begin,
               std::uint32_t end);

// step_block_fused() for position Verlet or symplectic Euler: a whole block
// (`whole`) in one pass of eight-vertex groups, else in pieces; through the
// ring when a.ring_mask (then packed_next is ignored).
BlockSums<float> step_block(const ForceArgs<float>& a, const IntegrateArgs<float>& in, bool spring,
                            Integrator integrator, bool whole, std::uint32_t begin, std::uint32_t end,
                            std::uint32_t ob, std::uint32_t oe, float* packed_next, float& potential);

// The same for a whole clay block (spring model, no ring) that also marks the
// entries that yield, from the lengths its forces compute.
BlockSums<float> step_whole_block_marking_yield(const ForceArgs<float>& a, const IntegrateArgs<float>& in,
                                                Integrator integrator, std::uint32_t begin, std::uint32_t ob,
                                                std::uint32_t oe, float* packed_next, float& potential,
                                                const YieldArgs& yield);

// yield_candidates() and outcodes().
bool yield_candidates(const ForceArgs<float>& a, float yield, float anchor_limit, bool springs, std::uint32_t begin,
                      std::uint32_t end, std::uint8_t* mask);
void outcodes(const float* x, const float* y, const float* z, std::uint32_t begin, std::uint32_t end,
              const float* lo, const float* hi, std::uint8_t* out);

}  // namespace sculpt::sim::kernel::avx2
