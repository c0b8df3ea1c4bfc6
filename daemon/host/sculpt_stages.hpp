// What the sim thread does around World::step in sculptd: stroke images the
// keeper sent (undo, redo) into the world, inputs due this tick (ring →
// ControlMapper) → ToolDriver → tool poses; after the step, each tool's
// contact rendered (sim::ContactRenderer, one per tool, fresh for each scene)
// to the haptics' FeedbackBoard. With a journal tap, each of
// these is recorded with its tick (keeper/journal.hpp). Allocation-free once
// constructed (tests/unit/host checks it with a counting operator new).
#pragma once

#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

#include "concurrency/spsc_ring.hpp"
#include "haptics/feedback_board.hpp"
#include "input/control_mapper.hpp"
#include "input/input_message.hpp"
#include "simloop/sim_thread.hpp"
#include "simloop/tool_driver.hpp"
#include "keeper/journal.hpp"
#include "server/published_state.hpp"
#include "sim/contact_render.hpp"

namespace sculpt::daemon {

class SculptStages final : public simloop::TickStages {
 public:
  // tools ≤ sim::kMaxTools. The ring carries io → sim messages.
  SculptStages(simloop::ToolDriver driver, haptics::FeedbackBoard& board, std::size_t ring_capacity);

  // io thread: the producer side of the input ring.
  concurrency::SpscRing<input::InputMessage>& ring() { return ring_; }
  // Messages applied so far (any thread; for tests and the stats).
  std::uint64_t applied() const { return applied_.load(std::memory_order_relaxed); }
  // Scheduled inputs applied after their tick (see ControlMapper::late);
  // read it only while the sim thread is stopped.
  std::uint64_t late_inputs() const { return mapper_.late(); }

  void input(std::uint64_t tick, std::span<sim::Tool> tools) override;
  void publish(std::uint64_t tick, const sim::World<float>& world) override;
  void paused_changed(std::uint64_t tick, bool paused) override;

  // Where what the sim thread does is recorded, and the world stroke images
  // are written into (both nullptr: no journal, no history moves). Set before the
  // sim thread starts.
  void set_journal(JournalTap* tap, sim::World<float>* world) {
    tap_ = tap;
    world_ = world;
  }
  // Undo and redo presses on the pads so far (monotonic; any thread).
  std::uint32_t undo_presses() const { return undo_presses_.load(std::memory_order_relaxed); }
  std::uint32_t redo_presses() const { return redo_presses_.load(std::memory_order_relaxed); }

  const simloop::ToolDriver& driver() const { return driver_; }
  // Which devices are attached, with their bindings (read while the sim
  // thread is stopped: a scene swap carries them over).
  const input::ControlMapper& mapper() const { return mapper_; }
  input::ControlMapper& mapper() { return mapper_; }
  simloop::ToolDriver& driver() { return driver_; }

  // Where the publish stage hands the tick's positions and tools to the
  // streaming server (nullptr: nowhere). Set before the sim thread starts.
  void set_published(server::PublishedState* state) { published_ = state; }

 private:
  void write_history_moves(std::uint64_t tick);
  bool fits(const HistoryMoveImages& e) const;
  std::size_t take_messages(std::uint64_t tick);

  simloop::ToolDriver driver_;
  haptics::FeedbackBoard& board_;
  std::vector<sim::ContactRenderer> felt_;  // per tool: raw reaction → felt contact
  concurrency::SpscRing<input::InputMessage> ring_;
  input::ControlMapper mapper_;
  std::atomic<std::uint64_t> applied_{0};
  server::PublishedState* published_ = nullptr;
  std::span<const sim::Tool> tools_;  // the sim thread's, seen in input()
  JournalTap* tap_ = nullptr;
  sim::World<float>* world_ = nullptr;
  std::atomic<std::uint32_t> undo_presses_{0}, redo_presses_{0};
};

}  // namespace sculpt::daemon
