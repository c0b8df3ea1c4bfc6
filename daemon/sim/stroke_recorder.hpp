// The recording side of edits (strokes.hpp), internal to the sim: per body,
// whether an edit is open, which blocks it has captured, and the blocks a
// swap changed that the viewers have not been told of yet.
//
// Every writer of a block's state (block_image.hpp) calls will_change(b, blk)
// (stroke_hook.hpp) before it writes; the first call for a block in the open
// edit hands its image to the sink.
//
// The broadphase is a writer too (it refits, wakes and marks the blocks it
// finds), yet only what it finds says whether an edit opens. So while no
// edit is touching the body, it runs with the blocks' BlockState stashed at
// their first write; once it is done, an edit that opens (or one released
// and still settling) captures those blocks with the stashed BlockState,
// which is all the broadphase writes of a block. Every size is fixed when the
// body is added: recording allocates nothing.
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
class EditRecorder {
 public:
  // Setup (allocates): sized for b, whose arrays are all in place.
  EditRecorder(std::uint32_t body_index, const Body<S>& b);

  // With no edit open (World::set_edit_sink closes them first).
  void set_sink(EditSink* sink) { sink_ = sink; }
  const BlockImageLayout& layout() const { return layout_; }
  bool open() const { return phase_ != Phase::closed; }

  // The tick's stages, on body b (World::step_body).
  void begin_broadphase(Body<S>& b) {
    if (sink_) begin_broadphase_slow(b);
  }
  void end_broadphase(Body<S>& b, std::uint64_t tick) {
    if (sink_) end_broadphase_slow(b, tick);
  }
  // Closes a released edit once b is at rest.
  void end_tick(Body<S>& b, std::uint64_t tick) {
    if (phase_ == Phase::released && b.awake_blocks == 0) close(b, tick);
  }
  // Closes the open edit now, between ticks; `tick` is its last.
  void close_now(Body<S>& b, std::uint64_t tick) {
    if (open()) close(b, tick);
  }

  // will_change's slow path: block blk is about to change and is not yet captured (or stashed).
  void take(Body<S>& b, std::uint32_t blk);

  // A swap changed block blk: the next step reports it to the viewers and
  // counts as input for the guard's energy test (as World::set_state does).
  void swapped(std::uint32_t blk) {
    swapped_[blk] = 1;
    swapped_any_ = true;
    swap_input_ = true;
  }
  bool swapped_any() const { return swapped_any_; }
  // Marks the swapped blocks changed (World::log_changes reports them).
  void mark_swapped(Body<S>& b);
  bool take_swap_input() {
    const bool was = swap_input_;
    swap_input_ = false;
    return was;
  }
  // restore_state replaced the whole state: nothing swapped is pending.
  void forget_swaps();
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
  EditSink* sink_ = nullptr;
  Phase phase_ = Phase::closed;
  EditSummary summary_;
  bool stashing_ = false;
  std::vector<std::uint8_t> captured_;  // per block: captured by the open edit
  std::vector<std::uint8_t> stashed_;   // per block: in the stash
  std::vector<std::uint32_t> stash_list_;
  std::vector<BlockState<S>> stash_state_;  // the BlockState of stash_list_[k] before the broadphase
  std::uint32_t stash_count_ = 0;
  std::vector<std::byte> image_;         // the image handed to the sink
  std::vector<std::uint8_t> swapped_;    // per block: swapped, not yet reported
  bool swapped_any_ = false;
  bool swap_input_ = false;
};

extern template class EditRecorder<float>;
extern template class EditRecorder<double>;

}  // namespace sculpt::sim
