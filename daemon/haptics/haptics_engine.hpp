// The haptics thread's work, without the thread: attached devices, the tools
// each one feels, and per poll what each device should play. Single-threaded;
// HapticsThread drives it. Tests drive it directly with a fake FfPort and a
// fake TimeSource (and an explicit CLOCK_BOOTTIME reading for suspend).
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "input/input_message.hpp"  // input::kMaxDevices
#include "haptics/device_player.hpp"
#include "haptics/device_tuning.hpp"
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

// Which devices a [[haptics.device]] override is for: every given field
// must match (vendor and product exactly, name as a substring).
struct DeviceMatch {
  std::optional<std::uint16_t> vendor;
  std::optional<std::uint16_t> product;
  std::string name;  // empty: any
  bool matches(const DeviceIdentity& id) const;
};
struct DeviceOverride {
  DeviceMatch match;
  DeviceTuning tuning;
};

struct HapticsSettings {
  bool enabled = true;                                  // false: no device is opened for FF
  std::chrono::milliseconds poll_interval{4};           // how often the thread reads the board
  TransportPacing pacing{};                             // per device, between any two writes
  std::chrono::milliseconds stall_after{15};            // board beats still this long: the sim thread stalled
  std::chrono::milliseconds effect_length{20000};       // replay.length of the force effect (< 65 s)
  std::chrono::milliseconds rearm_every{5000};          // it is replayed this often while it plays
  ForceScale force{};
  RumbleScale rumble{};
  ChangeThreshold change{};
  std::uint16_t gain = 0xffff;                          // FF_GAIN
  bool constant = true;                                 // FF_CONSTANT from the contact force
  bool rumble_on_onset = true;                          // a kick when contact begins
  DeviceTuning tuning{};                                // every device's gain and limit...
  std::vector<DeviceOverride> devices;                  // ...unless the first matching override says otherwise
  TriggerSettings triggers{};                           // DualSense adaptive triggers (trigger_renderer.hpp)
};

// Opens an event node for FF; the default is open_evdev_port.
using PortOpener = std::function<std::unique_ptr<FfPort>(const std::string& node)>;
// Finds and opens the DualSense hidraw node behind an event node; the default
// is open_dualsense_hidraw (nullopt: not a DualSense; throws: cannot open).
using TriggerOpener = std::function<std::optional<DualSenseHidraw>(const std::string& event_node)>;

// Where the engine's few messages go (device opened, no FF, open failed):
// priority is syslog's (4 warning, 6 info). Empty: stderr as plain text
// ("haptics: warning: ..."). sculptd passes its log module, which adds the
// sd-daemon prefix ("<4>") only when stderr is the journal.
using LogSink = std::function<void(int priority, const std::string& message)>;

struct HapticsStats {
  FfCounters ff;                              // uploads, errors, kicks, live effect ids
  std::atomic<int> devices{0};                // devices attached (FF or not)
  std::atomic<int> ff_devices{0};             // of those, with usable FF
  std::atomic<std::uint64_t> open_failures{0};
  // A freshly attached (or reopened) device's first write: succeeded, or
  // failed with an error; "not ready yet" answers (ENODEV from a uinput
  // device not created yet) are retried and counted apart, not as errors.
  std::atomic<std::uint64_t> first_uploads{0};
  std::atomic<std::uint64_t> first_upload_failures{0};
  std::atomic<std::uint64_t> not_ready_retries{0};
  std::atomic<std::uint64_t> stalls{0};       // sim thread stalls seen (effects zeroed)
  std::atomic<std::uint64_t> resumes{0};      // resumes from suspend seen (devices reopened)
  // Per device slot (the input layer's slots, which a replugged device keeps).
  static constexpr int kSlots = static_cast<int>(input::kMaxDevices);  // one per device slot
  std::array<std::atomic<std::uint64_t>, kSlots> slot_uploads{};       // successful uploads since start
  std::array<std::atomic<std::int64_t>, kSlots> slot_first_upload_ns{}; // latest attach → its first success
  std::array<std::atomic<std::uint16_t>, kSlots> slot_bustype{};       // 0: unknown / nothing attached
  std::array<std::atomic<double>, kSlots> slot_gain{};                 // the slot's DeviceTuning in force
  std::array<std::atomic<double>, kSlots> slot_limit{};
  HapticsStats() {
    for (auto& g : slot_gain) g.store(1.0);
    for (auto& l : slot_limit) l.store(1.0);
  }
  TriggerCounters triggers;                   // DualSense trigger reports
};

class HapticsEngine {
 public:
  // `time`: the clock every decision reads and every write is stamped with,
  // and what a write that must wait for its pacer sleeps on.
  HapticsEngine(const FeedbackBoard& board, HapticsSettings settings, PortOpener opener, HapticsStats& stats,
                LogSink log = {}, TimeSource& time = steady_time());
  ~HapticsEngine();  // shutdown()

  // A device appeared on `slot` (the input layer's stable slot) at `node`,
  // driving `tools`. Replaces what was on the slot (that one is shut down,
  // its erases paced; the same node keeps its pacer).
  // Open failures are counted and logged, never thrown.
  // `triggers`: which tools a DualSense's triggers drive (none: not driven).
  void attach(int slot, const std::string& node, std::vector<ToolStick> tools, TriggerBinding triggers = {});
  // Unplugged: the kernel already dropped its effects; forget the ids (and
  // the slot's pacer).
  void detach(int slot);
  // SIGHUP: new settings; run-time tunes are dropped (the config rules again).
  void configure(const HapticsSettings& settings);
  // Run-time gain and limit for a slot, kept across replug until configure().
  // Throws std::invalid_argument (naming the field, or the slot).
  void tune(int slot, DeviceTuning t);
  // The tuning in force for the slot: a run-time tune, else the config's for
  // the device attached there (overrides), else the [haptics] default.
  DeviceTuning tuning(int slot) const;

  // Reads the board and writes what is due, at the time source's now.
  // `boottime` (CLOCK_BOOTTIME, since boot) lets the engine see a suspend:
  // BOOTTIME runs on through it, the monotonic clock does not.
  void poll(std::optional<std::chrono::nanoseconds> boottime = std::nullopt);
  // When a zero (stall, hold) waits for a device's pacer: the earliest time
  // one may go out. The thread polls then rather than at its next tick.
  std::optional<Clock::time_point> next_due() const;
  // The machine resumed from suspend (logind's PrepareForSleep(false), or a
  // BOOTTIME jump): reopen every device, which sends a fresh neutral state.
  // A second report of the same resume (within 5 s) is ignored.
  void resumed(const std::string& how);
  // Erase every effect of every device (paced), close them. Idempotent.
  void shutdown();

  void set_trigger_opener(TriggerOpener opener) { trigger_opener_ = std::move(opener); }

  // For tests and logs.
  const FfDevice* device(int slot) const;
  const DevicePlayer* player(int slot) const;
  const TriggerRenderer* triggers(int slot) const;
  const std::string& last_error() const { return last_error_; }
  bool stalled() const { return stalled_; }

 private:
  struct Attached {
    int slot = 0;
    std::string node;
    std::vector<ToolStick> tools;
    std::unique_ptr<FfDevice> ff;  // null: no FF (or it could not be opened)
    DevicePlayer player;
    std::vector<std::uint64_t> onsets_seen;  // per tool: the board's onset counter at the last poll
    bool primed = false;                     // onsets before the first poll give no kick
    // ENODEV while the input layer still has the device plugged in: when it
    // was first seen, and how many times the node was reopened since attach.
    std::optional<Clock::time_point> gone_since;
    int reopens = 0;
    std::uint64_t uploads_counted = 0;  // of ff->uploads(), already in slot_uploads
    std::optional<Clock::time_point> opened_at;  // the first poll after the open
    bool first_settled = false;                  // the first write succeeded or failed
  };
  void open_ff(Attached& d);
  void detach_alive(int slot);
  // The pacer of the device on `slot` at `node`: the one it had (kept across
  // reopen, reconfigure and re-attach), or a new one with `interval`.
  std::shared_ptr<WritePacer> slot_pacer(int slot, const std::string& node, std::chrono::nanoseconds interval);
  void say(int priority, const std::string& message) const;
  bool silent(Clock::time_point now);
  void watch_suspend(Clock::time_point now, std::optional<std::chrono::nanoseconds> boottime);
  void poll_device(Attached& d, Clock::time_point now, bool silent);
  void watch_first_write(Attached& d, Clock::time_point now, bool attempted);
  void reopen_if_still_plugged(Attached& d, Clock::time_point now);
  void reopen(Attached& d);
  void count_uploads(int slot, Attached& d);
  PlayerTiming timing_for() const;
  void resumed_at(Clock::time_point now, const std::string& how);
  DeviceTuning config_tuning(const Attached* d) const;
  void publish_tuning(int slot);

  // DualSense triggers (haptics_engine_triggers.cpp), beside the FF devices:
  // a slot's renderer lives as long as its attach.
  struct TriggerSlot {
    int slot = 0;
    std::string node;
    TriggerBinding binding;
    std::unique_ptr<TriggerRenderer> renderer;  // null: not a DualSense, no access, or disabled
    bool polled = false;                        // in this poll already
  };
  // One per device (slot and node): its FF node and its triggers write to one
  // firmware, so they share it. Dropped on unplug.
  struct SlotPacer {
    std::string node;
    std::shared_ptr<WritePacer> pacer;
  };
  void attach_triggers(int slot, const std::string& node, TriggerBinding binding);
  void open_triggers(TriggerSlot& t);
  void detach_triggers(int slot, bool unplugged);
  void configure_triggers();
  void poll_triggers(bool before_motors, bool quiet);
  void shutdown_triggers();

  const FeedbackBoard& board_;
  HapticsSettings settings_;
  PortOpener opener_;
  HapticsStats& stats_;
  LogSink log_;
  TimeSource& time_;
  std::map<int, Attached> devices_;
  std::map<int, SlotPacer> pacers_;
  std::map<int, DeviceTuning> tunes_;  // run-time, per slot
  std::string last_error_;
  // The sim thread's beat, for stalls.
  std::uint64_t last_beats_ = 0;
  bool beats_moved_ = false;
  Clock::time_point last_beat_at_{};
  Hold last_hold_ = Hold::none;
  bool stalled_ = false;
  std::optional<std::chrono::nanoseconds> boot_offset_;  // CLOCK_BOOTTIME − CLOCK_MONOTONIC
  std::optional<Clock::time_point> last_resume_;
  TriggerOpener trigger_opener_ = [](const std::string& node) { return open_dualsense_hidraw(node); };
  std::map<int, TriggerSlot> trigger_slots_;
  bool told_no_trigger_access_ = false;  // EACCES on a hidraw node is said once
};

}  // namespace sculpt::haptics
