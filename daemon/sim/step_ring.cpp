// The ring path: the same one pass per block as the records, with the
// neighbours' step-start records in the world's ring of kernel::kRingBlocks
// blocks instead of a copy of the whole body (see kernel::ForceArgs::ring_mask).
#include <cstring>

#include "sim/step_paths.hpp"

namespace sculpt::sim {

// Block c into the ring (and its far vertices' records aside) once per
// substep, before anything moves it: every block within kRingReach of the
// stepping one holds its ring place until the stepping reaches kRingReach
// past it, as the awake list ascends.
void RingStepper::pack_into_ring(Substep<float>& s, std::uint32_t c) {
  Body<float>& b = s.body;
  if (b.ring_stamp[c] == s.forces.ring_epoch) return;
  b.ring_stamp[c] = s.forces.ring_epoch;
  const std::uint32_t c0 = b.begin_of(c);
  float* records = s.ring + 8 * std::size_t{c0 & s.forces.ring_mask};
  kernel::pack_into(s.forces, b.material.model, s.velocity, records, c0, b.end_of(c));
  for (std::uint32_t k = b.far_vertex_begin[c]; k < b.far_vertex_begin[c + 1]; ++k)
    std::memcpy(b.far_records.data() + 8 * std::size_t{k}, records + 8 * std::size_t{b.far_vertices[k] - c0},
                8 * sizeof(float));
}

void RingStepper::substep(Substep<float>& s) {
  Body<float>& b = s.body;
  s.forces.packed = s.ring;
  s.forces.ring_mask = b.ring_blocks * kernel::kBlock - 1;
  s.forces.ring_stamp = b.ring_stamp.data();
  s.forces.ring_epoch = ++b.ring_epoch;
  s.forces.far_records = b.far_records.data();
  if (s.grabs.any()) {
    s.grabs.mark_blocks(true);
    s.grabs.pull_tools();
  }
  for (std::uint32_t q = 0; q < b.awake_count; ++q) {
    const std::uint32_t blk = b.awake_list[q], b0 = b.begin_of(blk), b1 = b.end_of(blk);
    pack_into_ring(s, blk);
    for (std::uint32_t e = b.block_neighbour_begin[blk]; e < b.block_neighbour_begin[blk + 1]; ++e) {
      const std::uint32_t c = b.block_neighbours[e];
      if (c + kernel::kRingReach >= blk && c <= blk + kernel::kRingReach) pack_into_ring(s, c);
    }
    s.use_scratch(b0);  // for the pieces (grabbed blocks, the portable clones)
    if (b.block[blk].grabbed) {
      step_grabbed_block(s, q, nullptr, nullptr);
      continue;
    }
    float potential = 0;
    const kernel::BlockSums<float> sums =
        kernel::step_block_fused(s.forces, s.integrate, b.material.model, s.integrator, b0, b1,
                                 b.overflow_begin[blk], b.overflow_begin[blk + 1], nullptr, potential);
    s.potential[q] = potential;  // before account(), which adds it to the block's energy
    s.account(q, sums);
  }
  if (s.grabs.any()) s.grabs.mark_blocks(false);
}

}  // namespace sculpt::sim
