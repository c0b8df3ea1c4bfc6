#include "haptics/feedback_board.hpp"

namespace sculpt::haptics {

FeedbackBoard::FeedbackBoard(int tools)
    : tools_(tools < 0 ? 0 : tools), cells_(std::make_unique<Cell[]>(static_cast<std::size_t>(tools_))) {}

void FeedbackBoard::publish(int tool, const Felt& felt) {
  if (tool < 0 || tool >= tools_) return;
  Cell& s = cells_[static_cast<std::size_t>(tool)];
  ToolForce& w = s.writer_copy;
  w.force = felt.force;
  w.contacts = felt.contacts;
  w.touching = felt.touching;
  if (felt.onset) {
    ++w.onsets;
    w.last_onset_impulse = felt.onset_impulse;
  }
  ++w.ticks;
  s.value.store(w);
}

void FeedbackBoard::clear(int tool) {
  if (tool < 0 || tool >= tools_) return;
  Cell& s = cells_[static_cast<std::size_t>(tool)];
  s.writer_copy.force = {};
  s.writer_copy.contacts = 0;
  s.writer_copy.touching = false;
  ++s.writer_copy.ticks;
  s.value.store(s.writer_copy);
}

ToolForce FeedbackBoard::read(int tool) const {
  if (tool < 0 || tool >= tools_) return {};
  return cells_[static_cast<std::size_t>(tool)].value.load();
}

}  // namespace sculpt::haptics
