// The blow-up guard's state changes on one body: checkpoints of good blocks,
// restoring the last good state, and putting quiet blocks to sleep (which
// checkpoints them too). World decides when; these do it.
#pragma once

#include <cstdint>

#include "sim/body.hpp"

namespace sculpt::sim {

// Save block blk as the last good state (positions, and clay's rest shape
// from the same tick), unless a position is not finite.
template <class S>
void checkpoint_block(Body<S>& b, std::uint32_t blk);

// Every vertex back to its last good state, at rest; every block awake and
// changed, and no grab held.
template <class S>
void restore_body(Body<S>& b);

// At rest: no velocity, no acceleration, a fresh box and checkpoint.
template <class S>
void sleep_block(Body<S>& b, std::uint32_t blk);

}  // namespace sculpt::sim
