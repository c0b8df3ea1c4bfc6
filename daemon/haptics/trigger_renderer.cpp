#include "haptics/trigger_renderer.hpp"

#include <algorithm>
#include <cerrno>
#include <utility>

namespace sculpt::haptics {

dualsense::TriggerScale trigger_scale(const TriggerSettings& triggers, const ForceScale& force,
                                      const DeviceTuning& tuning) {
  dualsense::TriggerScale s;
  s.force = force;
  s.tuning = tuning;
  s.strength = triggers.strength;
  s.start = triggers.start;
  return s;
}

TriggerRenderer::TriggerRenderer(DualSenseHidraw hidraw, TriggerBinding binding, dualsense::TriggerScale scale,
                                 TriggerCounters* counters, std::chrono::nanoseconds stall_after,
                                 std::shared_ptr<WritePacer> pacer, TimeSource& time)
    : port_(std::move(hidraw.port)),
      transport_(hidraw.transport),
      binding_(binding),
      scale_(scale),
      counters_(counters),
      pacer_(dualsense::TriggerPacer::min_interval(transport_)),
      device_pacer_(pacer ? std::move(pacer)
                          : std::make_shared<WritePacer>(dualsense::TriggerPacer::min_interval(transport_))),
      time_(&time),
      stall_(stall_after) {
  if (counters_) counters_->devices.fetch_add(1, std::memory_order_relaxed);
}

TriggerRenderer::~TriggerRenderer() {
  shutdown();
  if (counters_) counters_->devices.fetch_sub(1, std::memory_order_relaxed);
}

dualsense::TriggerPair TriggerRenderer::want(const FeedbackBoard& board, Clock::time_point now) {
  const bool alive = stall_.alive(board.beats(), now);  // always advanced: a resumed sim is not "stalled" for long
  dualsense::TriggerPair p;
  if (board.hold() != Hold::none || !alive) return p;
  auto effect = [&](int tool) {
    if (tool < 0) return dualsense::neutral_effect();
    return dualsense::resistance_effect(scale_.start, dualsense::resistance_from_force(board.read(tool), scale_));
  };
  p.left = effect(binding_.left_tool);
  p.right = effect(binding_.right_tool);
  return p;
}

void TriggerRenderer::poll(const FeedbackBoard& board, Clock::time_point now) {
  if (gone_ || stopped_) return;
  const dualsense::TriggerPair p = want(board, now);
  if (!device_pacer_->ready(now) || !pacer_.should_send(p, now)) return;
  write(p);
}

bool TriggerRenderer::write(const dualsense::TriggerPair& pair) {
  std::array<std::uint8_t, dualsense::kMaxReportSize> buf{};
  const std::size_t len = dualsense::build_trigger_report(transport_, pair, bt_seq_, buf);
  const int err = port_->write_report(std::span<const std::uint8_t>(buf.data(), len));
  if (transport_ == dualsense::Transport::bluetooth) bt_seq_ = (bt_seq_ + 1) & 0x0f;
  if (err != ENODEV) {
    // Stamped when the write returned: the interval runs between the
    // reports the kernel got, however long this one took.
    const Clock::time_point at = time_->now();
    last_write_at_ = at;
    device_pacer_->wrote(at);
    pacer_writes_ = device_pacer_->writes();
    if (err == 0)
      pacer_.sent(pair, at);
    else
      pacer_.failed(at);
  }
  if (err == 0) {
    ++writes_;
    if (counters_) counters_->writes.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  if (counters_) counters_->errors.fetch_add(1, std::memory_order_relaxed);
  if (err == ENODEV) gone_ = true;  // unplugged: the detach follows
  return false;
}

void TriggerRenderer::shutdown() {
  if (stopped_) return;
  stopped_ = true;
  if (gone_) return;
  // Keep the spacing even now: the last write to the pad (ours, or its FF
  // node's) may be a moment ago.
  device_pacer_->wait(*time_);
  if (last_write_at_) time_->sleep_until(*last_write_at_ + dualsense::TriggerPacer::min_interval(transport_));
  write(dualsense::TriggerPair{});
}

void TriggerRenderer::forget() { gone_ = true; }

}  // namespace sculpt::haptics
