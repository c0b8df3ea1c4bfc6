#include "haptics/ff_device.hpp"

#include <cerrno>
#include <utility>

namespace sculpt::haptics {

FfDevice::FfDevice(std::unique_ptr<FfPort> port, const FfDeviceOptions& options, FfCounters* counters)
    : port_(std::move(port)), options_(options), counters_(counters) {
  caps_ = port_->caps();
  const bool has_room = caps_.effects_max > 0;
  const bool constant_ok = options_.constant && has_room && caps_.has(FF_CONSTANT);
  rumble_has_ = options_.rumble && has_room && caps_.has(FF_RUMBLE);
  mode_ = constant_ok ? FfMode::constant : rumble_has_ ? FfMode::rumble_only : FfMode::none;
  // Room for one effect only: the constant force takes it; kicks need a second id.
  rumble_ok_ = rumble_has_ && (mode_ == FfMode::rumble_only || caps_.effects_max >= 2);
  if (mode_ != FfMode::none) set_gain(options_.gain);
}

std::unique_ptr<FfDevice> FfDevice::open(const std::string& node, const FfDeviceOptions& options,
                                         FfCounters* counters) {
  return std::make_unique<FfDevice>(open_evdev_port(node), options, counters);
}

FfDevice::~FfDevice() { shutdown(); }

bool FfDevice::rumble_allowed() const { return rumble_ok_ && !gone_ && !shut_; }

const std::string& FfDevice::node() const { return port_->node(); }

void FfDevice::count_error(int err) {
  if (err == ENODEV) gone_ = true;
  if (counters_) counters_->errors.fetch_add(1, std::memory_order_relaxed);
}

void FfDevice::add_live(int delta) {
  if (counters_) counters_->live_effects.fetch_add(delta, std::memory_order_relaxed);
}

void FfDevice::set_gain(std::uint16_t gain) {
  options_.gain = gain;
  if (gone_ || shut_ || !caps_.has(FF_GAIN)) return;
  if (const int err = port_->write_ff(FF_GAIN, gain)) count_error(err);
}

int FfDevice::upload(ff_effect& e, std::int16_t& id) {
  e.id = id;
  const int err = port_->upload(e);
  if (err) return err;
  if (id < 0) {
    id = e.id;
    add_live(1);
  }
  ++uploads_;
  if (counters_) counters_->uploads.fetch_add(1, std::memory_order_relaxed);
  return 0;
}

bool FfDevice::erase(std::int16_t& id) {
  if (id < 0) return true;
  const std::int16_t old = std::exchange(id, -1);
  add_live(-1);
  if (gone_) return false;
  bool ok = true;
  if (const int err = port_->write_ff(static_cast<std::uint16_t>(old), 0)) {  // stop
    count_error(err);
    ok = false;
  }
  if (gone_) return false;
  if (const int err = port_->erase(old)) {
    count_error(err);
    ok = false;
  }
  return ok;
}

bool FfDevice::set_constant(const ConstantCommand& c) {
  if (mode_ != FfMode::constant || gone_ || shut_) return false;
  ff_effect e{};
  e.type = FF_CONSTANT;
  e.direction = c.direction;
  e.replay.length = 0;  // 0 plays until stopped: the level is updated in place instead
  e.u.constant.level = c.level;

  for (int attempt = 0; attempt < 2; ++attempt) {
    const bool fresh = constant_id_ < 0;
    const int err = upload(e, constant_id_);
    if (err == 0) {
      current_ = c;
      if (fresh) {
        if (const int perr = port_->write_ff(static_cast<std::uint16_t>(constant_id_), 1)) {
          count_error(perr);
          return false;
        }
      }
      return true;
    }
    count_error(err);
    if (err == EINVAL && !fresh) {
      // The id is no longer ours (erased behind our back): start over with −1.
      constant_id_ = -1;
      add_live(-1);
      continue;
    }
    if (err == EINVAL && fresh) {
      // The device refuses constant force after all: rumble kicks only.
      mode_ = rumble_has_ ? FfMode::rumble_only : FfMode::none;
      rumble_ok_ = rumble_has_;
      return false;
    }
    if (err == ENOSPC && fresh && rumble_id_ >= 0) {
      // No free id: the constant force matters more than the kick.
      erase(rumble_id_);
      rumble_ok_ = false;
      if (gone_) return false;
      continue;
    }
    return false;  // ENODEV, ENOSPC with nothing to give up, or anything else: retried on a later change
  }
  return false;
}

bool FfDevice::kick(const RumbleCommand& r) {
  if (!rumble_allowed() || !r.any()) return false;
  ff_effect e{};
  e.type = FF_RUMBLE;
  e.replay.length = r.length_ms;
  e.u.rumble.strong_magnitude = r.strong;
  e.u.rumble.weak_magnitude = r.weak;

  for (int attempt = 0; attempt < 2; ++attempt) {
    const bool fresh = rumble_id_ < 0;
    const int err = upload(e, rumble_id_);
    if (err == 0) {
      if (const int perr = port_->write_ff(static_cast<std::uint16_t>(rumble_id_), 1)) {
        count_error(perr);
        return false;
      }
      if (counters_) counters_->kicks.fetch_add(1, std::memory_order_relaxed);
      return true;
    }
    count_error(err);
    if (err == EINVAL && !fresh) {
      rumble_id_ = -1;
      add_live(-1);
      continue;
    }
    if ((err == EINVAL || err == ENOSPC) && fresh) rumble_ok_ = false;  // refused, or no id free for it
    return false;
  }
  return false;
}

void FfDevice::shutdown() {
  if (shut_) return;
  if (gone_) {
    forget();
  } else {
    erase(constant_id_);
    erase(rumble_id_);
  }
  shut_ = true;
}

void FfDevice::forget() {
  if (constant_id_ >= 0) add_live(-1);
  if (rumble_id_ >= 0) add_live(-1);
  constant_id_ = -1;
  rumble_id_ = -1;
  gone_ = true;
}

}  // namespace sculpt::haptics
