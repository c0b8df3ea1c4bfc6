#include "keeper/replica.hpp"

#include <fmt/format.h>

#include "simloop/scene_tools.hpp"
#include "scene/scene_world.hpp"
#include "sim/state_bytes.hpp"

namespace sculpt::daemon {

// The world's strokes, in global ticks, to the history.
class Replica::Sink final : public sim::StrokeSink {
 public:
  Sink(Replica& r) : r_(r) {}
  void opened(std::uint32_t body, std::uint64_t tick) override {
    r_.history_.opened(r_.scene_number_, body, body < r_.mesh_names_.size() ? r_.mesh_names_[body] : "", global(tick));
  }
  void captured(std::uint32_t body, std::uint32_t block, std::span<const std::byte> image) override {
    const sim::Body<float>& b = r_.world_->body(body);
    r_.history_.captured(body, block, b.end_of(block) - b.begin_of(block), image);
  }
  void closed(std::uint32_t body, const sim::StrokeSummary& summary) override {
    sim::StrokeSummary g = summary;
    g.first_tick = global(summary.first_tick);
    g.release_tick = summary.release_tick ? global(summary.release_tick) : 0;
    g.last_tick = global(summary.last_tick);
    r_.history_.closed(body, g);
  }

 private:
  // World tick t (counted from 1) ran at global tick first_tick + t - 1.
  std::uint64_t global(std::uint64_t t) const { return r_.first_tick_ + t - (t > 0 ? 1 : 0); }
  Replica& r_;
};

Replica::Replica(std::shared_ptr<const SceneBundle> bundle, const scene::Scene& scene, std::uint32_t scene_number,
                 std::uint64_t first_tick, History& history)
    : bundle_(std::move(bundle)),
      scene_number_(scene_number),
      first_tick_(first_tick),
      rate_(bundle_->settings.rate_hz.value_or(scene.settings.rate_hz)),
      history_(history),
      world_(scene::build_world(scene, rate_)),
      driver_(simloop::tool_driver(scene, bundle_->settings, rate_)),
      mapper_(driver_.size()),
      tools_(scene.tools.size()),
      sink_(std::make_unique<Sink>(*this)) {
  for (const auto& m : scene.meshes) mesh_names_.push_back(m.name);
  for (auto& t : tools_) t.active = false;
  world_->set_stroke_sink(sink_.get());
}

Replica::~Replica() { world_->set_stroke_sink(nullptr); }

// What the sim thread does in a tick after its inputs (SculptStages::input, SimThread::run_tick).
void Replica::step() {
  driver_.update_from(mapper_.controls(), std::span<sim::Tool>(tools_));
  world_->step(tools_);
}

void Replica::advance_to(std::uint64_t tick) {
  while (next_tick() < tick) step();
}

std::string Replica::apply(const JournalEntry& e) {
  advance_to(e.tick);
  switch (e.kind) {
    case JournalEntry::Kind::message: mapper_.take(e.message, e.tick); return {};
    case JournalEntry::Kind::pause: paused_ = true; return {};
    case JournalEntry::Kind::resume: paused_ = false; return {};
    case JournalEntry::Kind::history_move: break;
    case JournalEntry::Kind::scene:
    case JournalEntry::Kind::reached: return {};
  }
  if (e.refused) return {};
  world_->close_strokes();
  if (e.number == 0) return {};  // the keeper's mark: close the open strokes here
  Stroke* s = history_.find(e.number);
  if (!s) return fmt::format("stroke {} is no longer in the history: its undo or redo at tick {} could not be replayed",
                             e.number, e.tick);
  // The sim thread writes only a stroke of its own scene (it marks any other
  // refused); a journal from a file may say otherwise. (Strokes of this
  // scene read from a store were checked against its world at recovery.)
  if (s->scene != scene_number_)
    return fmt::format("stroke {} is of scene {}, not this one ({}): its undo or redo at tick {} was not replayed",
                       s->number, s->scene, scene_number_, e.tick);
  for (std::size_t i = 0; i < s->blocks.size(); ++i)
    world_->exchange_block_image(s->body, s->blocks[i],
                             std::span<std::byte>(s->images).subspan(i * s->image_bytes, s->image_bytes));
  history_.swapped(*s);
  return {};
}

std::vector<std::byte> Replica::state() const {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  const auto world = world_->state(), driver = driver_.state(), mapper = mapper_.state();
  w.value(first_tick_), w.value(static_cast<std::uint8_t>(paused_));
  w.array(world), w.array(driver), w.array(mapper);
  return out;
}

ReplicaState split_replica_state(std::span<const std::byte> bytes) {
  sim::StateReader r(bytes, /*dry=*/false);
  ReplicaState out;
  std::uint8_t paused = 0;
  r.value(out.first_tick, "replica: first tick"), r.value(paused, "replica: paused");
  out.paused = paused != 0;
  auto part = [&r](const char* what) {
    std::uint64_t n = 0;
    r.value(n, what);
    return r.take(n, what);
  };
  out.world = part("world"), out.driver = part("tool driver"), out.mapper = part("mapper");
  if (!r.done()) throw std::invalid_argument("state: bytes left over after the mapper");
  return out;
}

void Replica::restore_state(std::span<const std::byte> bytes) {
  const ReplicaState parts = split_replica_state(bytes);
  // Driver and mapper into copies first: the world (the likeliest to
  // refuse) checks everything before it changes anything.
  simloop::ToolDriver driver = driver_;
  driver.restore_state(parts.driver);
  input::ControlMapper mapper = mapper_;
  mapper.restore_state(parts.mapper);
  world_->restore_state(parts.world);
  driver_ = std::move(driver);
  mapper_ = mapper;
  first_tick_ = parts.first_tick;
  paused_ = parts.paused;
}

}  // namespace sculpt::daemon
