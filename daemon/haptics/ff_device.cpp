#include "haptics/ff_device.hpp"

#include <cerrno>
#include <utility>

namespace sculpt::haptics {

FfDevice::FfDevice(std::unique_ptr<FfPort> port, const FfDeviceOptions& options, FfCounters* counters,
                   std::shared_ptr<WritePacer> pacer, TimeSource& time)
    : port_(std::move(port)),
      options_(options),
      counters_(counters),
      pacer_(pacer ? std::move(pacer) : std::make_shared<WritePacer>(std::chrono::nanoseconds::zero())),
      time_(&time) {
  caps_ = port_->caps();
  identity_ = port_->identity();
  const bool has_room = caps_.effects_max > 0;
  const bool constant_ok = options_.constant && has_room && caps_.has(FF_CONSTANT);
  rumble_has_ = options_.rumble && has_room && caps_.has(FF_RUMBLE);
  mode_ = constant_ok ? FfMode::constant : rumble_has_ ? FfMode::rumble_only : FfMode::none;
  // Room for one effect only: the constant force takes it; kicks need a second id.
  rumble_ok_ = rumble_has_ && (mode_ == FfMode::rumble_only || caps_.effects_max >= 2);
  if (mode_ != FfMode::none && options_.gain_at_open) set_gain(options_.gain);
}

std::unique_ptr<FfDevice> FfDevice::open(const std::string& node, const FfDeviceOptions& options,
                                         FfCounters* counters) {
  return std::make_unique<FfDevice>(open_evdev_port(node), options, counters);
}

FfDevice::~FfDevice() { shutdown(); }

bool FfDevice::rumble_allowed() const { return rumble_ok_ && !gone_ && !shut_; }

const std::string& FfDevice::node() const { return port_->node(); }

template <class Call>
int FfDevice::paced(Call call) {
  pacer_->wait(*time_);
  const int err = call();
  // The time after the call: a write that took long (uinput waits for its
  // process, a driver for its transport) is not counted from its start.
  if (err != ENODEV) {
    pacer_->wrote(time_->now());
    ++writes_;
  }
  return err;
}

void FfDevice::count_error(int err) {
  if (err == ENODEV && wait_for_ready_ && !ready_seen_) {
    not_ready_ = true;  // not created yet: the caller retries, nothing is wrong
    return;
  }
  if (err == ENODEV) gone_ = true;
  if (counters_) counters_->errors.fetch_add(1, std::memory_order_relaxed);
}

void FfDevice::add_live(int delta) {
  if (counters_) counters_->live_effects.fetch_add(delta, std::memory_order_relaxed);
}

bool FfDevice::set_gain(std::uint16_t gain) {
  options_.gain = gain;
  if (gone_ || shut_ || !caps_.has(FF_GAIN)) return false;
  if (const int err = paced([&] { return port_->write_ff(FF_GAIN, gain); })) count_error(err);
  return true;
}

int FfDevice::upload(ff_effect& e, std::int16_t& id) {
  not_ready_ = false;
  e.id = id;
  const int err = paced([&] { return port_->upload(e); });
  if (err) return err;
  if (id < 0) {
    id = e.id;
    add_live(1);
  }
  ready_seen_ = true;
  ++uploads_;
  if (counters_) counters_->uploads.fetch_add(1, std::memory_order_relaxed);
  return 0;
}

bool FfDevice::erase(std::int16_t& id) {
  if (id < 0) return true;
  const std::int16_t old = std::exchange(id, -1);
  add_live(-1);
  if (gone_) return false;
  // No stop first: the kernel's erase stops a playing effect itself
  // (ff-core's erase_effect plays it 0 before the driver's erase).
  if (const int err = paced([&] { return port_->erase(old); })) {
    count_error(err);
    return false;
  }
  return true;
}

bool FfDevice::upload_constant(const ConstantCommand& c, std::uint16_t length_ms) {
  if (mode_ != FfMode::constant || !usable()) return false;
  if (give_up_rumble_) {
    // The ENOSPC of the last call: this call's write is the rumble's erase;
    // the constant's upload is the next one.
    give_up_rumble_ = false;
    erase(rumble_id_);
    return false;
  }
  ff_effect e{};
  e.type = FF_CONSTANT;
  e.direction = c.direction;
  // Finite: some drivers end a length-0 ("infinite") effect after ~65 s
  // anyway; the caller re-arms it well before this runs out.
  e.replay.length = length_ms;
  e.u.constant.level = c.level;

  const bool fresh = constant_id_ < 0;
  const int err = upload(e, constant_id_);
  if (err == 0) {
    current_ = c;
    return true;
  }
  count_error(err);
  if (err == EINVAL && !fresh) {
    // The id is no longer ours (erased behind our back): the next call starts over with −1.
    constant_id_ = -1;
    add_live(-1);
  } else if (err == EINVAL && fresh) {
    // The device refuses constant force after all: rumble only.
    mode_ = rumble_has_ ? FfMode::rumble_only : FfMode::none;
    rumble_ok_ = rumble_has_;
  } else if (err == ENOSPC && fresh && rumble_id_ >= 0) {
    // No free id: the constant force matters more than the kick.
    rumble_ok_ = false;
    give_up_rumble_ = true;
  }
  return false;  // ENODEV, ENOSPC with nothing to give up, or anything else: retried later
}

bool FfDevice::upload_rumble(const RumbleCommand& r) {
  if (!rumble_allowed()) return false;
  ff_effect e{};
  e.type = FF_RUMBLE;
  e.replay.length = r.length_ms;
  e.u.rumble.strong_magnitude = r.strong;
  e.u.rumble.weak_magnitude = r.weak;

  const bool fresh = rumble_id_ < 0;
  const int err = upload(e, rumble_id_);
  if (err == 0) {
    current_rumble_ = r;
    return true;
  }
  count_error(err);
  if (err == EINVAL && !fresh) {
    rumble_id_ = -1;  // vanished: the next call uploads with −1
    add_live(-1);
  } else if ((err == EINVAL || err == ENOSPC) && fresh) {
    rumble_ok_ = false;  // refused, or no id free for it
    if (mode_ == FfMode::rumble_only) mode_ = FfMode::none;
  }
  return false;
}

bool FfDevice::play(Effect which) {
  const std::int16_t id = which == Effect::constant ? constant_id_ : rumble_id_;
  if (id < 0 || !usable()) return false;
  not_ready_ = false;
  if (const int err = paced([&] { return port_->write_ff(static_cast<std::uint16_t>(id), 1); })) {
    count_error(err);
    return false;
  }
  ready_seen_ = true;
  return true;
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
