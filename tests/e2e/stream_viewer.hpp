// A test viewer: its own thread and kj event loop, connected to sculptd
// through the client library, subscribed with a tolerance and a rate, keeping
// a MeshMirror. It can stop reading (its thread blocks inside a frame, so its
// socket fills up) and resume. Everything the test reads is copied under a
// mutex.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <time.h>
#include <vector>

#include <kj/async-io.h>

#include "client/connection.hpp"
#include "client/mesh_mirror.hpp"

namespace sculpt::e2e {

class StreamViewer {
 public:
  struct Seen {
    std::uint64_t keyframes = 0, frames = 0, keepalives = 0, frames_with_meshes = 0;
    std::uint64_t sequence = 0;       // of the last keyframe or frame
    std::uint64_t not_increasing = 0; // keyframes and frames whose sequence was not above the last one's
    std::uint64_t frame_bytes = 0;    // message payloads of the frames received
    bool error = false;
    std::string error_text;
  };

  StreamViewer(std::string socket, float tolerance, float fps)
      : socket_(std::move(socket)), tolerance_(tolerance), fps_(fps) {
    thread_ = std::thread([this] { run(); });
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, std::chrono::seconds(20), [&] { return subscribed_ || seen_.error; });
  }
  ~StreamViewer() { stop(); }
  StreamViewer(const StreamViewer&) = delete;
  StreamViewer& operator=(const StreamViewer&) = delete;

  void stop() {
    {
      std::lock_guard lock(mutex_);
      blocked_ = false;
    }
    changed_.notify_all();
    stopping_.store(true);
    if (thread_.joinable()) thread_.join();
  }

  // The viewer's thread blocks inside its next frame until resume_reading().
  void stop_reading() {
    std::lock_guard lock(mutex_);
    blocked_ = true;
  }
  void resume_reading() {
    {
      std::lock_guard lock(mutex_);
      blocked_ = false;
    }
    changed_.notify_all();
  }

  float tolerance() const { return tolerance_; }
  Seen seen() const {
    std::lock_guard lock(mutex_);
    return seen_;
  }
  std::vector<client::MirrorMesh> meshes() const {
    std::lock_guard lock(mutex_);
    return mirror_.meshes();
  }
  // Waits until a frame or keyframe at or after `sequence` arrived.
  bool wait_for_sequence(std::uint64_t sequence, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return seen_.error || seen_.sequence >= sequence; }) &&
           !seen_.error;
  }
  bool wait_for_frames(std::uint64_t frames, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return seen_.error || seen_.frames >= frames; }) && !seen_.error;
  }
  // Tick → receipt latencies (ns) of the frames with changes since the last call.
  std::vector<std::int64_t> take_latencies() {
    std::lock_guard lock(mutex_);
    return std::exchange(latencies_, {});
  }
  bool blocked_now() const {
    std::lock_guard lock(mutex_);
    return inside_block_;
  }

 private:
  class Impl final : public proto::Viewer::Server {
   public:
    explicit Impl(StreamViewer& v) : v_(v) {}
    kj::Promise<void> keyframe(KeyframeContext context) override {
      std::lock_guard lock(v_.mutex_);
      try {
        v_.mirror_.apply(context.getParams().getKeyframe());
        if (v_.seen_.keyframes + v_.seen_.frames > 0 && v_.mirror_.sequence() <= v_.seen_.sequence)
          ++v_.seen_.not_increasing;
        ++v_.seen_.keyframes;
        v_.seen_.sequence = v_.mirror_.sequence();
      } catch (const std::exception& e) {
        v_.seen_.error = true;
        v_.seen_.error_text = e.what();
      }
      v_.changed_.notify_all();
      return kj::READY_NOW;
    }
    kj::Promise<void> frame(FrameContext context) override {
      {
        std::unique_lock lock(v_.mutex_);
        if (v_.blocked_) {
          v_.inside_block_ = true;
          v_.changed_.wait(lock, [&] { return !v_.blocked_; });
          v_.inside_block_ = false;
        }
      }
      std::lock_guard lock(v_.mutex_);
      try {
        const auto f = context.getParams().getFrame();
        v_.mirror_.apply(f);
        ++v_.seen_.frames;
        if (f.getMeshes().size() == 0) ++v_.seen_.keepalives;
        else ++v_.seen_.frames_with_meshes;
        if (f.getSequence() <= v_.seen_.sequence) ++v_.seen_.not_increasing;
        v_.seen_.sequence = f.getSequence();
        v_.seen_.frame_bytes += context.getParams().totalSize().wordCount * 8;
        if (f.getMeshes().size() > 0 && v_.latencies_.size() < kMaxLatencies) {
          timespec ts;
          clock_gettime(CLOCK_MONOTONIC, &ts);
          const std::int64_t now = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
          v_.latencies_.push_back(now - f.getPublishedNs());
        }
      } catch (const std::exception& e) {
        v_.seen_.error = true;
        v_.seen_.error_text = e.what();
      }
      v_.changed_.notify_all();
      return kj::READY_NOW;
    }

   private:
    StreamViewer& v_;
  };

  void run() {
    try {
      auto io = kj::setupAsyncIo();
      client::Connection c(io, socket_, "stream-test-viewer");
      auto req = c.session().subscribeRequest();
      req.setViewer(kj::heap<Impl>(*this));
      req.setToleranceM(tolerance_);
      req.setMaxFps(fps_);
      auto sub = req.send().wait(io.waitScope).getSubscription();
      {
        std::lock_guard lock(mutex_);
        subscribed_ = true;
      }
      changed_.notify_all();
      bool gone = false;
      auto disconnect = c.on_disconnect().then([&] { gone = true; }, [&](kj::Exception&&) { gone = true; })
                            .eagerlyEvaluate(nullptr);
      // Polls the stop flag between short timer waits (the loop serves the
      // daemon's calls meanwhile).
      while (!stopping_.load() && !gone) io.provider->getTimer().afterDelay(10 * kj::MILLISECONDS).wait(io.waitScope);
      if (gone) fail("the daemon hung up");
    } catch (const std::exception& e) {
      fail(e.what());
    } catch (const kj::Exception& e) {
      fail(e.getDescription().cStr());
    }
  }
  void fail(const std::string& what) {
    std::lock_guard lock(mutex_);
    seen_.error = true;
    seen_.error_text = what;
    changed_.notify_all();
  }

  std::string socket_;
  float tolerance_, fps_;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  client::MeshMirror mirror_;
  Seen seen_;
  static constexpr std::size_t kMaxLatencies = 1 << 20;
  std::vector<std::int64_t> latencies_;
  bool subscribed_ = false;
  bool blocked_ = false;
  bool inside_block_ = false;
};

}  // namespace sculpt::e2e
