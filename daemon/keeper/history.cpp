#include "keeper/history.hpp"

#include <algorithm>
#include <utility>

#include <fmt/format.h>

namespace sculpt::daemon {

History::Open* History::open_of(std::uint32_t body) {
  for (Open& o : open_)
    if (o.body == body) return &o;
  return nullptr;
}

bool History::open(std::uint32_t body) const {
  return std::any_of(open_.begin(), open_.end(), [body](const Open& o) { return o.body == body; });
}

bool History::open_changes() const {
  return std::any_of(open_.begin(), open_.end(), [](const Open& o) { return !o.stroke.blocks.empty(); });
}

void History::opened(std::uint32_t scene, std::uint32_t body, std::string_view mesh, std::uint64_t tick) {
  Open o;
  o.body = body;
  o.stroke.scene = scene;
  o.stroke.body = body;
  o.stroke.mesh = mesh;
  o.stroke.summary.first_tick = tick;
  if (Open* was = open_of(body)) *was = std::move(o);  // the world closes before it opens again
  else open_.push_back(std::move(o));
}

void History::captured(std::uint32_t body, std::uint32_t block, std::uint32_t vertices,
                       std::span<const std::byte> image) {
  Open* o = open_of(body);
  if (!o) return;
  Stroke& s = o->stroke;
  // A stroke that changes something is new work: what was undone cannot be redone on top of it.
  if (s.blocks.empty()) drop_redo_branch();
  s.image_bytes = image.size();
  s.blocks.push_back(block);
  s.images.insert(s.images.end(), image.begin(), image.end());
  s.vertices += vertices;
}

void History::closed(std::uint32_t body, const sim::StrokeSummary& summary) {
  Open* o = open_of(body);
  if (!o) return;
  Stroke s = std::move(o->stroke);
  open_.erase(open_.begin() + (o - open_.data()));
  if (s.blocks.empty()) return;  // a tool passed near and changed nothing
  s.summary = summary;
  s.number = next_number_++;
  used_ += s.bytes();
  changed_.push_back(s.number);
  touched_.push_back(s.number);
  strokes_.push_back(std::move(s));
  fit_budget();
}

void History::forget(const Stroke& s) {
  used_ -= s.bytes();
  gone_.push_back(s.number);
  touched_.push_back(s.number);
  changed_.erase(std::remove(changed_.begin(), changed_.end(), s.number), changed_.end());
}

void History::drop_redo_branch() {
  while (!strokes_.empty() && strokes_.back().undone) {
    forget(strokes_.back());
    strokes_.pop_back();
  }
}

void History::fit_budget() {
  while ((used_ > budget_ || strokes_.size() > max_strokes_) && !strokes_.empty()) {
    forget(strokes_.front());
    strokes_.pop_front();
    ++dropped_;
  }
}

History::Plan History::plan_undo(std::uint32_t count, std::uint32_t scene) {
  Plan p;
  auto it = std::find_if(strokes_.rbegin(), strokes_.rend(), [](const Stroke& s) { return !s.undone; });
  for (; it != strokes_.rend() && p.strokes.size() < count; ++it) {
    if (it->scene != scene) {
      if (p.strokes.empty())
        p.error = fmt::format("stroke {} was made before the scene was reloaded: undo stops at the reload",
                              it->number);
      break;
    }
    p.strokes.push_back(&*it);
  }
  if (p.strokes.empty() && p.error.empty()) p.error = "nothing to undo";
  return p;
}

History::Plan History::plan_redo(std::uint32_t count, std::uint32_t scene) {
  Plan p;
  auto it = std::find_if(strokes_.begin(), strokes_.end(), [](const Stroke& s) { return s.undone; });
  for (; it != strokes_.end() && p.strokes.size() < count; ++it) {
    if (it->scene != scene) {
      if (p.strokes.empty())
        p.error = fmt::format("stroke {} was made before the scene was reloaded: redo stops at the reload",
                              it->number);
      break;
    }
    p.strokes.push_back(&*it);
  }
  if (p.strokes.empty() && p.error.empty()) p.error = "nothing to redo";
  return p;
}

void History::swapped(Stroke& s) {
  s.undone = !s.undone;
  touched_.push_back(s.number);
  if (std::find(changed_.begin(), changed_.end(), s.number) == changed_.end()) changed_.push_back(s.number);
}

Stroke* History::find(std::uint32_t number) {
  for (Stroke& s : strokes_)
    if (s.number == number) return &s;
  return nullptr;
}

std::vector<std::uint32_t> History::take_changed() { return std::exchange(changed_, {}); }
std::vector<std::uint32_t> History::take_gone() { return std::exchange(gone_, {}); }

std::vector<std::uint32_t> History::take_touched(bool& all) {
  all = std::exchange(touched_all_, false);
  return std::exchange(touched_, {});
}

void History::restore(std::deque<Stroke> strokes, std::uint32_t next_number, std::uint64_t dropped) {
  strokes_ = std::move(strokes);
  open_.clear();
  changed_.clear();
  gone_.clear();
  touched_.clear();
  touched_all_ = true;
  used_ = 0;
  for (const Stroke& s : strokes_) used_ += s.bytes();
  next_number_ = next_number;
  dropped_ = dropped;
  fit_budget();
}

}  // namespace sculpt::daemon
