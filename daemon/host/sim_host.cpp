#include "host/sim_host.hpp"

#include <algorithm>
#include <cmath>

#include "log/log.hpp"

namespace sculpt::daemon {
namespace {

constexpr double kRealtimeWakeEarlyUs = 100.0;  // wake_early_us's default with --realtime (docs/daemon.md)

}  // namespace

void SimHost::install(Simulation first, std::uint64_t first_tick) {
  take_in(std::move(first), first_tick);
  pending_start_tick_ = first_tick;
  segment_first_tick_ = first_tick;
}

void SimHost::take_in(Simulation p, std::uint64_t first_tick) {
  scene_ = std::move(p.scene);
  bundle_ = std::move(p.bundle);
  rate_ = p.rate;
  tools_ = p.tools;
  world_ = std::move(p.world);
  stages_ = std::move(p.stages);
  scene_info_ = std::move(p.info);
  reader_ = std::move(p.reader);
  published_ = std::move(p.published);
  published_->start_at(first_tick);
}

simloop::SimThreadOptions SimHost::thread_options(std::uint64_t first_tick) const {
  simloop::SimThreadOptions so;
  so.rate_hz = rate_;
  so.realtime = cfg_.realtime;
  so.realtime_priority = cfg_.realtime_priority;
  // A SCHED_FIFO thread spinning to its deadline holds its CPU when the
  // deadline comes; without --realtime, spinning buys little. At most half
  // the period (a high --rate shrinks it below the configured value).
  // The default spins only on SCHED_FIFO; a configured value always does.
  const double early_us = cfg_.wake_early_us.value_or(cfg_.realtime ? kRealtimeWakeEarlyUs : 0.0);
  so.wake_early_ns = std::min<std::int64_t>(std::llround(early_us * 1e3), simloop::max_wake_early_ns(rate_));
  so.wake_early_needs_fifo = !cfg_.wake_early_us.has_value();
  so.first_tick = first_tick;
  // --duration counts simulated seconds across scene swaps (the rate may change).
  if (cfg_.duration_s > 0)
    so.max_ticks = first_tick + static_cast<std::uint64_t>(
                                    std::llround(std::max(0.0, cfg_.duration_s - simulated_before_s_) * rate_));
  return so;
}

void SimHost::start(std::uint64_t first_tick, bool paused) {
  auto sim = std::make_unique<simloop::SimThread>(*world_, *stages_, tools_, thread_options(first_tick));
  if (paused) sim->request_pause(true);
  const simloop::RealtimeResult rt = sim->start();
  sim_ = std::move(sim);
  for (const auto& w : rt.warnings) log::warning("{}", w);
  if (cfg_.realtime && rt.fifo)
    log::info("sim thread: SCHED_FIFO priority {}{}", cfg_.realtime_priority, rt.locked ? ", memory locked" : "");
}

void SimHost::restart_if_missing() {
  if (sim_) return;
  try {
    start(pending_start_tick_, pending_start_paused_);
    log::notice("sim thread started at tick {}", pending_start_tick_);
  } catch (const std::exception& e) {
    if (!start_failure_logged_) log::err("cannot start the sim thread: {}; retrying", e.what());
    start_failure_logged_ = true;
  }
}

void SimHost::request_stop() {
  if (sim_) sim_->request_stop();
  stop_requested_ = sim_ != nullptr;
}

SimHost::Outgoing SimHost::swap(Simulation next) {
  const bool was_paused = paused_after_stop_.value_or(paused());
  stop_requested_ = false;
  paused_after_stop_.reset();
  if (sim_) sim_->stop();
  const std::uint64_t tick = current_tick();
  sim_.reset();
  Outgoing old{std::move(scene_), std::move(stages_), std::move(published_), std::move(world_), std::move(bundle_)};
  simulated_before_s_ += static_cast<double>(tick - segment_first_tick_) / rate_;
  segment_first_tick_ = tick;
  take_in(std::move(next), tick);  // the new published state continues from the tick the old one reached
  pending_start_tick_ = tick;
  pending_start_paused_ = was_paused;
  start_failure_logged_ = false;
  return old;
}

void SimHost::stop() {
  if (sim_) sim_->stop();
}

double SimHost::simulated_s() const {
  return simulated_before_s_ + static_cast<double>(current_tick() - segment_first_tick_) / rate_;
}

std::string SimHost::set_paused(bool paused) {
  if (!sim_) return "the sim thread is not running (it could not be started; see the log)";
  if (stop_requested_) {  // a scene is being swapped in: its thread starts this way
    paused_after_stop_ = paused;
    log::info("{}", paused ? "paused" : "resumed");
    return {};
  }
  if (!sim_->request_pause(paused)) return "the sim thread's command ring is full; try again";
  log::info("{}", paused ? "paused" : "resumed");
  return {};
}

}  // namespace sculpt::daemon
