// One DualSense's adaptive triggers, driven from the FeedbackBoard: each
// trigger resists with the felt contact force of the tool it drives (the tool
// whose depth role the trigger axis is bound to), and is neutral when that
// tool is not touching, the board is held, the sim stalled, and on shutdown.
// Single-threaded (the haptics thread); time passed in, and each write
// stamped on the device's WritePacer (shared with a DualSense's FF node: one
// firmware) with the time it returned.
//
//   TriggerRenderer r(open_dualsense_hidraw(node).value(), {left_tool, right_tool}, scale);
//   r.poll(board, now);   // every haptics poll
//   r.forget();           // unplugged: nothing more is written
//   r.shutdown();         // stop: neutral written, then nothing more
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "haptics/dualsense_triggers.hpp"
#include "haptics/effect_math.hpp"
#include "haptics/feedback_board.hpp"
#include "haptics/hidraw_port.hpp"
#include "haptics/pacer.hpp"

namespace sculpt::haptics {

// Which tool each trigger drives (-1: none; that trigger stays neutral).
struct TriggerBinding {
  int left_tool = -1;   // ABS_Z (L2) bound to the tool's depth role
  int right_tool = -1;  // ABS_RZ (R2)
  bool any() const { return left_tool >= 0 || right_tool >= 0; }
  bool operator==(const TriggerBinding&) const = default;
};

// [haptics] triggers, trigger_strength, trigger_start.
struct TriggerSettings {
  bool enabled = true;     // false: no hidraw node is opened
  double strength = 1.0;   // 0..1 of the full force byte at full-scale force
  std::uint8_t start = 0;  // where on the travel the resistance begins
};

// The level curve and the pad's tuning are the motors': one felt force reads
// the same on the stick and on the trigger, and the hard limit holds for both.
dualsense::TriggerScale trigger_scale(const TriggerSettings& triggers, const ForceScale& force,
                                      const DeviceTuning& tuning);

struct TriggerCounters {
  std::atomic<std::uint64_t> writes{0};  // reports written
  std::atomic<std::uint64_t> errors{0};  // failed writes
  std::atomic<int> devices{0};           // DualSenses with their triggers driven now
};

class TriggerRenderer {
 public:
  static constexpr std::chrono::milliseconds kStallAfter{100};  // a 1 kHz sim beats 100 times in this

  // `stall_after`: the engine passes its own (HapticsSettings::stall_after),
  // so the triggers go neutral within the same budget as the motors.
  // `pacer`: the device's, shared with its FF node (null: one of its own,
  // the transport's interval); `time` stamps it and waits for it.
  TriggerRenderer(DualSenseHidraw hidraw, TriggerBinding binding, dualsense::TriggerScale scale,
                  TriggerCounters* counters = nullptr, std::chrono::nanoseconds stall_after = kStallAfter,
                  std::shared_ptr<WritePacer> pacer = nullptr, TimeSource& time = steady_time());
  ~TriggerRenderer();  // shutdown()
  TriggerRenderer(const TriggerRenderer&) = delete;
  TriggerRenderer& operator=(const TriggerRenderer&) = delete;

  // What the pad should have now (advances the stall watch).
  dualsense::TriggerPair want(const FeedbackBoard& board, Clock::time_point now);
  // Writes it when it changed and the transport's interval has passed since
  // this renderer's last write and since the device's (the pacer's).
  void poll(const FeedbackBoard& board, Clock::time_point now);
  void set_scale(const dualsense::TriggerScale& scale) { scale_ = scale; }
  // Writes neutral once more (waiting on the time source until both
  // intervals allow it), then nothing. Idempotent.
  void shutdown();
  // Unplugged: the pad is gone with its state; nothing more is written.
  void forget();

  bool gone() const { return gone_; }
  bool stopped() const { return stopped_; }
  dualsense::Transport transport() const { return transport_; }
  const std::string& node() const { return port_->node(); }
  const dualsense::TriggerPair& last_sent() const { return pacer_.last_sent(); }
  std::uint64_t writes() const { return writes_; }
  // The device's last write was this renderer's (its pacer counted no other since).
  bool wrote_last() const { return pacer_writes_ == device_pacer_->writes(); }

 private:
  // Writes and stamps both pacers when it returned; false: failed (ENODEV
  // marks it gone).
  bool write(const dualsense::TriggerPair& pair);

  std::unique_ptr<HidrawPort> port_;
  dualsense::Transport transport_;
  TriggerBinding binding_;
  dualsense::TriggerScale scale_;
  TriggerCounters* counters_;
  dualsense::TriggerPacer pacer_;
  std::shared_ptr<WritePacer> device_pacer_;
  TimeSource* time_;
  dualsense::StallWatch stall_;
  std::uint8_t bt_seq_ = 0;
  std::uint64_t writes_ = 0;
  std::uint64_t pacer_writes_ = ~std::uint64_t{0};  // the device pacer's count after our last write
  std::optional<Clock::time_point> last_write_at_;
  bool gone_ = false;
  bool stopped_ = false;
};

}  // namespace sculpt::haptics
