// The server's viewer streams: each viewer's baseline, rate and tolerance,
// the keyframes and the frames the pump sends.
#include "server/server.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include <capnp/rpc.h>
#include <fmt/format.h>

#include "files/unique_fd.hpp"
#include "server/checked_stream.hpp"
#include "server/encode.hpp"
#include "server/interfaces.hpp"
#include "server/server_parts.hpp"
#include "simloop/sim_thread.hpp"

namespace sculpt::server {
namespace {

bool same_tools(const PublishedHeader& a, const PublishedHeader& b) {
  if (a.tool_count != b.tool_count) return false;
  return std::memcmp(a.tools.data(), b.tools.data(), sizeof(PublishedTool) * a.tool_count) == 0;
}

// A tolerance is metres: finite and not negative (0: every change). The
// call fails with the reason otherwise.
float checked_tolerance(float tolerance) {
  KJ_REQUIRE(std::isfinite(tolerance) && tolerance >= 0,
             "toleranceM must be a finite number of metres >= 0 (0 sends every change)", tolerance);
  return tolerance;
}

}  // namespace

float clamp_fps(float fps, float fallback) {
  if (!std::isfinite(fps) || fps <= 0) return fallback;
  return std::clamp(fps, 0.1f, 1000.0f);
}

std::uint64_t Server::add_stream(proto::Viewer::Client viewer, float tolerance, float fps, std::uint64_t client) {
  std::size_t mine = 0;
  for (const auto& [id, st] : streams_) mine += st->client == client && !st->dead;
  KJ_REQUIRE(mine < options_.max_viewers_per_client,
             "too many subscriptions on one connection (max_viewers_per_client)", options_.max_viewers_per_client);
  auto s = std::make_unique<Stream>(kj::mv(viewer));
  s->id = next_stream_++;
  s->client = client;
  s->tolerance = checked_tolerance(tolerance);
  s->fps = clamp_fps(fps, options_.default_fps);
  const std::uint64_t id = s->id;
  if (options_.log)
    options_.log(6, fmt::format("client {}: viewer {} subscribed (tolerance {} m, {} fps)", client, id, s->tolerance,
                                s->fps));
  streams_.emplace(id, std::move(s));
  return id;
}

void Server::remove_stream(std::uint64_t id) {
  auto it = streams_.find(id);
  if (it == streams_.end()) return;
  // Not from inside its own pending promise: that only marks it dead.
  it->second->dead = true;
}

void Server::set_rate(std::uint64_t id, float fps) {
  if (auto it = streams_.find(id); it != streams_.end()) it->second->fps = clamp_fps(fps, options_.default_fps);
}

void Server::set_tolerance(std::uint64_t id, float tolerance) {
  const float checked = checked_tolerance(tolerance);
  if (auto it = streams_.find(id); it != streams_.end()) it->second->tolerance = checked;
}

void Server::fill_keyframe_now(proto::Keyframe::Builder out) {
  if (!reader_) return;
  reader_->sync();
  server::fill_keyframe(out, scene_, *reader_);
}

kj::Promise<void> Server::pump_loop() {
  return io_.provider->getTimer().afterDelay(options_.pump_period).then([this] {
    pump();
    return pump_loop();
  });
}

void Server::pump() {
  check_queues();
  if (!exports_.empty()) expire_exports(simloop::monotonic_ns());
  // Ended streams go first (never from inside their own promise).
  for (auto it = streams_.begin(); it != streams_.end();) {
    if (it->second->dead) {
      if (options_.log) options_.log(7, fmt::format("viewer {} ended", it->first));
      it = streams_.erase(it);
    } else {
      ++it;
    }
  }
  if (streams_.empty() || !reader_) return;
  reader_->sync();
  const std::int64_t now = simloop::monotonic_ns();
  for (auto& [id, s] : streams_) {
    if (s->in_flight || s->dead) continue;
    if (s->needs_keyframe) {
      send_keyframe(*s);
      continue;
    }
    const auto period = static_cast<std::int64_t>(1e9 / s->fps);
    if (now - s->last_send_ns < period) continue;
    send_frame(*s, now);
  }
}

kj::Promise<void> Server::track_send(std::uint64_t id, kj::Promise<void> sent) {
  // One stream call in flight per viewer: its return frees the viewer for
  // the next frame, its failure ends the stream.
  return sent
      .then([this, id] {
              if (auto it = streams_.find(id); it != streams_.end()) it->second->in_flight = false;
            },
            [this, id](kj::Exception&& e) {
              if (auto it = streams_.find(id); it != streams_.end()) {
                it->second->dead = true;
                if (options_.log) options_.log(4, fmt::format("viewer {} ended: {}", id, e.getDescription().cStr()));
              }
            })
      .eagerlyEvaluate(nullptr);
}

void Server::send_keyframe(Stream& s) {
  auto req = s.viewer.keyframeRequest(keyframe_size_hint());
  auto keyframe = req.initKeyframe();
  server::fill_keyframe(keyframe, scene_, *reader_);
  s.baseline.resize(reader_->body_count());
  for (std::size_t b = 0; b < reader_->body_count(); ++b) {
    const auto p = reader_->positions(b);
    s.baseline[b].assign(p.begin(), p.end());
  }
  s.evaluated = reader_->serial();
  s.sent_header = reader_->header();
  // Strictly increasing per viewer, also across a scene swap's new keyframe.
  s.sequence = s.keyframes == 0 ? reader_->header().tick : std::max(reader_->header().tick, s.sequence + 1);
  keyframe.setSequence(s.sequence);
  ++s.keyframes;
  s.needs_keyframe = false;
  s.in_flight = true;
  s.last_send_ns = simloop::monotonic_ns();
  counters_.bytes_sent += req.totalSize().wordCount * 8;
  ++counters_.keyframes;
  s.pending = track_send(s.id, req.send());
}

bool Server::send_frame(Stream& s, std::int64_t now) {
  const PublishedReader& r = *reader_;
  const PublishedHeader& h = r.header();
  const float tol2 = s.tolerance * s.tolerance;
  std::size_t changed_meshes = 0;
  for (std::size_t b = 0; b < r.body_count(); ++b) {
    auto& idx = scratch_[b];
    idx.clear();
    const auto pos = r.positions(b);
    auto& base = s.baseline[b];
    for (std::uint32_t k = 0; k < r.blocks(b); ++k) {
      if (r.block_serial(b, k) <= s.evaluated) continue;
      for (const std::uint32_t o : r.block_vertices(b, k)) {
        const float* p = &pos[std::size_t{o} * 3];
        float* q = &base[std::size_t{o} * 3];
        const float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (d2 > tol2 || (tol2 == 0 && (p[0] != q[0] || p[1] != q[1] || p[2] != q[2]))) idx.push_back(o);
      }
    }
    if (!idx.empty()) {
      std::sort(idx.begin(), idx.end());
      ++changed_meshes;
    }
  }
  s.evaluated = r.serial();
  const bool tools_moved = !same_tools(h, s.sent_header);
  const bool keepalive = now - s.last_send_ns >= options_.keepalive_ns;
  if (changed_meshes == 0 && !tools_moved && !keepalive) return false;

  auto req = s.viewer.frameRequest();
  auto f = req.initFrame();
  // Strictly increasing per viewer: a frame at the same tick as the last
  // (a keep-alive while paused, tools moved) goes one past it.
  f.setSequence(std::max(h.tick, s.sequence + 1));
  f.setSimTimeNs(static_cast<std::uint64_t>(std::llround(static_cast<double>(h.tick) * 1e9 / scene_.rate_hz)));
  f.setPublishedNs(h.published_ns);
  auto meshes = f.initMeshes(static_cast<unsigned>(changed_meshes));
  unsigned m = 0;
  for (std::size_t b = 0; b < r.body_count(); ++b) {
    const auto& idx = scratch_[b];
    if (idx.empty()) continue;
    auto md = meshes[m++];
    md.setMeshId(static_cast<std::uint32_t>(b));
    auto list = md.initIndices(static_cast<unsigned>(idx.size()));
    auto bytes = md.initPositions(idx.size() * 12);
    const auto pos = r.positions(b);
    auto& base = s.baseline[b];
    auto* out = reinterpret_cast<float*>(bytes.begin());
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const std::uint32_t o = idx[k];
      list.set(static_cast<unsigned>(k), o);
      std::memcpy(out + k * 3, &pos[std::size_t{o} * 3], 12);
      std::memcpy(&base[std::size_t{o} * 3], &pos[std::size_t{o} * 3], 12);
    }
    set_bounds(md.initBounds(), r.bounds(b));
  }
  fill_tools(f.initTools(static_cast<unsigned>(std::min<std::size_t>(h.tool_count, scene_.tools.size()))), scene_, h);
  if (now - s.last_stats_ns >= options_.stats_every_ns) {
    DaemonStatus d = status_now();
    d.jitter.clear();  // the overlay needs the quantiles, not the histogram
    d.stats.recent_overruns.clear();  // nor the overrun records (status has them)
    server::fill_stats(f.initStats(), d);
    f.setHasStats(true);
    s.last_stats_ns = now;
  }
  s.sent_header = h;
  s.sequence = f.getSequence();
  s.last_send_ns = now;
  s.in_flight = true;
  counters_.bytes_sent += req.totalSize().wordCount * 8;
  ++counters_.frames;
  if (changed_meshes == 0 && !tools_moved) ++counters_.keepalives;
  s.pending = track_send(s.id, req.send());
  return true;
}

}  // namespace sculpt::server
