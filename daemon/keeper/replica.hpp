// A second copy of the running world, off the real-time thread: built from
// the same scene bundle and fed the journal (keeper/journal.hpp), it goes
// through the same ticks and ends up with the same bits, later. It is what
// the keeper snapshots (the sim thread never copies its world), what
// records the strokes for undo (its world's strokes go to the History), and
// what recovery replays the journal on.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "input/control_mapper.hpp"
#include "simloop/tool_driver.hpp"
#include "keeper/history.hpp"
#include "keeper/journal.hpp"
#include "keeper/scene_bundle.hpp"
#include "sim/strokes.hpp"
#include "sim/world.hpp"

namespace sculpt::daemon {

// Replica::state() in its parts.
struct ReplicaState {
  std::uint64_t first_tick = 0;
  bool paused = false;
  std::span<const std::byte> world, driver, mapper;
};
// Throws std::invalid_argument naming what is wrong.
ReplicaState split_replica_state(std::span<const std::byte> bytes);

class Replica {
 public:
  // `first_tick`: the global tick the world's first step runs at (the
  // sim thread's SimThreadOptions::first_tick). Throws what building throws.
  Replica(std::shared_ptr<const SceneBundle> bundle, const scene::Scene& scene, std::uint32_t scene_number,
          std::uint64_t first_tick, History& history);
  ~Replica();
  Replica(const Replica&) = delete;
  Replica& operator=(const Replica&) = delete;

  // The global tick the world steps next.
  std::uint64_t next_tick() const { return first_tick_ + world_->tick(); }
  // Steps every tick before `tick`.
  void advance_to(std::uint64_t tick);
  // A journal entry of this scene, at a tick >= next_tick() (the ticks
  // before it are stepped first). A history move exchanges stroke `e.number`'s images;
  // returns "" or what could not be done (the stroke is gone).
  std::string apply(const JournalEntry& e);
  bool paused() const { return paused_; }

  // The world, the driver and the mapper as bytes (allocates), and back
  // onto a replica built from the same bundle; restore throws
  // std::invalid_argument naming what does not match.
  std::vector<std::byte> state() const;
  void restore_state(std::span<const std::byte> bytes);

  const sim::World<float>& world() const { return *world_; }
  sim::World<float>& world() { return *world_; }
  const std::shared_ptr<const SceneBundle>& bundle() const { return bundle_; }
  std::uint32_t scene_number() const { return scene_number_; }
  std::uint64_t first_tick() const { return first_tick_; }
  const simloop::ToolDriver& driver() const { return driver_; }
  const input::ControlMapper& mapper() const { return mapper_; }
  double rate() const { return rate_; }

 private:
  class Sink;
  void step();

  std::shared_ptr<const SceneBundle> bundle_;
  std::uint32_t scene_number_;
  std::uint64_t first_tick_;
  double rate_;
  History& history_;
  std::unique_ptr<sim::World<float>> world_;
  simloop::ToolDriver driver_;
  input::ControlMapper mapper_;
  std::vector<sim::Tool> tools_;
  std::unique_ptr<Sink> sink_;
  std::vector<std::string> mesh_names_;  // in body order
  bool paused_ = false;
};

}  // namespace sculpt::daemon
