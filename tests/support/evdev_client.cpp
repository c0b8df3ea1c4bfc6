#include "support/evdev_client.hpp"

#include <fcntl.h>
#include <libevdev/libevdev.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

namespace sculpt::support {

ff_effect constant_effect(std::int16_t level, std::uint16_t direction, std::uint16_t length_ms,
                          std::int16_t id) {
  ff_effect e{};
  e.type = FF_CONSTANT;
  e.id = id;
  e.direction = direction;
  e.replay.length = length_ms;
  e.u.constant.level = level;
  return e;
}

ff_effect rumble_effect(std::uint16_t strong, std::uint16_t weak, std::uint16_t length_ms, std::int16_t id) {
  ff_effect e{};
  e.type = FF_RUMBLE;
  e.id = id;
  e.replay.length = length_ms;
  e.u.rumble.strong_magnitude = strong;
  e.u.rumble.weak_magnitude = weak;
  return e;
}

ff_effect sine_effect(std::int16_t magnitude, std::uint16_t period_ms, std::uint16_t length_ms, std::int16_t id) {
  ff_effect e{};
  e.type = FF_PERIODIC;
  e.id = id;
  e.replay.length = length_ms;
  e.u.periodic.waveform = FF_SINE;
  e.u.periodic.period = period_ms;
  e.u.periodic.magnitude = magnitude;
  return e;
}

EvdevClient::EvdevClient(const std::string& node)
    : fd_(::open(node.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC)) {
  if (!fd_.valid()) throw std::system_error(errno, std::generic_category(), "EvdevClient: open " + node);
  const int rc = libevdev_new_from_fd(fd_.get(), &dev_);
  if (rc < 0) throw std::system_error(-rc, std::generic_category(), "EvdevClient: libevdev on " + node);
}

EvdevClient::~EvdevClient() { close(); }

std::string EvdevClient::name() const { return dev_ ? libevdev_get_name(dev_) : ""; }

bool EvdevClient::has_ff(std::uint16_t bit) const { return dev_ && libevdev_has_event_code(dev_, EV_FF, bit); }

int EvdevClient::ff_effects_max() const {
  int n = 0;
  if (::ioctl(fd_.get(), EVIOCGEFFECTS, &n) < 0) return -errno;
  return n;
}

int EvdevClient::upload(ff_effect& effect) { return ::ioctl(fd_.get(), EVIOCSFF, &effect) < 0 ? errno : 0; }

int EvdevClient::erase(std::int16_t id) {
  return ::ioctl(fd_.get(), EVIOCRMFF, static_cast<long>(id)) < 0 ? errno : 0;
}

int EvdevClient::write_ff(std::uint16_t code, std::int32_t value) {
  input_event ev{};
  ev.type = EV_FF;
  ev.code = code;
  ev.value = value;
  const ssize_t n = ::write(fd_.get(), &ev, sizeof ev);
  if (n < 0) return errno;
  return n == static_cast<ssize_t>(sizeof ev) ? 0 : EIO;
}

int EvdevClient::play(std::int16_t id, std::int32_t count) { return write_ff(static_cast<std::uint16_t>(id), count); }
int EvdevClient::stop(std::int16_t id) { return write_ff(static_cast<std::uint16_t>(id), 0); }
int EvdevClient::set_gain(std::uint16_t gain) { return write_ff(FF_GAIN, gain); }
int EvdevClient::set_autocenter(std::uint16_t strength) { return write_ff(FF_AUTOCENTER, strength); }

std::optional<input_event> EvdevClient::next_event(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    input_event ev{};
    const int rc = libevdev_next_event(dev_, LIBEVDEV_READ_FLAG_NORMAL, &ev);
    if (rc == LIBEVDEV_READ_STATUS_SUCCESS) return ev;
    if (rc == LIBEVDEV_READ_STATUS_SYNC) {
      // SYN_DROPPED: drain the resync so the state is right, then go on.
      while (libevdev_next_event(dev_, LIBEVDEV_READ_FLAG_SYNC, &ev) == LIBEVDEV_READ_STATUS_SYNC) {
      }
      continue;
    }
    if (rc != -EAGAIN) throw std::system_error(-rc, std::generic_category(), "EvdevClient: read event");
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return std::nullopt;
    pollfd p{fd_.get(), POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) < 0 && errno != EINTR)
      throw std::system_error(errno, std::generic_category(), "EvdevClient: poll");
  }
}

int EvdevClient::close() {
  if (dev_) {
    libevdev_free(dev_);
    dev_ = nullptr;
  }
  if (!fd_.valid()) return 0;
  return fd_.reset() < 0 ? errno : 0;
}

}  // namespace sculpt::support
