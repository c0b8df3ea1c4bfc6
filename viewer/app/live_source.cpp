// Live input: sculptd's stream. Single-threaded: the kj event loop runs
// inside pump(), between frames, so the Viewer callbacks write the model
// while nobody renders it. Reconnects whenever the daemon goes away.
#include <fmt/format.h>
#include <kj/async-io.h>
#include <kj/debug.h>

#include <chrono>
#include <ctime>
#include <memory>
#include <stdexcept>
#include <utility>

#include "app/source.hpp"
#include "cli/conventions.hpp"
#include "client/connection.hpp"
#include "client/mesh_mirror.hpp"
#include "client/socket_path.hpp"

namespace sculpt::view {

namespace {

using Clock = std::chrono::steady_clock;

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1000000000 + ts.tv_nsec;
}

class LiveSource;

// What the daemon calls. It may outlive the source inside capnp's
// bookkeeping, so it reaches the source through a pointer the source clears.
class ViewerImpl final : public proto::Viewer::Server {
 public:
  explicit ViewerImpl(std::shared_ptr<LiveSource*> owner) : owner_(std::move(owner)) {}

 protected:
  kj::Promise<void> keyframe(KeyframeContext context) override;
  kj::Promise<void> frame(FrameContext context) override;

 private:
  std::shared_ptr<LiveSource*> owner_;
};

class LiveSource final : public Source {
 public:
  explicit LiveSource(const Options& options)
      : options_(options),
        io_(kj::setupAsyncIo()),
        path_(client::resolve_socket_path(options.socket)),
        self_(std::make_shared<LiveSource*>(this)) {
    model_.scene = "";
    try {
      connect();
    } catch (const client::ClientError& e) {
      if (e.kind() != client::ClientError::Kind::no_daemon || !options_.wait) {
        throw std::runtime_error(fmt::format(
            "{}{}", e.what(),
            e.kind() == client::ClientError::Kind::no_daemon
                ? " (is sculptd running? start it, pass --socket PATH, or --wait to keep trying)"
                : ""));
      }
      note_down(e.what());
    }
  }

  ~LiveSource() noexcept override {
    *self_ = nullptr;
    drop();
  }

  void pump(double timeout_s) override {
    if (!connection_ && Clock::now() >= next_retry_) {
      try {
        connect();
        say(fmt::format("connected to {} ({})", path_, connection_->server()));
      } catch (const client::ClientError& e) {
        if (e.kind() == client::ClientError::Kind::incompatible) throw std::runtime_error(e.what());
        note_down(e.what());
      }
    }
    const auto ms = static_cast<std::int64_t>(timeout_s * 1000.0);
    try {
      io_.provider->getTimer().afterDelay(ms * kj::MILLISECONDS).wait(io_.waitScope);
    } catch (const kj::Exception& e) {
      lost(fmt::format("the daemon went away ({})", e.getDescription().cStr()));
    }
    if (!lost_why_.empty()) {
      drop();
      note_down(std::exchange(lost_why_, {}));
    }
    if (!fatal_.empty()) throw std::runtime_error(fatal_);
  }

  bool has_state() const override { return mirror_.has_keyframe(); }

  std::vector<std::string> describe() const override {
    std::vector<std::string> lines;
    if (!connection_) {
      lines.push_back(fmt::format("NO DAEMON ON {}: RETRYING", path_));
    }
    if (const auto& s = model_.stats) {
      lines.push_back(fmt::format("SCULPTD {:.0f} HZ{}  JITTER P99 {:.0f} US  OVERRUNS {}{}", s->rate_hz,
                                  measured_hz_ > 0 ? fmt::format(" (KEPT {:.0f})", measured_hz_) : "",
                                  s->jitter_p99_us, s->overruns, s->paused ? "  PAUSED" : ""));
      lines.push_back(fmt::format("AWAKE {}/{} VERTICES  VIEWERS {}  DEVICES {}", s->vertices_awake,
                                  s->vertices_total, s->viewers, s->devices));
    }
    if (mirror_.has_keyframe()) {
      lines.push_back(fmt::format("TICK {}  FRAMES {}  LAG {:.1f} MS", mirror_.sequence(), mirror_.frames(),
                                  lag_ms_));
    }
    return lines;
  }

  // --- called by ViewerImpl, inside pump() ---
  void on_keyframe(proto::Keyframe::Reader s) {
    try {
      mirror_.apply(s);
    } catch (const client::MirrorError& e) {
      fatal_ = fmt::format("the daemon sent a keyframe this viewer cannot use: {}", e.what());
      return;
    }
    ViewModel m;
    m.scene = s.getScene().cStr();
    for (const auto& mm : mirror_.meshes()) {
      std::string material;
      for (const auto pm : s.getMeshes()) {
        if (pm.getId() == mm.id) material = pm.getMaterial().getName().cStr();
      }
      m.meshes.emplace_back(mm.id, mm.name, material, mm.triangles, mm.rest, mm.positions);
      m.meshes.back().set_bounds({mm.lo, mm.hi});
    }
    copy_tools(m);
    m.stats = model_.stats;
    m.sequence = mirror_.sequence();
    m.generation = model_.generation + 1;
    const auto b = s.getSceneBounds();
    m.scene_bounds = {{b.getMin().getX(), b.getMin().getY(), b.getMin().getZ()},
                      {b.getMax().getX(), b.getMax().getY(), b.getMax().getZ()}};
    if (m.scene_bounds.empty()) m.scene_bounds = m.bounds_now();
    model_ = std::move(m);
    say(fmt::format("keyframe: {} meshes, tick {}", model_.meshes.size(), model_.sequence));
  }

  void on_frame(proto::DeltaFrame::Reader f) {
    if (!mirror_.has_keyframe()) return;
    std::span<const client::ChangedRange> ranges;
    try {
      ranges = mirror_.apply(f);
    } catch (const client::MirrorError& e) {
      // Out of step with the daemon: start over with a fresh keyframe.
      lost(fmt::format("out of step with the daemon ({}): resubscribing", e.what()));
      return;
    }
    // model_.meshes was built in the mirror's order (on_keyframe), so a
    // mirror index is a model index; the mirror already holds the new bounds.
    for (const auto& r : ranges) {
      const auto& mm = mirror_.meshes()[r.mesh];
      model_.meshes[r.mesh].set_range(
          r.begin, r.end,
          std::span<const float>(mm.positions).subspan(std::size_t{r.begin} * 3, std::size_t{r.end - r.begin} * 3));
    }
    for (std::size_t k = 0; k < model_.meshes.size(); ++k) {
      model_.meshes[k].set_bounds({mirror_.meshes()[k].lo, mirror_.meshes()[k].hi});
    }
    copy_tools(model_);
    model_.sequence = mirror_.sequence();
    if (mirror_.published_ns() > 0) lag_ms_ = static_cast<double>(monotonic_ns() - mirror_.published_ns()) * 1e-6;
    if (f.getHasStats()) {
      const auto s = f.getStats();
      ViewStats v;
      v.rate_hz = s.getRateHz();
      v.jitter_p99_us = s.getJitterUs().getP99();
      v.overruns = s.getOverruns();
      v.vertices_total = s.getVerticesTotal();
      v.vertices_awake = s.getVerticesAwake();
      v.viewers = s.getViewers();
      v.devices = s.getDevices();
      v.paused = s.getPaused();
      // The rate the loop really keeps, between two stats messages.
      if (last_uptime_s_ > 0 && s.getUptimeS() > last_uptime_s_ && s.getTicks() >= last_ticks_) {
        measured_hz_ = static_cast<double>(s.getTicks() - last_ticks_) / (s.getUptimeS() - last_uptime_s_);
      }
      last_ticks_ = s.getTicks();
      last_uptime_s_ = s.getUptimeS();
      model_.stats = v;
    }
  }

 private:
  void say(const std::string& text) const {
    if (!options_.quiet) cli::note(text);
  }

  void note_down(const std::string& why) {
    if (why != last_down_) say(fmt::format("{}; retrying every 0.5 s", why));
    last_down_ = why;
    next_retry_ = Clock::now() + std::chrono::milliseconds(500);
  }

  // Called inside the event loop; pump() drops the connection afterwards.
  void lost(const std::string& why) {
    if (lost_why_.empty()) lost_why_ = why;
    last_down_.clear();
  }

  void copy_tools(ViewModel& m) const {
    m.tools.clear();
    for (const auto& t : mirror_.tools()) {
      ViewTool v;
      v.id = t.id;
      v.shape = t.shape == proto::ToolShape::CAPSULE ? ToolShape::capsule : ToolShape::sphere;
      v.radius = t.radius;
      v.half_length = t.half_length;
      v.position = t.position;
      v.orientation = t.orientation;
      v.grabbing = t.grabbing;
      v.force = t.contact_force;
      v.contacts = t.contacts;
      m.tools.push_back(v);
    }
  }

  void connect() {
    auto c = std::make_unique<client::Connection>(io_, path_, "sculpt-view 0.1.0");
    auto req = c->session().subscribeRequest();
    req.setViewer(kj::heap<ViewerImpl>(self_));
    req.setToleranceM(options_.tolerance_m);
    req.setMaxFps(static_cast<float>(options_.max_fps > 0 ? options_.max_fps : options_.fps));
    auto reply = client::guarded("subscribe", [&] { return req.send().wait(io_.waitScope); });
    subscription_ = reply.getSubscription();
    watch_ = c->on_disconnect()
                 .then([this]() { lost("the daemon went away"); },
                       [this](kj::Exception&& e) {
                         lost(fmt::format("the daemon went away ({})", e.getDescription().cStr()));
                       })
                 .eagerlyEvaluate(nullptr);
    connection_ = std::move(c);
    last_down_.clear();
  }

  void drop() {
    watch_ = nullptr;
    subscription_ = nullptr;
    connection_.reset();
  }

  Options options_;
  kj::AsyncIoContext io_;
  std::string path_;
  std::shared_ptr<LiveSource*> self_;
  std::unique_ptr<client::Connection> connection_;
  proto::Subscription::Client subscription_{nullptr};
  kj::Maybe<kj::Promise<void>> watch_;
  client::MeshMirror mirror_;
  std::string lost_why_;  // "" while connected
  std::string fatal_;
  std::string last_down_;
  Clock::time_point next_retry_{};
  double lag_ms_ = 0;
  std::uint64_t last_ticks_ = 0;
  double last_uptime_s_ = 0;
  double measured_hz_ = 0;
};

kj::Promise<void> ViewerImpl::keyframe(KeyframeContext context) {
  if (LiveSource* s = *owner_) s->on_keyframe(context.getParams().getKeyframe());
  return kj::READY_NOW;
}

kj::Promise<void> ViewerImpl::frame(FrameContext context) {
  if (LiveSource* s = *owner_) s->on_frame(context.getParams().getFrame());
  return kj::READY_NOW;
}

}  // namespace

std::unique_ptr<Source> make_live_source(const Options& options) { return std::make_unique<LiveSource>(options); }

}  // namespace sculpt::view
