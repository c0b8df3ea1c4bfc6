#include "input/replay_source.hpp"

#include <cmath>

#include <fmt/format.h>

namespace sculpt::input {

ReplaySource::ReplaySource(const std::filesystem::path& file, double rate_hz, Binder binder)
    : reader_(file), rate_hz_(rate_hz), binder_(std::move(binder)) {
  if (!(rate_hz_ > 0.0) || !std::isfinite(rate_hz_))
    throw RecordingError(fmt::format("{}: replay rate must be a positive number of Hz", file.string()));
}

void ReplaySource::start(std::uint64_t start_tick) { start_tick_ = start_tick == 0 ? 1 : start_tick; }

std::uint64_t replay_tick(std::uint64_t start_tick, std::int64_t t_us, double rate_hz) {
  if (t_us < 0) t_us = 0;
  if (rate_hz == std::floor(rate_hz) && rate_hz > 0 && rate_hz < 1e9) {
    const auto rate = static_cast<std::uint64_t>(rate_hz);
    const auto t = static_cast<std::uint64_t>(t_us);
    return start_tick + (t * rate + 500000) / 1000000;
  }
  return start_tick + static_cast<std::uint64_t>(std::llround(static_cast<double>(t_us) * rate_hz / 1e6));
}

std::uint64_t ReplaySource::tick_of(std::int64_t t_us) const { return replay_tick(start_tick_, t_us, rate_hz_); }

std::optional<InputMessage> ReplaySource::next() {
  if (pending_) {
    auto m = pending_;
    pending_.reset();
    return m;
  }
  const auto& devices = reader_.header().devices;
  if (attached_ < devices.size()) {
    const auto slot = static_cast<std::uint8_t>(attached_++);
    last_tick_ = start_tick_;
    return InputMessage::attach(slot, binder_ ? binder_(slot, devices[slot]) : DeviceBinding{}, start_tick_);
  }
  if (finished_) return std::nullopt;
  for (;;) {
    if (!frame_ || frame_pos_ >= frame_->events.size()) {
      frame_ = reader_.next();
      frame_pos_ = 0;
      if (!frame_) {
        finished_ = true;
        return std::nullopt;
      }
      if (frame_->events.empty()) continue;
    }
    InputFrame f;
    f.slot = static_cast<std::uint8_t>(frame_->device);
    f.device_time_us = frame_->t_us;
    f.device_clock = true;
    f.at_tick = tick_of(frame_->t_us);
    while (frame_pos_ < frame_->events.size() && f.push(frame_->events[frame_pos_])) ++frame_pos_;
    f.partial = frame_pos_ < frame_->events.size();
    last_tick_ = f.at_tick;
    return InputMessage::of_frame(f);
  }
}

std::size_t ReplaySource::pump(concurrency::SpscRing<InputMessage>& ring, std::uint64_t horizon_tick) {
  std::size_t n = 0;
  for (;;) {
    if (!pending_) {
      pending_ = next();
      if (!pending_) return n;
    }
    if (horizon_tick != 0 && pending_->at_tick > horizon_tick) return n;
    if (!ring.try_push(*pending_)) return n;
    pending_.reset();
    ++n;
  }
}

}  // namespace sculpt::input
