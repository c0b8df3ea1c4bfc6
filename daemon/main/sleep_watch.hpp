// logind's PrepareForSleep signal on the system bus, on its own thread: tells
// the caller when the machine is about to sleep (true) and has resumed
// (false). Pads may lose their FF state over a suspend; the haptics thread
// also sees the resume by CLOCK_BOOTTIME jumping, this is the prompt path.
// Without a system bus (containers, the test VM) it logs once and does nothing.
#pragma once

#include <atomic>
#include <functional>
#include <thread>

namespace sculpt::daemon {

class SleepWatch {
 public:
  // on_sleep(true) before a suspend, on_sleep(false) after the resume; called
  // on the watch's thread.
  explicit SleepWatch(std::function<void(bool sleeping)> on_sleep);
  ~SleepWatch();  // stop()
  SleepWatch(const SleepWatch&) = delete;
  SleepWatch& operator=(const SleepWatch&) = delete;

  void start();  // connects on its thread: the caller never waits for the bus
  void stop();

 private:
  void run();
  std::function<void(bool)> on_sleep_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace sculpt::daemon
