#include "keeper/pad_history.hpp"

#include "log/log.hpp"

namespace sculpt::daemon {

void PadHistory::poll(const void* counter, std::uint32_t undo, std::uint32_t redo, bool paused, Keeper& keeper,
                      kj::TaskSet& tasks) {
  if (counter != counter_) {
    counter_ = counter;
    undo_seen_ = undo;
    redo_seen_ = redo;
    return;
  }
  if (undo != undo_seen_) move(true, undo - undo_seen_, paused, keeper, tasks);
  if (redo != redo_seen_) move(false, redo - redo_seen_, paused, keeper, tasks);
  undo_seen_ = undo;
  redo_seen_ = redo;
}

void PadHistory::move(bool undo, std::uint32_t count, bool paused, Keeper& keeper, kj::TaskSet& tasks) {
  const char* what = undo ? "undo" : "redo";
  if (paused) {
    log::info("{} (pad): the sculpt is paused; resume first", what);
    return;
  }
  tasks.add((undo ? keeper.undo(count) : keeper.redo(count)).then([what](HistoryMoveResult r) {
    if (!r.error.empty()) log::info("{} (pad): {}", what, r.error);
    else log::info("{} (pad): {} stroke{} at tick {}", what, r.done, r.done == 1 ? "" : "s", r.tick);
  }));
}

}  // namespace sculpt::daemon
