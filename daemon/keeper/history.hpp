// The strokes of a sculpt, for undo and redo. A stroke is one working of one
// mesh (sim/strokes.hpp: from a tool's onset near it to its release and rest)
// with the image of every block it changed. Undo and redo are the same
// swap (the world takes the images, the images take what the world had),
// so a stroke's images are its "before" while it is done and its "after"
// while it is undone; undo N then redo N gives back the same bits.
//
// Linear: the undone strokes are always the newest ones (the redo branch);
// a new stroke drops them as soon as it changes a block. Bounded by a memory
// budget and a count (kMaxStrokes): the oldest strokes fall off first. Strokes made on a scene that has since been reloaded stay
// listed but cannot be undone. One thread (the keeper's replica) uses it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sim/strokes.hpp"

namespace sculpt::daemon {

struct Stroke {
  std::uint32_t number = 0;  // from 1, per store
  std::uint32_t scene = 0;   // the keeper's scene number
  std::uint32_t body = 0;
  std::string mesh;          // the body's name in its scene
  sim::StrokeSummary summary;  // global ticks
  std::uint64_t vertices = 0;
  bool undone = false;
  std::vector<std::uint32_t> blocks;
  std::vector<std::byte> images;  // blocks.size() × image_bytes
  std::size_t image_bytes = 0;

  std::uint64_t bytes() const { return images.size() + blocks.size() * sizeof(std::uint32_t) + sizeof(Stroke); }
};

// The most strokes a history keeps, whatever the budget: what listing,
// publishing and saving them costs grows with the count (each has its blob
// in the store), and recovery builds no more than this.
inline constexpr std::size_t kMaxStrokes = 10000;

class History {
 public:
  explicit History(std::uint64_t budget_bytes, std::size_t max_strokes = kMaxStrokes)
      : budget_(budget_bytes), max_strokes_(max_strokes) {}

  // Kept up to date as the replica's world reports its strokes.
  void opened(std::uint32_t scene, std::uint32_t body, std::string_view mesh, std::uint64_t tick);
  void captured(std::uint32_t body, std::uint32_t block, std::uint32_t vertices, std::span<const std::byte> image);
  void closed(std::uint32_t body, const sim::StrokeSummary& summary);

  // The strokes `count` undos (newest done first) or redos (oldest undone
  // first) would swap, or why none can. `scene`: the one running now.
  struct Plan {
    std::vector<Stroke*> strokes;
    std::string error;
  };
  Plan plan_undo(std::uint32_t count, std::uint32_t scene);
  Plan plan_redo(std::uint32_t count, std::uint32_t scene);
  // The stroke's images were swapped with the world's.
  void swapped(Stroke& s);
  Stroke* find(std::uint32_t number);

  const std::deque<Stroke>& strokes() const { return strokes_; }
  std::uint64_t budget() const { return budget_; }
  std::size_t max_strokes() const { return max_strokes_; }
  std::uint64_t used() const { return used_; }
  std::uint64_t dropped() const { return dropped_; }
  bool open(std::uint32_t body) const;
  // Some open stroke has changed a block already (closing it would keep it).
  bool open_changes() const;
  std::uint32_t next_number() const { return next_number_; }

  // For the store: strokes added or swapped since the last take, and the
  // numbers of those gone (budget, redo branch).
  std::vector<std::uint32_t> take_changed();
  std::vector<std::uint32_t> take_gone();
  // For what `history` shows: the numbers of strokes added, swapped or gone
  // since the last take; `all` when every stroke may have changed (restore).
  std::vector<std::uint32_t> take_touched(bool& all);
  // A history read back from a store: its strokes in order, the next number.
  void restore(std::deque<Stroke> strokes, std::uint32_t next_number, std::uint64_t dropped);

 private:
  struct Open {
    std::uint32_t body = 0;
    Stroke stroke;
  };
  Open* open_of(std::uint32_t body);
  void drop_redo_branch();
  void fit_budget();
  void forget(const Stroke& s);

  std::uint64_t budget_;
  std::size_t max_strokes_;
  std::uint64_t used_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint32_t next_number_ = 1;
  std::deque<Stroke> strokes_;
  std::vector<Open> open_;
  std::vector<std::uint32_t> changed_, gone_, touched_;
  bool touched_all_ = true;
};

}  // namespace sculpt::daemon
