#include "haptics/dualsense_triggers.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace sculpt::haptics::dualsense {

bool is_dualsense(std::uint16_t vendor, std::uint16_t product) {
  return vendor == kSonyVendor && (product == kDualSenseProduct || product == kDualSenseEdgeProduct);
}

TriggerEffect neutral_effect() { return TriggerEffect{}; }

TriggerEffect resistance_effect(std::uint8_t start, std::uint8_t force) {
  if (force == 0) return neutral_effect();
  TriggerEffect e;
  e.mode = kModeResistance;
  e.params[0] = start;
  e.params[1] = force;
  return e;
}

namespace {
void put_block(std::uint8_t* at, const TriggerEffect& e) {
  at[0] = e.mode;
  std::memcpy(at + 1, e.params.data(), e.params.size());
}
}  // namespace

std::size_t build_trigger_report(Transport transport, const TriggerPair& effects, std::uint8_t bt_seq,
                                 std::span<std::uint8_t, kMaxReportSize> out) {
  std::fill(out.begin(), out.end(), std::uint8_t{0});
  const bool bt = transport == Transport::bluetooth;
  const std::size_t len = bt ? kBtReportSize : kUsbReportSize;
  std::uint8_t* common = out.data() + (bt ? kBtCommonOffset : kUsbCommonOffset);
  if (bt) {
    out[0] = kBtReportId;
    out[1] = static_cast<std::uint8_t>((bt_seq & 0x0f) << 4);  // seq in the high nibble, tag nibble 0
    out[2] = kBtTag;
  } else {
    out[0] = kUsbReportId;
  }
  common[kValidFlag0] = kFlag0RightTrigger | kFlag0LeftTrigger;
  put_block(common + kRightTriggerBlock, effects.right);
  put_block(common + kLeftTriggerBlock, effects.left);
  if (bt) {
    const std::uint32_t crc = bt_output_crc(std::span<const std::uint8_t>(out.data(), len - 4));
    for (int i = 0; i < 4; ++i) out[len - 4 + i] = static_cast<std::uint8_t>(crc >> (8 * i));
  }
  return len;
}

std::uint32_t crc32(std::uint32_t crc, std::span<const std::uint8_t> data) {
  crc = ~crc;
  for (std::uint8_t byte : data) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

std::uint32_t bt_output_crc(std::span<const std::uint8_t> report_without_crc) {
  const std::uint8_t seed = kOutputCrcSeed;
  return crc32(crc32(0, std::span<const std::uint8_t>(&seed, 1)), report_without_crc);
}

std::uint8_t resistance_from_force(const ToolForce& felt, const TriggerScale& scale) {
  const double magnitude = std::hypot(felt.force[0], felt.force[1], felt.force[2]);
  const double level = tuned(level_from_force(magnitude, felt.touching, scale.force), scale.tuning);
  const double strength = std::clamp(std::isfinite(scale.strength) ? scale.strength : 0.0, 0.0, 1.0);
  if (!(level > 0) || strength == 0) return 0;
  return static_cast<std::uint8_t>(std::clamp(std::lround(level * strength * 255.0), 1L, 255L));
}

bool StallWatch::alive(std::uint64_t beats, Clock::time_point now) {
  if (!seen_ || beats != last_beats_) {
    seen_ = true;
    last_beats_ = beats;
    moved_at_ = now;
    return true;
  }
  return now - moved_at_ <= stall_after_;
}

std::chrono::nanoseconds TriggerPacer::min_interval(Transport t) {
  using namespace std::chrono_literals;
  return t == Transport::bluetooth ? std::chrono::nanoseconds(25ms) : std::chrono::nanoseconds(10ms);
}

bool TriggerPacer::should_send(const TriggerPair& want, Clock::time_point now) const {
  if (!has_sent_) return true;
  if (now - last_at_ < interval_) return false;
  return retry_ || !(want == last_);
}

void TriggerPacer::sent(const TriggerPair& p, Clock::time_point now) {
  has_sent_ = true;
  retry_ = false;
  last_ = p;
  last_at_ = now;
}

void TriggerPacer::failed(Clock::time_point now) {
  // Not known what the pad has: resend once the interval has passed.
  has_sent_ = true;
  retry_ = true;
  last_at_ = now;
}

}  // namespace sculpt::haptics::dualsense
