// What the sim thread did that a replay must do again, told to the keeper
// (keeper/keeper.hpp) as it happens: every input message it applied, each
// pause and resume, each stroke image set it wrote (an undo or a redo), each
// with the tick it happened at. Replaying these on a world built from the
// same scene gives the same bits (the simulation is deterministic), which is
// what the replica, the journal on disk and recovery rely on.
//
// The tap outlives every scene: a swap hands the new sim thread the same
// one, so one journal runs across scene swaps (one producer at a time: the
// old thread has finished before the new one starts, and the io thread
// writes the swap's own entry while neither runs).
#pragma once

#include <atomic>
#include <cstdint>
#include <span>

#include "concurrency/spsc_ring.hpp"
#include "input/input_message.hpp"

namespace sculpt::daemon {

struct JournalEntry {
  enum class Kind : std::uint8_t {
    message,  // `message` applied before the tick's step
    pause,    // the loop paused before running `tick`
    resume,   // ...and resumed
    history_move,  // stroke images `number` written before the tick's step (undo/redo)
    scene,    // the io thread swapped in scene `number` (the keeper's number); `tick` is its first
    reached,  // the keeper's mark on disk: the sim thread had finished `tick` and every tick before
  };
  Kind kind = Kind::message;
  bool refused = false;  // history_move: not written (made on another scene)
  std::uint64_t tick = 0;
  std::uint32_t number = 0;  // history_move: the keeper's request; scene: the scene's
  std::int64_t wall_ns = 0;  // reached: when it was committed (CLOCK_REALTIME)
  input::InputMessage message{};
};

// Stroke images for the sim thread to write into its world (an undo or a
// redo), prepared by the keeper; none (id 0): a mark the sim thread only
// records, where the replica closes the strokes still open. Immutable and owned by the keeper until
// the sim thread reports them written (JournalEntry::Kind::history_move with `id`).
struct HistoryMoveImages {
  std::uint32_t id = 0;       // the keeper's request number
  std::uint32_t scene = 0;    // the scene they were made on: written only there
  std::uint32_t body = 0;
  std::span<const std::uint32_t> blocks;
  std::span<std::byte> images;  // blocks.size() × the body's image size; the sim thread may scribble on it
};

class JournalTap {
 public:
  explicit JournalTap(std::size_t capacity = 16384) : entries_(capacity), history_moves_(64) {}

  // Sim thread (or the io thread while no sim thread runs).
  bool record(const JournalEntry& e) { return entries_.try_push(e); }
  // Room for `n` more: the input stage applies no more messages than the
  // journal can take, so nothing applied goes unrecorded.
  bool room_for(std::size_t n) const { return entries_.capacity() - entries_.size() >= n + 1; }
  // The sim thread finished `tick`; every entry of a tick up to it is in
  // the ring (release after the entries).
  void reached(std::uint64_t tick) { finished_.store(tick + 1, std::memory_order_release); }
  // Every tick before this one is finished (0: none yet).
  std::uint64_t finished() const { return finished_.load(std::memory_order_acquire); }
  // The scene the running sim thread's world belongs to (the keeper's number).
  std::atomic<std::uint32_t> scene{0};

  // Keeper thread.
  concurrency::SpscRing<JournalEntry>& entries() { return entries_; }
  bool send_history_move(const HistoryMoveImages* e) { return history_moves_.try_push(e); }
  // Sim thread.
  concurrency::SpscRing<const HistoryMoveImages*>& history_moves() { return history_moves_; }
  // Sim thread: entries refused for want of room (should stay 0).
  std::atomic<std::uint64_t> held_back{0};

 private:
  concurrency::SpscRing<JournalEntry> entries_;
  concurrency::SpscRing<const HistoryMoveImages*> history_moves_;
  std::atomic<std::uint64_t> finished_{0};
};

}  // namespace sculpt::daemon
