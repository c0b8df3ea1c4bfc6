#include "haptics/trigger_renderer.hpp"

#include <algorithm>
#include <cerrno>
#include <thread>
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
                                 TriggerCounters* counters, std::chrono::nanoseconds stall_after)
    : port_(std::move(hidraw.port)),
      transport_(hidraw.transport),
      binding_(binding),
      scale_(scale),
      counters_(counters),
      pacer_(dualsense::TriggerPacer::min_interval(transport_)),
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
  if (!pacer_.should_send(p, now)) return;
  last_write_at_ = now;
  if (write(p))
    pacer_.sent(p, now);
  else
    pacer_.failed(now);
}

bool TriggerRenderer::write(const dualsense::TriggerPair& pair) {
  std::array<std::uint8_t, dualsense::kMaxReportSize> buf{};
  const std::size_t len = dualsense::build_trigger_report(transport_, pair, bt_seq_, buf);
  const int err = port_->write_report(std::span<const std::uint8_t>(buf.data(), len));
  if (transport_ == dualsense::Transport::bluetooth) bt_seq_ = (bt_seq_ + 1) & 0x0f;
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
  // Keep the transport's spacing even now: the last write may be a moment ago.
  // (Bounded by the interval: a poll time from a test's own clock may lie ahead.)
  const auto interval = dualsense::TriggerPacer::min_interval(transport_);
  const auto wait = last_write_at_ + interval - Clock::now();
  if (wait > Clock::duration::zero()) std::this_thread::sleep_for(std::min<Clock::duration>(wait, interval));
  write(dualsense::TriggerPair{});
}

void TriggerRenderer::forget() { gone_ = true; }

}  // namespace sculpt::haptics
