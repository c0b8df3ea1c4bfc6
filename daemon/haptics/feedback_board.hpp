// The sim thread → haptics thread handoff: per tool the latest contact
// force, written every tick without waiting, read by the paced haptics thread.
//
//   FeedbackBoard board(tools);                      // setup (allocates)
//   board.publish(t, world.feedback()[t]);           // sim thread, every tick: no allocation, no locks
//   ToolForce f = board.read(t);                     // haptics thread, whenever it likes
//
// Onsets are counted (monotonic), so a contact that begins and ends between two
// haptics polls still gives its rumble kick.
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "concurrency/seqlock.hpp"
#include "sim/tool.hpp"

namespace sculpt::haptics {

struct ToolForce {
  std::array<double, 3> force{};   // N, reaction of the meshes on the tool (sim axes)
  std::uint32_t contacts = 0;
  std::uint64_t onsets = 0;        // contact onsets so far (monotonic)
  double last_onset_impulse = 0;   // N·s of the latest onset
  std::uint64_t ticks = 0;         // publishes so far (tells a fresh value from a stale one)
};

class FeedbackBoard {
 public:
  explicit FeedbackBoard(int tools);
  FeedbackBoard(const FeedbackBoard&) = delete;
  FeedbackBoard& operator=(const FeedbackBoard&) = delete;

  int tools() const { return tools_; }

  // Sim thread (single writer). Out-of-range tools are ignored. Allocation-free.
  void publish(int tool, const sim::ToolFeedback& feedback);
  // A tool that is gone (device unplugged, tool inactive): zero force, onsets kept.
  void clear(int tool);

  // Any thread. Out-of-range tools read as zero.
  ToolForce read(int tool) const;

 private:
  struct Cell {
    concurrency::Seqlock<ToolForce> value;
    ToolForce writer_copy;  // the sim thread's own copy: counters continue from it
  };
  int tools_;
  std::unique_ptr<Cell[]> cells_;
};

}  // namespace sculpt::haptics
