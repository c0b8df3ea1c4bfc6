#include "haptics/device_player.hpp"

#include <utility>

namespace sculpt::haptics {

void DevicePlayer::kick(const RumbleCommand& k) {
  if (!k.any()) return;
  if (!kick_pending_ || k.strong > kick_pending_->strong) kick_pending_ = k;
}

void DevicePlayer::silence() {
  want({}, {});
  silenced_ = true;
  kick_pending_.reset();
  kick_play_pending_ = false;
  kick_until_.reset();
}

void DevicePlayer::restart() {
  kick_pending_.reset();
  kick_play_pending_ = false;
  kick_until_.reset();
  gain_pending_.reset();
  started_until_.reset();
  main_mode_ = FfMode::none;
}

RumbleCommand DevicePlayer::rumble_target(Clock::time_point now) const {
  RumbleCommand r = kick_until_ && now < *kick_until_ ? kick_playing_ : want_rumble_;
  r.length_ms = static_cast<std::uint16_t>(timing_.effect_length.count());
  return r;
}

bool DevicePlayer::quiet(const FfDevice& ff) const {
  if (kick_pending_ || kick_play_pending_) return false;
  if (ff.mode() == FfMode::constant) return !ff.holds(FfDevice::Effect::constant) || ff.current_constant().level == 0;
  return !ff.holds(FfDevice::Effect::rumble) || !ff.current_rumble().any();
}

bool DevicePlayer::zero_waiting(const FfDevice& ff) const {
  return silenced_ && !ff.gone() && ff.mode() != FfMode::none && !quiet(ff);
}

bool DevicePlayer::step(FfDevice& ff, Clock::time_point now) {
  const FfMode mode = ff.mode();
  if (mode == FfMode::none || ff.gone() || !ff.pacer().ready(now)) return false;
  if (mode != main_mode_) {  // first step, or the device refused constant force
    started_until_.reset();
    main_mode_ = mode;
  }
  const bool constant = mode == FfMode::constant;
  const auto main = constant ? FfDevice::Effect::constant : FfDevice::Effect::rumble;
  const auto length = static_cast<std::uint16_t>(timing_.effect_length.count());
  if (!constant && kick_until_ && now >= *kick_until_) kick_until_.reset();

  auto upload_main = [&](const RumbleCommand& r) {
    return constant ? ff.upload_constant(want_constant_, length) : ff.upload_rumble(r);
  };
  last_write_gain_ = false;
  if (!ff.holds(main)) {
    if (upload_main(rumble_target(now))) started_until_.reset();
    return true;
  }
  if (zero_waiting(ff)) {  // the safety zero goes first
    upload_main(rumble_target(now));
    return true;
  }
  if (gain_pending_) {
    const std::uint16_t g = *std::exchange(gain_pending_, std::nullopt);
    if (ff.set_gain(g)) {
      last_write_gain_ = true;
      return true;
    }
  }
  if (!main_playing(now)) {
    if (ff.play(main)) started_until_ = now + timing_.effect_length;
    return true;
  }
  const bool changed = constant ? is_real_change(ff.current_constant(), want_constant_, timing_.change)
                                : is_real_change(ff.current_rumble(), rumble_target(now), timing_.change);
  // A kick under way is finished first; a new one waits one write when the
  // force has changed meanwhile, so frequent kicks never starve the force.
  if (kick_play_pending_) {
    kick_play_pending_ = false;
    last_was_kick_ = true;
    if (ff.play(FfDevice::Effect::rumble)) ++kicks_;
    return true;
  }
  if (kick_pending_ && !(last_was_kick_ && changed)) {
    last_was_kick_ = true;
    if (!constant) {
      RumbleCommand k = *kick_pending_;
      const auto kick_length = std::chrono::milliseconds(k.length_ms);
      k.length_ms = length;
      if (ff.upload_rumble(k)) {
        kick_playing_ = k;
        kick_until_ = now + kick_length;
        ++kicks_;
      }
      kick_pending_.reset();
      return true;
    }
    if (ff.rumble_allowed()) {
      kick_play_pending_ = ff.upload_rumble(*kick_pending_);
      kick_pending_.reset();
      return true;
    }
    kick_pending_.reset();  // no kicks on this device
  }
  last_was_kick_ = false;
  if (changed) {
    upload_main(rumble_target(now));
    return true;
  }
  if (*started_until_ - now <= timing_.effect_length - timing_.rearm_every) {
    if (ff.play(main)) started_until_ = now + timing_.effect_length;
    return true;
  }
  return false;
}

}  // namespace sculpt::haptics
