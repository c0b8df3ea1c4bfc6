// The composition root on the io loop: the housekeeping timer (the
// duration, the replay pump, READY, the watchdog, the status line, the
// pads' undo and redo), the signals, a reload (main/daemon_root.hpp).
#include <chrono>
#include <csignal>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include <kj/async-io.h>
#include <kj/async-unix.h>
#include <kj/debug.h>
#include <kj/timer.h>

#include "main/daemon_root.hpp"
#include "client/socket_path.hpp"
#include "input/mapping.hpp"
#include "keeper/scene_bundle.hpp"
#include "keeper/store_place.hpp"
#include "log/log.hpp"
#include "main/notify.hpp"
#include "main/run_report.hpp"
#include "simloop/compaction.hpp"
#include "simloop/preemption.hpp"

namespace sculpt::daemon {
namespace {

constexpr auto kHousekeeping = 20 * kj::MILLISECONDS;  // duration check, replay pump, watchdog
constexpr std::chrono::seconds kStatusEvery{5};

}  // namespace

void Daemon::taskFailed(kj::Exception&& e) {
  log::err("io loop: {}", e.getDescription().cStr());
  request_stop(1);
}

// Polled: the sim thread leaves its loop within a tick once it runs.
kj::Promise<void> Daemon::until_sim_stopped() {
  if (sims_.stopped()) return kj::READY_NOW;
  return io_.provider->getTimer().afterDelay(1 * kj::MILLISECONDS).then([this] { return until_sim_stopped(); });
}

kj::Promise<void> Daemon::watch_signal(int sig) {
  return io_.unixEventPort.onSignal(sig).then([this, sig](siginfo_t) -> kj::Promise<void> {
    if (sig == SIGHUP) {
      reload_->request();
    } else {
      log::notice("{}: stopping", sig == SIGTERM ? "SIGTERM" : "SIGINT");
      request_stop(0);
    }
    return watch_signal(sig);
  });
}

kj::Promise<void> Daemon::housekeeping() {
  return io_.provider->getTimer().afterDelay(kHousekeeping).then([this]() -> kj::Promise<void> {
    if (stopping_) return kj::READY_NOW;
    housekeep();
    return housekeeping();
  });
}

void Daemon::housekeep() {
  const auto now = std::chrono::steady_clock::now();
  sims_.restart_if_missing();
  if (const std::string line = blowups_.check(sims_.stats(), sims_.current_tick(), now); !line.empty())
    log::warning("{}", line);
  feed_watchdog(now);
  hub_.log_held_tunes(now);
  const simloop::SimThread* sim = sims_.thread();
  if (!sim) return;
  announce_ready_once();
  if (sim->finished() && !sims_.swapping()) {
    log::info("duration reached: {} ticks", sim->ticks());
    request_stop(0);
    return;
  }
  input_->pump(sims_.stages().ring());
  if (keeper_) {
    const SculptStages& stages = sims_.stages();
    pad_history_.poll(&stages, stages.undo_presses(), stages.redo_presses(), sims_.paused(), *keeper_, *tasks_);
  }
  // A fact tests (and people reading debug logs) can wait for: nothing
  // moves any more, so the meshes stay bit-identical from here on.
  const bool at_rest = sim->stats().vertices_awake.load(std::memory_order_relaxed) == 0;
  if (at_rest && !at_rest_) log::debug("all meshes at rest (tick {})", sim->ticks());
  at_rest_ = at_rest;
  if (now >= next_status_) {
    notify::status(status_line());
    next_status_ = now + kStatusEvery;
  }
}

// READY promises a ticking loop (docs/daemon.md): sent at the first
// housekeeping after the sim thread's first wake. One that never ticks
// fails the start through systemd's TimeoutStartSec.
void Daemon::announce_ready_once() {
  if (ready_sent_ || sims_.stats().heartbeats.load(std::memory_order_acquire) == 0) return;
  ready_sent_ = true;
  notify::ready(status_line());
  log::notice("sculptd ready: {} Hz, input {}, socket {}{}", sims_.rate(), to_string(cfg_.input), socket_path_,
              listen_->activated() ? " (socket activation)" : "");
}

// A sim thread that could not start yet counts as stalled: its heartbeats
// do not move, so systemd restarts the service if it never does.
void Daemon::feed_watchdog(std::chrono::steady_clock::time_point now) {
  switch (watchdog_->check(now, sims_.stats().heartbeats.load(std::memory_order_acquire), cfg_.watchdog_fraction)) {
    case Watchdog::Due::ping: notify::watchdog(); break;
    case Watchdog::Due::stalled:
      log::err("sim thread stalled at tick {}: withholding the watchdog ping", sims_.current_tick());
      break;
    case Watchdog::Due::nothing:
    case Watchdog::Due::still_stalled: break;
  }
}

std::string Daemon::status_line() {
  const simloop::SimThread* sim = sims_.thread();
  return fmt::format("{} ticks, {} overruns, {} devices, {} FF uploads", sim ? sim->ticks() : 0,
                     sim ? sim->stats().overrun_log.total() : 0, desk_.device_count(), desk_.ff_uploads());
}

// SIGHUP's new configuration, read and with the flags on top: the
// mapping, log level, haptics, watchdog and input delay apply now (live
// devices are bound again), the rest at the next start.
void Daemon::apply_config(DaemonConfig next) {
  input::MappingConfig mapping = input::parse_mapping(next.mapping_table, next.file.empty() ? "config" : next.file);
  if (const std::string later = restart_needed(cfg_, next); !later.empty()) log::notice("{}", later);
  hub_.set_mapping(std::move(mapping));
  cfg_.log_level = next.log_level;
  log::set_level(next.log_level);
  cfg_.haptics = next.haptics;
  haptics_->configure(next.haptics);
  cfg_.watchdog_fraction = next.watchdog_fraction;
  cfg_.input_delay_ms = next.input_delay_ms;
  hub_.set_input_delay_ms(next.input_delay_ms);
  cfg_.stats_json = next.stats_json;
  cfg_.hash_out = next.hash_out;
  cfg_.mapping_table = std::move(next.mapping_table);
  if (input_->live()) hub_.rebind(*input_->live());
}

void Daemon::request_stop(int status) {
  if (stopping_) return;
  stopping_ = true;
  exit_->fulfill(kj::cp(status));
}

}  // namespace sculpt::daemon
