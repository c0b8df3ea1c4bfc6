// The sim thread's hand-off to the streaming server: the latest positions of
// every mesh, written by the sim thread each tick WITHOUT allocating, locking
// or waiting, read by the io thread whenever it likes.
//
// Layout: per body, positions in the body's internal (spatial) order, split
// into blocks of kBlock vertices, each block under its own sequence lock
// (odd while being written). The sim thread rewrites only the blocks that
// World::changes() names, so its cost follows what moved, not the mesh size.
// A header seqlock carries the tick, the times and the tools. The reader
// (PublishedReader, io thread) copies a block only when its sequence moved,
// retries a torn copy on its next pass, and keeps its own copy in the file's
// vertex order for the viewers.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "sim/limits.hpp"
#include "concurrency/seqlock.hpp"
#include "sim/tool.hpp"
#include "sim/world.hpp"

namespace sculpt::server {

inline constexpr std::uint32_t kBlock = 64;     // vertices per published block

struct PublishedTool {
  bool active = false;
  bool grab = false;
  std::uint8_t shape = 0;              // sim::ToolShape
  float radius = 0;
  std::array<float, 3> position{}, half_axis{}, velocity{}, force{};
  std::uint32_t contacts = 0;
};

struct PublishedHeader {
  std::uint64_t tick = 0;              // ticks completed (the tick's number + 1); 0: nothing yet
  std::int64_t published_ns = 0;       // CLOCK_MONOTONIC at publish
  std::uint32_t awake_vertices = 0;
  std::uint32_t tool_count = 0;
  std::array<PublishedTool, sim::kMaxTools> tools{};
};

class PublishedState {
 public:
  // Sized from the world (allocates; before the sim thread starts). Copies
  // the world's current positions in, so a reader starts from the truth.
  // first_tick: the sim thread's tick number for the world's tick 0.
  PublishedState(const sim::World<float>& world, double rate_hz, std::uint64_t first_tick = 0);
  // Renumbers the ticks before the sim thread starts: the world's tick 0 is
  // `first_tick` (a scene swapped in continues the timeline; built ahead,
  // off the io thread, before that tick is known).
  void start_at(std::uint64_t first_tick);
  PublishedState(const PublishedState&) = delete;
  PublishedState& operator=(const PublishedState&) = delete;

  // Sim thread, once per tick after World::step: the changed blocks and the
  // header. No allocation, no lock, no wait.
  void publish(std::uint64_t tick, const sim::World<float>& world, std::span<const sim::Tool> tools,
               std::int64_t now_ns);

  struct BodyLayout {
    std::uint32_t n = 0;
    std::uint32_t blocks = 0;
    std::vector<std::uint32_t> to_original;   // internal → file order
  };
  std::size_t body_count() const { return bodies_.size(); }
  const BodyLayout& layout(std::size_t b) const { return bodies_[b].layout; }
  double rate_hz() const { return rate_hz_; }

 private:
  friend class PublishedReader;
  struct alignas(64) BlockSeq {
    std::atomic<std::uint64_t> seq{0};
  };
  struct Body {
    BodyLayout layout;
    std::unique_ptr<std::atomic<std::uint32_t>[]> xyz;  // float bits, 3 per vertex, internal order
    std::unique_ptr<BlockSeq[]> seq;                    // per block
  };
  void write_block(Body& b, const sim::Body<float>& body, std::uint32_t block);

  std::vector<Body> bodies_;
  concurrency::Seqlock<PublishedHeader> header_;
  double rate_hz_;
};

// The io thread's view: a consistent copy of the latest published positions
// in the file's vertex order, plus a change serial per block so viewers can
// find what changed since they last looked.
class PublishedReader {
 public:
  explicit PublishedReader(const PublishedState& state);

  // Copies in every block whose sequence moved (torn ones are retried on the
  // next call). Returns the header that all copied data is at least as new as.
  const PublishedHeader& sync();

  const PublishedHeader& header() const { return header_; }
  std::size_t body_count() const { return bodies_.size(); }
  std::uint32_t vertices(std::size_t b) const { return state_.layout(b).n; }
  std::uint32_t blocks(std::size_t b) const { return state_.layout(b).blocks; }
  // File order, x,y,z per vertex.
  std::span<const float> positions(std::size_t b) const { return bodies_[b].positions; }
  // Serial of the sync() that last changed this block (0: the initial copy).
  std::uint64_t block_serial(std::size_t b, std::uint32_t block) const { return bodies_[b].serial[block]; }
  std::uint64_t serial() const { return serial_; }
  // File-order indices of the vertices in a block.
  std::span<const std::uint32_t> block_vertices(std::size_t b, std::uint32_t block) const;
  // Bounds of the current positions of a body: recomputed when asked after a
  // change (a frame or keyframe), not on every sync — the pump syncs far more
  // often than viewers take frames, and a rescan walks the whole body.
  const std::array<float, 6>& bounds(std::size_t b) const;
  std::uint64_t torn_retries() const { return torn_; }

 private:
  struct Body {
    std::vector<float> positions;
    std::vector<std::uint64_t> seen;    // block sequence copied last
    std::vector<std::uint64_t> serial;  // sync() serial of its last change
    mutable std::array<float, 6> bounds{};
    mutable bool bounds_stale = true;
    std::vector<float> scratch;         // one block
  };
  const PublishedState& state_;
  std::vector<Body> bodies_;
  PublishedHeader header_{};
  std::uint64_t serial_ = 0;
  std::uint64_t torn_ = 0;
};

}  // namespace sculpt::server
