// A body's blocks as the broadphase and the sleeping see them: awake or
// asleep, and a box that covers the block's triangles.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "sim/body.hpp"
#include "sim/stroke_hook.hpp"

namespace sculpt::sim {

template <class S>
void wake_block(Body<S>& b, std::uint32_t blk) {
  will_change(b, blk);
  BlockState<S>& s = b.block[blk];
  s.quiet_ticks = 0;
  if (!s.awake) {
    s.awake = true;
    ++b.awake_blocks;
  }
}

// The block's exact box from its vertices now.
template <class S>
void refit_block(Body<S>& b, std::uint32_t blk) {
  will_change(b, blk);
  BlockState<S>& s = b.block[blk];
  const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
  std::array<S, 3> lo{b.x[b0], b.y[b0], b.z[b0]}, hi = lo;
  for (std::uint32_t i = b0 + 1; i < b1; ++i) {
    lo[0] = std::min(lo[0], b.x[i]), hi[0] = std::max(hi[0], b.x[i]);
    lo[1] = std::min(lo[1], b.y[i]), hi[1] = std::max(hi[1], b.y[i]);
    lo[2] = std::min(lo[2], b.z[i]), hi[2] = std::max(hi[2], b.z[i]);
  }
  s.lo = lo;
  s.hi = hi;
  s.grow = 0;
}

// Whether coordinate `a` of a vertex of the block can be x: within the box
// at the last refit grown by how far any vertex may have moved since (the
// invariant the broadphase relies on, which the step, the pushes and the
// guard keep), with room for rounding. For a state read from outside.
template <class S>
bool within_block_box(const BlockState<S>& s, int a, double x) {
  const double lo = s.lo[a], hi = s.hi[a];
  const double slack = static_cast<double>(s.grow) * (1 + 1e-3) + 1e-3 * static_cast<double>(s.reach) +
                       1e-6 * std::max(std::abs(lo), std::abs(hi)) + 1e-9;
  return x >= lo - slack && x <= hi + slack;
}

// The body's box: the union of its blocks' boxes, grown.
template <class S>
void update_box(Body<S>& b) {
  if (b.blocks == 0) return;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = std::numeric_limits<S>::max();
    b.hi[k] = std::numeric_limits<S>::lowest();
  }
  for (const BlockState<S>& s : b.block) {
    const S g = s.grow + s.reach;
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min(b.lo[k], s.lo[k] - g);
      b.hi[k] = std::max(b.hi[k], s.hi[k] + g);
    }
  }
}

}  // namespace sculpt::sim
