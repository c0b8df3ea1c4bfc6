// The composition root's class (main/daemon.hpp runs it): builds the
// modules, wires them to each other and to the io loop (signals,
// housekeeping timer, device events), and orders the steps that involve
// several of them: the start, a scene swap, a reload, the shutdown. For
// daemon.cpp (the start, a scene swap, the shutdown) and housekeeping.cpp
// (the io loop's timer and signals, a reload) only.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include <kj/async-io.h>
#include <kj/async-unix.h>

#include "devices/device_hub.hpp"
#include "devices/input_source.hpp"
#include "haptics/feedback_board.hpp"
#include "haptics/haptics_thread.hpp"
#include "host/scene_loader.hpp"
#include "host/sim_host.hpp"
#include "keeper/journal.hpp"
#include "keeper/keeper.hpp"
#include "keeper/pad_history.hpp"
#include "main/blowup_log.hpp"
#include "main/config_reload.hpp"
#include "main/control_desk.hpp"
#include "main/daemon.hpp"
#include "main/room_settings.hpp"
#include "main/sleep_watch.hpp"
#include "main/watchdog.hpp"
#include "server/listener.hpp"
#include "server/server.hpp"

namespace sculpt::daemon {

class Daemon final : public kj::TaskSet::ErrorHandler {
 public:
  Daemon(RunOptions opts, kj::AsyncIoContext& io)
      : opts_(std::move(opts)),
        cfg_(opts_.config),
        io_(io),
        sims_(sim_host_settings(cfg_)),
        hub_(cfg_.input_clock == InputClock::device, cfg_.input_delay_ms, [this] { return sims_.current_tick(); }),
        desk_(sims_, hub_, [this](std::function<SceneSource()> read, const char* what) {
          return loader_->load(std::move(read), simulation_settings(cfg_), what);
        }) {}
  ~Daemon() noexcept {
    stop_threads();
    keeper_.reset();
    std::error_code ec;
    if (!memory_store_.empty()) std::filesystem::remove_all(memory_store_, ec);
  }

  int run();

 private:
  void taskFailed(kj::Exception&& e) override;

  void setup();

  struct StartPoint {
    std::uint64_t tick = 0;
    bool paused = false;
  };

  // The keeper and its store, when the config wants one (keeper/store_place.hpp).
  void open_store();

  // The sculpt the store holds, recovered, or the configured scene anew.
  StartPoint install_first_scene();

  // Listening before READY=1, so a client started after the daemon is
  // ready always finds the socket.
  void start_server();

  // Replaces the running simulation with `next`, already built (a loaded
  // scene, or the current one again for reset): the sim thread stops, the
  // new world takes over the tick count, the queued inputs and the attached
  // devices, viewers get a new keyframe. Nothing of this can fail but the
  // new thread's start, which is retried (SimHost::restart_if_missing).
  void swap_in(Simulation next, const char* what);

  // Polled: the sim thread leaves its loop within a tick once it runs.
  kj::Promise<void> until_sim_stopped();

  kj::Promise<void> watch_signal(int sig);

  kj::Promise<void> housekeeping();

  void housekeep();

  // READY promises a ticking loop (docs/daemon.md): sent at the first
  // housekeeping after the sim thread's first wake. One that never ticks
  // fails the start through systemd's TimeoutStartSec.
  void announce_ready_once();

  // A sim thread that could not start yet counts as stalled: its heartbeats
  // do not move, so systemd restarts the service if it never does.
  void feed_watchdog(std::chrono::steady_clock::time_point now);

  std::string status_line();

  // SIGHUP's new configuration, read and with the flags on top: the
  // mapping, log level, haptics, watchdog and input delay apply now (live
  // devices are bound again), the rest at the next start.
  void apply_config(DaemonConfig next);

  void request_stop(int status);

  void stop_threads();

  int shutdown(int status);

  RunOptions opts_;
  DaemonConfig& cfg_;
  kj::AsyncIoContext& io_;
  kj::Own<kj::PromiseFulfiller<int>> exit_;

  std::unique_ptr<haptics::FeedbackBoard> board_;  // read by the sim, haptics and worker threads: outlives them
  SimHost sims_;
  DeviceHub hub_;
  ControlDesk desk_;
  std::unique_ptr<haptics::HapticsThread> haptics_;
  std::unique_ptr<SleepWatch> sleep_;  // after haptics_: destroyed first
  std::unique_ptr<InputSource> input_;  // after hub_, its devices' listener: destroyed first
  BlowupLog blowups_;
  std::unique_ptr<JournalTap> tap_;
  std::unique_ptr<Keeper> keeper_;           // none: no store
  std::filesystem::path memory_store_;       // the store's directory in memory, when the state directory failed
  PadHistory pad_history_;
  std::unique_ptr<server::Server> server_;
  std::unique_ptr<server::ListenSocket> listen_;
  std::string socket_path_;
  std::unique_ptr<Watchdog> watchdog_;
  std::unique_ptr<SceneLoader> loader_;
  std::unique_ptr<ConfigReload> reload_;
  std::chrono::steady_clock::time_point next_status_{}, started_{};
  bool ready_sent_ = false;  // READY and "sculptd ready" go out once, after the first tick
  bool at_rest_ = true;
  bool stopping_ = false;
  kj::Own<kj::TaskSet> tasks_;  // last: its promises use everything above
};

}  // namespace sculpt::daemon
