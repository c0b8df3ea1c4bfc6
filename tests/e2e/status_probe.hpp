// A client that asks a running sculptd for its status every 10 ms, on its
// own thread and connection, and keeps every call: whether it was answered,
// how long the answer took, and what of that time was the machine's.
//
// The tests use it to check that the daemon kept answering (failures == 0)
// whatever else it was doing; how long the answers took is a benchmark's
// figure (status_bench.cpp), never a test's: a shared machine can make any
// answer late on its own.
//
// What is whose: around each call the probe reads the run-queue time
// (/proc/.../schedstat, field 2: time runnable but waiting for a CPU) of its
// own thread, of the daemon's io thread (its main thread, where the kj loop
// runs) and of every thread of the daemon. Time the probe or the io thread
// spent waiting for a CPU was the machine's; the rest of the wait is the
// daemon's part. The other daemon threads' queueing is kept apart: they wait
// for a CPU while the io thread runs too, so taking it off as well gives only
// a lower bound of the daemon's part.
#pragma once

#include <dirent.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <kj/async-io.h>

#include "client/connection.hpp"

namespace sculpt::e2e {

class StatusProbe {
 public:
  struct Sample {
    std::chrono::steady_clock::time_point at;  // when the call was sent
    double wait_ms = 0;                        // until its answer (or failure)
    double probe_queued_ms = 0;                // the probe thread's run-queue time meanwhile
    double io_queued_ms = 0;                   // the daemon's io thread's
    double daemon_queued_ms = 0;               // all the daemon's threads', summed (the io thread's included)
    bool ok = true;
    // The wait less the probe's and the io thread's queueing.
    double daemons_part_ms() const { return std::max(0.0, wait_ms - probe_queued_ms - io_queued_ms); }
    // ... less every daemon thread's queueing: a lower bound.
    double daemons_part_all_ms() const { return std::max(0.0, wait_ms - probe_queued_ms - daemon_queued_ms); }
  };
  struct Result {
    std::uint64_t calls = 0, failures = 0;
    std::string first_failure;
    std::vector<Sample> samples;  // since the start or the last take_samples()
  };

  StatusProbe(std::string socket, pid_t daemon, std::chrono::milliseconds every = std::chrono::milliseconds(10))
      : socket_(std::move(socket)), daemon_(daemon), every_(every) {
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
  // Calls made so far, answered or failed.
  std::uint64_t calls() const {
    std::lock_guard lock(mutex_);
    return result_.calls;
  }
  // The samples since the last call (the counts go on).
  std::vector<Sample> take_samples() {
    std::lock_guard lock(mutex_);
    return std::exchange(result_.samples, {});
  }
  // Waits until `n` more calls were made than when it was called; false
  // after `timeout`.
  bool wait_for_calls(std::uint64_t n, std::chrono::milliseconds timeout) {
    const std::uint64_t target = calls() + n;
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (calls() < target) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

  // Run-queue time (ns) of one thread, 0 where not readable.
  static std::uint64_t run_delay_ns(const std::string& schedstat) {
    std::ifstream in(schedstat);
    std::uint64_t on_cpu = 0, waited = 0;
    in >> on_cpu >> waited;
    return waited;
  }
  // Run-queue time (ns) of every thread of `pid` now, by thread id.
  static std::map<pid_t, std::uint64_t> run_delays_ns(pid_t pid) {
    std::map<pid_t, std::uint64_t> out;
    const std::string dir = "/proc/" + std::to_string(pid) + "/task";
    if (DIR* d = ::opendir(dir.c_str())) {
      while (const dirent* e = ::readdir(d)) {
        if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
        out[static_cast<pid_t>(std::atoi(e->d_name))] = run_delay_ns(dir + "/" + e->d_name + "/schedstat");
      }
      ::closedir(d);
    }
    return out;
  }

 private:
  void run() {
    const std::string mine = "/proc/thread-self/schedstat";
    auto io = kj::setupAsyncIo();
    std::unique_ptr<client::Connection> c;
    while (!stop_.load()) {
      const std::uint64_t mine0 = run_delay_ns(mine);
      const auto daemon0 = run_delays_ns(daemon_);
      const auto t0 = std::chrono::steady_clock::now();
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
      const auto daemon1 = run_delays_ns(daemon_);
      const std::uint64_t mine1 = run_delay_ns(mine);
      Sample s;
      s.at = t0;
      s.ok = ok;
      s.wait_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
      s.probe_queued_ms = static_cast<double>(mine1 - mine0) * 1e-6;
      for (const auto& [tid, after] : daemon1) {
        // A thread that began during the call waited all its queueing then.
        const auto before = daemon0.find(tid);
        const std::uint64_t base = before == daemon0.end() ? 0 : std::min(before->second, after);
        const double ms = static_cast<double>(after - base) * 1e-6;
        s.daemon_queued_ms += ms;
        if (tid == daemon_) s.io_queued_ms = ms;
      }
      {
        std::lock_guard lock(mutex_);
        ++result_.calls;
        if (!ok) {
          ++result_.failures;
          if (result_.first_failure.empty()) result_.first_failure = why;
        }
        if (result_.samples.size() < kMaxSamples) result_.samples.push_back(s);
      }
      std::this_thread::sleep_until(t0 + every_);
    }
  }

  static constexpr std::size_t kMaxSamples = 1 << 20;
  std::string socket_;
  pid_t daemon_;
  std::chrono::milliseconds every_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  Result result_;
  std::thread thread_;
};

// p50, p99 and the largest of some figures (the nearest-rank percentile).
struct Spread {
  double p50 = NAN, p99 = NAN, max = NAN;
};
inline Spread spread(std::vector<double> v) {
  Spread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const auto rank = [&](double q) {
    const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
    return v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)];
  };
  s.p50 = rank(0.5), s.p99 = rank(0.99), s.max = v.back();
  return s;
}

// What a set of status calls waited, and whose the wait was.
struct WaitSpread {
  std::size_t calls = 0, failures = 0;
  Spread wait, probe_queued, io_queued, daemon_queued, daemons_part, daemons_part_all;
};
inline WaitSpread wait_spread(const std::vector<StatusProbe::Sample>& samples) {
  WaitSpread w;
  std::vector<double> wait, probe, io, all, part, part_all;
  for (const auto& s : samples) {
    ++w.calls;
    if (!s.ok) {
      ++w.failures;
      continue;
    }
    wait.push_back(s.wait_ms), probe.push_back(s.probe_queued_ms), io.push_back(s.io_queued_ms);
    all.push_back(s.daemon_queued_ms), part.push_back(s.daemons_part_ms()), part_all.push_back(s.daemons_part_all_ms());
  }
  w.wait = spread(wait), w.probe_queued = spread(probe), w.io_queued = spread(io), w.daemon_queued = spread(all);
  w.daemons_part = spread(part), w.daemons_part_all = spread(part_all);
  return w;
}

// One line for a test's log: the figures, not a verdict.
inline void print_waits(const char* what, const std::vector<StatusProbe::Sample>& samples) {
  const WaitSpread w = wait_spread(samples);
  std::printf("%s: %zu status calls (%zu failed), wait p50 %.1f p99 %.1f max %.1f ms; the daemon's part (the wait "
              "less the probe's and the daemon io thread's run-queue time) p50 %.1f p99 %.1f max %.1f ms "
              "(figures only: status_bench measures them)\n",
              what, w.calls, w.failures, w.wait.p50, w.wait.p99, w.wait.max, w.daemons_part.p50, w.daemons_part.p99,
              w.daemons_part.max);
}

}  // namespace sculpt::e2e
