// The running simulation and its sim thread, on the io thread: one scene's
// world, stages and published state (host/simulation.hpp) installed at a
// time, the thread that ticks them, and the timeline across scene swaps
// (tick numbers continue, simulated time adds up over the rates of the
// scenes that ran). A thread that could not start is retried by
// restart_if_missing(); meanwhile the tick and pause state it will start
// with stand in for its own.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "simloop/sim_thread.hpp"
#include "host/simulation.hpp"

namespace sculpt::daemon {

// What the sim thread's start reads of the daemon's configuration; none of
// it changes before a restart (main/config_reload.hpp).
struct SimHostSettings {
  bool realtime = false;
  int realtime_priority = 50;
  std::optional<double> wake_early_us;  // unset: kRealtimeWakeEarlyUs with realtime, else 0
  double duration_s = 0.0;              // 0: run until stopped
};

class SimHost {
 public:
  // What a swap took out, for the caller to carry over and free.
  struct Outgoing {
    scene::Scene scene;
    std::unique_ptr<SculptStages> stages;
    std::unique_ptr<server::PublishedState> published;
    std::unique_ptr<sim::World<float>> world;
    std::shared_ptr<const SceneBundle> bundle;
  };

  explicit SimHost(SimHostSettings settings) : cfg_(settings) {}
  ~SimHost() { stop(); }
  SimHost(const SimHost&) = delete;
  SimHost& operator=(const SimHost&) = delete;

  // The first scene, before any thread runs; start() follows. A recovered
  // world continues its timeline: `first_tick` is its origin (SimThreadOptions).
  void install(Simulation first, std::uint64_t first_tick = 0);
  // Starts the thread at `first_tick`. Throws when it cannot be created.
  void start(std::uint64_t first_tick, bool paused);
  // Stops the running thread and puts `next` in its place, its ticks going
  // on from where the old one stopped; the thread is not started here
  // (restart_if_missing() does).
  Outgoing swap(Simulation next);
  // Starts the thread of an installed scene that has none running; logs a
  // failure once per swap.
  void restart_if_missing();
  void stop();
  // A swap's first half, so the io loop never waits on the sim thread: ask
  // it to stop, and swap once stopped() (a thread the host has to wake may
  // sit on a busy machine's run queue for tens of milliseconds). A pause or
  // resume asked meanwhile applies to the thread the swap starts.
  void request_stop();
  bool stopped() const { return !sim_ || sim_->finished(); }
  // Between request_stop() and the swap: a finished thread is not the end of the run.
  bool swapping() const { return stop_requested_; }

  const scene::Scene& scene() const { return scene_; }
  const std::shared_ptr<const SceneBundle>& bundle() const { return bundle_; }
  double rate() const { return rate_; }
  std::size_t tools() const { return tools_; }
  SculptStages& stages() { return *stages_; }
  const sim::World<float>& world() const { return *world_; }
  server::PublishedState& published() { return *published_; }
  // What the server shows of the installed scene, taken once by it.
  server::SceneInfo take_scene_info() { return std::move(scene_info_); }
  std::unique_ptr<server::PublishedReader> take_reader() { return std::move(reader_); }

  // nullptr while no thread runs.
  simloop::SimThread* thread() { return sim_.get(); }
  std::uint64_t current_tick() const { return sim_ ? sim_->ticks() : pending_start_tick_; }
  double simulated_s() const;
  // The running thread's stats (zeros while none runs).
  const simloop::LoopStats& stats() const { return sim_ ? sim_->stats() : idle_stats_; }
  bool paused() const {
    if (stop_requested_ && paused_after_stop_) return *paused_after_stop_;
    return sim_ ? sim_->paused() : pending_start_paused_;
  }
  // "" or why the request could not be made.
  std::string set_paused(bool paused);

 private:
  void take_in(Simulation p, std::uint64_t first_tick);
  simloop::SimThreadOptions thread_options(std::uint64_t first_tick) const;

  const SimHostSettings cfg_;
  scene::Scene scene_;
  std::shared_ptr<const SceneBundle> bundle_;
  double rate_ = 1000.0;
  std::size_t tools_ = 0;
  std::unique_ptr<sim::World<float>> world_;
  std::unique_ptr<SculptStages> stages_;
  std::unique_ptr<server::PublishedState> published_;
  server::SceneInfo scene_info_;
  std::unique_ptr<server::PublishedReader> reader_;
  std::unique_ptr<simloop::SimThread> sim_;   // after world/stages: stopped (destroyed) first
  simloop::LoopStats idle_stats_;
  std::uint64_t pending_start_tick_ = 0;
  bool pending_start_paused_ = false;
  bool stop_requested_ = false;               // request_stop() until the swap
  std::optional<bool> paused_after_stop_;     // set_paused() while stopping
  bool start_failure_logged_ = false;
  // The scenes before this one ran this long; this one from this tick on.
  double simulated_before_s_ = 0;
  std::uint64_t segment_first_tick_ = 0;
};

}  // namespace sculpt::daemon
