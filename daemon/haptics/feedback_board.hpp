// The sim thread → haptics thread handoff: per tool the latest felt contact
// force, written every tick without waiting, read by the paced haptics thread.
//
//   FeedbackBoard board(tools);                      // setup (allocates)
//   board.publish(t, felt);                          // sim thread, every tick: no allocation, no locks
//   board.beat();                                    // sim thread, once per tick: it is alive
//   board.set_hold(Hold::paused);                    // any thread: render nothing until Hold::none
//   ToolForce f = board.read(t);                     // haptics thread, whenever it likes
//
// Onsets are counted (monotonic), so a contact that begins and ends between two
// haptics polls still gives its rumble kick.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>

#include "concurrency/seqlock.hpp"

namespace sculpt::haptics {

// What the sim thread says a tool should feel this tick: the contact
// renderer's output, not the world's raw per-tick reaction.
struct Felt {
  std::array<double, 3> force{};   // N, the force on the tool (sim axes)
  std::uint32_t contacts = 0;      // vertices the tool pushed this tick
  bool touching = false;           // in contact (steady while resting on a surface)
  bool onset = false;              // a new contact began this tick
  double onset_impulse = 0;        // N·s: how hard it began, for a kick
};

struct ToolForce {
  std::array<double, 3> force{};   // N, felt force on the tool (sim axes)
  std::uint32_t contacts = 0;
  bool touching = false;
  std::uint64_t onsets = 0;        // contact onsets so far (monotonic)
  double last_onset_impulse = 0;   // N·s of the latest onset
  std::uint64_t ticks = 0;         // publishes so far (tells a fresh value from a stale one)
};

// Why nothing should be felt now, whatever the tools last said.
enum class Hold : std::uint8_t {
  none,      // render what the tools say
  paused,    // the sculpt is paused: the loop runs no ticks
  swapping,  // a scene is being replaced
  stopped,   // the daemon is stopping
};

class FeedbackBoard {
 public:
  explicit FeedbackBoard(int tools);
  FeedbackBoard(const FeedbackBoard&) = delete;
  FeedbackBoard& operator=(const FeedbackBoard&) = delete;

  int tools() const { return tools_; }

  // Sim thread (single writer). Out-of-range tools are ignored. Allocation-free.
  void publish(int tool, const Felt& felt);
  // A tool that is gone (device unplugged, tool inactive): zero force, onsets kept.
  void clear(int tool);

  // Sim thread, once per tick: the haptics thread takes a beat count that
  // stops moving for a stall.
  void beat() { beats_.fetch_add(1, std::memory_order_release); }
  std::uint64_t beats() const { return beats_.load(std::memory_order_acquire); }

  // Any thread.
  void set_hold(Hold h) { hold_.store(h, std::memory_order_release); }
  Hold hold() const { return hold_.load(std::memory_order_acquire); }

  // Any thread. Out-of-range tools read as zero.
  ToolForce read(int tool) const;

 private:
  struct Cell {
    concurrency::Seqlock<ToolForce> value;
    ToolForce writer_copy;  // the sim thread's own copy: counters continue from it
  };
  int tools_;
  std::unique_ptr<Cell[]> cells_;
  std::atomic<std::uint64_t> beats_{0};
  std::atomic<Hold> hold_{Hold::none};
};

}  // namespace sculpt::haptics
