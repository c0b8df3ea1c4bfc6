// The server on FakeControl (fake_control.hpp) listening on a Unix socket,
// on a thread of its own: what sculptctl's tests and the fuzz seed recorder
// (fake_sculptd.cpp) talk to instead of a sculptd whose daemon side does not
// implement history and export yet.
#pragma once

#include <condition_variable>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "fake_control.hpp"
#include "server/listener.hpp"

namespace sculpt::test {

class FakeDaemon {
 public:
  // `setup` runs on the server's thread before it listens.
  explicit FakeDaemon(std::string socket, std::function<void(FakeControl&)> setup = {}) : socket_(std::move(socket)) {
    thread_ = std::thread([this, setup = std::move(setup)] { run(setup); });
    std::unique_lock lock(mutex_);
    ready_cv_.wait(lock, [this] { return ready_; });
    if (!error_.empty()) {
      lock.unlock();
      thread_.join();
      throw std::runtime_error(error_);
    }
  }
  ~FakeDaemon() {
    executor_->executeSync([this] { stop_->fulfill(); });
    thread_.join();
  }
  FakeDaemon(const FakeDaemon&) = delete;
  FakeDaemon& operator=(const FakeDaemon&) = delete;

  const std::string& socket() const { return socket_; }
  // Runs `f` with the control on the server's thread (to change its answers
  // or read what it was asked) and waits for it.
  void with_control(const std::function<void(FakeControl&)>& f) {
    executor_->executeSync([&] { f(*control_); });
  }

 private:
  void run(const std::function<void(FakeControl&)>& setup) {
    Harness h;
    if (setup) setup(h.control);
    server::ListenSocket listener;
    try {
      listener = server::ListenSocket::open(socket_);
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      error_ = e.what();
      ready_ = true;
      ready_cv_.notify_all();
      return;
    }
    h.server->listen(listener.release());
    auto stop = kj::newPromiseAndFulfiller<void>();
    {
      std::lock_guard lock(mutex_);
      executor_ = &kj::getCurrentThreadExecutor();
      stop_ = kj::mv(stop.fulfiller);
      control_ = &h.control;
      ready_ = true;
    }
    ready_cv_.notify_all();
    stop.promise.wait(h.io.waitScope);
    h.server->close();
  }

  std::string socket_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable ready_cv_;
  bool ready_ = false;
  std::string error_;
  const kj::Executor* executor_ = nullptr;
  kj::Own<kj::PromiseFulfiller<void>> stop_;
  FakeControl* control_ = nullptr;
};

}  // namespace sculpt::test
