// Clay's yield (Material::plastic): after a tick's forces, which use the rest
// shape from before, the rest shape follows the deformation past the yield
// strain. A vectorised pass (kernel::yield_candidates, or the fused kernel
// while it computes the forces) marks in a mask what might yield; only the
// marked entries get the exact test, with the same bits as testing them all.
#pragma once

#include <cstddef>
#include <cstdint>

#include "sim/body.hpp"

namespace sculpt::sim {

// How far a vertex may leave its anchor's rest position before the anchor follows.
template <class S>
S clay_anchor_limit(const Body<S>& b) {
  return static_cast<S>(b.material.yield_strain) * b.mean_edge;
}

// Bytes of one block's yield mask: one bit per vertex for the anchors and for each ELL column.
template <class S>
std::size_t clay_mask_bytes(const Body<S>& b) {
  return (1 + static_cast<std::size_t>(b.columns)) * (kernel::kBlock / 8);
}

// Yield block blk on the present x (the steppers that test before they move).
template <class S>
void yield_block(Body<S>& b, std::uint32_t blk, std::uint8_t* mask);

// The exact tests and clamps for the entries marked in mask, with the
// positions the step started from: x, or (records: the fused pass has
// already moved x) the current packed records, which hold the same bits.
template <class S>
void apply_yields(Body<S>& b, std::uint32_t blk, const std::uint8_t* mask, const S* records);

}  // namespace sculpt::sim
