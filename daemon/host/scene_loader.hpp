// Scene loads off the io loop: a load (or a reset) builds the new
// simulation on the worker thread while the io loop serves clients and
// feeds the watchdog, then hands it to the io thread to swap in; what the
// swap replaced is freed on the disposer thread (a big world takes a while
// to free, longer still under ASan's quarantine). One load at a time.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <kj/async.h>

#include "haptics/feedback_board.hpp"
#include "host/simulation.hpp"
#include "host/worker.hpp"
#include "scene/scene.hpp"

namespace sculpt::daemon {

// The scene's own warnings and its meshes', one log line each.
void log_scene_warnings(const scene::Scene& s);
std::size_t vertices_of(const scene::Scene& s);
// Its meshes' names, in body order.
std::vector<std::string> mesh_names(const scene::Scene& s);

class SceneLoader {
 public:
  // Swaps a built simulation in, on the io thread.
  using SwapIn = std::function<void(Simulation next, const char* what)>;
  // Resolves once the running sim thread has stopped, without blocking the io loop.
  using StopSim = std::function<kj::Promise<void>()>;

  // `tasks` keeps the workers' promises; `stopping` turns a finished build
  // away. Both outlive the loader.
  SceneLoader(kj::TaskSet& tasks, const bool& stopping, haptics::FeedbackBoard& board, StopSim stop_sim,
              SwapIn swap_in)
      : tasks_(tasks),
        stopping_(stopping),
        board_(board),
        stop_sim_(std::move(stop_sim)),
        swap_in_(std::move(swap_in)) {}

  // Builds a copy of each scene for the keeper's replica too (Simulation::replica_scene).
  void set_copies_for_replica(bool on) { copies_for_replica_ = on; }

  // Builds read()'s scene with `settings` on the worker, then swaps it in.
  // Resolves to "" or the error (the running sculpt is then untouched). The
  // build goes on when the caller goes away (a client disconnecting).
  kj::Promise<std::string> load(std::function<SceneSource()> read, simloop::SimulationSettings settings, const char* what);

  // Frees `parts` on the disposer thread: at once, or after what it is
  // freeing now (back-to-back loads queue up; the io loop frees nothing).
  template <class Parts>
  void dispose(Parts parts) {
    unfreed_.push_back(std::make_shared<Parts>(std::move(parts)));
    free_unfreed();
  }

 private:
  kj::TaskSet& tasks_;
  const bool& stopping_;
  haptics::FeedbackBoard& board_;
  void free_unfreed();

  StopSim stop_sim_;
  bool loading_ = false;  // a load runs, from its request to its swap
  bool copies_for_replica_ = false;
  SwapIn swap_in_;
  std::vector<std::shared_ptr<void>> unfreed_;  // replaced, waiting for the disposer
  Worker worker_;    // builds
  Worker disposer_;  // frees what a swap replaced
};

}  // namespace sculpt::daemon
