#include "main/daemon.hpp"

#include <chrono>
#include <csignal>
#include <ctime>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include <fmt/chrono.h>
#include <kj/async-io.h>
#include <kj/async-unix.h>
#include <kj/debug.h>
#include <kj/timer.h>

#include "client/socket_path.hpp"
#include "haptics/feedback_board.hpp"
#include "haptics/haptics_thread.hpp"
#include "input/mapping.hpp"
#include "simloop/compaction.hpp"
#include "simloop/preemption.hpp"
#include "main/room_settings.hpp"
#include "main/blowup_log.hpp"
#include "main/config_reload.hpp"
#include "main/control_desk.hpp"
#include "devices/device_hub.hpp"
#include "devices/input_source.hpp"
#include "keeper/journal.hpp"
#include "keeper/keeper.hpp"
#include "log/log.hpp"
#include "main/notify.hpp"
#include "main/run_report.hpp"
#include "keeper/scene_bundle.hpp"
#include "host/scene_loader.hpp"
#include "host/sim_host.hpp"
#include "main/sleep_watch.hpp"
#include "main/watchdog.hpp"
#include "server/listener.hpp"
#include "server/server.hpp"

namespace sculpt::daemon {
namespace {

constexpr auto kHousekeeping = 20 * kj::MILLISECONDS;  // duration check, replay pump, watchdog
constexpr std::chrono::seconds kStatusEvery{5};

// SIGTERM or SIGINT waiting: kj keeps them blocked on this thread until the
// io loop runs, so work before it (recovery) asks here.
bool termination_pending() {
  sigset_t pending;
  return sigpending(&pending) == 0 && (sigismember(&pending, SIGTERM) == 1 || sigismember(&pending, SIGINT) == 1);
}

// The composition root: builds the modules, wires them to each other and to
// the io loop (signals, housekeeping timer, device events), and orders the
// steps that involve several of them: the start, a scene swap, a reload,
// the shutdown.
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

  int run() {
    auto exit = kj::newPromiseAndFulfiller<int>();
    exit_ = kj::mv(exit.fulfiller);
    try {
      setup();
    } catch (const RecoveryStopped& e) {  // SIGTERM or SIGINT while it replayed: a stop like any other
      log::notice("{}: stopping", e.what());
      stop_threads();
      return 0;
    } catch (const std::exception& e) {
      log::err("{}", e.what());
      stop_threads();
      return 1;
    }
    const int status = exit.promise.wait(io_.waitScope);
    return shutdown(status);
  }

 private:
  void taskFailed(kj::Exception&& e) override {
    log::err("io loop: {}", e.getDescription().cStr());
    request_stop(1);
  }

  void setup() {
    log::set_level(cfg_.log_level);
    tasks_ = kj::heap<kj::TaskSet>(*this);
    // Before the io loop runs (and before READY), so here, once, the scene
    // loads on the io thread.
    board_ = std::make_unique<haptics::FeedbackBoard>(static_cast<int>(input::kMaxTools));
    loader_ = std::make_unique<SceneLoader>(
        *tasks_, stopping_, *board_,
        [this] {
          // The scene is replaced: nothing is felt until the new one ticks.
          board_->set_hold(haptics::Hold::swapping);
          sims_.request_stop();
          return until_sim_stopped();
        },
        [this](Simulation next, const char* what) { swap_in(std::move(next), what); });
    reload_ = std::make_unique<ConfigReload>(opts_.config_path, opts_.config_optional, opts_.overrides, *tasks_,
                                             stopping_, [this](DaemonConfig next) { apply_config(std::move(next)); });
    open_store();
    const StartPoint start = install_first_scene();
    blowups_.reset(mesh_names(sims_.scene()));
    log::info("scene {}: {} meshes, {} vertices, {} tools; {} Hz", sims_.scene().file.string(),
              sims_.scene().meshes.size(), vertices_of(sims_.scene()), sims_.tools(), sims_.rate());

    hub_.set_mapping(input::parse_mapping(cfg_.mapping_table, cfg_.file.empty() ? "config" : cfg_.file));
    hub_.use_scene(sims_.scene(), sims_.tools(), sims_.stages(), sims_.rate());
    haptics_ = std::make_unique<haptics::HapticsThread>(
        *board_, cfg_.haptics, haptics::open_evdev_port,
        [](int priority, const std::string& message) { log::write_priority(priority, "haptics: " + message); });
    haptics_->start();
    // Pads may lose their FF state over a suspend: reopened at the resume.
    sleep_ = std::make_unique<SleepWatch>([h = haptics_.get()](bool sleeping) {
      if (!sleeping) h->resumed();
    });
    sleep_->start();
    hub_.set_haptics(haptics_.get());
    desk_.set_haptics(haptics_.get());
    desk_.set_keeper(keeper_.get());

    input_ = std::make_unique<InputSource>(cfg_.input, cfg_.input_clock, sims_.rate(), hub_, io_.unixEventPort);
    input_->pump(sims_.stages().ring());
    desk_.set_input(input_.get());

    start_server();
    if (keeper_) keeper_->start();
    // The sim thread. READY waits for its first tick (housekeep()).
    board_->set_hold(start.paused ? haptics::Hold::paused : haptics::Hold::none);
    sims_.start(start.tick, start.paused);
    // Once per process, not at every scene swap: the kernel's settings that
    // hold up a real-time thread.
    if (cfg_.realtime) {
      if (auto w = loop::preemption_warning(loop::current_preemption_model())) log::warning("{}", *w);
      if (auto w = loop::compaction_warning(loop::current_compact_unevictable_allowed())) log::warning("{}", *w);
    }

    for (int sig : {SIGTERM, SIGINT, SIGHUP}) tasks_->add(watch_signal(sig));
    if (auto events = input_->run()) tasks_->add(kj::mv(*events));
    watchdog_ = std::make_unique<Watchdog>(notify::watchdog_interval());
    tasks_->add(housekeeping());
    started_ = std::chrono::steady_clock::now();
    desk_.set_started(started_);
  }

  struct StartPoint {
    std::uint64_t tick = 0;
    bool paused = false;
  };

  // The keeper and its store, when the config wants one. A store another
  // daemon holds stops the start (two daemons never share one); one that
  // cannot be opened otherwise (a read-only or full state directory) is
  // replaced by one in memory: undo works, a crash loses the sculpt.
  void open_store() {
    if (!store_wanted(cfg_)) return;
    tap_ = std::make_unique<JournalTap>();
    KeeperSettings settings = keeper_settings(cfg_);
    try {
      keeper_ = std::make_unique<Keeper>(settings, *tap_);
    } catch (const store::StoreInUse&) {
      throw;
    } catch (const store::StoreError& e) {
      memory_store_ = make_memory_dir();
      log::warning("autosave: {}; the sculpt is kept in memory only ({}): undo works, a crash loses it", e.what(),
                   memory_store_.string());
      settings.dir = memory_store_;
      keeper_ = std::make_unique<Keeper>(settings, *tap_);
    }
    loader_->set_copies_for_replica(true);
  }

  // The sculpt the store holds, recovered, or the configured scene anew.
  StartPoint install_first_scene() {
    std::optional<Recovered> rec;
    // --open: only a file that recovers replaces the saved sculpt (kept beside it).
    if (keeper_ && !cfg_.store.open.empty()) rec = keeper_->open_file(cfg_.store.open, termination_pending);
    else if (keeper_ && !cfg_.store.fresh) rec = keeper_->recover(termination_pending);
    if (!rec) {
      if (keeper_) keeper_->start_anew();
      auto bundle = std::make_shared<SceneBundle>(read_bundle(cfg_.scene, simulation_settings(cfg_)));
      scene::Scene first = load_bundle(*bundle);
      log_scene_warnings(first);
      auto copy = keeper_ ? std::make_shared<const scene::Scene>(first) : nullptr;
      Simulation sim = build_simulation(std::move(first), bundle->settings, *board_);
      sim.bundle = bundle;
      if (keeper_) sim.stages->set_journal(tap_.get(), sim.world.get());
      sims_.install(std::move(sim));
      if (keeper_) keeper_->scene_started(bundle, std::move(copy), 0);
      return {};
    }
    log_recovery(*rec);
    Simulation sim = build_simulation(std::move(rec->scene), rec->bundle->settings, *board_, rec->state);
    sim.bundle = rec->bundle;
    sim.stages->set_journal(tap_.get(), sim.world.get());
    sims_.install(std::move(sim), rec->next_tick);
    keeper_->scene_started(rec->bundle, nullptr, rec->next_tick, /*recovered=*/true);
    // The devices of the run that ended are gone: their slots are freed
    // (through the journal) before the live ones attach again.
    for (std::uint8_t slot = 0; slot < input::kMaxDevices; ++slot)
      (void)sims_.stages().ring().try_push(input::InputMessage::detach(slot));
    return {rec->next_tick, rec->paused};
  }

  void log_recovery(const Recovered& r) {
    // What a crash loses is the input after the last commit: when that was says how much.
    std::string last;
    if (r.committed_ns > 0) {
      const std::time_t secs = static_cast<std::time_t>(r.committed_ns / 1000000000);
      std::tm tm{};
      gmtime_r(&secs, &tm);
      last = fmt::format(" (the journal's last commit {:%Y-%m-%d %H:%M:%S}.{:03d} UTC: input after it was not saved)", tm,
                         static_cast<int>(r.committed_ns / 1000000 % 1000));
    }
    log::notice("recovered the sculpt of {} at tick {} (mesh hash {:016x}){}: the snapshot of tick {} and {} journal "
                "entries, {} strokes of history, in {:.0f} ms; {}{}",
                r.bundle->file, r.next_tick > 0 ? r.next_tick - 1 : 0, r.hash, r.paused ? ", paused" : "",
                r.snapshot_tick, r.replayed, r.strokes, r.seconds * 1e3, r.loss, last);
    for (const std::string& l : r.lost) log::warning("recovery: {}", l);
    if (r.bundle->file != cfg_.scene && cfg_.store.open.empty())
      log::notice("the config names scene {}: start with --fresh to sculpt it instead", cfg_.scene);
  }

  static std::filesystem::path make_memory_dir() {
    const char* shm = "/dev/shm";
    std::string pattern = std::string(std::filesystem::is_directory(shm) ? shm : "/tmp") + "/sculptd-store-XXXXXX";
    if (!mkdtemp(pattern.data())) throw std::runtime_error("autosave: cannot make a directory in memory for the store");
    return pattern;
  }

  // Undo and redo buttons on the pads (the mapper counts presses on the sim thread).
  void take_pad_edits() {
    if (!keeper_) return;
    const SculptStages& stages = sims_.stages();
    if (&stages != pad_stages_) {
      pad_stages_ = &stages;
      undo_seen_ = stages.undo_presses();
      redo_seen_ = stages.redo_presses();
      return;
    }
    const std::uint32_t undo = stages.undo_presses(), redo = stages.redo_presses();
    if (undo != undo_seen_) pad_edit(true, undo - undo_seen_);
    if (redo != redo_seen_) pad_edit(false, redo - redo_seen_);
    undo_seen_ = undo;
    redo_seen_ = redo;
  }

  void pad_edit(bool undo, std::uint32_t count) {
    const char* what = undo ? "undo" : "redo";
    if (sims_.paused()) {
      log::info("{} (pad): the sculpt is paused; resume first", what);
      return;
    }
    tasks_->add((undo ? keeper_->undo(count) : keeper_->redo(count)).then([what](EditResult r) {
      if (!r.error.empty()) log::info("{} (pad): {}", what, r.error);
      else log::info("{} (pad): {} stroke{} at tick {}", what, r.done, r.done == 1 ? "" : "s", r.tick);
    }));
  }

  // Listening before READY=1, so a client started after the daemon is
  // ready always finds the socket.
  void start_server() {
    server::ServerOptions sopts;
    sopts.name = fmt::format("sculptd {}", SCULPTD_VERSION);
    sopts.log = [](int priority, const std::string& line) { log::write_priority(priority, line); };
    server_ = std::make_unique<server::Server>(io_, desk_, sopts);
    (void)server_->set_scene(sims_.take_scene_info(), sims_.published(), sims_.take_reader());
    hub_.set_server(server_.get());
    listen_ = std::make_unique<server::ListenSocket>(server::ListenSocket::open(client::resolve_socket_path(cfg_.socket)));
    socket_path_ = listen_->path();
    server_->listen(listen_->release());
  }

  // Replaces the running simulation with `next`, already built (a loaded
  // scene, or the current one again for reset): the sim thread stops, the
  // new world takes over the tick count, the queued inputs and the attached
  // devices, viewers get a new snapshot. Nothing of this can fail but the
  // new thread's start, which is retried (SimHost::restart_if_missing).
  void swap_in(Simulation next, const char* what) {
    struct Replaced {
      SimHost::Outgoing parts;
      server::Server::Replaced shown;
    };
    const auto began = std::chrono::steady_clock::now();
    auto replica_scene = std::move(next.replica_scene);
    if (keeper_) next.stages->set_journal(tap_.get(), next.world.get());
    SimHost::Outgoing old = sims_.swap(std::move(next));
    const std::uint64_t tick = sims_.current_tick();
    if (keeper_) keeper_->scene_started(sims_.bundle(), std::move(replica_scene), tick);
    // Devices first (as attach messages due now, bound to the new scene's
    // tools, live or recorded alike), then what was queued. Viewers read the
    // old published state until set_scene().
    hub_.use_scene(sims_.scene(), sims_.tools(), sims_.stages(), sims_.rate());
    if (input_->live()) hub_.rebind(*input_->live());
    hub_.carry_over(*old.stages, input_->recorded());
    server::Server::Replaced shown = server_->set_scene(sims_.take_scene_info(), sims_.published(), sims_.take_reader());
    hub_.tell_server();
    loader_->dispose(Replaced{std::move(old), std::move(shown)});
    blowups_.reset(mesh_names(sims_.scene()));
    sims_.restart_if_missing();
    board_->set_hold(sims_.paused() ? haptics::Hold::paused : haptics::Hold::none);
    log::notice("{}: scene {} ({} meshes, {} vertices) from tick {} (the swap held the io loop {:.1f} ms)", what,
                sims_.scene().file.string(), sims_.scene().meshes.size(), vertices_of(sims_.scene()),
                tick,
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - began).count());
  }

  // Polled: the sim thread leaves its loop within a tick once it runs.
  kj::Promise<void> until_sim_stopped() {
    if (sims_.stopped()) return kj::READY_NOW;
    return io_.provider->getTimer().afterDelay(1 * kj::MILLISECONDS).then([this] { return until_sim_stopped(); });
  }

  kj::Promise<void> watch_signal(int sig) {
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

  kj::Promise<void> housekeeping() {
    return io_.provider->getTimer().afterDelay(kHousekeeping).then([this]() -> kj::Promise<void> {
      if (stopping_) return kj::READY_NOW;
      housekeep();
      return housekeeping();
    });
  }

  void housekeep() {
    const auto now = std::chrono::steady_clock::now();
    sims_.restart_if_missing();
    if (const std::string line = blowups_.check(sims_.stats(), sims_.current_tick(), now); !line.empty())
      log::warning("{}", line);
    feed_watchdog(now);
    hub_.log_held_tunes(now);
    const loop::SimThread* sim = sims_.thread();
    if (!sim) return;
    announce_ready_once();
    if (sim->finished() && !sims_.swapping()) {
      log::info("duration reached: {} ticks", sim->ticks());
      request_stop(0);
      return;
    }
    input_->pump(sims_.stages().ring());
    take_pad_edits();
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
  void announce_ready_once() {
    if (ready_sent_ || sims_.stats().heartbeats.load(std::memory_order_acquire) == 0) return;
    ready_sent_ = true;
    notify::ready(status_line());
    log::notice("sculptd ready: {} Hz, input {}, socket {}{}", sims_.rate(), to_string(cfg_.input), socket_path_,
                listen_->activated() ? " (socket activation)" : "");
  }

  // A sim thread that could not start yet counts as stalled: its heartbeats
  // do not move, so systemd restarts the service if it never does.
  void feed_watchdog(std::chrono::steady_clock::time_point now) {
    switch (watchdog_->check(now, sims_.stats().heartbeats.load(std::memory_order_acquire), cfg_.watchdog_fraction)) {
      case Watchdog::Due::ping: notify::watchdog(); break;
      case Watchdog::Due::stalled:
        log::err("sim thread stalled at tick {}: withholding the watchdog ping", sims_.current_tick());
        break;
      case Watchdog::Due::nothing:
      case Watchdog::Due::still_stalled: break;
    }
  }

  std::string status_line() {
    const loop::SimThread* sim = sims_.thread();
    return fmt::format("{} ticks, {} overruns, {} devices, {} FF uploads", sim ? sim->ticks() : 0,
                       sim ? sim->stats().overrun_log.total() : 0, desk_.device_count(), desk_.ff_uploads());
  }

  // SIGHUP's new configuration, read and with the flags on top: the
  // mapping, log level, haptics, watchdog and input delay apply now (live
  // devices are bound again), the rest at the next start.
  void apply_config(DaemonConfig next) {
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

  void request_stop(int status) {
    if (stopping_) return;
    stopping_ = true;
    exit_->fulfill(kj::cp(status));
  }

  void stop_threads() {
    if (server_) server_->close();  // no client reads the published state any more
    if (board_) board_->set_hold(haptics::Hold::stopped);  // zero felt before the sim thread stops beating
    sims_.stop();
    if (keeper_) keeper_->stop();  // after the sim thread: it takes everything it did
    sleep_.reset();                  // before the haptics thread it tells about resumes
    if (haptics_) haptics_->stop();  // stops and erases every effect, closes its fds
  }

  int shutdown(int status) {
    notify::stopping("stopping");
    stop_threads();
    if (keeper_) {
      const KeeperStats k = keeper_->stats();
      log::info("autosave: {} journal entries ({} bytes) in {} commits, the longest gap between two {:.0f} ms; {} "
                "snapshots, the last of {} bytes of state ({} stored) in {:.0f} ms",
                k.entries, k.journal_bytes, k.commits, k.longest_commit_gap_ms, k.snapshots, k.snapshot_state_bytes,
                k.snapshot_stored_bytes, k.snapshot_ms);
    }
    RunTotals totals;
    totals.stats = loop::snapshot(sims_.stats(), sims_.rate());
    totals.stats.devices = desk_.device_count();  // attached until now
    tasks_ = nullptr;
    input_->close();
    totals.stats.ff_uploads = haptics_->stats().ff.uploads.load();
    totals.stats.viewers = server_ ? server_->viewers() : 0;
    totals.stats.bytes_sent = server_ ? server_->counters().bytes_sent : 0;
    totals.ff_errors = haptics_->stats().ff.errors.load();
    totals.mesh_hash = sims_.world().hash();
    totals.late_inputs = sims_.stages().late_inputs();
    totals.replay = input_->replaying();
    return report_run(totals, cfg_) ? status : 1;
  }

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
  const SculptStages* pad_stages_ = nullptr;  // whose undo/redo presses were seen
  std::uint32_t undo_seen_ = 0, redo_seen_ = 0;
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
