// The Sony DualSense's adaptive triggers, as bytes: the output report that
// sets each trigger's resistance, the felt force → resistance mapping, and
// when to send. Pure (no I/O, time passed in): unit-tested byte for byte.
//
// Byte layout (docs/haptics.md, "DualSense triggers", has the table and the
// sources): Linux drivers/hid/hid-playstation.c gives the report ids, sizes,
// headers, the BT tag/sequence byte and the CRC32; the trigger valid flags
// (valid_flag0 bit 2 right, bit 3 left) and the two 11-byte effect blocks
// inside the driver's reserved2[28] come from dualsensectl and Nielk1's
// TriggerEffectGenerator.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>

#include "haptics/device_tuning.hpp"
#include "haptics/effect_math.hpp"
#include "haptics/feedback_board.hpp"

namespace sculpt::haptics::dualsense {

using Clock = std::chrono::steady_clock;

inline constexpr std::uint16_t kSonyVendor = 0x054c;
inline constexpr std::uint16_t kDualSenseProduct = 0x0ce6;
inline constexpr std::uint16_t kDualSenseEdgeProduct = 0x0df2;
bool is_dualsense(std::uint16_t vendor, std::uint16_t product);

enum class Transport : std::uint8_t { usb, bluetooth };

// hid-playstation.c: DS_OUTPUT_REPORT_USB 0x02 (63 bytes with the id),
// DS_OUTPUT_REPORT_BT 0x31 (78 bytes: id, seq_tag, tag 0x10, the common part,
// 24 reserved, CRC32 little-endian).
inline constexpr std::uint8_t kUsbReportId = 0x02;
inline constexpr std::size_t kUsbReportSize = 63;
inline constexpr std::uint8_t kBtReportId = 0x31;
inline constexpr std::size_t kBtReportSize = 78;
inline constexpr std::uint8_t kBtTag = 0x10;
inline constexpr std::uint8_t kOutputCrcSeed = 0xa2;  // PS_OUTPUT_CRC32_SEED
inline constexpr std::size_t kMaxReportSize = kBtReportSize;

// Where the common part starts in each report, and where its fields sit.
inline constexpr std::size_t kUsbCommonOffset = 1;
inline constexpr std::size_t kBtCommonOffset = 3;
inline constexpr std::size_t kValidFlag0 = 0;
inline constexpr std::uint8_t kFlag0RightTrigger = 1u << 2;
inline constexpr std::uint8_t kFlag0LeftTrigger = 1u << 3;
inline constexpr std::size_t kRightTriggerBlock = 10;  // mode, then 10 parameter bytes
inline constexpr std::size_t kLeftTriggerBlock = 21;
inline constexpr std::size_t kTriggerBlockSize = 11;

// Effect modes (Nielk1's TriggerEffectType). 0x05 is the firmware's "off":
// no resistance, the trigger stop back at neutral. 0x01 is continuous
// resistance: from parameter 0 (start position, 0..255 of the travel) on, the
// trigger resists with parameter 1 (force, 0..255).
inline constexpr std::uint8_t kModeOff = 0x05;
inline constexpr std::uint8_t kModeResistance = 0x01;

struct TriggerEffect {
  std::uint8_t mode = kModeOff;
  std::array<std::uint8_t, 10> params{};
  bool operator==(const TriggerEffect&) const = default;
  bool neutral() const { return mode == kModeOff; }
};

TriggerEffect neutral_effect();
// Continuous resistance of `force` from `start`; force 0 is the neutral effect,
// so "no resistance" has one spelling and the pacer sees one state.
TriggerEffect resistance_effect(std::uint8_t start, std::uint8_t force);

struct TriggerPair {
  TriggerEffect left;
  TriggerEffect right;
  bool operator==(const TriggerPair&) const = default;
};

// Builds the output report that sets both triggers and nothing else: only
// the two trigger valid flags are set, so the rumble motors, lights and audio
// keep what the kernel driver last gave them (the firmware applies a field
// only when its valid flag is set; the driver itself sends rumble-only and
// light-only reports that way). `bt_seq` (0..15) goes into the BT header's
// high nibble. Returns the report's length (kUsbReportSize or kBtReportSize).
std::size_t build_trigger_report(Transport transport, const TriggerPair& effects, std::uint8_t bt_seq,
                                 std::span<std::uint8_t, kMaxReportSize> out);

// CRC-32 (IEEE, reflected, as zlib's crc32 and the kernel's ~crc32_le(~0, ..))
// continuing from `crc` (start with 0).
std::uint32_t crc32(std::uint32_t crc, std::span<const std::uint8_t> data);
// The BT output report's CRC: over the seed byte 0xA2, then the report
// without its last 4 bytes.
std::uint32_t bt_output_crc(std::span<const std::uint8_t> report_without_crc);

// How a felt force becomes a trigger's resistance.
struct TriggerScale {
  ForceScale force{};              // the felt level curve every effect shares (effect_math.hpp)
  DeviceTuning tuning{};           // the pad's gain and hard limit
  double strength = 1.0;           // 0..1: the full-level force byte is strength·255
  std::uint8_t start = 0;          // where on the travel the resistance begins (0: at rest)
};

// 0 (neutral) when the tool is not touching or the force is not finite;
// else round(tuned(level_from_force(|F|)) · strength · 255), at least 1: the
// lightest touch is felt, as on the motors. Monotonic in |F|.
std::uint8_t resistance_from_force(const ToolForce& felt, const TriggerScale& scale);

// Why the triggers must be neutral whatever the tools say: the board is held
// (paused, swapping, stopped) or its beat stopped moving (the sim stalled).
class StallWatch {
 public:
  explicit StallWatch(std::chrono::nanoseconds stall_after) : stall_after_(stall_after) {}
  // True while the beat moved within stall_after of `now`. The first look
  // counts as a move (a fresh watch does not call a running sim stalled).
  bool alive(std::uint64_t beats, Clock::time_point now);

 private:
  std::chrono::nanoseconds stall_after_;
  bool seen_ = false;
  std::uint64_t last_beats_ = 0;
  Clock::time_point moved_at_{};
};

// Per device: only on a real change against what the pad has, and no more
// often than the transport allows (USB ≥ 10 ms, Bluetooth ≥ 25 ms apart).
// A change that has to wait is not lost; a failed write is retried once the
// interval has passed.
class TriggerPacer {
 public:
  explicit TriggerPacer(std::chrono::nanoseconds min_interval) : interval_(min_interval) {}
  static std::chrono::nanoseconds min_interval(Transport t);

  bool should_send(const TriggerPair& want, Clock::time_point now) const;
  void sent(const TriggerPair& p, Clock::time_point now);
  void failed(Clock::time_point now);
  // Nothing is known of the pad's state: the next want goes out.
  void reset() { has_sent_ = false; }
  const TriggerPair& last_sent() const { return last_; }

 private:
  std::chrono::nanoseconds interval_;
  bool has_sent_ = false;
  bool retry_ = false;
  TriggerPair last_{};
  Clock::time_point last_at_{};
};

}  // namespace sculpt::haptics::dualsense
