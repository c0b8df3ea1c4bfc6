// The hook every writer of a block's state calls first (stroke_recorder.hpp):
// while a stroke is open, the first change of a block in it captures the
// block's image; otherwise it costs one test of a null pointer.
#pragma once

#include <cstdint>

#include "sim/body.hpp"

namespace sculpt::sim {

template <class S>
void capture_block(Body<S>& b, std::uint32_t blk);  // b.strokes->take(b, blk)

// Call before writing anything of block blk's state (block_image.hpp lists it).
template <class S>
[[gnu::always_inline]] inline void will_change(Body<S>& b, std::uint32_t blk) {
  if (b.stroke_done && !b.stroke_done[blk]) [[unlikely]]
    capture_block(b, blk);
}

}  // namespace sculpt::sim
