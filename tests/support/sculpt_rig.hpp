// A sculpt run by hand, tick by tick, as sculptd's sim thread runs it
// (SimThread::run_tick): a scene bundle (the built-in scene unless given), a
// recording pushed through the input ring, the stages writing the
// journal. The keeper tests and benchmark compare what the keeper and its
// replica make of the journal with it. Header-only; whoever includes it
// links sculpt_daemon.
#pragma once

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "haptics/feedback_board.hpp"
#include "input/mapping.hpp"
#include "input/replay_source.hpp"
#include "simloop/scene_tools.hpp"
#include "keeper/journal.hpp"
#include "keeper/scene_bundle.hpp"
#include "host/simulation.hpp"

namespace sculpt::daemon::testing {

class Rig {
 public:
  // `recording`: a recording to replay from start_at()'s tick ("" : none).
  explicit Rig(JournalTap* tap, const std::string& recording, std::span<const std::byte> state = {},
               std::shared_ptr<SceneBundle> bundle = nullptr)
      : bundle_(bundle ? std::move(bundle)
                       : std::make_shared<SceneBundle>(read_bundle("builtin:default", simloop::SimulationSettings{}))),
        board_(static_cast<int>(sim::kMaxTools)),
        sim_(build_simulation(load_bundle(*bundle_), bundle_->settings, board_, state)),
        router_(simloop::tool_routes(sim_.scene)),
        tools_(sim_.tools) {
    for (auto& t : tools_) t.active = false;
    if (tap) sim_.stages->set_journal(tap, sim_.world.get());
    if (!recording.empty()) {
      replay_ = std::make_unique<input::ReplaySource>(
          recording, sim_.rate,
          [this](std::uint8_t slot, const input::DeviceInfo& info) { return router_.attach(slot, info, mapping_); });
    }
  }

  // The sim thread's next tick is `tick`; the recording starts there.
  void start_at(std::uint64_t tick) {
    next_ = tick;
    if (replay_) replay_->start(tick);
  }
  // One tick, as SimThread::run_tick does it; the hash after it is kept.
  void tick() {
    if (replay_) replay_->pump(sim_.stages->ring(), next_ + 64);
    const auto began = std::chrono::steady_clock::now();
    sim_.stages->input(next_, tools_);
    input_ns_ = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - began).count();
    sim_.world->step(tools_);
    sim_.stages->publish(next_, *sim_.world);
    hashes_[next_] = sim_.world->hash();
    ++next_;
  }
  void run(std::uint64_t ticks) {
    for (std::uint64_t i = 0; i < ticks; ++i) tick();
  }
  // A pause or resume, as SimThread::take_commands tells the stages.
  void pause(bool paused) { sim_.stages->paused_changed(next_, paused); }

  std::uint64_t next_tick() const { return next_; }
  // How long the last tick's input stage took (stroke images are written there).
  double input_ns() const { return input_ns_; }
  std::uint64_t hash_after(std::uint64_t tick) const { return hashes_.at(tick); }
  bool recording_done() const { return !replay_ || replay_->finished(); }
  Simulation& sim() { return sim_; }
  const std::shared_ptr<SceneBundle>& bundle() const { return bundle_; }

 private:
  std::shared_ptr<SceneBundle> bundle_;
  haptics::FeedbackBoard board_;
  Simulation sim_;
  input::MappingConfig mapping_;
  input::ToolRouter router_;
  std::unique_ptr<input::ReplaySource> replay_;
  std::vector<sim::Tool> tools_;
  std::uint64_t next_ = 0;
  double input_ns_ = 0;
  std::map<std::uint64_t, std::uint64_t> hashes_;
};

}  // namespace sculpt::daemon::testing
