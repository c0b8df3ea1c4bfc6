#include "main/daemon.hpp"

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

// SIGTERM or SIGINT waiting: kj keeps them blocked on this thread until the
// io loop runs, so work before it (recovery) asks here.
bool termination_pending() {
  sigset_t pending;
  return sigpending(&pending) == 0 && (sigismember(&pending, SIGTERM) == 1 || sigismember(&pending, SIGINT) == 1);
}

}  // namespace

int Daemon::run() {
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

void Daemon::setup() {
  log::set_level(cfg_.log_level);
  tasks_ = kj::heap<kj::TaskSet>(*this);
  // Before the io loop runs (and before READY), so here, once, the scene
  // loads on the io thread.
  board_ = std::make_unique<haptics::FeedbackBoard>(static_cast<int>(sim::kMaxTools));
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
    if (auto w = simloop::preemption_warning(simloop::current_preemption_model())) log::warning("{}", *w);
    if (auto w = simloop::compaction_warning(simloop::current_compact_unevictable_allowed())) log::warning("{}", *w);
  }

  for (int sig : {SIGTERM, SIGINT, SIGHUP}) tasks_->add(watch_signal(sig));
  if (auto events = input_->run()) tasks_->add(kj::mv(*events));
  watchdog_ = std::make_unique<Watchdog>(notify::watchdog_interval());
  tasks_->add(housekeeping());
  started_ = std::chrono::steady_clock::now();
  desk_.set_started(started_);
}

// The keeper and its store, when the config wants one (keeper/store_place.hpp).
void Daemon::open_store() {
  if (!store_wanted(cfg_)) return;
  tap_ = std::make_unique<JournalTap>();
  OpenedKeeper opened = open_keeper(keeper_settings(cfg_), *tap_);
  keeper_ = std::move(opened.keeper);
  memory_store_ = std::move(opened.memory_dir);
  loader_->set_copies_for_replica(true);
}

// The sculpt the store holds, recovered, or the configured scene anew.
Daemon::StartPoint Daemon::install_first_scene() {
  std::optional<Recovered> rec;
  // --open: only a file that recovers replaces the saved sculpt (kept beside it).
  if (keeper_ && !cfg_.keeper.open.empty()) rec = keeper_->open_file(cfg_.keeper.open, termination_pending);
  else if (keeper_ && !cfg_.keeper.fresh) rec = keeper_->recover(termination_pending);
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
  log_recovery(*rec, cfg_.scene, !cfg_.keeper.open.empty());
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

// Listening before READY=1, so a client started after the daemon is
// ready always finds the socket.
void Daemon::start_server() {
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
// devices, viewers get a new keyframe. Nothing of this can fail but the
// new thread's start, which is retried (SimHost::restart_if_missing).
void Daemon::swap_in(Simulation next, const char* what) {
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

void Daemon::stop_threads() {
  if (server_) server_->close();  // no client reads the published state any more
  if (board_) board_->set_hold(haptics::Hold::stopped);  // zero felt before the sim thread stops beating
  sims_.stop();
  if (keeper_) keeper_->stop();  // after the sim thread: it takes everything it did
  sleep_.reset();                  // before the haptics thread it tells about resumes
  if (haptics_) haptics_->stop();  // stops and erases every effect, closes its fds
}

int Daemon::shutdown(int status) {
  notify::stopping("stopping");
  stop_threads();
  if (keeper_) log_keeper_stats(keeper_->stats());
  RunTotals totals;
  totals.stats = simloop::reading(sims_.stats(), sims_.rate());
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

int run(RunOptions options) {
  // Before any thread exists: kj blocks these signals and delivers them to
  // the io loop; the sim and haptics threads inherit the blocked mask.
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) kj::UnixEventPort::captureSignal(sig);
  auto io = kj::setupAsyncIo();
  Daemon daemon(std::move(options), io);
  return daemon.run();
}

}  // namespace sculpt::daemon

