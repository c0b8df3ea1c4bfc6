// The haptics thread's work, without the thread: attached devices, the tools
// each one feels, and per poll the decision what to upload. Single-threaded;
// HapticsThread drives it. Tests drive it directly with a fake FfPort and an
// explicit clock.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "haptics/effect_math.hpp"
#include "haptics/feedback_board.hpp"
#include "haptics/ff_device.hpp"
#include "haptics/ff_port.hpp"
#include "haptics/pacer.hpp"
#include "haptics/trigger_renderer.hpp"

namespace sculpt::haptics {

// A tool a device feels, and how its stick maps onto the tool's axes.
struct ToolStick {
  int tool = 0;
  StickPlane plane{};
};

struct HapticsSettings {
  bool enabled = true;                                  // false: no device is opened for FF
  std::chrono::milliseconds poll_interval{4};           // how often the thread reads the board
  std::chrono::milliseconds min_upload_interval{25};    // per device, between uploads
  ForceScale force{};
  RumbleScale rumble{};
  ChangeThreshold change{};
  std::uint16_t gain = 0xffff;                          // FF_GAIN
  bool constant = true;                                 // FF_CONSTANT from the contact force
  bool rumble_on_onset = true;                          // FF_RUMBLE kick when contact begins
  TriggerSettings triggers{};                           // DualSense adaptive triggers (trigger_renderer.hpp)
};

// Opens an event node for FF; the default is open_evdev_port.
using PortOpener = std::function<std::unique_ptr<FfPort>(const std::string& node)>;
// Finds and opens the DualSense hidraw node behind an event node; the default
// is open_dualsense_hidraw (nullopt: not a DualSense; throws: cannot open).
using TriggerOpener = std::function<std::optional<DualSenseHidraw>(const std::string& event_node)>;

// Where the engine's few messages go (device opened, no FF, open failed):
// priority is syslog's (4 warning, 6 info). Empty: stderr with the sd-daemon
// prefix. sculptd passes its log module.
using LogSink = std::function<void(int priority, const std::string& message)>;

struct HapticsStats {
  FfCounters ff;                              // uploads, errors, kicks, live effect ids
  std::atomic<int> devices{0};                // devices attached (FF or not)
  std::atomic<int> ff_devices{0};             // of those, with usable FF
  std::atomic<std::uint64_t> open_failures{0};
  // Successful uploads per device slot (the input layer's slots, which a
  // replugged device keeps), counted since the daemon started.
  static constexpr int kSlots = 16;
  std::array<std::atomic<std::uint64_t>, kSlots> slot_uploads{};
  TriggerCounters triggers;                   // DualSense trigger reports
};

class HapticsEngine {
 public:
  HapticsEngine(const FeedbackBoard& board, HapticsSettings settings, PortOpener opener,
                HapticsStats& stats, LogSink log = {});
  ~HapticsEngine();  // shutdown()

  // A device appeared on `slot` (the input layer's stable slot) at `node`,
  // driving `tools`. Replaces what was on the slot (that one is shut down).
  // Open failures are counted and logged, never thrown.
  // `triggers`: which tools a DualSense's triggers drive (none: not driven).
  void attach(int slot, const std::string& node, std::vector<ToolStick> tools, TriggerBinding triggers = {});
  // Unplugged: the kernel already dropped its effects; forget the ids.
  void detach(int slot);
  void configure(const HapticsSettings& settings);

  // Reads the board and uploads what is due.
  void poll(Clock::time_point now);
  // Stop and erase every effect of every device, close them. Idempotent.
  void shutdown();

  void set_trigger_opener(TriggerOpener opener) { trigger_opener_ = std::move(opener); }

  // For tests and logs.
  const FfDevice* device(int slot) const;
  const TriggerRenderer* triggers(int slot) const;
  const std::string& last_error() const { return last_error_; }

 private:
  struct Attached {
    std::string node;
    std::vector<ToolStick> tools;
    std::unique_ptr<FfDevice> ff;  // null: no FF (or it could not be opened)
    ConstantPacer constant;
    KickPacer kick;
    std::vector<std::uint64_t> onsets_seen;  // per tool: the board's onset counter at the last poll
    bool primed = false;                     // onsets before the first poll give no kick
    // ENODEV while the input layer still has the device plugged in: when it
    // was first seen, and how many times the node was reopened since attach.
    std::optional<Clock::time_point> gone_since;
    int reopens = 0;
    std::uint64_t uploads_counted = 0;  // of ff->uploads(), already in slot_uploads
  };
  void open_ff(Attached& d);
  void detach_alive(int slot);
  void say(int priority, const std::string& message) const;
  void poll_device(Attached& d, Clock::time_point now);
  void reopen_if_still_plugged(Attached& d, Clock::time_point now);
  void count_uploads(int slot, Attached& d);

  // DualSense triggers (haptics_engine_triggers.cpp), beside the FF devices:
  // a slot's renderer lives as long as its attach.
  struct TriggerSlot {
    std::string node;
    TriggerBinding binding;
    std::unique_ptr<TriggerRenderer> renderer;  // null: not a DualSense, no access, or disabled
  };
  void attach_triggers(int slot, const std::string& node, TriggerBinding binding);
  void open_triggers(TriggerSlot& t);
  void detach_triggers(int slot, bool unplugged);
  void configure_triggers();
  void poll_triggers(Clock::time_point now);
  void shutdown_triggers();

  const FeedbackBoard& board_;
  HapticsSettings settings_;
  PortOpener opener_;
  HapticsStats& stats_;
  LogSink log_;
  std::map<int, Attached> devices_;
  std::string last_error_;
  TriggerOpener trigger_opener_ = [](const std::string& node) { return open_dualsense_hidraw(node); };
  std::map<int, TriggerSlot> trigger_slots_;
  bool told_no_trigger_access_ = false;  // EACCES on a hidraw node is said once
};

}  // namespace sculpt::haptics
