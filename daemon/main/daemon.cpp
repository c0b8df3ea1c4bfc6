#include "main/daemon.hpp"

#include <sys/epoll.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <system_error>

#include <kj/async-io.h>
#include <kj/async-unix.h>
#include <kj/debug.h>
#include <kj/timer.h>

#include "haptics/feedback_board.hpp"
#include "haptics/haptics_thread.hpp"
#include "input/device_manager.hpp"
#include "input/mapping.hpp"
#include "input/replay_source.hpp"
#include "loop/sim_thread.hpp"
#include "loop/stats_json.hpp"
#include "loop/tool_driver.hpp"
#include "main/log.hpp"
#include "main/notify.hpp"
#include "main/pipeline.hpp"
#include "scene/scene.hpp"
#include "sim/world.hpp"

namespace sculpt::daemon {
namespace {

constexpr std::size_t kRingCapacity = 4096;                 // io → sim messages in flight
constexpr auto kHousekeeping = 20 * kj::MILLISECONDS;       // duration check, replay pump, watchdog
constexpr double kReplayLeadSeconds = 1.0;                  // replay messages queued this far ahead
constexpr std::chrono::seconds kStatusEvery{5};

loop::Box mesh_bounds(const scene::Scene& s) {
  loop::Box b{{0, 0, 0}, {0, 0, 0}};
  bool any = false;
  for (const auto& m : s.meshes)
    for (const auto& p : m.loaded.mesh.positions)
      for (int a = 0; a < 3; ++a) {
        const double v = p[a];
        if (!any || v < b.lo[a]) b.lo[a] = v;
        if (!any || v > b.hi[a]) b.hi[a] = v;
        any = any || a == 2;
      }
  return b;
}

std::vector<loop::ToolSpec> tool_specs(const scene::Scene& s) {
  std::vector<loop::ToolSpec> out;
  for (const auto& t : s.tools) {
    loop::ToolSpec spec;
    spec.shape = t.shape == scene::ToolShape::capsule ? sim::ToolShape::capsule : sim::ToolShape::sphere;
    spec.radius = t.radius;
    spec.half_length = t.half_length;
    spec.position = t.position;
    spec.speed = t.speed;
    out.push_back(spec);
  }
  return out;
}

std::vector<input::ToolRoute> tool_routes(const scene::Scene& s) {
  std::vector<input::ToolRoute> out;
  for (const auto& t : s.tools) {
    input::ToolRoute r;
    r.device = t.device;
    r.device_name = t.device_name;
    r.stick = t.stick == scene::Stick::right ? input::Stick::right
              : t.stick == scene::Stick::main ? input::Stick::main
                                              : input::Stick::left;
    out.push_back(r);
  }
  return out;
}

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

void write_file(const std::string& path, const std::string& text, const char* what) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error(std::string(what) + ": cannot write " + path);
}

class Daemon final : public input::DeviceListener, public kj::TaskSet::ErrorHandler {
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
    anchors_[slot % anchors_.size()] = Anchor{};
    push(input::InputMessage::attach(slot, b), "attach");
    log::info("device {}: {} [{}] on slot {}, drives {} tool(s)", info.node.empty() ? "(recorded)" : info.node,
              info.name, input::to_string(info.kind), slot, std::popcount(b.tool_mask));
    if (haptics_ && !info.node.empty()) haptics_->attach(slot, info.node, tool_sticks(b, tools_));
  }
  void on_detach(std::uint8_t slot) override {
    router_.detach(slot);
    anchors_[slot % anchors_.size()] = Anchor{};
    push(input::InputMessage::detach(slot), "detach");
    if (haptics_) haptics_->detach(slot);
    log::info("device on slot {} is gone", slot);
  }
  void on_frame(const input::InputFrame& frame) override {
    input::InputFrame f = frame;
    if (cfg_.input_clock == InputClock::device) f.at_tick = device_tick(f);
    push(input::InputMessage::of_frame(f), "frame");
  }
  void on_log(int priority, const std::string& message) override {
    log::write(static_cast<log::Level>(std::clamp(priority, 3, 7)), message);
  }

 private:
  struct Anchor {
    bool valid = false;
    std::int64_t base = 0;   // tick of device time 0
    std::int64_t last = 0;   // ticks stay in order
  };

  void taskFailed(kj::Exception&& e) override {
    log::err("io loop: {}", e.getDescription().cStr());
    request_stop(1);
  }

  std::uint64_t current_tick() const { return sim_ ? sim_->ticks() : 0; }

  // --input-clock device: the frame applies at its device time plus a fixed
  // delay, counted from the device's first frame, not when it arrived: a
  // session replayed through uinput lands on the ticks `replay:` gives it.
  std::uint64_t device_tick(const input::InputFrame& f) {
    // Frames without a device clock (a resync, a device without
    // MSC_TIMESTAMP) apply in order, right after what is already queued.
    if (!f.device_clock) return 0;
    Anchor& a = anchors_[f.slot % anchors_.size()];
    // Rounded exactly as ReplaySource rounds: same session, same ticks.
    auto ticks_of = [this](std::int64_t t_us) { return static_cast<std::int64_t>(input::replay_tick(0, t_us, rate_)); };
    if (!a.valid) {
      const auto delay = static_cast<std::int64_t>(std::llround(cfg_.input_delay_ms * 1e-3 * rate_));
      a.base = static_cast<std::int64_t>(current_tick()) + delay - ticks_of(f.device_time_us);
      a.last = 1;
      a.valid = true;
      log::debug("slot {}: device clock anchored: device time {} us applies on tick {}", f.slot, f.device_time_us,
                 a.base + ticks_of(f.device_time_us));
    }
    std::int64_t t = a.base + ticks_of(f.device_time_us);
    t = std::max({t, a.last, std::int64_t{1}});
    a.last = t;
    return static_cast<std::uint64_t>(t);
  }

  void push(const input::InputMessage& m, const char* what) {
    if (stages_->ring().try_push(m)) return;
    // The sim thread drains the ring every tick; a full ring means it is stuck.
    if (dropped_++ % 1000 == 0) log::warning("input ring full: dropped a {} message ({} so far)", what, dropped_);
  }

  void setup() {
    log::set_level(cfg_.log_level);
    // Scene, world, tools.
    scene_ = scene::load_scene(cfg_.scene);
    for (const auto& w : scene_.warnings) log::warning("scene {}: {}", scene_.file.string(), w);
    for (const auto& m : scene_.meshes)
      for (const auto& w : m.loaded.warnings) log::warning("scene {}: mesh {}: {}", scene_.file.string(), m.name, w);
    rate_ = cfg_.rate_hz.value_or(scene_.settings.rate_hz);
    sim::SimSettings settings = scene_.settings;
    settings.rate_hz = rate_;
    tools_ = scene_.tools.size();
    if (tools_ > input::kMaxTools)
      throw std::runtime_error(fmt::format("scene {}: {} tools, at most {} can be driven", scene_.file.string(),
                                           tools_, input::kMaxTools));
    const int slots = static_cast<int>(std::max<std::size_t>(tools_, 1));
    world_ = std::make_unique<sim::World<float>>(settings, slots);
    std::size_t vertices = 0;
    for (const auto& m : scene_.meshes) {
      world_->add_body(m.loaded.mesh, scene_.material_of(m));
      vertices += m.loaded.mesh.positions.size();
    }
    const auto specs = tool_specs(scene_);
    loop::DriverLimits limits;
    limits.bounds = loop::tool_bounds(mesh_bounds(scene_), specs, cfg_.tool_margin);
    limits.size_step = cfg_.size_step;
    limits.min_scale = cfg_.min_scale;
    limits.max_scale = cfg_.max_scale;
    board_ = std::make_unique<haptics::FeedbackBoard>(slots);
    stages_ = std::make_unique<SculptStages>(loop::ToolDriver(specs, limits, rate_), *board_, kRingCapacity);
    log::info("scene {}: {} meshes, {} vertices, {} tools; {} Hz", scene_.file.string(), scene_.meshes.size(),
              vertices, tools_, rate_);

    // Mapping and haptics.
    mapping_ = input::parse_mapping(cfg_.mapping_table, cfg_.file.empty() ? "config" : cfg_.file);
    router_.set_routes(tool_routes(scene_));
    haptics_ = std::make_unique<haptics::HapticsThread>(*board_, cfg_.haptics);
    haptics_->start();

    // Input.
    if (cfg_.input.kind == InputSpec::Kind::replay) {
      replay_ = std::make_unique<input::ReplaySource>(
          cfg_.input.replay, rate_, [this](std::uint8_t slot, const input::DeviceInfo& info) {
            router_.detach(slot);
            auto b = router_.attach(slot, info, mapping_);
            for (const auto& w : router_.warnings()) log::warning("{}", w);
            return b;
          });
      replay_->start(1);
      replay_->pump(stages_->ring(), replay_horizon());
      log::info("input: replaying {} ({} devices)", cfg_.input.replay.string(), replay_->header().devices.size());
    } else {
      input::DeviceManagerOptions o;
      o.discovery = cfg_.input.kind == InputSpec::Kind::evdev ? input::Discovery::inotify : input::Discovery::automatic;
      devices_ = std::make_unique<input::DeviceManager>(*this, o);
      devices_->on_fds_changed([this] { fds_changed_ = true; });
      epoll_ = ::epoll_create1(EPOLL_CLOEXEC);
      if (epoll_ < 0) throw std::system_error(errno, std::generic_category(), "epoll_create1");
      devices_->start();
      sync_device_fds();
      device_observer_ = kj::heap<kj::UnixEventPort::FdObserver>(io_.unixEventPort, epoll_,
                                                                  kj::UnixEventPort::FdObserver::OBSERVE_READ);
      log::info("input: live devices ({}), {} attached, clock {}", devices_->discovery(), devices_->attached(),
                cfg_.input_clock == InputClock::device ? "device" : "arrival");
    }

    // The sim thread.
    loop::SimThreadOptions so;
    so.rate_hz = rate_;
    so.realtime = cfg_.realtime;
    so.realtime_priority = cfg_.realtime_priority;
    if (cfg_.duration_s > 0) so.max_ticks = static_cast<std::uint64_t>(std::llround(cfg_.duration_s * rate_));
    sim_ = std::make_unique<loop::SimThread>(*world_, *stages_, tools_, so);
    const loop::RealtimeResult rt = sim_->start();
    for (const auto& w : rt.warnings) log::warning("{}", w);
    if (cfg_.realtime && rt.fifo) log::info("sim thread: SCHED_FIFO priority {}{}", cfg_.realtime_priority,
                                            rt.locked ? ", memory locked" : "");

    // The io loop's tasks.
    tasks_ = kj::heap<kj::TaskSet>(*this);
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) tasks_->add(watch_signal(sig));
    if (device_observer_) tasks_->add(pump_devices());
    watchdog_ = notify::watchdog_interval();
    tasks_->add(housekeeping());
    started_ = std::chrono::steady_clock::now();
    notify::ready(status_line());
    log::notice("sculptd ready: {} Hz, input {}, socket {} (served by a later release)", rate_, to_string(cfg_.input),
                cfg_.socket);
  }

  std::uint64_t replay_horizon() const {
    return current_tick() + static_cast<std::uint64_t>(std::llround(kReplayLeadSeconds * rate_)) + 1;
  }

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

  kj::Promise<void> pump_devices() {
    if (drain_devices()) return kj::evalLater([this] { return pump_devices(); });
    return device_observer_->whenBecomesReadable().then([this] { return pump_devices(); });
  }

  // Dispatches ready device fds; true when some may still be ready (the
  // level-triggered inner epoll said so after the round limit).
  bool drain_devices() {
    std::array<epoll_event, 16> ev{};
    for (int round = 0; round < 32; ++round) {
      const int n = ::epoll_wait(epoll_, ev.data(), static_cast<int>(ev.size()), 0);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      for (int i = 0; i < n; ++i) {
        devices_->dispatch(ev[static_cast<std::size_t>(i)].data.fd);
        if (fds_changed_) sync_device_fds();
      }
    }
    return true;
  }

  // Re-registers every device fd: a closed fd's number may already belong
  // to a new device, so nothing registered before is trusted.
  void sync_device_fds() {
    fds_changed_ = false;
    for (int fd : registered_) ::epoll_ctl(epoll_, EPOLL_CTL_DEL, fd, nullptr);  // errors: already gone
    registered_ = devices_->fds();
    for (int fd : registered_) {
      epoll_event e{};
      e.events = EPOLLIN;
      e.data.fd = fd;
      if (::epoll_ctl(epoll_, EPOLL_CTL_ADD, fd, &e) != 0)
        log::warning("cannot watch device fd {}: {}", fd, std::strerror(errno));
    }
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
    if (sim_->finished()) {
      log::info("duration reached: {} ticks", sim_->ticks());
      request_stop(0);
      return;
    }
    if (replay_ && !replay_->finished()) replay_->pump(stages_->ring(), replay_horizon());
    if (watchdog_ && now >= next_watchdog_) {
      // Only a ticking sim thread keeps the service alive: a stuck one gets
      // the process restarted (Restart=on-failure) after WatchdogSec.
      const std::uint64_t t = sim_->ticks();
      if (t != watchdog_ticks_) {
        notify::watchdog();
        watchdog_ticks_ = t;
        stalled_logged_ = false;
      } else if (!stalled_logged_) {
        log::err("sim thread stalled at tick {}: withholding the watchdog ping", t);
        stalled_logged_ = true;
      }
      next_watchdog_ = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                 *watchdog_ * cfg_.watchdog_fraction);
    }
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
                       sim_ ? sim_->stats().overruns.load() : 0, device_count(),
                       haptics_ ? haptics_->stats().ff.uploads.load() : 0);
  }

  void reload() {
    const std::string what = opts_.config_path.empty() ? std::string("(no config file)") : opts_.config_path.string();
    try {
      DaemonConfig next =
          opts_.config_path.empty() ? DaemonConfig{} : load_config(opts_.config_path, opts_.config_optional);
      if (opts_.overrides) opts_.overrides(next);
      input::MappingConfig mapping = input::parse_mapping(next.mapping_table, next.file.empty() ? "config" : next.file);
      // What needs a restart is reported, not applied: the sculpt is kept.
      if (next.scene != cfg_.scene || next.rate_hz != cfg_.rate_hz || to_string(next.input) != to_string(cfg_.input) ||
          next.realtime != cfg_.realtime || next.socket != cfg_.socket)
        log::notice("SIGHUP: scene, rate, input, socket and realtime changes take effect at the next start");
      mapping_ = std::move(mapping);
      cfg_.log_level = next.log_level;
      log::set_level(next.log_level);
      cfg_.haptics = next.haptics;
      haptics_->configure(next.haptics);
      cfg_.watchdog_fraction = next.watchdog_fraction;
      cfg_.input_delay_ms = next.input_delay_ms;
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
    if (sim_) sim_->stop();
    if (haptics_) haptics_->stop();  // stops and erases every effect, closes its fds
  }

  int shutdown(int status) {
    notify::stopping("stopping");
    stop_threads();
    const std::uint64_t devices = device_count();  // attached until now
    tasks_ = nullptr;
    device_observer_ = nullptr;
    devices_.reset();
    if (epoll_ >= 0) ::close(epoll_);
    epoll_ = -1;
    loop::StatsSnapshot s = loop::snapshot(sim_->stats(), rate_);
    s.devices = devices;
    s.ff_uploads = haptics_->stats().ff.uploads.load();
    const std::uint64_t hash = world_->hash();
    log::info("stopped after {} ticks: {} overruns, jitter p50 {:.1f} us p99 {:.1f} us max {:.1f} us, "
              "{} FF uploads ({} errors), final mesh hash {:016x}",
              s.ticks, s.overruns, s.jitter_us.p50, s.jitter_us.p99, s.jitter_us.max, s.ff_uploads,
              haptics_->stats().ff.errors.load(), hash);
    try {
      if (!cfg_.stats_json.empty()) write_file(cfg_.stats_json, loop::stats_json(s).dump(2) + "\n", "--stats-json");
      if (!cfg_.hash_out.empty()) write_file(cfg_.hash_out, fmt::format("{:016x}\n", hash), "--hash-out");
    } catch (const std::exception& e) {
      log::err("{}", e.what());
      return 1;
    }
    return status;
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
  std::array<Anchor, input::kMaxDevices> anchors_{};
  std::uint64_t dropped_ = 0;

  std::unique_ptr<sim::World<float>> world_;
  std::unique_ptr<haptics::FeedbackBoard> board_;
  std::unique_ptr<SculptStages> stages_;
  std::unique_ptr<haptics::HapticsThread> haptics_;
  std::unique_ptr<input::ReplaySource> replay_;
  std::unique_ptr<input::DeviceManager> devices_;
  std::unique_ptr<loop::SimThread> sim_;   // after world/stages: stopped (destroyed) first
  int epoll_ = -1;
  std::vector<int> registered_;
  bool fds_changed_ = false;
  kj::Own<kj::UnixEventPort::FdObserver> device_observer_;

  std::optional<std::chrono::microseconds> watchdog_;
  std::chrono::steady_clock::time_point next_watchdog_{}, next_status_{}, started_{};
  std::uint64_t watchdog_ticks_ = std::numeric_limits<std::uint64_t>::max();
  bool stalled_logged_ = false;
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
