#include "sim/guard.hpp"

#include <algorithm>

#include "sim/blocks.hpp"
#include "sim/motion.hpp"

namespace sculpt::sim {

template <class S>
void checkpoint_block(Body<S>& b, std::uint32_t blk) {
  will_change(b, blk);
  const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
  // Positions and clay rest shape from the same tick, or neither: a block
  // that is not finite keeps its older checkpoint whole (and stays dirty).
  if (!b.save_positions(blk)) return;
  if (b.plastic) {
    std::copy(b.rx.data() + b0, b.rx.data() + b1, b.srx.data() + b0);
    std::copy(b.ry.data() + b0, b.ry.data() + b1, b.sry.data() + b0);
    std::copy(b.rz.data() + b0, b.rz.data() + b1, b.srz.data() + b0);
    if (!b.slen.empty())
      for (int s = 0; s < b.columns; ++s) {
        const std::size_t o = static_cast<std::size_t>(s) * b.n;
        std::copy(b.rest_length.data() + o + b0, b.rest_length.data() + o + b1, b.slen.data() + o + b0);
      }
  }
  b.block[blk].dirty = false;
}

template <class S>
void restore_body(Body<S>& b) {
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) will_change(b, blk);  // asleep ones too
  for (std::uint32_t i = 0; i < b.n; ++i) {
    const std::array<S, 3> p = b.saved_position(i);
    b.x[i] = p[0], b.y[i] = p[1], b.z[i] = p[2];
    b.wx[i] = b.wy[i] = b.wz[i] = S(0);
    if (!b.ax.empty()) b.ax[i] = b.ay[i] = b.az[i] = S(0);
  }
  if (b.plastic) {
    std::copy_n(b.srx.data(), b.n, b.rx.data());
    std::copy_n(b.sry.data(), b.n, b.ry.data());
    std::copy_n(b.srz.data(), b.n, b.rz.data());
    if (!b.slen.empty()) std::copy_n(b.slen.data(), b.slen.size(), b.rest_length.data());
  }
  for (std::uint32_t i = 0; i < b.n; ++i) sync_records(b, i, S(1));  // velocity 0: any dt
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk) {
    wake_block(b, blk);
    BlockState<S>& s = b.block[blk];
    s.changed = true;
    s.dirty = false;
    s.energy = 0;
    s.accel_current = false;  // zeroed above
    refit_block(b, blk);
  }
  for (auto& tc : b.tools) tc.grab_count = 0, tc.grabbing = false;
  update_box(b);
}

template <class S>
void sleep_block(Body<S>& b, std::uint32_t blk) {
  will_change(b, blk);
  BlockState<S>& s = b.block[blk];
  const std::uint32_t b0 = b.begin_of(blk), b1 = b.end_of(blk);
  for (std::uint32_t i = b0; i < b1; ++i) {
    b.wx[i] = b.wy[i] = b.wz[i] = S(0);
    if (!b.ax.empty()) b.ax[i] = b.ay[i] = b.az[i] = S(0);
    sync_records(b, i, S(1));  // at rest: velocity 0 whatever the dt
  }
  s.awake = false;
  s.accel_current = false;  // zeroed above
  s.quiet_ticks = 0;
  --b.awake_blocks;
  refit_block(b, blk);
  checkpoint_block(b, blk);
}

template void checkpoint_block(Body<float>&, std::uint32_t);
template void checkpoint_block(Body<double>&, std::uint32_t);
template void restore_body(Body<float>&);
template void restore_body(Body<double>&);
template void sleep_block(Body<float>&, std::uint32_t);
template void sleep_block(Body<double>&, std::uint32_t);

}  // namespace sculpt::sim
