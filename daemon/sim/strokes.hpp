// Strokes: what the daemon's undo history is built from. A stroke is one
// continuous working of one body by tools, from the tick a tool comes near it
// until it is at rest again after the last tool left. While a stroke is open, the world hands its sink
// the pre-image of every block the stroke is about to change (copy on first
// change), so a later World::exchange_block_image of those images puts the body
// back as it was when the stroke opened; exchanging again puts it back as it
// was after. docs/simulation.md ("Strokes and block images") has the rules.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace sculpt::sim {

// One stroke of one body. Ticks are World::tick() values.
struct StrokeSummary {
  std::uint64_t first_tick = 0;    // the tick it opened (a tool came near)
  std::uint64_t release_tick = 0;  // the first tick after it with no tool near (0: closed while a tool was near)
  std::uint64_t last_tick = 0;     // the last tick whose changes it holds
  std::uint64_t tools = 0;         // bit t: tool slot t came near during the stroke
};

// Told a world's strokes as they happen, on the thread that steps the world
// (inside World::step, or World::close_strokes). A sink must not call back into
// the world. For a real-time world its methods must not allocate or block.
class StrokeSink {
 public:
  virtual ~StrokeSink() = default;
  virtual void opened(std::uint32_t body, std::uint64_t tick) = 0;
  // Block `block` of `body` is about to change for the first time in the open
  // stroke; `image` is its state now, as World::block_image writes it (valid
  // during the call only).
  virtual void captured(std::uint32_t body, std::uint32_t block, std::span<const std::byte> image) = 0;
  virtual void closed(std::uint32_t body, const StrokeSummary& stroke) = 0;
};

}  // namespace sculpt::sim
