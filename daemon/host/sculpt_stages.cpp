#include "host/sculpt_stages.hpp"

#include <stdexcept>
#include <string>

namespace sculpt::daemon {

SculptStages::SculptStages(simloop::ToolDriver driver, haptics::FeedbackBoard& board, std::size_t ring_capacity)
    : driver_(std::move(driver)),
      board_(board),
      felt_(driver_.size(), sim::ContactRenderer(driver_.dt())),
      ring_(ring_capacity),
      mapper_(driver_.size()) {
  if (driver_.size() > sim::kMaxTools)
    throw std::invalid_argument("the scene has " + std::to_string(driver_.size()) + " tools; at most " +
                                std::to_string(sim::kMaxTools) + " can be driven");
}

void SculptStages::input(std::uint64_t tick, std::span<sim::Tool> tools) {
  if (tap_) write_history_moves(tick);
  const std::size_t n = tap_ ? take_messages(tick) : mapper_.drain(ring_, tick);
  if (n) applied_.store(applied_.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
  driver_.update_from(mapper_.controls(), tools);
  tools_ = tools;
  undo_presses_.store(mapper_.undo_presses(), std::memory_order_relaxed);
  redo_presses_.store(mapper_.redo_presses(), std::memory_order_relaxed);
}

// ControlMapper::drain, journaling each message; one the journal has no room
// for waits in the ring (applied late rather than unrecorded).
std::size_t SculptStages::take_messages(std::uint64_t tick) {
  std::size_t n = 0;
  while (const input::InputMessage* m = ring_.peek()) {
    if (m->at_tick != 0 && m->at_tick > tick) break;
    if (!tap_->room_for(1)) {
      tap_->held_back.fetch_add(1, std::memory_order_relaxed);
      break;
    }
    mapper_.take(*m, tick);
    JournalEntry e;
    e.kind = JournalEntry::Kind::message;
    e.tick = tick;
    e.message = *m;
    tap_->record(e);
    ring_.pop();
    ++n;
  }
  return n;
}

// Whether the images fit this world, checked before any is written (what
// World::exchange_block_image would throw for, so that it never does here).
bool SculptStages::fits(const HistoryMoveImages& e) const {
  if (e.body >= world_->body_count()) return false;
  const std::size_t size = world_->block_image_bytes(e.body);
  if (e.images.size() != e.blocks.size() * size) return false;
  for (const std::uint32_t b : e.blocks)
    if (b >= world_->body(e.body).blocks) return false;
  return true;
}

// Undo and redo: the keeper's images into the world, before the tick's
// inputs (the replica writes them at the same point). Images made on
// another scene are refused, and that is recorded too.
void SculptStages::write_history_moves(std::uint64_t tick) {
  while (const HistoryMoveImages* const* next = tap_->history_moves().peek()) {
    if (!tap_->room_for(1)) return;
    const HistoryMoveImages& e = **next;
    // No blocks: the keeper's mark that closes open strokes, recorded at this tick.
    bool written = world_ && e.scene == tap_->scene.load(std::memory_order_relaxed) && (e.blocks.empty() || fits(e));
    if (written) {
      const std::size_t size = world_->block_image_bytes(e.body);
      for (std::size_t i = 0; i < e.blocks.size(); ++i)
        world_->exchange_block_image(e.body, e.blocks[i], e.images.subspan(i * size, size));
    }
    JournalEntry j;
    j.kind = JournalEntry::Kind::history_move;
    j.refused = !written;
    j.tick = tick;
    j.number = e.id;
    tap_->record(j);
    tap_->history_moves().pop();
  }
}

void SculptStages::paused_changed(std::uint64_t tick, bool paused) {
  // Paused, the loop runs no ticks: nothing may stay felt (an effect left
  // playing while paused), and the haptics thread must not take the
  // missing beats for a stall.
  board_.set_hold(paused ? haptics::Hold::paused : haptics::Hold::none);
  if (!tap_) return;
  JournalEntry e;
  e.kind = paused ? JournalEntry::Kind::pause : JournalEntry::Kind::resume;
  e.tick = tick;
  if (!tap_->record(e)) tap_->held_back.fetch_add(1, std::memory_order_relaxed);
}

void SculptStages::publish(std::uint64_t tick, const sim::World<float>& world) {
  if (tap_) tap_->reached(tick);
  if (published_) published_->publish(tick, world, tools_, simloop::monotonic_ns());
  const auto feedback = world.feedback();
  for (std::size_t t = 0; t < driver_.size() && t < feedback.size(); ++t) {
    const sim::Tool& tool = driver_.tool(t);
    if (tool.active) {
      // The pose this tick's step used: the renderer takes the tool's velocity from successive ones.
      const sim::RenderedContact& c = felt_[t].update(feedback[t], tool.position);
      board_.publish(static_cast<int>(t), {c.force, c.contacts, c.touching, c.onset, c.onset_impulse});
    } else {
      felt_[t].reset();
      board_.clear(static_cast<int>(t));
    }
  }
  board_.beat();
}

}  // namespace sculpt::daemon
