// StrokeRecorder (stroke_recorder.hpp): a stroke's life on one body, tick by tick.
//
//   closed ──tool near──▶ touching ──no tool near──▶ released ──at rest──▶ closed
//                                                     │
//                                       tool near ────┘ close (last tick: the one before), open again
//
// and close_strokes() closes from any phase.
#include "sim/stroke_recorder.hpp"

#include <algorithm>
#include <cstring>

namespace sculpt::sim {

template <class S>
StrokeRecorder<S>::StrokeRecorder(std::uint32_t body_index, const Body<S>& b)
    : index_(body_index),
      layout_(block_image_layout(b)),
      captured_(b.blocks, 0),
      stashed_(b.blocks, 0),
      stash_list_(b.blocks),
      stash_state_(b.blocks),
      image_(layout_.bytes),
      swapped_(b.blocks, 0) {}

template <class S>
void StrokeRecorder<S>::take(Body<S>& b, std::uint32_t blk) {
  if (!stashing_) return capture(b, blk, nullptr);
  stashed_[blk] = 1;
  stash_list_[stash_count_] = blk;
  std::memcpy(&stash_state_[stash_count_++], &b.block[blk], sizeof(BlockState<S>));  // padding too: it is in the state
}

// A touching stroke captures what the broadphase changes; otherwise whether
// a stroke opens is known only after it, so it stashes.
template <class S>
void StrokeRecorder<S>::begin_broadphase_slow(Body<S>& b) {
  stashing_ = phase_ != Phase::touching;
  b.stroke_done = stashing_ ? stashed_.data() : captured_.data();
}

// A tool is near b when it has candidate blocks of b or holds vertices of b.
template <class S>
void StrokeRecorder<S>::end_broadphase_slow(Body<S>& b, std::uint64_t tick) {
  std::uint64_t near = 0;
  for (std::size_t t = 0; t < b.tools.size(); ++t) {
    const ToolContact<S>& tc = b.tools[t];
    if (tc.candidate_count > 0 || (tc.grabbing && tc.grab_count > 0)) near |= std::uint64_t{1} << t;
  }
  if (stashing_) {
    stashing_ = false;
    if (near && phase_ == Phase::released) close(b, tick - 1);  // this tick's changes are the next stroke's
    if (near && phase_ == Phase::closed) open(b, tick);
    unstash(b);
  }
  if (!open()) {
    b.stroke_done = nullptr;
    return;
  }
  b.stroke_done = captured_.data();
  summary_.tools |= near;
  if (!near && phase_ == Phase::touching) {
    phase_ = Phase::released;
    summary_.release_tick = tick;
  }
}

// The stashed blocks into the open stroke (those it has not captured yet),
// with their BlockState from before the broadphase; with none open, dropped.
template <class S>
void StrokeRecorder<S>::unstash(Body<S>& b) {
  for (std::uint32_t k = 0; k < stash_count_; ++k) {
    const std::uint32_t blk = stash_list_[k];
    if (open() && !captured_[blk]) capture(b, blk, &stash_state_[k]);
    stashed_[blk] = 0;
  }
  stash_count_ = 0;
}

template <class S>
void StrokeRecorder<S>::open(Body<S>& b, std::uint64_t tick) {
  phase_ = Phase::touching;
  summary_ = {.first_tick = tick};
  std::fill(captured_.begin(), captured_.end(), std::uint8_t{0});
  b.stroke_done = captured_.data();
  sink_->opened(index_, tick);
}

template <class S>
void StrokeRecorder<S>::close(Body<S>& b, std::uint64_t last_tick) {
  phase_ = Phase::closed;
  summary_.last_tick = last_tick;
  b.stroke_done = nullptr;
  sink_->closed(index_, summary_);
}

template <class S>
void StrokeRecorder<S>::capture(const Body<S>& b, std::uint32_t blk, const BlockState<S>* block_state) {
  write_block_image(b, layout_, blk, image_.data());
  if (block_state) std::memcpy(image_.data(), block_state, sizeof *block_state);  // the image starts with it
  captured_[blk] = 1;
  sink_->captured(index_, blk, image_);
}

template <class S>
void StrokeRecorder<S>::mark_exchanged(Body<S>& b) {
  if (!exchanged_any_) return;
  for (std::uint32_t blk = 0; blk < b.blocks; ++blk)
    if (swapped_[blk]) b.block[blk].changed = true, swapped_[blk] = 0;
  exchanged_any_ = false;
}

template <class S>
void StrokeRecorder<S>::forget_exchanges() {
  std::fill(swapped_.begin(), swapped_.end(), std::uint8_t{0});
  exchanged_any_ = exchange_input_ = false;
}

template <class S>
std::size_t StrokeRecorder<S>::bytes() const {
  return sizeof(*this) + captured_.capacity() + stashed_.capacity() + stash_list_.capacity() * 4 +
         stash_state_.capacity() * sizeof(BlockState<S>) + image_.capacity() + swapped_.capacity();
}

template <class S>
void capture_block(Body<S>& b, std::uint32_t blk) {
  b.strokes->take(b, blk);
}

template class StrokeRecorder<float>;
template class StrokeRecorder<double>;
template void capture_block(Body<float>&, std::uint32_t);
template void capture_block(Body<double>&, std::uint32_t);

}  // namespace sculpt::sim
