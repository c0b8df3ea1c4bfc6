// The records path: one pass per block while its data is in L1: forces with
// the neighbours from the current packed buffer, integrate, then pack into the
// other buffer, which the next substep reads.
#include "sim/clay.hpp"
#include "sim/step_paths.hpp"

namespace sculpt::sim {

float step_grabbed_block(Substep<float>& s, std::uint32_t q, std::uint8_t* yield_mask, float* packed_next) {
  Body<float>& b = s.body;
  const std::uint32_t blk = b.awake_list[q], b0 = b.begin_of(blk), b1 = b.end_of(blk);
  const float potential = s.block_forces(q);
  if (yield_mask)  // before it moves, as the fused kernel marks the others
    kernel::yield_candidates(s.forces, static_cast<float>(b.material.yield_strain), clay_anchor_limit(b),
                             b.material.model == ForceModel::spring, b0, b1, yield_mask);
  s.grabs.accelerate(blk, s.forces);
  s.potential[q] = potential;  // before account(), which adds it to the block's energy
  s.account(q, s.block_integrate(q));
  if (packed_next) kernel::pack(s.forces, b.material.model, s.velocity, packed_next, b0, b1);
  return potential;
}

// Clay yields on the state the tick starts from: the fused kernel marks the
// candidates while it computes the forces, and they are applied after the
// sweep from the current buffer, which still holds every vertex as the step
// found it.
void RecordsStepper::substep(Substep<float>& s) {
  Body<float>& b = s.body;
  const Material& m = b.material;
  s.forces.packed = b.packed[b.packed_cur].data();
  float* next = b.packed[b.packed_cur ^ 1].data();
  if (s.grabs.any()) {
    s.grabs.mark_blocks(true);
    s.grabs.pull_tools();
  }
  const bool yields = b.plastic && s.first();
  for (std::uint32_t q = 0; q < b.awake_count; ++q) {
    const std::uint32_t blk = b.awake_list[q], b0 = b.begin_of(blk), b1 = b.end_of(blk);
    s.use_scratch(b0);  // nothing waits: later blocks read the other packed buffer
    if (b.block[blk].grabbed) {
      step_grabbed_block(s, q, yields ? s.mask_of(q) : nullptr, next);
      continue;
    }
    kernel::YieldArgs ya{};
    if (yields) ya = {s.mask_of(q), static_cast<float>(m.yield_strain), clay_anchor_limit(b)};
    float potential = 0;
    const kernel::BlockSums<float> sums =
        kernel::step_block_fused(s.forces, s.integrate, m.model, s.integrator, b0, b1, b.overflow_begin[blk],
                                 b.overflow_begin[blk + 1], next, potential, yields ? &ya : nullptr);
    s.potential[q] = potential;
    s.account(q, sums);
  }
  if (yields)
    for (std::uint32_t q = 0; q < b.awake_count; ++q)
      apply_yields(b, b.awake_list[q], s.mask_of(q), b.packed[b.packed_cur].data());
  if (s.grabs.any()) s.grabs.mark_blocks(false);
  b.packed_cur ^= 1;
}

}  // namespace sculpt::sim
