#include "input/evdev_device.hpp"

#include <fcntl.h>
#include <libevdev/libevdev.h>
#include <linux/input.h>
#include <sys/ioctl.h>
#include <time.h>

#include <cerrno>
#include <system_error>

namespace sculpt::input {

std::int64_t monotonic_us() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

DeviceInfo describe_evdev(libevdev* dev, int fd, const std::string& node) {
  DeviceInfo d;
  const char* s;
  d.name = (s = libevdev_get_name(dev)) ? s : "";
  d.phys = (s = libevdev_get_phys(dev)) ? s : "";
  d.uniq = (s = libevdev_get_uniq(dev)) ? s : "";
  d.bustype = static_cast<std::uint16_t>(libevdev_get_id_bustype(dev));
  d.vendor = static_cast<std::uint16_t>(libevdev_get_id_vendor(dev));
  d.product = static_cast<std::uint16_t>(libevdev_get_id_product(dev));
  d.version = static_cast<std::uint16_t>(libevdev_get_id_version(dev));
  d.node = node;
  if (libevdev_has_event_type(dev, EV_ABS)) {
    for (unsigned c = 0; c <= ABS_MAX; ++c) {
      if (!libevdev_has_event_code(dev, EV_ABS, c)) continue;
      const input_absinfo* a = libevdev_get_abs_info(dev, c);
      if (!a) continue;
      d.axes.push_back({static_cast<std::uint16_t>(c), a->value, a->minimum, a->maximum, a->fuzz, a->flat,
                        a->resolution});
    }
  }
  if (libevdev_has_event_type(dev, EV_KEY))
    for (unsigned c = 0; c <= KEY_MAX; ++c)
      if (libevdev_has_event_code(dev, EV_KEY, c)) d.buttons.push_back(static_cast<std::uint16_t>(c));
  if (libevdev_has_event_type(dev, EV_FF)) {
    for (unsigned c = 0; c <= FF_MAX; ++c)
      if (libevdev_has_event_code(dev, EV_FF, c)) d.ff.push_back(static_cast<std::uint16_t>(c));
    int n = 0;
    if (fd >= 0 && ::ioctl(fd, EVIOCGEFFECTS, &n) == 0) d.ff_effects_max = n;
  }
  d.has_msc_timestamp = libevdev_has_event_code(dev, EV_MSC, MSC_TIMESTAMP);
  d.kind = classify_capabilities(d);
  return d;
}

EvdevDevice::EvdevDevice(const std::filesystem::path& node)
    : fd_(::open(node.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)) {
  if (!fd_.valid()) throw std::system_error(errno, std::generic_category(), "open " + node.string());
  const int rc = libevdev_new_from_fd(fd_.get(), &dev_);
  if (rc < 0) throw std::system_error(-rc, std::generic_category(), "libevdev on " + node.string());
  // Event times on the same clock as the loop's ticks.
  libevdev_set_clock_id(dev_, CLOCK_MONOTONIC);
  info_ = describe_evdev(dev_, fd_.get(), node.string());
}

EvdevDevice::~EvdevDevice() {
  if (dev_) libevdev_free(dev_);
}

EvdevDevice::ReadResult EvdevDevice::read(const std::function<void(const InputFrame&)>& emit, int* error) {
  arrival_us_ = monotonic_us();
  for (;;) {
    input_event ev{};
    int rc = libevdev_next_event(dev_, LIBEVDEV_READ_FLAG_NORMAL, &ev);
    if (rc == LIBEVDEV_READ_STATUS_SYNC) {
      // SYN_DROPPED: the kernel's buffer overflowed. What was dropped is
      // replaced by the difference between libevdev's state and the device's:
      // read those events (they end with a SYN_REPORT) and go on.
      ++resyncs_;
      frame_.count = 0;   // the half report before the drop is stale
      have_msc_ = false;
      while ((rc = libevdev_next_event(dev_, LIBEVDEV_READ_FLAG_SYNC, &ev)) == LIBEVDEV_READ_STATUS_SYNC)
        handle(ev, true, emit);
      if (rc == -EAGAIN) continue;
    }
    if (rc == LIBEVDEV_READ_STATUS_SUCCESS) {
      handle(ev, false, emit);
      continue;
    }
    if (rc == -EAGAIN) return ReadResult::drained;
    if (error) *error = -rc;
    return ReadResult::gone;  // -ENODEV: unplugged; anything else: unusable all the same
  }
}

void EvdevDevice::flush(const std::function<void(const InputFrame&)>& emit, bool partial) {
  if (frame_.count == 0) return;
  frame_.partial = partial;
  frame_.arrival_us = arrival_us_;
  frame_.device_clock = have_msc_;
  if (have_msc_) frame_.device_time_us = msc_total_;
  emit(frame_);
  frame_.count = 0;
  frame_.resync = false;
}

void EvdevDevice::handle(const input_event& ev, bool resync, const std::function<void(const InputFrame&)>& emit) {
  if (resync) frame_.resync = true;
  switch (ev.type) {
    case EV_SYN:
      if (ev.code == SYN_REPORT) {
        frame_.kernel_time_us = static_cast<std::int64_t>(ev.input_event_sec) * 1000000 + ev.input_event_usec;
        if (!have_msc_) frame_.device_time_us = frame_.kernel_time_us;
        flush(emit, false);
        have_msc_ = false;
        frame_.resync = false;  // a resync with nothing to report must not flag the next report
      }
      break;
    case EV_MSC:
      if (ev.code == MSC_TIMESTAMP) {
        // A 32-bit microsecond counter that wraps (every ~71 min): unwrap.
        const auto v = static_cast<std::uint32_t>(ev.value);
        if (!msc_started_) msc_total_ = v, msc_started_ = true;
        else msc_total_ += static_cast<std::uint32_t>(v - msc_last_);
        msc_last_ = v;
        have_msc_ = true;
      }
      break;
    case EV_ABS:
    case EV_KEY:
      if (frame_.count == 0)  // a split part before its SYN_REPORT: the first event's time
        frame_.kernel_time_us = static_cast<std::int64_t>(ev.input_event_sec) * 1000000 + ev.input_event_usec;
      if (!frame_.push({ev.type, ev.code, ev.value})) {
        flush(emit, true);
        frame_.push({ev.type, ev.code, ev.value});
      }
      break;
    default:
      break;  // LEDs, sounds, FF status: not input for the tools
  }
}

}  // namespace sculpt::input
