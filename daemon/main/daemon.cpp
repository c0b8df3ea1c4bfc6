#include "main/daemon.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <csignal>
#include <memory>
#include <optional>
#include <utility>

#include <kj/async-io.h>
#include <kj/async-unix.h>
#include <kj/debug.h>
#include <kj/timer.h>

#include "haptics/feedback_board.hpp"
#include "haptics/haptics_thread.hpp"
#include "input/device_manager.hpp"
#include "input/mapping.hpp"
#include "input/device_clock.hpp"
#include "input/replay_feed.hpp"
#include "input/replay_source.hpp"
#include "loop/compaction.hpp"
#include "loop/preemption.hpp"
#include "loop/sim_thread.hpp"
#include "loop/scene_tools.hpp"
#include "loop/stats_json.hpp"
#include "loop/tool_driver.hpp"
#include "main/log.hpp"
#include "main/notify.hpp"
#include "main/blowup_log.hpp"
#include "main/device_events.hpp"
#include "main/device_table.hpp"
#include "main/pipeline.hpp"
#include "main/simulation.hpp"
#include "main/watchdog.hpp"
#include "main/worker.hpp"
#include "client/socket_path.hpp"
#include "scene/atomic_file.hpp"
#include "scene/scene.hpp"
#include "server/listener.hpp"
#include "server/published_state.hpp"
#include "server/server.hpp"
#include "sim/world.hpp"

namespace sculpt::daemon {
namespace {

constexpr std::size_t kRingCapacity = 4096;                 // io → sim messages in flight
// A replay is queued as far ahead as this ring holds (~1 KiB a message; a
// minute and more of a typical session), so an io thread starved for
// seconds on a loaded machine still delivers every frame before its tick:
// a late one would make the run differ from the recording.
constexpr std::size_t kReplayRingCapacity = 16384;
constexpr std::size_t kReplayReadAhead = 4096;  // messages read from the session before the io thread takes them
constexpr double kRealtimeWakeEarlyUs = 100.0;  // wake_early_us's default with --realtime (docs/daemon.md)
constexpr auto kHousekeeping = 20 * kj::MILLISECONDS;       // duration check, replay pump, watchdog
constexpr std::chrono::seconds kStatusEvery{5};

// The tool driver moves tool component i along the scene's axis i, so the
// binding's components are the haptics' axes.
std::vector<haptics::ToolStick> tool_sticks(const input::DeviceBinding& b, std::size_t tools) {
  std::vector<haptics::ToolStick> out;
  for (std::size_t t = 0; t < tools; ++t) {
    if (!b.drives(t)) continue;
    const input::StickPlane p = input::stick_plane(b, t);
    haptics::ToolStick ts;
    ts.tool = static_cast<int>(t);
    if (p.valid) {
      ts.plane.x_axis = p.x_component;
      ts.plane.y_axis = p.y_component;
      ts.plane.x_sign = p.x_scale;
      ts.plane.y_sign = p.y_scale;
    } else {
      ts.plane.x_axis = -1;
      ts.plane.y_axis = -1;
    }
    out.push_back(ts);
  }
  return out;
}


class Daemon final : public input::DeviceListener, public kj::TaskSet::ErrorHandler, public server::DaemonControl {
 public:
  Daemon(RunOptions opts, kj::AsyncIoContext& io) : opts_(std::move(opts)), cfg_(opts_.config), io_(io) {}
  ~Daemon() noexcept override { stop_threads(); }

  int run() {
    auto exit = kj::newPromiseAndFulfiller<int>();
    exit_ = kj::mv(exit.fulfiller);
    try {
      setup();
    } catch (const std::exception& e) {
      log::err("{}", e.what());
      stop_threads();
      return 1;
    }
    const int status = exit.promise.wait(io_.waitScope);
    return shutdown(status);
  }

  // --- input::DeviceListener (io thread) ------------------------------------
  void on_attach(std::uint8_t slot, const input::DeviceInfo& info) override {
    router_.detach(slot);
    const input::DeviceBinding b = router_.attach(slot, info, mapping_);
    for (const auto& w : router_.warnings()) log::warning("{}", w);
    remember_device(slot, info, b);
    clock_.forget(slot);
    push(input::InputMessage::attach(slot, b), "attach");
    log::info("device {}: {} [{}] on slot {}, drives {} tool(s)", info.node.empty() ? "(recorded)" : info.node,
              info.name, input::to_string(info.kind), slot, std::popcount(b.tool_mask));
    if (haptics_ && !info.node.empty()) haptics_->attach(slot, info.node, tool_sticks(b, tools_));
  }
  void on_detach(std::uint8_t slot) override {
    router_.detach(slot);
    device_table_.detached(slot);
    tell_server_devices();
    clock_.forget(slot);
    push(input::InputMessage::detach(slot), "detach");
    if (haptics_) haptics_->detach(slot);
    log::info("device on slot {} is gone", slot);
  }
  void on_frame(const input::InputFrame& frame) override {
    input::InputFrame f = frame;
    if (cfg_.input_clock == InputClock::device) {
      const input::DeviceClock::Placement p = clock_.place(f, current_tick());
      if (p.anchored)
        log::debug("slot {}: device clock anchored: device time {} us applies on tick {}", f.slot, f.device_time_us,
                   p.tick);
      f.at_tick = p.tick;
    }
    push(input::InputMessage::of_frame(f), "frame");
  }
  void on_log(int priority, const std::string& message) override {
    log::write(static_cast<log::Level>(std::clamp(priority, 3, 7)), message);
  }

 private:
  void taskFailed(kj::Exception&& e) override {
    log::err("io loop: {}", e.getDescription().cStr());
    request_stop(1);
  }

  std::uint64_t current_tick() const { return sim_ ? sim_->ticks() : pending_start_tick_; }
  double simulated_s() const {
    return simulated_before_s_ + static_cast<double>(current_tick() - segment_first_tick_) / rate_;
  }
  // The running sim thread's stats (zeros in the moment a swap's new thread
  // could not start yet).
  const loop::LoopStats& loop_stats() const { return sim_ ? sim_->stats() : idle_stats_; }

  void push(const input::InputMessage& m, const char* what) {
    if (stages_->ring().try_push(m)) return;
    // The sim thread drains the ring every tick; a full ring means it is stuck.
    if (dropped_++ % 1000 == 0) log::warning("input ring full: dropped a {} message ({} so far)", what, dropped_);
  }

  void setup() {
    log::set_level(cfg_.log_level);
    // Scene, world, tools. Before the io loop runs (and before READY), so
    // here, once, the scene loads on the io thread.
    board_ = std::make_unique<haptics::FeedbackBoard>(static_cast<int>(input::kMaxTools));
    scene::Scene first = scene::load_scene(cfg_.scene);
    log_scene_warnings(first);
    install(build_simulation(std::move(first), simulation_settings(), *board_), 0);
    blowups_.reset(mesh_names());
    log::info("scene {}: {} meshes, {} vertices, {} tools; {} Hz", scene_.file.string(), scene_.meshes.size(),
              vertices_of(scene_), tools_, rate_);

    // Mapping and haptics.
    mapping_ = input::parse_mapping(cfg_.mapping_table, cfg_.file.empty() ? "config" : cfg_.file);
    router_.set_routes(loop::tool_routes(scene_));
    haptics_ = std::make_unique<haptics::HapticsThread>(*board_, cfg_.haptics);
    haptics_->start();

    // Input.
    if (cfg_.input.kind == InputSpec::Kind::replay) {
      // Every line checked before the first tick (one at a time: bounded
      // memory), so a bad line deep in the file is named now, not mid-run.
      input::check_session(cfg_.input.replay);
      input::ReplaySource source(cfg_.input.replay, rate_, [this](std::uint8_t slot, const input::DeviceInfo& info) {
        return bind_recorded(slot, info);
      });
      source.start(1);
      // The attaches are bound here; the frames are read on the feed's own
      // thread, the first ring's worth before the first tick.
      for (std::size_t d = 0; d < source.header().devices.size(); ++d) push(*source.next(), "attach");
      replay_ = std::make_unique<input::ReplayFeed>(std::move(source), kReplayReadAhead);
      replay_->pump(stages_->ring());
      log::info("input: replaying {} ({} devices)", cfg_.input.replay.string(), replay_->header().devices.size());
    } else {
      input::DeviceManagerOptions o;
      o.discovery = cfg_.input.kind == InputSpec::Kind::evdev ? input::Discovery::inotify : input::Discovery::automatic;
      devices_ = std::make_unique<input::DeviceManager>(*this, o);
      devices_->start();
      device_events_ = std::make_unique<DeviceEvents>(io_.unixEventPort, *devices_);
      log::info("input: live devices ({}), {} attached, clock {}", devices_->discovery(), devices_->attached(),
                cfg_.input_clock == InputClock::device ? "device" : "arrival");
    }

    // The streaming and control server: listening before READY=1, so a
    // client started after the daemon is ready always finds the socket.
    server::ServerOptions sopts;
    sopts.name = fmt::format("sculptd {}", SCULPTD_VERSION);
    sopts.log = [](int priority, const std::string& line) {
      log::write(static_cast<log::Level>(std::clamp(priority, 3, 7)), line);
    };
    server_ = std::make_unique<server::Server>(io_, *this, sopts);
    (void)server_->set_scene(std::move(scene_info_), *published_, std::move(reader_));
    tell_server_devices();
    listen_ = std::make_unique<server::ListenSocket>(server::ListenSocket::open(client::resolve_socket_path(cfg_.socket)));
    socket_path_ = listen_->path();
    server_->listen(listen_->release());

    // The sim thread. READY waits for its first tick (housekeep()).
    start_sim(0, false);
    // Once per process, not at every scene swap: the kernel's settings that
    // hold up a real-time thread.
    if (cfg_.realtime) {
      if (auto w = loop::preemption_warning(loop::current_preemption_model())) log::warning("{}", *w);
      if (auto w = loop::compaction_warning(loop::current_compact_unevictable_allowed())) log::warning("{}", *w);
    }

    // The io loop's tasks.
    tasks_ = kj::heap<kj::TaskSet>(*this);
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) tasks_->add(watch_signal(sig));
    if (device_events_) tasks_->add(device_events_->run());
    watchdog_ = std::make_unique<Watchdog>(notify::watchdog_interval());
    tasks_->add(housekeeping());
    started_ = std::chrono::steady_clock::now();
  }

  // READY promises a ticking loop (docs/daemon.md): sent at the first
  // housekeeping after the sim thread's first wake. One that never ticks
  // fails the start through systemd's TimeoutStartSec.
  void announce_ready_once() {
    if (ready_sent_ || loop_stats().heartbeats.load(std::memory_order_acquire) == 0) return;
    ready_sent_ = true;
    notify::ready(status_line());
    log::notice("sculptd ready: {} Hz, input {}, socket {}{}", rate_, to_string(cfg_.input), socket_path_,
                listen_->activated() ? " (socket activation)" : "");
  }

  // A recorded device's binding to the current scene's tools.
  input::DeviceBinding bind_recorded(std::uint8_t slot, const input::DeviceInfo& info) {
    router_.detach(slot);
    const input::DeviceBinding b = router_.attach(slot, info, mapping_);
    for (const auto& w : router_.warnings()) log::warning("{}", w);
    remember_device(slot, info, b);
    return b;
  }

  std::vector<std::string> mesh_names() const {
    std::vector<std::string> names;
    for (const auto& m : scene_.meshes) names.push_back(m.name);
    return names;
  }

  static std::size_t vertices_of(const scene::Scene& s) {
    std::size_t n = 0;
    for (const auto& m : s.meshes) n += m.loaded.mesh.positions.size();
    return n;
  }

  // The configuration a build of a scene reads, copied for the worker thread.
  SimulationSettings simulation_settings() const {
    SimulationSettings b;
    b.rate_hz = cfg_.rate_hz;
    b.tool_margin = cfg_.tool_margin;
    b.size_step = cfg_.size_step;
    b.min_scale = cfg_.min_scale;
    b.max_scale = cfg_.max_scale;
    b.ring_capacity = cfg_.input.kind == InputSpec::Kind::replay ? kReplayRingCapacity : kRingCapacity;
    return b;
  }

  static void log_scene_warnings(const scene::Scene& s) {
    for (const auto& w : s.warnings) log::warning("scene {}: {}", s.file.string(), w);
    for (const auto& m : s.meshes)
      for (const auto& w : m.loaded.warnings) log::warning("scene {}: mesh {}: {}", s.file.string(), m.name, w);
  }

  // Takes the parts in (no sim thread running; the caller has moved out
  // whatever of the old stages and published state it still needs), with a
  // published state whose ticks go on from first_tick.
  void install(Simulation p, std::uint64_t first_tick) {
    scene_ = std::move(p.scene);
    rate_ = p.rate;
    clock_.set_rate(rate_);
    tools_ = p.tools;
    world_ = std::move(p.world);
    stages_ = std::move(p.stages);
    scene_info_ = std::move(p.info);
    reader_ = std::move(p.reader);
    published_ = std::move(p.published);
    published_->start_at(first_tick);
  }

  void start_sim(std::uint64_t first_tick, bool paused) {
    loop::SimThreadOptions so;
    so.rate_hz = rate_;
    so.realtime = cfg_.realtime;
    so.realtime_priority = cfg_.realtime_priority;
    // A SCHED_FIFO thread spinning to its deadline holds its CPU when the
    // deadline comes; without --realtime, spinning buys little. At most half
    // the period (a high --rate shrinks it below the configured value).
    // The default spins only on SCHED_FIFO; a configured value always does.
    const double early_us = cfg_.wake_early_us.value_or(cfg_.realtime ? kRealtimeWakeEarlyUs : 0.0);
    so.wake_early_ns = std::min<std::int64_t>(std::llround(early_us * 1e3), loop::max_wake_early_ns(rate_));
    so.wake_early_needs_fifo = !cfg_.wake_early_us.has_value();
    so.first_tick = first_tick;
    // --duration counts simulated seconds across scene swaps (the rate may change).
    if (cfg_.duration_s > 0)
      so.max_ticks = first_tick + static_cast<std::uint64_t>(
                                      std::llround(std::max(0.0, cfg_.duration_s - simulated_before_s_) * rate_));
    auto sim = std::make_unique<loop::SimThread>(*world_, *stages_, tools_, so);
    if (paused) sim->request_pause(true);
    const loop::RealtimeResult rt = sim->start();
    sim_ = std::move(sim);
    for (const auto& w : rt.warnings) log::warning("{}", w);
    if (cfg_.realtime && rt.fifo) log::info("sim thread: SCHED_FIFO priority {}{}", cfg_.realtime_priority,
                                            rt.locked ? ", memory locked" : "");
  }

  // After a swap whose new sim thread could not start (no thread could be
  // created): the world is installed, its thread starts as soon as it can.
  void restart_sim_if_missing() {
    if (sim_) return;
    try {
      start_sim(pending_start_tick_, pending_start_paused_);
      log::notice("sim thread started at tick {}", pending_start_tick_);
    } catch (const std::exception& e) {
      if (!start_failure_logged_) log::err("cannot start the sim thread: {}; retrying", e.what());
      start_failure_logged_ = true;
    }
  }

  // Replaces the running simulation with `next`, already built (a loaded
  // scene, or the current one again for reset): the sim thread stops, the
  // new world takes over the tick count, the queued inputs and the attached
  // devices, viewers get a new snapshot. Nothing of this can fail but the
  // new thread's start, which is retried (restart_sim_if_missing).
  void swap_in(Simulation next, const char* what) {
    const auto began = std::chrono::steady_clock::now();
    const bool paused = sim_ ? sim_->paused() : pending_start_paused_;
    if (sim_) sim_->stop();
    const std::uint64_t tick = sim_ ? sim_->ticks() : pending_start_tick_;
    sim_.reset();
    // The old stages hold the queued inputs and the bindings; viewers read
    // the old published state until set_scene() below.
    std::unique_ptr<SculptStages> old = std::move(stages_);
    std::unique_ptr<server::PublishedState> old_published = std::move(published_);
    std::unique_ptr<sim::World<float>> old_world = std::move(world_);
    scene::Scene old_scene = std::move(scene_);
    simulated_before_s_ += static_cast<double>(tick - segment_first_tick_) / rate_;
    segment_first_tick_ = tick;
    install(std::move(next), tick);  // the new published state continues from the tick the old one reached
    // Devices first (as attach messages due now, bound to the new scene's
    // tools, live or recorded alike), then what was queued.
    router_.set_routes(loop::tool_routes(scene_));
    if (devices_) {
      for (const auto& [slot, info] : devices_->devices()) on_attach(slot, info);
    } else {
      const auto& recorded = replay_->header().devices;
      for (std::uint8_t slot = 0; slot < recorded.size(); ++slot)
        if (old->mapper().attached(slot))
          push(input::InputMessage::attach(slot, bind_recorded(slot, recorded[slot])), "attach");
    }
    while (auto m = old->ring().try_pop()) push(*m, "queued");
    server::Server::Replaced shown = server_->set_scene(std::move(scene_info_), *published_, std::move(reader_));
    tell_server_devices();
    dispose(std::move(old_scene), std::move(shown), std::move(old), std::move(old_published), std::move(old_world));
    blowups_.reset(mesh_names());
    pending_start_tick_ = tick;
    pending_start_paused_ = paused;
    start_failure_logged_ = false;
    restart_sim_if_missing();
    log::notice("{}: scene {} ({} meshes, {} vertices) from tick {} (the swap held the io loop {:.1f} ms)", what,
                scene_.file.string(), scene_.meshes.size(), vertices_of(scene_), tick,
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - began).count());
  }

  // Frees a replaced simulation off the io loop (a big world takes a while
  // to free, longer still under ASan's quarantine): on the disposer thread,
  // or here when that is still busy with the last one.
  void dispose(scene::Scene scene, server::Server::Replaced shown, std::unique_ptr<SculptStages> stages,
               std::unique_ptr<server::PublishedState> published, std::unique_ptr<sim::World<float>> world) {
    struct Old {
      scene::Scene scene;
      server::Server::Replaced shown;
      std::unique_ptr<SculptStages> stages;
      std::unique_ptr<server::PublishedState> published;
      std::unique_ptr<sim::World<float>> world;
    };
    auto old = std::make_shared<Old>(
        Old{std::move(scene), std::move(shown), std::move(stages), std::move(published), std::move(world)});
    if (disposer_.busy()) return;  // freed right here, as `old` goes
    tasks_->add(disposer_.run([old = std::move(old)]() mutable { old.reset(); }));
  }

  // Builds `build()`'s scene on the worker thread, then swaps it in on the
  // io thread: the io loop serves clients and feeds the watchdog meanwhile.
  // Resolves to "" or the error (the running sculpt is then untouched). The
  // build goes on when the caller goes away (a client disconnecting).
  kj::Promise<std::string> load_off_loop(std::function<scene::Scene()> read, const char* what) {
    if (worker_.busy()) return std::string("a scene is being loaded already; try again when it is done");
    struct Job {
      std::optional<Simulation> built;
      std::string error;
    };
    auto job = std::make_shared<Job>();
    const SimulationSettings settings = simulation_settings();
    haptics::FeedbackBoard& board = *board_;
    auto done = worker_.run([job, read = std::move(read), settings, &board] {
      try {
        job->built.emplace(build_simulation(read(), settings, board));
      } catch (const std::exception& e) {
        job->error = e.what();
      }
    }).then([this, job, what]() -> std::string {
      if (!job->error.empty() || stopping_) {
        if (!job->error.empty()) log::warning("{}: {}; keeping the current sculpt", what, job->error);
        return job->error.empty() ? std::string("the daemon is stopping") : job->error;
      }
      log_scene_warnings(job->built->scene);
      swap_in(std::move(*job->built), what);
      return std::string();
    }, [what](kj::Exception&& e) -> std::string {
      log::err("{}: {}", what, e.getDescription().cStr());
      return e.getDescription().cStr();
    });
    auto forked = done.fork();
    tasks_->add(forked.addBranch().ignoreResult());
    return forked.addBranch();
  }

  void remember_device(std::uint8_t slot, const input::DeviceInfo& info, const input::DeviceBinding& b) {
    device_table_.attached(slot, info, b);
    tell_server_devices();
  }

  // The streamed tools say which device drives them.
  void tell_server_devices() {
    if (server_) server_->set_tool_devices(device_table_.slot_of_tools(tools_));
  }

  // --- server::DaemonControl (io thread) -------------------------------------------
  server::DaemonStatus status() override {
    server::DaemonStatus d;
    d.stats = loop::snapshot(loop_stats(), rate_);
    const loop::LatencyHistogram& j = loop_stats().jitter;
    for (std::size_t i = 0; i < loop::LatencyHistogram::kBuckets; ++i)
      if (const std::uint64_t n = j.bucket(i))
        d.jitter.push_back({loop::LatencyHistogram::lower_bound(i), loop::LatencyHistogram::upper_bound(i), n});
    d.stats.devices = device_count();
    d.stats.ff_uploads = haptics_ ? haptics_->stats().ff.uploads.load() : 0;
    d.paused = paused_now();
    d.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
    d.scene = scene_.file.string();
    d.sim_time_ns = static_cast<std::uint64_t>(std::llround(simulated_s() * 1e9));
    return d;
  }
  std::vector<server::DeviceEntry> devices() override {
    std::vector<server::DeviceEntry> out;
    for (const auto& [slot, d] : device_table_.entries()) {
      out.push_back(d);
      static_assert(haptics::HapticsStats::kSlots >= input::kMaxDevices, "a device slot without an FF counter");
      if (haptics_ && slot < haptics::HapticsStats::kSlots)
        out.back().ff_uploads = haptics_->stats().slot_uploads[slot].load(std::memory_order_relaxed);
    }
    return out;
  }
  kj::Promise<std::string> load_scene(const std::string& path) override {
    if (path.empty()) return std::string("the scene path is empty");
    if (path != "builtin:default" && !std::filesystem::path(path).is_absolute())
      return "scene path must be absolute (the daemon's working directory is not yours): " + path;
    return load_off_loop([path] { return scene::load_scene(path); }, "load scene");
  }
  kj::Promise<std::string> reset() override {
    // The scene as loaded, again (meshes keep their loaded shapes in it),
    // copied on the worker: only a swap changes scene_, and none runs while
    // a load does.
    return load_off_loop([this] { return scene_; }, "reset");
  }
  std::string set_paused(bool paused) override {
    if (!sim_) return "the sim thread is not running (it could not be started; see the log)";
    if (!sim_->request_pause(paused)) return "the sim thread's command ring is full; try again";
    log::info("{}", paused ? "paused" : "resumed");
    return {};
  }

  bool paused_now() override { return sim_ ? sim_->paused() : pending_start_paused_; }

  kj::Promise<void> watch_signal(int sig) {
    return io_.unixEventPort.onSignal(sig).then([this, sig](siginfo_t) -> kj::Promise<void> {
      if (sig == SIGHUP) {
        reload();
      } else {
        log::notice("{}: stopping", sig == SIGTERM ? "SIGTERM" : "SIGINT");
        request_stop(0);
      }
      return watch_signal(sig);
    });
  }

  kj::Promise<void> housekeeping() {
    return io_.provider->getTimer().afterDelay(kHousekeeping).then([this]() -> kj::Promise<void> {
      if (stopping_) return kj::READY_NOW;
      housekeep();
      return housekeeping();
    });
  }

  // Queues the replay as far ahead as the ring holds (from memory: the
  // feed's thread reads the file). A file that changed under us after the
  // start's check (a bad line) ends the replay, with the error, and never
  // the daemon: the sculpt goes on with what was played.
  void pump_replay() {
    if (!replay_ || replay_failed_) return;
    replay_->pump(stages_->ring());
    if (const auto error = replay_->error()) {
      replay_failed_ = true;
      log::err("replay ended early: {}; the sculpt goes on without its remaining frames", *error);
    }
  }

  void log_blowups(std::chrono::steady_clock::time_point now) {
    const std::string line = blowups_.check(loop_stats(), current_tick(), now);
    if (!line.empty()) log::warning("{}", line);
  }

  // A sim thread that could not start yet counts as stalled: its heartbeats
  // do not move, so systemd restarts the service if it never does.
  void feed_watchdog(std::chrono::steady_clock::time_point now) {
    switch (watchdog_->check(now, loop_stats().heartbeats.load(std::memory_order_acquire), cfg_.watchdog_fraction)) {
      case Watchdog::Due::ping: notify::watchdog(); break;
      case Watchdog::Due::stalled:
        log::err("sim thread stalled at tick {}: withholding the watchdog ping", current_tick());
        break;
      case Watchdog::Due::nothing:
      case Watchdog::Due::still_stalled: break;
    }
  }

  void housekeep() {
    const auto now = std::chrono::steady_clock::now();
    restart_sim_if_missing();
    log_blowups(now);
    feed_watchdog(now);
    if (!sim_) return;
    announce_ready_once();
    if (sim_->finished()) {
      log::info("duration reached: {} ticks", sim_->ticks());
      request_stop(0);
      return;
    }
    pump_replay();
    // A fact tests (and people reading debug logs) can wait for: nothing
    // moves any more, so the meshes stay bit-identical from here on.
    const bool at_rest = sim_->stats().vertices_awake.load(std::memory_order_relaxed) == 0;
    if (at_rest && !at_rest_) log::debug("all meshes at rest (tick {})", sim_->ticks());
    at_rest_ = at_rest;
    if (now >= next_status_) {
      notify::status(status_line());
      next_status_ = now + kStatusEvery;
    }
  }

  std::uint64_t device_count() const {
    if (replay_) return replay_->header().devices.size();
    return devices_ ? devices_->attached() : 0;
  }

  std::string status_line() const {
    return fmt::format("{} ticks, {} overruns, {} devices, {} FF uploads", sim_ ? sim_->ticks() : 0,
                       sim_ ? sim_->stats().overrun_log.total() : 0, device_count(),
                       haptics_ ? haptics_->stats().ff.uploads.load() : 0);
  }

  // SIGHUP: the config file is read on its own thread (the io loop never
  // waits on a file), then applied here. A SIGHUP during a reload reads the
  // file again once that one is done.
  void reload() {
    if (config_reader_.busy()) {
      reload_again_ = true;
      return;
    }
    struct Read {
      std::optional<DaemonConfig> config;
      std::string error;
    };
    auto read = std::make_shared<Read>();
    tasks_->add(config_reader_.run([read, path = opts_.config_path, optional = opts_.config_optional] {
      try {
        read->config.emplace(path.empty() ? DaemonConfig{} : load_config(path, optional));
      } catch (const std::exception& e) {
        read->error = e.what();
      }
    }).then([this, read] {
      if (!stopping_) apply_config(std::move(read->config), read->error);
      if (std::exchange(reload_again_, false) && !stopping_) reload();
    }));
  }

  void apply_config(std::optional<DaemonConfig> read, const std::string& read_error) {
    const std::string what = opts_.config_path.empty() ? std::string("(no config file)") : opts_.config_path.string();
    try {
      if (!read) throw std::runtime_error(read_error);
      DaemonConfig next = std::move(*read);
      if (opts_.overrides) opts_.overrides(next);
      input::MappingConfig mapping = input::parse_mapping(next.mapping_table, next.file.empty() ? "config" : next.file);
      // What needs a restart is reported, not applied: the sculpt is kept.
      if (next.scene != cfg_.scene || next.rate_hz != cfg_.rate_hz || to_string(next.input) != to_string(cfg_.input) ||
          next.realtime != cfg_.realtime || next.realtime_priority != cfg_.realtime_priority ||
          next.wake_early_us != cfg_.wake_early_us || next.socket != cfg_.socket)
        log::notice("SIGHUP: scene, rate, input, socket, realtime, realtime_priority and wake_early_us changes take "
                    "effect at the next start");
      mapping_ = std::move(mapping);
      cfg_.log_level = next.log_level;
      log::set_level(next.log_level);
      cfg_.haptics = next.haptics;
      haptics_->configure(next.haptics);
      cfg_.watchdog_fraction = next.watchdog_fraction;
      cfg_.input_delay_ms = next.input_delay_ms;
      clock_.set_delay_ms(next.input_delay_ms);
      cfg_.stats_json = next.stats_json;
      cfg_.hash_out = next.hash_out;
      cfg_.mapping_table = std::move(next.mapping_table);
      if (devices_)
        for (const auto& [slot, info] : devices_->devices()) on_attach(slot, info);  // rebind with the new mapping
      log::notice("SIGHUP: reloaded {}", what);
    } catch (const std::exception& e) {
      log::err("SIGHUP: {}; keeping the running configuration", e.what());
    }
  }

  void request_stop(int status) {
    if (stopping_) return;
    stopping_ = true;
    exit_->fulfill(kj::cp(status));
  }

  void stop_threads() {
    if (server_) server_->close();  // no client reads the published state any more
    if (sim_) sim_->stop();
    if (haptics_) haptics_->stop();  // stops and erases every effect, closes its fds
  }

  int shutdown(int status) {
    notify::stopping("stopping");
    stop_threads();
    const std::uint64_t devices = device_count();  // attached until now
    tasks_ = nullptr;
    device_events_.reset();
    devices_.reset();
    loop::StatsSnapshot s = loop::snapshot(loop_stats(), rate_);
    s.devices = devices;
    s.ff_uploads = haptics_->stats().ff.uploads.load();
    s.viewers = server_ ? server_->viewers() : 0;
    s.bytes_sent = server_ ? server_->counters().bytes_sent : 0;
    const std::uint64_t hash = world_->hash();
    if (const std::uint64_t late = stages_->late_inputs(); late != 0)
      log::warning("{} input messages arrived after their tick (the io thread fell behind){}", late,
                   replay_ ? ": this replay is not reproducible" : "");
    log::info("stopped after {} ticks: {} overruns, jitter p50 {:.1f} us p99 {:.1f} us max {:.1f} us, "
              "{} FF uploads ({} errors), final mesh hash {:016x}",
              s.ticks, s.overruns, s.jitter_us.p50, s.jitter_us.p99, s.jitter_us.max, s.ff_uploads,
              haptics_->stats().ff.errors.load(), hash);
    // Whole or not at all, like a save: a reader never sees half a file.
    const auto write = [](const char* flag, const std::string& path, const std::string& text) {
      if (path.empty()) return true;
      try {
        scene::write_file_atomically(path, text);
        return true;
      } catch (const std::exception& e) {
        log::err("{}: {}", flag, e.what());
        return false;
      }
    };
    const bool stats_written = write("--stats-json", cfg_.stats_json, loop::stats_json(s).dump(2) + "\n");
    const bool hash_written = write("--hash-out", cfg_.hash_out, fmt::format("{:016x}\n", hash));
    return stats_written && hash_written ? status : 1;
  }

  RunOptions opts_;
  DaemonConfig& cfg_;
  kj::AsyncIoContext& io_;
  kj::Own<kj::PromiseFulfiller<int>> exit_;

  scene::Scene scene_;
  double rate_ = 1000.0;
  std::size_t tools_ = 0;
  input::MappingConfig mapping_;
  input::ToolRouter router_;
  input::DeviceClock clock_{1000.0, cfg_.input_delay_ms};  // --input-clock device; its rate follows the scene's
  std::uint64_t dropped_ = 0;

  std::unique_ptr<sim::World<float>> world_;
  std::unique_ptr<haptics::FeedbackBoard> board_;
  std::unique_ptr<SculptStages> stages_;
  std::unique_ptr<haptics::HapticsThread> haptics_;
  std::unique_ptr<input::ReplayFeed> replay_;
  bool replay_failed_ = false;
  std::unique_ptr<input::DeviceManager> devices_;
  std::unique_ptr<server::PublishedState> published_;
  DeviceTable device_table_;
  std::unique_ptr<loop::SimThread> sim_;   // after world/stages: stopped (destroyed) first
  loop::LoopStats idle_stats_;             // loop_stats() while sim_ is missing
  std::uint64_t pending_start_tick_ = 0;   // where a sim thread that could not start will start
  // Simulated time: the scenes before this one ran this long, and this one
  // from this tick on, at rate_.
  double simulated_before_s_ = 0;
  std::uint64_t segment_first_tick_ = 0;
  bool pending_start_paused_ = false;
  bool start_failure_logged_ = false;
  server::SceneInfo scene_info_;           // of scene_, built off the loop, until the server takes it
  std::unique_ptr<server::PublishedReader> reader_;  // likewise
  BlowupLog blowups_;
  Worker worker_;                          // loads scenes off the io loop
  Worker disposer_;                        // frees what a swap replaced
  Worker config_reader_;                   // reads the config on SIGHUP
  bool reload_again_ = false;              // a SIGHUP came during a reload
  std::unique_ptr<server::Server> server_;
  std::unique_ptr<server::ListenSocket> listen_;
  std::string socket_path_;
  std::unique_ptr<DeviceEvents> device_events_;  // after devices_: destroyed first

  std::unique_ptr<Watchdog> watchdog_;
  std::chrono::steady_clock::time_point next_status_{}, started_{};
  bool ready_sent_ = false;  // READY and "sculptd ready" go out once, after the first tick
  bool at_rest_ = true;
  bool stopping_ = false;
  kj::Own<kj::TaskSet> tasks_;  // last: its promises use everything above
};

}  // namespace

int run(RunOptions options) {
  // Before any thread exists: kj blocks these signals and delivers them to
  // the io loop; the sim and haptics threads inherit the blocked mask.
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) kj::UnixEventPort::captureSignal(sig);
  auto io = kj::setupAsyncIo();
  Daemon daemon(std::move(options), io);
  return daemon.run();
}

}  // namespace sculpt::daemon
