// A client that asks a running sculptd for its status every 10 ms, on its
// own thread and connection, and keeps how long each answer took. The io
// loop must never make it wait long, whatever else the daemon is doing
// (loading a scene, serving a flood, refusing garbage).
//
// A shared machine can make any answer late on its own: the daemon's io
// thread or the probe's thread may sit runnable while another process has
// the CPU. Each call reads both threads' time on the run queue
// (/proc/.../schedstat, field 2) before and after: a wait longer than the
// limit is the host's when that queueing accounts for what went over. Only
// the rest are the daemon's.
#pragma once

#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <kj/async-io.h>

#include "client/connection.hpp"

namespace sculpt::e2e {

class StatusProbe {
 public:
  struct Result {
    std::uint64_t calls = 0, failures = 0;
    double worst_ms = 0;            // longest wait, whoever's
    double worst_daemon_ms = 0;     // longest wait once the run-queue time of both threads is taken off
    std::uint64_t over_limit = 0;   // waits over the limit
    std::uint64_t over_limit_daemon = 0;  // of those, not accounted for by queueing: the daemon's
    std::string first_failure;
    // When each wait whose daemon's part (less queueing) was over half the
    // limit began, and that part (ms).
    std::vector<std::pair<std::chrono::steady_clock::time_point, double>> slow;
  };

  StatusProbe(std::string socket, pid_t daemon, double limit_ms = 50)
      : socket_(std::move(socket)), daemon_(daemon), limit_ms_(limit_ms) {
    thread_ = std::thread([this] { run(); });
  }
  ~StatusProbe() { stop(); }
  StatusProbe(const StatusProbe&) = delete;
  StatusProbe& operator=(const StatusProbe&) = delete;

  Result stop() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
    return result();
  }
  Result result() const {
    std::lock_guard lock(mutex_);
    return result_;
  }

 private:
  // Nanoseconds the thread has waited on a run queue (0 where not readable).
  static std::uint64_t run_delay_ns(const std::string& schedstat) {
    std::ifstream in(schedstat);
    std::uint64_t on_cpu = 0, waited = 0;
    in >> on_cpu >> waited;
    return waited;
  }

  void run() {
    const std::string daemon_io = "/proc/" + std::to_string(daemon_) + "/task/" + std::to_string(daemon_) + "/schedstat";
    const std::string mine = "/proc/thread-self/schedstat";
    auto io = kj::setupAsyncIo();
    std::unique_ptr<client::Connection> c;
    while (!stop_.load()) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::uint64_t q0 = run_delay_ns(daemon_io) + run_delay_ns(mine);
      bool ok = true;
      std::string why;
      try {
        if (!c) c = std::make_unique<client::Connection>(io, socket_, "status-probe");
        c->session().statusRequest().send().wait(io.waitScope);
      } catch (const std::exception& e) {
        ok = false, why = e.what();
        c.reset();
      } catch (const kj::Exception& e) {
        ok = false, why = e.getDescription().cStr();
        c.reset();
      }
      const auto t1 = std::chrono::steady_clock::now();
      const std::uint64_t q1 = run_delay_ns(daemon_io) + run_delay_ns(mine);
      const double ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
      const double queued_ms = static_cast<double>(q1 - q0) * 1e-6;
      {
        std::lock_guard lock(mutex_);
        ++result_.calls;
        if (!ok) {
          ++result_.failures;
          if (result_.first_failure.empty()) result_.first_failure = why;
        }
        result_.worst_ms = std::max(result_.worst_ms, ms);
        result_.worst_daemon_ms = std::max(result_.worst_daemon_ms, ms - queued_ms);
        if (ms > limit_ms_) {
          ++result_.over_limit;
          if (ms - queued_ms > limit_ms_) ++result_.over_limit_daemon;
        }
        // Half the limit is worth a line in the log: what the daemon was doing then.
        if (ms - queued_ms > limit_ms_ / 2) result_.slow.emplace_back(t0, ms - queued_ms);
      }
      std::this_thread::sleep_until(t0 + std::chrono::milliseconds(10));
    }
  }

  std::string socket_;
  pid_t daemon_;
  double limit_ms_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  Result result_;
  std::thread thread_;
};

}  // namespace sculpt::e2e
