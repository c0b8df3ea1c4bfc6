// The capturing side of strokes (strokes.hpp), internal to the sim: per body,
// whether a stroke is open, which blocks it has captured, and the blocks a
// swap changed that the viewers have not been told of yet.
//
// Every writer of a block's state (block_image.hpp) calls will_change(b, blk)
// (stroke_hook.hpp) before it writes; the first call for a block in the open
// stroke hands its image to the sink.
//
// The broadphase is a writer too (it refits, wakes and marks the blocks it
// finds), yet only what it finds says whether a stroke opens. So while no
// stroke is touching the body, it runs with the blocks' BlockState stashed at
// their first write; once it is done, a stroke that opens (or one released
// and still settling) captures those blocks with the stashed BlockState,
// which is all the broadphase writes of a block. Every size is fixed when the
// body is added: capturing allocates nothing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "sim/block_image.hpp"
#include "sim/body.hpp"
#include "sim/stroke_hook.hpp"
#include "sim/strokes.hpp"

namespace sculpt::sim {

template <class S>
class StrokeRecorder {
 public:
  // Setup (allocates): sized for b, whose arrays are all in place.
  StrokeRecorder(std::uint32_t body_index, const Body<S>& b);

  // With no stroke open (World::set_stroke_sink closes them first).
  void set_sink(StrokeSink* sink) { sink_ = sink; }
  const BlockImageLayout& layout() const { return layout_; }
  bool open() const { return phase_ != Phase::closed; }

  // The tick's stages, on body b (World::step_body).
  void begin_broadphase(Body<S>& b) {
    if (sink_) begin_broadphase_slow(b);
  }
  void end_broadphase(Body<S>& b, std::uint64_t tick) {
    if (sink_) end_broadphase_slow(b, tick);
  }
  // Closes a released stroke once b is at rest.
  void end_tick(Body<S>& b, std::uint64_t tick) {
    if (phase_ == Phase::released && b.awake_blocks == 0) close(b, tick);
  }
  // Closes the open stroke now, between ticks; `tick` is its last.
  void close_now(Body<S>& b, std::uint64_t tick) {
    if (open()) close(b, tick);
  }

  // will_change's slow path: block blk is about to change and is not yet captured (or stashed).
  void take(Body<S>& b, std::uint32_t blk);

  // A swap changed block blk: the next step reports it to the viewers and
  // counts as input for the guard's energy test (as World::set_state does).
  void swapped(std::uint32_t blk) {
    swapped_[blk] = 1;
    exchanged_any_ = true;
    exchange_input_ = true;
  }
  bool exchanged_any() const { return exchanged_any_; }
  // Marks the swapped blocks changed (World::log_changes reports them).
  void mark_exchanged(Body<S>& b);
  bool take_exchange_input() {
    const bool was = exchange_input_;
    exchange_input_ = false;
    return was;
  }
  // restore_state replaced the whole state: nothing swapped is pending.
  void forget_exchanges();
  std::size_t bytes() const;

 private:
  enum class Phase : std::uint8_t { closed, touching, released };

  void begin_broadphase_slow(Body<S>& b);
  void end_broadphase_slow(Body<S>& b, std::uint64_t tick);
  void open(Body<S>& b, std::uint64_t tick);
  void close(Body<S>& b, std::uint64_t last_tick);
  void unstash(Body<S>& b);
  void capture(const Body<S>& b, std::uint32_t blk, const BlockState<S>* block_state);

  std::uint32_t index_;
  BlockImageLayout layout_;
  StrokeSink* sink_ = nullptr;
  Phase phase_ = Phase::closed;
  StrokeSummary summary_;
  bool stashing_ = false;
  std::vector<std::uint8_t> captured_;  // per block: captured by the open stroke
  std::vector<std::uint8_t> stashed_;   // per block: in the stash
  std::vector<std::uint32_t> stash_list_;
  std::vector<BlockState<S>> stash_state_;  // the BlockState of stash_list_[k] before the broadphase
  std::uint32_t stash_count_ = 0;
  std::vector<std::byte> image_;         // the image handed to the sink
  std::vector<std::uint8_t> swapped_;    // per block: swapped, not yet reported
  bool exchanged_any_ = false;
  bool exchange_input_ = false;
};

extern template class StrokeRecorder<float>;
extern template class StrokeRecorder<double>;

}  // namespace sculpt::sim
