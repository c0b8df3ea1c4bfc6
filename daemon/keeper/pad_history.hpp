// Undo and redo buttons on the pads: the sim thread's mapper counts the
// presses (host/sculpt_stages.hpp); the io thread's housekeeping turns new
// presses into history moves here.
#pragma once

#include <cstdint>

#include <kj/async.h>

#include "keeper/keeper.hpp"

namespace sculpt::daemon {

class PadHistory {
 public:
  // The presses counted so far by `counter` (a new one, after a scene swap:
  // counting starts from these, nothing is done). A paused sculpt does none.
  void poll(const void* counter, std::uint32_t undo_presses, std::uint32_t redo_presses, bool paused, Keeper& keeper,
            kj::TaskSet& tasks);

 private:
  void move(bool undo, std::uint32_t count, bool paused, Keeper& keeper, kj::TaskSet& tasks);

  const void* counter_ = nullptr;
  std::uint32_t undo_seen_ = 0, redo_seen_ = 0;
};

}  // namespace sculpt::daemon
