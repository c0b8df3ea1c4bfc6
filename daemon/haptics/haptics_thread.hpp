// sculptd's haptics thread: never the simulation thread. Paced (every
// poll_interval) it reads the FeedbackBoard and updates each device's effects
// through its OWN O_RDWR fds, so FF ioctls (which wait for the driver, up to
// 30 s on a stuck uinput device) block neither the io nor the sim thread.
//
//   HapticsThread haptics(board, settings);
//   haptics.start();
//   haptics.attach(slot, "/dev/input/event5", {{tool, plane}});   // io thread, on hot-plug
//   haptics.detach(slot);                                          // io thread, on unplug
//   haptics.stats().ff.uploads.load();                             // any thread
//   haptics.stop();                                                // stops + erases every effect
//
// Commands travel through a mutex-protected queue: this thread is not real-time.
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "haptics/haptics_engine.hpp"

namespace sculpt::haptics {

class HapticsThread {
 public:
  HapticsThread(const FeedbackBoard& board, HapticsSettings settings, PortOpener opener = open_evdev_port,
                LogSink log = {});
  ~HapticsThread();  // stop()
  HapticsThread(const HapticsThread&) = delete;
  HapticsThread& operator=(const HapticsThread&) = delete;

  void start();
  // Stops and erases every effect of every device, then joins. Idempotent.
  void stop();
  bool running() const { return thread_.joinable(); }

  // Thread-safe; applied at the thread's next wake-up (immediately woken).
  void attach(int slot, std::string node, std::vector<ToolStick> tools, TriggerBinding triggers = {});
  void detach(int slot);
  void configure(const HapticsSettings& settings);  // SIGHUP: also drops run-time tunes

  // Run-time gain and limit for a slot (0..kSlots-1): any thread, applied at
  // the next poll, kept for the slot across replug until configure().
  // Throws std::invalid_argument naming the field (or the slot).
  void tune(int slot, DeviceTuning t);
  // Any thread: the slot's tuning in force (a tune is seen at once).
  DeviceTuning tuning(int slot) const;
  // Any thread: the machine resumed from suspend (logind): devices are
  // reopened with a neutral state at the next poll.
  void resumed();
  // Any thread: the attached device's input_id.bustype; 0 when unknown.
  std::uint16_t bustype(int slot) const;

  // Blocks until every command queued so far has been applied and one poll
  // has run after it (tests and orderly shutdown; never from the sim thread).
  void flush();

  const HapticsStats& stats() const { return stats_; }

 private:
  struct Attach { int slot; std::string node; std::vector<ToolStick> tools; TriggerBinding triggers; };
  struct Detach { int slot; };
  struct Configure { HapticsSettings settings; };
  struct Tune { int slot; DeviceTuning tuning; };
  struct Resumed {};
  using Command = std::variant<Attach, Detach, Configure, Tune, Resumed>;

  void run();
  void push(Command c);

  HapticsStats stats_;
  HapticsEngine engine_;
  std::chrono::milliseconds poll_interval_;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable done_;
  std::deque<Command> queue_;
  std::uint64_t polls_ = 0;      // polls completed
  bool wake_now_ = false;        // flush(): poll without waiting for the schedule
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace sculpt::haptics
