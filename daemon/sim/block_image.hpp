// A block's image: every byte of World::state() that belongs to one block
// of a body and can change, in a fixed order and a size that is the same for
// every block of the body (a short last block is padded with zeros):
//
//   BlockState, CheckpointGrid                          (the block)
//   x y z, wx wy wz                                    kBlock each
//   clay: rx ry rz, srx sry srz                        kBlock each
//   ax ay az (bodies on the arrays path)               kBlock each
//   clay, spring model: rest_length, slen              kBlock per ELL column each
//   clay: the rest lengths of the block's overflow     padded to the body's most per block
//   packed records, the current buffer then the other  8·kBlock each (bodies that have them)
//   sx sy sz (the guard's 16-bit checkpoint)             kBlock each
//
// Left out: what never changes (the network, and the rest shape of elastic
// bodies), and the ring stamps, a clock like the body's ring_epoch: a stamp
// is only ever compared with the epoch of the substep running, which every
// substep advances first, so an older value of one means what any other does.
// The packed records go in current-first order so an image swapped in at the
// other parity of Body::packed_cur is still the same state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "sim/body.hpp"

namespace sculpt::sim {

struct BlockImageLayout {
  std::size_t bytes = 0;               // of every block's image
  std::uint32_t overflow_slots = 0;    // clay: overflow rest lengths per image
};

// Setup: the layout of b's images (b's arrays all sized).
template <class S>
BlockImageLayout block_image_layout(const Body<S>& b);

// Block blk's image into out (layout.bytes).
template <class S>
void write_block_image(const Body<S>& b, const BlockImageLayout& layout, std::uint32_t blk, std::byte* out);

// Exchanges block blk's state with the image (layout.bytes, checked by the
// caller), and keeps what the body derives from its blocks right: the count
// of awake blocks and the body's box (bit for bit what update_box gives).
// Allocates nothing.
template <class S>
void exchange_block_state(Body<S>& b, const BlockImageLayout& layout, std::uint32_t blk, std::byte* image);

// What an image from outside (a stroke read back from a store) must be
// before it is swapped in, value by value as World::restore_state holds a
// state: flags that are flags, the block's reach the body's, positions finite
// and within ±max_coordinate, velocities within `max_speed` (m/s; w per
// substep of at most `dts`), rest lengths finite and not negative (padding
// entries 0). "" or what is wrong.
struct BlockImageBounds {
  double max_coordinate = 1e6;
  double max_speed = 0;
  double dts = 0;  // the longest substep the body takes (position Verlet's w is v·dts)
  int sleep_ticks = 0;
};
template <class S>
std::string block_image_error(const Body<S>& b, const BlockImageLayout& layout, std::uint32_t blk,
                              const std::byte* image, const BlockImageBounds& bounds);

}  // namespace sculpt::sim
